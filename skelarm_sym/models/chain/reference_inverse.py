"""NumPy judges of the chain's inverse functions: SVD, pinv, the recursion's dJ/dt, finite differences.

NumPy only (and :mod:`skelarm_sym.models.chain.reference`); nothing from :mod:`skelarm_sym.derive` or the
program. Batched over leading axes.

* ``manipulability(J)``: product of the singular values (SVD).
* ``jacobian_hessian(chain, q)``: ``Hs[..., r, c, j] = dJ[r, c]/dq_j`` as the recursion's ``dJ/dt`` at
  ``dq = e_j`` (propagated velocities, no differencing, and none of the generator's cross products).
* ``manipulability_gradient(J, Hs)``: ``w tr(J^+ dJ/dq_j)`` with ``w J^+ = V diag(prod_{l != i} s_l) U^T``.
* ``damped_least_squares(J, rhs, lam, rcond, scales)``: ``lam > 0``: ``V diag(s / (s^2 + lam^2)) U^T rhs``;
  ``lam = 0``: the minimum-norm least-squares solution of ``J dq = rhs`` within the row space that the
  SVD of ``S J`` keeps (singular values above ``rcond`` times the largest; ``S = diag(scales)``).
* ``jacobian_rpy(T, J)``: ``blockdiag(I, E^-1) J`` from roll, pitch, yaw by ``atan2``.
* ``central_difference(f, q, h)``: for the tests.
"""

from __future__ import annotations

import numpy as np

from .reference import chain_kinematics

__all__ = [
    "manipulability", "jacobian_hessian", "manipulability_gradient", "damped_least_squares", "jacobian_rpy",
    "central_difference", "solve_condition",
]


def manipulability(J: np.ndarray) -> np.ndarray:
    """Product of the singular values of ``J`` (..., m, n), shape (...)."""
    return np.prod(np.linalg.svd(np.asarray(J, dtype=float), compute_uv=False), axis=-1)


def jacobian_hessian(chain, q: np.ndarray) -> np.ndarray:
    """``(..., 6, n, n)``: ``[..., r, c, j] = dJ[r, c]/dq_j`` (see the module docstring)."""
    q = np.asarray(q, dtype=float)
    n = int(chain.n)
    out = np.empty(q.shape[:-1] + (6, n, n))
    for j in range(n):
        dq = np.zeros_like(q)
        dq[..., j] = 1.0
        out[..., j] = chain_kinematics(chain, q, dq).dJ
    return out


def manipulability_gradient(J: np.ndarray, Hs: np.ndarray) -> np.ndarray:
    """``dw/dq`` (..., n) from ``J`` (..., m, n) and ``Hs`` (..., m, n, n) (rows of ``Hs`` as ``J``'s)."""
    U, s, Vt = np.linalg.svd(np.asarray(J, dtype=float), full_matrices=False)
    k = s.shape[-1]
    others = np.stack([np.prod(np.delete(s, i, axis=-1), axis=-1) for i in range(k)], axis=-1)
    wpinv = np.einsum("...ji,...i,...ki->...jk", np.swapaxes(Vt, -1, -2), others, U)  # (..., n, m)
    return np.einsum("...cr,...rcj->...j", wpinv, Hs)


def damped_least_squares(J, rhs, lam: float, rcond: float, scales=None) -> np.ndarray:
    """``J^T (J J^T + lam^2 I)^-1 rhs``; ``lam = 0``: minimum-norm least squares in the kept row space."""
    J = np.asarray(J, dtype=float)
    rhs = np.asarray(rhs, dtype=float)
    if lam > 0:
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        f = s / (s**2 + lam**2)
        return np.einsum("...ji,...i,...ki,...k->...j", np.swapaxes(Vt, -1, -2), f, U, rhs)
    S = np.ones(J.shape[-2]) if scales is None else np.asarray(scales, dtype=float)
    _, s, Vt = np.linalg.svd(S[:, None] * J, full_matrices=True)
    kept = np.zeros(Vt.shape[:-1], dtype=bool)
    kept[..., : s.shape[-1]] = s > rcond * s[..., :1]
    V = np.swapaxes(Vt, -1, -2) * kept[..., None, :]  # the kept row space (scaled rank rule)
    z = np.einsum("...ij,...j->...i", np.linalg.pinv(J @ V), rhs)  # unweighted least squares in it
    return np.einsum("...ij,...j->...i", V, z)


