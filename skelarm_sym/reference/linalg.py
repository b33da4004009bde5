"""NumPy linear algebra the inverse functions are judged by: damped least squares, manipulability.

Independent of the symbolic side and of the generator's own rank rules: solutions come
from NumPy's eigen-decomposition/SVD.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Solve:
    """Result of :func:`damped_least_squares`. ``...`` is the batch shape.

    Attributes:
        x: the solution, ``(..., n)``.
        rank: rank used for ``A = M M^T + lambda^2 I`` (``r`` when regular), ``(...)``.
        condition: largest over smallest kept eigenvalue of ``A``, ``(...)``: how much
            rounding in ``A`` can be amplified in ``x``.
        rows: ``r``, the size of ``A``.
    """

    x: np.ndarray
    rank: np.ndarray
    condition: np.ndarray
    rows: int

    @property
    def regular(self) -> np.ndarray:
        """True where ``A`` has full rank ``rows`` (the exact inverse was used), ``(...)``."""
        return self.rank == self.rows


def damped_least_squares(M: object, rhs: object, lam: float, rank_tol: float) -> Solve:
    """``x = M^T (M M^T + lam^2 I)^+ rhs`` by eigen-decomposition (NumPy only).

    ``M`` is ``(..., r, n)`` with ``r`` 2 or 3, ``rhs`` ``(..., r)``. The rank rule is
    the documented one of the emitted code, applied to the eigenvalues ``e`` of ``A``
    (``s = sum(e)``, ``c`` the sum of pairwise products): for ``r = 2``, regular when
    ``prod(e) > rank_tol * s**2``, else rank one; for ``r = 3``, rank one when
    ``c <= rank_tol * s**2``, else regular when ``prod(e) > rank_tol * s * c``, else rank two. The pseudo-inverse keeps that many largest eigenvalues.
    """
    M = np.asarray(M, dtype=float)
    rhs = np.asarray(rhs, dtype=float)
    r = M.shape[-2]
    A = M @ np.swapaxes(M, -1, -2) + lam**2 * np.eye(r)
    e, U = np.linalg.eigh(A)  # ascending
    e = np.maximum(e, 0.0)  # A is positive semi-definite; drop rounding below zero
    s = e.sum(axis=-1)
    if r == 2:
        rank = np.where(np.prod(e, axis=-1) > rank_tol * s**2, 2, 1)
    else:
        pairs = e[..., 0] * e[..., 1] + e[..., 0] * e[..., 2] + e[..., 1] * e[..., 2]
        rank = np.where(pairs > rank_tol * s**2, np.where(np.prod(e, axis=-1) > rank_tol * s * pairs, 3, 2), 1)
    keep = np.arange(r) >= (r - rank[..., None])
    safe = np.where(keep, e, 1.0)
    inv_e = np.where(keep, 1.0 / safe, 0.0)
    coeffs = np.einsum("...ji,...j->...i", U, rhs) * inv_e
    u = np.einsum("...ij,...j->...i", U, coeffs)
    x = np.einsum("...ji,...j->...i", M, u)
    smallest = np.take_along_axis(e, (r - rank)[..., None], axis=-1)[..., 0]
    return Solve(x, rank, e[..., -1] / smallest, r)


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
