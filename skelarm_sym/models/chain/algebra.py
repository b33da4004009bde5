"""Small algebra on lists of SymPy expressions (3-vectors, 3 x 3 rows; exact zeros fold by themselves) and
the rotations the chain derivation splits: ``Rz`` products, a rotation taking ``z`` to an axis, ``Rz`` angles."""

from __future__ import annotations

import math
from typing import Sequence

import sympy as sp

Vector = list  # three SymPy expressions
Rows = list  # 3 x 3 as rows of SymPy expressions


def matvec(m: Sequence[Sequence[sp.Expr]], v: Sequence[sp.Expr]) -> Vector:
    """``m v`` for a 3 x 3 ``m``."""
    return [sp.Add(*[m[i][j] * v[j] for j in range(3)]) for i in range(3)]


def matmul(a: Sequence[Sequence[sp.Expr]], b: Sequence[Sequence[sp.Expr]]) -> Rows:
    """``a b`` for 3 x 3 matrices."""
    return [[sp.Add(*[a[i][k] * b[k][j] for k in range(3)]) for j in range(3)] for i in range(3)]


def _rows(matrix: sp.Matrix) -> Rows:
    return [[matrix[i, j] for j in range(matrix.cols)] for i in range(matrix.rows)]


def _rz(trig: tuple[sp.Expr, sp.Expr] | None, v: Sequence[sp.Expr]) -> Vector:
    """``Rz(psi) v`` for ``trig = (cos psi, sin psi)``; ``v`` itself when ``trig`` is ``None``."""
    if trig is None:
        return list(v)
    c, s = trig
    return [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]


def _times_rz(m: Sequence[Sequence[sp.Expr]], trig) -> Rows:
    """``m Rz(psi)``: the first two columns of ``m`` mixed."""
    if trig is None:
        return [list(r) for r in m]
    c, s = trig
    return [[c * r[0] + s * r[1], c * r[1] - s * r[0], r[2]] for r in m]


def _rz_times(trig, m: Sequence[Sequence[sp.Expr]]) -> Rows:
    """``Rz(psi) m``: the first two rows of ``m`` mixed."""
    if trig is None:
        return [list(r) for r in m]
    c, s = trig
    return [[c * a - s * b for a, b in zip(m[0], m[1])], [s * a + c * b for a, b in zip(m[0], m[1])], list(m[2])]


def _z_alignment(axis: Sequence[sp.Expr]) -> sp.Matrix:
    """A rotation ``Q`` with ``Q e_z = axis`` (exact for +-x, +-y, +-z)."""
    a = [sp.sympify(x) for x in axis]
    exact = {
        (0, 0, 1): sp.eye(3),
        (0, 0, -1): sp.Matrix([[1, 0, 0], [0, -1, 0], [0, 0, -1]]),
        (1, 0, 0): sp.Matrix([[0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
        (-1, 0, 0): sp.Matrix([[0, 0, -1], [0, 1, 0], [1, 0, 0]]),
        (0, 1, 0): sp.Matrix([[1, 0, 0], [0, 0, 1], [0, -1, 0]]),
        (0, -1, 0): sp.Matrix([[1, 0, 0], [0, 0, -1], [0, 1, 0]]),
    }
    key = tuple(int(x) if x.is_Integer else None for x in a)
    if key in exact:
        return exact[key]
    v = [float(x) for x in a]
    helper = [1.0, 0.0, 0.0] if abs(v[0]) < 0.9 else [0.0, 1.0, 0.0]
    u = [helper[1] * v[2] - helper[2] * v[1], helper[2] * v[0] - helper[0] * v[2], helper[0] * v[1] - helper[1] * v[0]]
    norm = math.sqrt(sum(x * x for x in u))
    u = [x / norm for x in u]
    w = [v[1] * u[2] - v[2] * u[1], v[2] * u[0] - v[0] * u[2], v[0] * u[1] - v[1] * u[0]]
    return sp.Matrix([[sp.Float(u[i]), sp.Float(w[i]), sp.Float(v[i])] for i in range(3)])


def _numeric(expr: sp.Expr) -> sp.Expr:
    """A constant with pi or radicals as a Float (so it prints as a literal); exact 0 and rationals stay."""
    expr = sp.sympify(expr)
    if expr.free_symbols or expr.is_Rational or expr.is_Float:
        return expr
    return sp.Float(expr.evalf(30), 17)


def _z_rotation_angle(rotation: sp.Matrix) -> sp.Expr | None:
    """``beta`` when ``rotation`` is ``Rz(beta)`` (exact where it is a multiple of pi/2), else ``None``."""
    if rotation[2, 2] != 1 or any(rotation[i, j] != 0 for i, j in ((0, 2), (1, 2), (2, 0), (2, 1))):
        return None
    c, s = rotation[0, 0], rotation[1, 0]
    if c.free_symbols or s.free_symbols:
        return None
    for k, (ck, sk) in enumerate(((1, 0), (0, 1), (-1, 0), (0, -1))):
        if c == ck and s == sk:
            return sp.Integer(k) * sp.pi / 2 if k else sp.S.Zero
    return sp.Float(math.atan2(float(s), float(c)))


def _split_z(rotation: sp.Matrix) -> tuple[sp.Matrix, sp.Expr] | None:
    """``(P, beta)`` with ``rotation = P Rz(beta)`` and ``P`` a signed permutation, when ``rotation`` takes
    ``z`` exactly to a base axis and ``beta`` is not a multiple of pi/2 (else ``None``: nothing to gain)."""
    if rotation.free_symbols:
        return None
    column = [rotation[i, 2] for i in range(3)]
    if not all(x.is_Integer for x in column) or sorted(abs(int(x)) for x in column) != [0, 0, 1]:
        return None
    j = (next(i for i in range(3) if column[i] != 0) + 1) % 3
    beta = math.atan2(-float(rotation[j, 1]), float(rotation[j, 0]))
    if abs(beta / (math.pi / 2) - round(beta / (math.pi / 2))) < 1e-12:
        return None
    c, s = math.cos(beta), math.sin(beta)
    turned = [[float(rotation[i, 0]) * c - float(rotation[i, 1]) * s, float(rotation[i, 0]) * s + float(rotation[i, 1]) * c,
               float(rotation[i, 2])] for i in range(3)]  # rotation Rz(-beta)
    P = [[round(x) for x in row] for row in turned]
    if any(abs(x - y) > 1e-9 for row, prow in zip(turned, P) for x, y in zip(row, prow)):
        return None
    return sp.Matrix(P), sp.Float(beta)
