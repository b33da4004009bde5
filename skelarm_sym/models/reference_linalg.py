"""NumPy linear algebra the inverse functions are judged by: damped least squares, manipulability.

Independent of the symbolic side and of the generator's own rank rules: solutions come
from NumPy's SVD, with a relative cutoff the caller derives from the working precision.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Solve:
    """Result of :func:`damped_least_squares`. ``...`` is the batch shape.

    Attributes:
        x: the solution, ``(..., n)``.
        rank: number of singular values of the (row-scaled) matrix kept, ``(...)``.
        condition: condition number of the matrix the normal equations solve, ``D (M M^T + lam^2 I) D``,
            over its kept eigenvalues, ``(...)``: how much rounding in ``M`` a solve through that
            matrix may amplify (at most ``cond(D M)^2`` undamped).
        rows: ``r``, the number of rows of ``M``.
    """

    x: np.ndarray
    rank: np.ndarray
    condition: np.ndarray
    rows: int

    @property
    def regular(self) -> np.ndarray:
        """True where every direction was kept, ``(...)``."""
        return self.rank == min(self.rows, self.x.shape[-1])


def damped_least_squares(M: object, rhs: object, lam: float, rcond: float, row_scale: object = None) -> Solve:
    """``x = argmin |M x - rhs|^2 + lam^2 |x|^2`` of least norm, from NumPy's SVD (no closed form, no rank rule
    of the generator).

    ``M`` is ``(..., r, n)``, ``rhs`` ``(..., r)``. ``lam > 0``: ``x = sum_i s_i / (s_i^2 + lam^2) (u_i . rhs) v_i``
    over the singular triplets of ``M`` (every direction, none dropped: a zero ``s_i`` contributes nothing).
    ``lam = 0``: the minimum-norm least-squares solution ``pinv(D M) D rhs`` with ``D = diag(row_scale)``
    (rows of different units measured in one unit, so the answer does not depend on the unit of
    length), dropping the singular values of ``D M`` below ``rcond`` times the largest (``rcond`` is
    relative, hence scale-free; :func:`skelarm_sym.check` derives it from the working precision).
    Where ``D M`` has full row rank the result is ``pinv(M) rhs`` whatever ``D``.
    """
    M = np.asarray(M, dtype=float)
    rhs = np.asarray(rhs, dtype=float)
    r, n = M.shape[-2:]
    D = np.ones(r) if row_scale is None else np.asarray(row_scale, dtype=float)
    DM = D[..., :, None] * M
    if lam > 0:
        U, s, Vt = np.linalg.svd(M, full_matrices=False)
        coeffs = np.einsum("...ji,...j->...i", U, rhs) * (s / (s**2 + lam**2))
        x = np.einsum("...ij,...i->...j", Vt, coeffs)
        e = np.linalg.eigvalsh(DM @ np.swapaxes(DM, -1, -2) + lam**2 * (D[..., :, None] * D[..., None, :]) * np.eye(r))
        rank = np.full(M.shape[:-2], min(r, n))
        return Solve(x, rank, e[..., -1] / e[..., 0], r)
    U, s, Vt = np.linalg.svd(DM, full_matrices=False)
    keep = s > rcond * s[..., :1]
    inv = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    coeffs = np.einsum("...ji,...j->...i", U, D * rhs) * inv
    x = np.einsum("...ij,...i->...j", Vt, coeffs)
    rank = keep.sum(axis=-1)
    smallest = np.take_along_axis(s, np.maximum(rank - 1, 0)[..., None], axis=-1)[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        condition = np.where(rank > 0, (s[..., 0] / np.where(rank > 0, smallest, 1.0)) ** 2, 1.0)
    return Solve(x, rank, condition, r)


def manipulability(J: object) -> np.ndarray:
    """``sqrt(det(J J^T))`` of Jacobians ``(..., r, n)`` by the Cauchy-Binet formula:
    ``det(J J^T)`` is the sum of the squared ``r x r`` minors of ``J`` (no cancellation
    near singular poses; cost grows as n^r, fine for a reference)."""
    from itertools import combinations

    J = np.asarray(J, dtype=float)
    r, n = J.shape[-2:]
    total = np.zeros(J.shape[:-2])
    for columns in combinations(range(n), r):
        total = total + np.linalg.det(J[..., list(columns)]) ** 2
    return np.sqrt(total)
