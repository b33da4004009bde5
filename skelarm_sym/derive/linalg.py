"""Closed-form small linear algebra for derivations: Gram sums, determinants, symmetric solves.

Every helper takes a ``step`` recorder (see :class:`skelarm_sym.derive.StepRecorder`)
and names its intermediate quantities with it, so the expressions handed to CSE
stay small and the cost stays linear in the number of columns.

Symmetric positive semi-definite solves (``sym_solve``) pick, at run time, the
exact inverse when the matrix is regular and its Moore-Penrose pseudo-inverse
when it is (numerically) rank deficient, using closed forms only:

* 2 x 2, ``s = tr A``, ``d = det A``: if ``d > tol * s**2`` then ``A^-1 = (s I - A) / d``
  (Cayley-Hamilton), else ``A`` has rank one and ``A^+ = A / s**2``.
* 3 x 3, ``c = `` sum of the principal 2 x 2 minors: if ``c <= tol * s**2`` the rank
  is one and ``A^+ = A / s**2``; else if ``d > tol * s * c`` then ``A^-1 = adj(A) / d``;
  else the rank is two and ``A^+ = ((s**2 - c) A - s A**2) / c**2``.

In eigenvalues ``e1 >= e2 >= e3``: ``d / c`` is about ``e3`` and ``c / s`` about ``e2``,
so each test asks whether the next eigenvalue is above ``tol`` times the largest.

(For a rank-two ``A = a u u' + b w w'``: ``s A - A**2 = ab P`` with ``P`` the
projector onto its range, so ``A^+ = (s P - A) / (ab)`` and ``ab = c``.)
The tests check each branch against ``numpy.linalg.pinv``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import sympy as sp

Recorder = Callable[[str, sp.Expr], sp.Expr]


def gram(step: Recorder, rows: Sequence[Sequence[sp.Expr]], label: str) -> list[list[sp.Expr]]:
    """``M M^T`` for the matrix with ``rows`` (each a sequence of column entries); symmetric, named by ``step``."""
    size = len(rows)
    out: list[list[sp.Expr]] = [[sp.S.Zero] * size for _ in range(size)]
    for i in range(size):
        for j in range(i, size):
            value = step(f"{label}{i}{j}", sp.Add(*[a * b for a, b in zip(rows[i], rows[j])]))
            out[i][j] = out[j][i] = value
    return out


def nonzero(value: sp.Expr) -> sp.Expr:
    """``value`` where it is positive, else 1: a divisor that is never zero, for a quantity that
    is only used where it is positive (a select keeps both branches finite).

    A sum of positive symbols (a planar arm's reach, its lengths) is ``value`` itself, as SymPy's comparison
    would find; asked of SymPy, that takes an assumption query over every term (44 ms at 128 links)."""
    if value.is_Add and all(a.is_Symbol and a.is_positive for a in value.args):
        return value
    return sp.Piecewise((value, sp.StrictGreaterThan(value, 0)), (sp.S.One, True))


def select(cond: sp.Expr, then: sp.Expr, otherwise: sp.Expr) -> sp.Expr:
    """``Piecewise((then, cond), (otherwise, True))``. When ``cond`` is a symbol (a named step) and the two
    branches are different expressions that are not themselves ``Piecewise``, SymPy's evaluation of it
    changes nothing (no condition repeats, none is constant, no branch collapses), so it is built
    unevaluated: the same expression, at a fifth of the cost (per column of a planar arm, twice)."""
    plain = cond.is_Symbol and then != otherwise and not isinstance(then, sp.Piecewise) and not isinstance(otherwise, sp.Piecewise)
    return sp.Piecewise((then, cond), (otherwise, True), evaluate=not plain)


@dataclass(frozen=True)
class GramSchmidt2:
    """One Gram-Schmidt step on the two rows ``x, y`` of ``M`` (see :func:`gram_schmidt2`).

    ``p`` is the longer row (``first``: it is ``x``), ``o`` the other one, ``ratio = p.o / |p|^2``,
    ``r = o - ratio p`` (orthogonal to ``p``), ``pp = |p|^2``, ``rr = |r|^2``. Then
    ``M' = [p; o] = [[1, 0], [ratio, 1]] [p; r]`` and ``det(M M^T) = pp * rr`` (no cancellation).
    """

    first: sp.Expr
    p: list[sp.Expr]
    ratio: sp.Expr
    r: list[sp.Expr]
    pp: sp.Expr
    rr: sp.Expr


def gram_schmidt2(step: Recorder, rows: Sequence[Sequence[sp.Expr]], G: list[list[sp.Expr]], label: str) -> GramSchmidt2:
    """The Gram-Schmidt step of a two-row ``M`` with Gram matrix ``G``, pivoting on the longer row.

    One column (``n = 1``): the rows are multiples of each other, so ``r = 0`` exactly (rounding
    would leave a residual of about eps |o| along ``p``, which a damped solve amplifies by 1/lambda^2).
    """
    if len(rows) != 2:
        raise ValueError("gram_schmidt2 handles two-row matrices")
    x, y = rows
    first = step(f"{label}first", sp.GreaterThan(G[0][0], G[1][1]))
    pivot = step(f"{label}pivot", sp.Piecewise((G[0][0], first), (G[1][1], True)))
    ratio = step(f"{label}ratio", G[0][1] / nonzero(pivot))
    p = [step(f"{label}p{i}", select(first, a, b)) for i, (a, b) in enumerate(zip(x, y))]
    if len(x) == 1:
        return GramSchmidt2(first, p, ratio, [sp.S.Zero], pivot, sp.S.Zero)
    residual = [
        step(f"{label}r{i}", select(first, b, a) - ratio * pi)
        for i, (a, b, pi) in enumerate(zip(x, y, p))
    ]
    rr = step(f"{label}rr", sp.Add(*[r**2 for r in residual]))
    return GramSchmidt2(first, p, ratio, residual, pivot, rr)


def damping_scale(step: Recorder, lam: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
    """``(lam2, kappa)`` for a damping ``lam >= 0``: ``kappa = 1 / max(1, lam)^2`` and ``lam2 = kappa lam^2
    = min(lam, 1)^2``. A damped system ``A + lam^2 I`` solved as ``kappa A + lam2 I`` has the same solution
    and entries no larger than ``A``'s and 1, so nothing overflows for any finite ``lam`` (``lam^2`` does
    from 1.8e154 in double, 1.8e19 in float; ``lam^4`` from 1.3e77 and 4.3e9)."""
    big = sp.StrictGreaterThan(lam, 1)
    mu = step("mu", 1 / sp.Piecewise((lam, big), (sp.S.One, True)))
    clipped = step("lamclip", sp.Piecewise((sp.S.One, big), (lam, True)))  # min(lam, 1): (lam mu)**2 would expand to lam**2 mu**2
    return step("lam2", clipped**2), step("kappa", mu**2)


def damped_solve2(
    step: Recorder,
    gs: GramSchmidt2,
    G: list[list[sp.Expr]],
    lam2: sp.Expr,
    rhs: Sequence[sp.Expr],
    tol: sp.Symbol,
    label: str,
    kappa: sp.Expr = sp.S.One,
) -> list[sp.Expr]:
    """``M^T (M M^T + lambda^2 I)^+ rhs`` for a two-row ``M`` from its Gram-Schmidt step ``gs`` (n entries).

    ``lam2 = kappa lambda^2`` and ``kappa`` (see :func:`damping_scale`; ``kappa = 1``: ``lam2`` is ``lambda^2``):
    everything below is computed for ``kappa (M M^T) + lam2 I``, whose solution is the same, so no product
    overflows for a huge lambda and the answer tends to 0 (exactly 0 once ``kappa`` underflows).

    In the orthogonal basis ``p, r`` of the row space (``M' = L [p; r]``, ``L`` unit lower
    triangular, ``rhs' = (v1, v2)`` permuted as the rows) the damped solution is

        dq = (p (rr v1 + lam2 (v1 + ratio v2)) + r (pp (v2 - ratio v1) + lam2 v2)) / det,
        det = det(M M^T + lam2 I) = pp rr + lam2 tr(M M^T) + lam2^2

    (Cauchy-Binet: every term is non-negative, nothing cancels; with ``kappa``, ``pp``, ``rr`` and ``tr`` are
    multiplied by it, and so are both coefficients). Its error follows the
    conditioning of the problem: ``r`` carries the rounding of ``M`` (about eps |M|), amplified by
    ``1 / (rr + lam2)``; the normal-equations form ``M^T adj(A) rhs / det A`` loses a further factor
    ``cond(A)`` to cancellation (``M^T adj(A)`` is nearly zero in the directions that ``det A``
    makes small). Rank rule (homogeneous in ``M`` and ``lam2``, so independent of the unit of length
    when lambda has the unit of ``M``): ``A`` counts as rank one when ``det <= tol tr(A)^2``
    (smallest eigenvalue below about ``tol`` times the largest), and then ``r`` is dropped:
    ``dq = p (v1 + ratio v2) / (pp (1 + ratio^2) + lam2)``, the damped (lambda = 0: minimum-norm
    least-squares) solution of ``[p; ratio p] dq = rhs'``. Divisors are never zero: a zero
    matrix gives ``dq = 0``.
    """
    first = gs.first
    scaled = kappa != 1
    pp = step(f"{label}ppk", gs.pp * kappa) if scaled else gs.pp
    rr = step(f"{label}rrk", gs.rr * kappa) if scaled else gs.rr
    v1 = step(f"{label}v1", sp.Piecewise((rhs[0], first), (rhs[1], True)))
    v2 = step(f"{label}v2", sp.Piecewise((rhs[1], first), (rhs[0], True)))
    trace = step(f"{label}tr", (G[0][0] + G[1][1]) * kappa)
    det = step(f"{label}det", pp * rr + lam2 * (trace + lam2))
    regular = step(f"{label}regular", sp.StrictGreaterThan(det, tol * (trace + 2 * lam2) ** 2))
    along = step(f"{label}along", v1 + gs.ratio * v2)
    inv_det = step(f"{label}idet", kappa / sp.Piecewise((det, regular), (sp.S.One, True)))
    one = step(f"{label}one", pp * (1 + gs.ratio**2) + lam2)
    inv_one = step(f"{label}ione", kappa / nonzero(one))
    alpha = step(f"{label}alpha", sp.Piecewise(((rr * v1 + lam2 * along) * inv_det, regular), (along * inv_one, True)))
    if all(r == 0 for r in gs.r):
        return [step(f"{label}x{i}", p * alpha) for i, p in enumerate(gs.p)]
    beta = step(f"{label}beta", sp.Piecewise(((pp * (v2 - gs.ratio * v1) + lam2 * v2) * inv_det, regular), (sp.S.Zero, True)))
    return [step(f"{label}x{i}", p * alpha + r * beta) for i, (p, r) in enumerate(zip(gs.p, gs.r))]


def _cofactor_det(m: Sequence[Sequence[sp.Expr]]) -> sp.Expr:
    if len(m) == 1:
        return m[0][0]
    if len(m) == 2:
        return m[0][0] * m[1][1] - m[0][1] * m[1][0]
    return (
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    )


def _matvec(step: Recorder, matrix: Sequence[Sequence[sp.Expr]], vector: Sequence[sp.Expr], label: str) -> list[sp.Expr]:
    return [step(f"{label}{i}", sp.Add(*[a * x for a, x in zip(row, vector)])) for i, row in enumerate(matrix)]


def sym_solve(
    step: Recorder,
    matrix: Sequence[Sequence[sp.Expr]],
    rhs: Sequence[sp.Expr],
    tol: sp.Symbol,
    label: str,
) -> list[sp.Expr]:
    """``A^+ rhs`` for a symmetric positive semi-definite 2 x 2 or 3 x 3 ``A`` (see the module docstring).

    ``tol`` is the relative rank tolerance (a symbol the backends print as a
    precision-dependent constant). The result is finite whenever ``A != 0``.
    """
    size = len(matrix)
    A = [list(row) for row in matrix]
    s = step(f"{label}tr", sp.Add(*[A[i][i] for i in range(size)]))
    Ar = _matvec(step, A, rhs, f"{label}Ar")
    inv_s2 = step(f"{label}is2", 1 / nonzero(s) ** 2)
    rank_one = [step(f"{label}r1_{i}", x * inv_s2) for i, x in enumerate(Ar)]
    if size == 2:
        d = step(f"{label}det", _cofactor_det(A))
        regular = step(f"{label}regular", sp.StrictGreaterThan(d, tol * s**2))
        inv_d = step(f"{label}idet", 1 / nonzero(d))
        exact = [(s * r - x) * inv_d for r, x in zip(rhs, Ar)]
        return [step(f"{label}x{i}", sp.Piecewise((e, regular), (o, True))) for i, (e, o) in enumerate(zip(exact, rank_one))]
    if size == 3:
        cof = [[_cofactor(A, i, j) for j in range(3)] for i in range(3)]
        cof = [[step(f"{label}C{i}{j}", cof[i][j]) if j >= i else None for j in range(3)] for i in range(3)]
        adj = [[cof[min(i, j)][max(i, j)] for j in range(3)] for i in range(3)]  # symmetric A: adj symmetric
        d = step(f"{label}det", sp.Add(*[A[0][j] * adj[0][j] for j in range(3)]))
        c2 = step(f"{label}c2", adj[0][0] + adj[1][1] + adj[2][2])
        regular = step(f"{label}regular", sp.StrictGreaterThan(d, tol * s * c2))
        rank_two = step(f"{label}rank2", sp.StrictGreaterThan(c2, tol * s**2))
        inv_d = step(f"{label}idet", 1 / nonzero(d))
        exact = [sp.Add(*[a * r for a, r in zip(row, rhs)]) * inv_d for row in adj]
        AAr = _matvec(step, A, Ar, f"{label}AAr")
        inv_c2 = step(f"{label}ic2", 1 / nonzero(c2) ** 2)
        k = step(f"{label}k", s**2 - c2)
        two = [(k * x - s * y) * inv_c2 for x, y in zip(Ar, AAr)]
        return [  # regular is only trusted where rank_two holds (rounding can make c2 and d slightly negative)
            step(f"{label}x{i}", sp.Piecewise((sp.Piecewise((e, regular), (t, True)), rank_two), (o, True)))
            for i, (e, t, o) in enumerate(zip(exact, two, rank_one))
        ]
    raise ValueError(f"sym_solve handles 2 x 2 and 3 x 3 matrices, got {size} x {size}")


def _cofactor(m: Sequence[Sequence[sp.Expr]], i: int, j: int) -> sp.Expr:
    rows = [r for r in range(3) if r != i]
    cols = [c for c in range(3) if c != j]
    minor = m[rows[0]][cols[0]] * m[rows[1]][cols[1]] - m[rows[0]][cols[1]] * m[rows[1]][cols[0]]
    return minor if (i + j) % 2 == 0 else -minor