def solve_condition(J, lam: float, rcond: float, scales=None) -> np.ndarray:
    """``(s_max^2 + lam^2) / (s_min_kept^2 + lam^2)`` of the scaled ``J``: how much rounding the solve amplifies;
    1 (nothing amplified) where ``J`` is zero and ``lam`` is 0 (a rotor's tool origin on its axis)."""
    J = np.asarray(J, dtype=float)
    S = np.ones(J.shape[-2]) if scales is None else np.asarray(scales, dtype=float)
    s = np.linalg.svd(S[:, None] * J, compute_uv=False)
    top = s[..., :1]
    kept = np.where(s > rcond * top, s, np.inf)
    smallest = kept.min(axis=-1)
    smallest = np.where(np.isfinite(smallest), smallest, top[..., 0])
    return np.maximum(1.0, (top[..., 0] ** 2 + lam**2) / np.maximum(smallest**2 + lam**2, 1e-300))


def rpy(R: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (..., 3) of ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    R = np.asarray(R, dtype=float)
    pitch = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 0, 0], R[..., 1, 0]))
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    return np.stack([roll, pitch, yaw], axis=-1)


def jacobian_rpy(T: np.ndarray, J: np.ndarray) -> np.ndarray:
    """``blockdiag(I, E^-1) J`` with ``omega = E d(rpy)/dt`` (regular poses only)."""
    angles = rpy(np.asarray(T)[..., :3, :3])
    p, y = angles[..., 1], angles[..., 2]
    cp, sp_, cy, sy = np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    zero, one = np.zeros_like(p), np.ones_like(p)
    Einv = np.stack([
        np.stack([cy / cp, sy / cp, zero], axis=-1),
        np.stack([-sy, cy, zero], axis=-1),
        np.stack([cy * sp_ / cp, sy * sp_ / cp, one], axis=-1),
    ], axis=-2)
    J = np.asarray(J, dtype=float)
    return np.concatenate([J[..., :3, :], Einv @ J[..., 3:, :]], axis=-2)


