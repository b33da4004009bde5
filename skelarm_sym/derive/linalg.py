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


def gram_root(step: Recorder, rows: Sequence[Sequence[sp.Expr]], G: list[list[sp.Expr]], label: str) -> sp.Expr:
    """``sqrt(det(M M^T))`` for a two-row ``M`` with Gram matrix ``G`` (from :func:`gram`).

    ``det = |x|^2 |y|^2 - (x.y)^2`` cancels catastrophically near a singular pose
    (its square root then carries an error of about sqrt(eps) * |M|^2). Instead
    the shorter row is made orthogonal to the longer one first (one Gram-Schmidt
    step): with ``x`` the longer row, ``det = |x|^2 |y - (x.y/|x|^2) x|^2``, a product of
    sums of squares that keeps full relative accuracy and is never negative.
    """
    if len(rows) != 2:
        raise ValueError("gram_root handles two-row matrices")
    x, y = rows
    first = step(f"{label}first", sp.GreaterThan(G[0][0], G[1][1]))
    pivot = step(f"{label}pivot", sp.Piecewise((G[0][0], first), (G[1][1], True)))
    ratio = step(f"{label}ratio", G[0][1] / pivot)
    residual = [
        step(f"{label}r{i}", sp.Piecewise((b, first), (a, True)) - ratio * sp.Piecewise((a, first), (b, True)))
        for i, (a, b) in enumerate(zip(x, y))
    ]
    return sp.sqrt(pivot * step(f"{label}rr", sp.Add(*[r**2 for r in residual])))


def add_diagonal(step: Recorder, matrix: list[list[sp.Expr]], value: sp.Expr, label: str) -> list[list[sp.Expr]]:
    """``matrix + value * I`` (new list; diagonal entries named by ``step``)."""
    out = [list(row) for row in matrix]
    for i in range(len(out)):
        out[i][i] = step(f"{label}{i}{i}", out[i][i] + value)
    return out


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
    inv_s2 = step(f"{label}is2", 1 / s**2)
    rank_one = [step(f"{label}r1_{i}", x * inv_s2) for i, x in enumerate(Ar)]
    if size == 2:
        d = step(f"{label}det", _cofactor_det(A))
        regular = step(f"{label}regular", sp.StrictGreaterThan(d, tol * s**2))
        inv_d = step(f"{label}idet", 1 / d)
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
        inv_d = step(f"{label}idet", 1 / d)
        exact = [sp.Add(*[a * r for a, r in zip(row, rhs)]) * inv_d for row in adj]
        AAr = _matvec(step, A, Ar, f"{label}AAr")
        inv_c2 = step(f"{label}ic2", 1 / c2**2)
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
