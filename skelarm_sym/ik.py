"""Pose and position IK for 3-D chains on top of emitted functions (NumPy side; a C version is left to do).

``solve_pose(module, q0, target, ...)`` takes any module (or object) with ``pose(q)`` and
``jacobian(q)`` (the emitted NumPy module or the compiled C wrapper) and runs Levenberg-Marquardt:
error ``e = [p_t - p; log(R_t R^T)]`` (axis-angle of the rotation from the current to the target
orientation, in base axes), step ``dq = J^T (J J^T + mu I)^-1 e`` with ``mu = lambda^2 + c |e|^2``
(Levenberg-Marquardt damping that vanishes at the solution), joint limits by clamping, a step is
accepted only when it lowers ``|e|`` (else ``c`` grows tenfold). Statuses: ``converged`` (position error
<= tol and rotation error <= tol), ``stalled`` (no accepted step can lower the error: closest reach),
``max_iter``, ``invalid`` (non-finite input; raises ``ValueError`` in Python unless ``raise_invalid`` is False).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class IKResult:
    q: np.ndarray
    status: str
    position_error: float
    rotation_error: float
    iterations: int


def rotation_log(R: np.ndarray) -> np.ndarray:
    """Axis-angle vector of a rotation matrix (accurate near 0 and near pi)."""
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = np.linalg.norm(v) / 2.0
    angle = np.arctan2(s, c)
    if angle < 1e-6:
        return v / 2.0 * (1.0 + angle**2 / 6.0)
    if np.pi - angle > 1e-4:
        return v * (angle / (2.0 * s))
    # near pi: axis from the symmetric part
    B = (R + R.T) / 2.0 - c * np.eye(3)
    i = int(np.argmax(np.diag(B)))
    axis = B[:, i] / np.sqrt(max(B[i, i], 1e-300))
    if axis @ v < 0:
        axis = -axis
    return axis * angle


def _error(T: np.ndarray, target: np.ndarray, position_only: bool) -> np.ndarray:
    dp = target[:3, 3] - T[:3, 3]
    if position_only:
        return dp
    return np.concatenate([dp, rotation_log(target[:3, :3] @ T[:3, :3].T)])


def _solve(module, q0, target, lam, tol, max_iter, lower, upper, position_only) -> IKResult:
    q = np.array(q0, dtype=float)
    target = np.asarray(target, dtype=float)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(target)) and np.isfinite(lam) and lam >= 0 and tol > 0 and max_iter >= 0):
        raise ValueError("q0, target, lambda must be finite, lambda >= 0, tol > 0, max_iter >= 0")
    lo = np.full(q.shape, -np.inf) if lower is None else np.array([-np.inf if x is None else x for x in lower], dtype=float)
    hi = np.full(q.shape, np.inf) if upper is None else np.array([np.inf if x is None else x for x in upper], dtype=float)
    q = np.clip(q, lo, hi)
    rows = 3 if position_only else 6
    e = _error(module.pose(q), target, position_only)
    c = 1e-3
    for it in range(max_iter + 1):
        pe = float(np.linalg.norm(e[:3]))
        re = 0.0 if position_only else float(np.linalg.norm(e[3:]))
        if pe <= tol and re <= tol:
            return IKResult(q, "converged", pe, re, it)
        if it == max_iter:
            return IKResult(q, "max_iter", pe, re, it)
        J = module.jacobian(q)[:rows]
        err2 = float(e @ e)
        while True:
            mu = lam**2 + c * err2
            dq = J.T @ np.linalg.solve(J @ J.T + mu * np.eye(rows), e)
            trial = np.clip(q + dq, lo, hi)
            et = _error(module.pose(trial), target, position_only)
            if float(et @ et) < err2:
                q, e = trial, et
                c = max(c / 10.0, 1e-12)
                break
            c *= 10.0
            if c > 1e12:
                return IKResult(q, "stalled", pe, re, it)
    raise AssertionError("unreachable")


def solve_pose(module, q0, target, lam: float = 0.0, tol: float = 1e-10, max_iter: int = 100, limits=None) -> IKResult:
    """Pose IK to ``target`` (4 x 4); ``limits``: ``(lower, upper)`` sequences (``None`` entries: none)."""
    lower, upper = limits if limits is not None else (None, None)
    return _solve(module, q0, target, lam, tol, max_iter, lower, upper, False)


def solve_position(module, q0, target_position, lam: float = 0.0, tol: float = 1e-10, max_iter: int = 100, limits=None) -> IKResult:
    """Position-only IK of the tool origin to ``target_position`` (3)."""
    target = np.eye(4)
    p = np.asarray(target_position, dtype=float)
    if p.shape != (3,):
        raise ValueError("target_position must have shape (3,)")
    target[:3, 3] = p
    lower, upper = limits if limits is not None else (None, None)
    return _solve(module, q0, target, lam, tol, max_iter, lower, upper, True)