def central_difference(f, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """``[..., j] = (f(q + h e_j) - f(q - h e_j)) / 2h`` for ``f`` of one configuration (..., n)."""
    q = np.asarray(q, dtype=float)
    cols = []
    for j in range(q.shape[-1]):
        e = np.zeros_like(q)
        e[..., j] = h
        cols.append((np.asarray(f(q + e)) - np.asarray(f(q - e))) / (2 * h))
    return np.stack(cols, axis=-1)


def reach_length(chain) -> float:
    """The judge's own length scale of the rank rule: the sum of the lengths of the chain's constant
    translations after the base (1 when there are none), from the numeric chain."""
    total = sum(float(np.linalg.norm(m[:3, 3])) for j in chain.joints for m in (j.before, j.after))
    total += float(np.linalg.norm(np.asarray(chain.tool)[:3, 3]))
    return total if total > 0 else 1.0


def jacobian_rpy_locked(T: np.ndarray, J: np.ndarray) -> np.ndarray:
    """The documented value of the roll-pitch-yaw Jacobian at gimbal lock (pitch = +-pi/2): the roll and
    yaw rows zero, the pitch row ``[-sin(yaw), cos(yaw), 0]`` with yaw read from R as ``atan2(-R01, R11)``
    (the roll = 0 convention)."""
    R = np.asarray(T, dtype=float)[..., :3, :3]
    yaw = np.arctan2(-R[..., 0, 1], R[..., 1, 1])
    zero = np.zeros_like(yaw)
    Einv = np.stack([
        np.stack([zero, zero, zero], axis=-1),
        np.stack([-np.sin(yaw), np.cos(yaw), zero], axis=-1),
        np.stack([zero, zero, zero], axis=-1),
    ], axis=-2)
    J = np.asarray(J, dtype=float)
    return np.concatenate([J[..., :3, :], Einv @ J[..., 3:, :]], axis=-2)


REGULAR, LOCKED = 1e-6, 1e-20
"""The judge's gimbal-lock bands for cos(pitch)^2: above REGULAR a pose is regular (atan2 angles), below
LOCKED it is locked (the documented value); between, where the emitted code's own switch lies, either
answer is right and the check accepts the one the code gave."""


def check_expectations(chain, q, kinematics, rcond: float, rng, rounded, floor: float):
    """Expected values for the check of the inverse functions (NumPy only; used by the chain's check).

    Returns ``(forward, forward_condition, alternatives, solves)``: outputs computable from ``q`` alone
    with their tolerance scaling, second documented answers near a switch, and a list of
    ``(label, extra_values, expected, condition, second_answers, second_condition)`` for the solves (undamped
    and damped). ``rcond`` is the judge's relative SVD cut-off (from the working precision, not the
    generator's rank rule); the rows of the 6-row solve are scaled by the judge's own :func:`reach_length`.

    Undamped solves have a second answer: the minimum-norm solution keeping every singular value above
    ``floor`` (one machine epsilon of the working precision). Where the smallest lies between that and the cut-off, the code's rank rule (a
    Gram-Schmidt residual, which is at least the smallest singular value and may be much larger) can keep
    the direction the judge drops, and then its answer is the exact inverse rounded, not the truncated
    one (seen: float UR5 near the wrist singularity, q5 = -1.7e-4, ratio 3.6e-6, |dq| 1.2e4). Its
    ``second_condition`` is the relative error allowed there, not a factor of the tolerance: ``n`` machine
    epsilons times the ratio of the kept singular values (times the reach for the 6-row solve), the
    forward error of a backward-stable solve on the rows of J (Gram-Schmidt), not on J J^T. (Zero, or the
    truncated answer, is then still far outside it: it would not do to accept any answer there.)
    """
    J, T = kinematics.J, kinematics.T
    m, n = len(q), int(chain.n)
    length = reach_length(chain)
    Hs = jacobian_hessian(chain, q)
    w = manipulability(J)
    row_norms = np.linalg.norm(J, axis=-1)
    hadamard = np.prod(np.maximum(row_norms, 1e-300), axis=-1) if n >= 6 else np.prod(np.linalg.norm(J, axis=-2), axis=-1)
    grad = manipulability_gradient(J, Hs)
    R = T[..., :3, :3]
    c2 = R[..., 0, 0] ** 2 + R[..., 1, 0] ** 2
    locked = c2 < LOCKED
    safe = np.where(locked[:, None, None], np.eye(4), T)
    JA_regular = jacobian_rpy(safe, J)
    JA_locked = jacobian_rpy_locked(T, J)
    forward = {
        "w": w[:, None],
        "w_position": manipulability(J[..., :3, :])[:, None],
        "Hs": Hs,
        "grad": grad,
        "JA": np.where(locked[:, None, None], JA_locked, JA_regular),
    }
    alternatives = {"JA": np.where((c2 <= REGULAR)[:, None, None], JA_locked, forward["JA"])}
    size = lambda x: np.maximum(1.0, np.abs(x).reshape(m, -1).max(axis=-1))  # noqa: E731
    hmax = np.abs(Hs).reshape(m, -1).max(axis=-1)
    # the judge's own product of singular values is off by about eps sigma_1 prod_{i<n} sigma_i (each sigma_i by
    # eps sigma_1): at a singular pose that is not bounded by the rows' product (a zero row: UR5 at q = 0), and
    # in millimetres it is 1e9 times the metre's (w = 0 exactly, the judge 5e-10)
    def svd_scale(jac):
        s = np.linalg.svd(jac, compute_uv=False)
        return s[..., 0] * np.prod(s[..., :-1], axis=-1)

    condition = {
        "w": np.maximum(np.maximum(1.0, hadamard / size(w)), svd_scale(J) / size(w)),
        "w_position": np.maximum(np.maximum(1.0, np.prod(np.linalg.norm(J[..., :3, :], axis=-1), axis=-1) / size(w)),
                                 svd_scale(J[..., :3, :]) / size(w)),
        "Hs": np.maximum(1.0, 3 * hmax / size(Hs)),
        "grad": np.maximum(1.0, n * hadamard * np.maximum(hmax, 1.0) / size(grad)),
        "JA": np.where(locked, 1.0, np.maximum(1.0, np.abs(J).reshape(m, -1).max(axis=-1) / np.maximum(c2, LOCKED) / size(forward["JA"]))),
    }
    # w is not differentiable where J loses rank: no value to compare the gradient with there
    sv = np.linalg.svd(J, compute_uv=False)
    condition["grad"] = np.where(sv[..., -1] > 1e-6 * sv[..., 0], condition["grad"], 1e300)
    twist = rounded(rng.uniform(-1, 1, (m, 6)))
    scales = np.array([1 / length] * 3 + [1.0] * 3)
    solves = []
    for lam in (0.0, 0.1):
        dq = damped_least_squares(J, twist, lam, rcond, scales)
        dqp = damped_least_squares(J[..., :3, :], twist[..., :3], lam, rcond)
        c6 = solve_condition(J, lam, rcond, scales) * np.maximum(1.0, length)
        c3 = solve_condition(J[..., :3, :], lam, rcond)
        expected = {"dq": dq, "dq_position": dqp}
        cond = {"dq": c6, "dq_position": c3}
        kept, kept_condition = {}, {}
        if lam == 0:  # the code may keep a direction the judge drops: the answer on that rank is right too
            kept = {"dq": damped_least_squares(J, twist, 0.0, floor, scales),
                    "dq_position": damped_least_squares(J[..., :3, :], twist[..., :3], 0.0, floor)}
            bound = max(n, 2) * floor  # n epsilons times the ratio of the kept singular values (times the reach)
            kept_condition = {"dq": bound * np.sqrt(solve_condition(J, 0.0, floor, scales)) * np.maximum(1.0, length),
                              "dq_position": bound * np.sqrt(solve_condition(J[..., :3, :], 0.0, floor))}
        solves.append((f"lambda={lam:g}", {"twist": twist, "v": twist[..., :3], "lambda": lam}, expected, cond,
                       kept, kept_condition))
    return forward, condition, alternatives, solves

