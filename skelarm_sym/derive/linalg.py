"""Closed-form small linear algebra for derivations: Gram sums, the two-row damped solve.

Every helper takes a ``step`` recorder (see :class:`skelarm_sym.derive.StepRecorder`)
and names its intermediate quantities with it, so the expressions handed to CSE
stay small and the cost stays linear in the number of columns.

``damped_solve2`` solves ``M^T (M M^T + lambda^2 I)^+ rhs`` for a two-row ``M`` through one
Gram-Schmidt step on its rows, choosing at run time between the regular closed form and the
rank-one pseudo-inverse (its docstring states the rule); more rows go through
:func:`skelarm_sym.derive.solve6.damped_least_squares`. The tests check both branches against
NumPy's SVD.
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
    when lambda has the unit of ``M``): ``M`` counts as rank one when its smallest singular value is
    below about ``tol`` times its largest (``pp rr <= tol^2 tr(M M^T)^2``; the error of the regular form
    follows ``cond(M)``, so it holds up to there) and lambda at most ``sqrt(tol) |M|_F``
    (``lam2 <= tol tr``), and then ``r`` is dropped:
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
    # J's second singular value at most tol times the largest is rounding for a planar arm (tol grows with its links:
    # its sums of n terms, and angles of whole turns, round to a few n eps): dropped while the damping is at most
    # sqrt(tol) |M|_F (kept, it added s / lambda^2: 2e8 times the answer at lambda = 1e-12 of a stretched arm's size,
    # 1.5e6 times a folded 64-link arm's)
    regular = step(f"{label}regular", sp.Or(sp.StrictGreaterThan(pp * rr, tol**2 * trace**2),
                                           sp.StrictGreaterThan(lam2, tol * trace)))
    along = step(f"{label}along", v1 + gs.ratio * v2)
    inv_det = step(f"{label}idet", kappa / sp.Piecewise((det, regular), (sp.S.One, True)))
    one = step(f"{label}one", pp * (1 + gs.ratio**2) + lam2)
    inv_one = step(f"{label}ione", kappa / nonzero(one))
    alpha = step(f"{label}alpha", sp.Piecewise(((rr * v1 + lam2 * along) * inv_det, regular), (along * inv_one, True)))
    if all(r == 0 for r in gs.r):
        return [step(f"{label}x{i}", p * alpha) for i, p in enumerate(gs.p)]
    beta = step(f"{label}beta", sp.Piecewise(((pp * (v2 - gs.ratio * v1) + lam2 * v2) * inv_det, regular), (sp.S.Zero, True)))
    return [step(f"{label}x{i}", p * alpha + r * beta) for i, (p, r) in enumerate(zip(gs.p, gs.r))]
