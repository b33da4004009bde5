"""Judge of "all IK solutions": pose reproduction, completeness against a numeric multi-start IK, EAIK.

NumPy only, on top of this package's forward recursion (:func:`.reference.chain_kinematics`); it imports
nothing from :mod:`skelarm_sym.closed_ik` (a test reads the imports). It reads a *numeric* chain (what
``Chain.numeric()`` returns) and solutions as arrays ``(k, n)``.

* :func:`pose_error`: ``|p(q) - p_t| / reach`` and ``max |R(q) - R_t|`` (both dimensionless), with
  ``reach`` the sum of the lengths of the chain's constant translations (:func:`reach`).
* :func:`multistart_ik`: Levenberg-Marquardt from ``starts`` random configurations (uniform in
  ``[-pi, pi]`` for revolute joints, in ``[-reach, reach]`` for prismatic ones; unconstrained), batched over
  the starts: error ``[p_t - p; log(R_t R^T)]`` in base axes with the geometric Jacobian of the reference
  (LOCAL_WORLD_ALIGNED); damping ``mu`` per start, divided by 3 after a successful step and multiplied by 4
  otherwise; a start whose weighted error is below ``tol / 1000`` takes no more steps. Converged: both errors
  of :func:`pose_error` at most ``tol``. Coordinates in ``fixed`` (a dict ``{coordinate: value}``, the locked
  joint) do not move. Returns the distinct converged configurations. :func:`multistart_ik_each` gives the
  same for many targets at once (one batch of every target's starts: about 2.5x faster for ten targets).
* :func:`same`: two configurations equal within ``tol`` (revolute joints modulo 2 pi).
* :func:`missing`: the rows of one set that have no equal in another.
* :func:`eaik_solutions`: EAIK's solutions (``pip install eaik``; ``None`` when it is not installed) from
  the product-of-exponentials data of :func:`hp_data` (EAIK's layout) for the pose ``[R_t R_0^T, p_t]``.
"""

from __future__ import annotations

import numpy as np

from .reference import chain_kinematics

__all__ = ["reach", "pose_error", "multistart_ik", "multistart_ik_each", "same", "missing", "hp_data", "eaik_solutions", "revolute_mask"]


def revolute_mask(chain) -> np.ndarray:
    """(n,) bool: coordinate ``c`` is revolute (moves a revolute joint)."""
    mask = np.zeros(int(chain.n), bool)
    for j in chain.joints:
        if j.kind == "revolute":
            mask[int(j.coordinate)] = True
    return mask


def reach(chain) -> float:
    """Sum of the lengths of the chain's constant translations (m): the length scale of relative errors."""
    total = float(np.linalg.norm(np.asarray(chain.base)[:3, 3]) + np.linalg.norm(np.asarray(chain.tool)[:3, 3]))
    for j in chain.joints:
        total += float(np.linalg.norm(np.asarray(j.before)[:3, 3]) + np.linalg.norm(np.asarray(j.after)[:3, 3]))
    return max(total, 1e-300)


def pose_error(chain, q, target) -> tuple[np.ndarray, np.ndarray]:
    """``(position error / reach, max |R - R_t|)`` of configurations ``q`` (..., n) against ``target`` (4, 4), or
    each against its own (..., 4, 4)."""
    T = chain_kinematics(chain, q).T
    target = np.asarray(target, float)
    if target.shape[-1] == 16:  # row-major 16-vectors
        target = target.reshape(*target.shape[:-1], 4, 4)
    pos = np.linalg.norm(T[..., :3, 3] - target[..., :3, 3], axis=-1) / reach(chain)
    rot = np.max(np.abs(T[..., :3, :3] - target[..., :3, :3]), axis=(-1, -2))
    return pos, rot


def _log3(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of rotations (..., 3, 3) (the angle in [0, pi])."""
    v = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    s = np.linalg.norm(v, axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    theta = np.arctan2(s, c)
    scale = np.where(s > 1e-12, theta / np.maximum(s, 1e-300), 1.0)
    out = v * scale[..., None]
    # near pi: the axis from the symmetric part
    near_pi = (s <= 1e-6) & (c < 0)
    if np.any(near_pi):
        B = 0.5 * (R[near_pi] + np.swapaxes(R[near_pi], -1, -2)) - c[near_pi, None, None] * np.eye(3)
        idx = np.argmax(np.diagonal(B, axis1=-2, axis2=-1), axis=-1)
        axis = B[np.arange(len(idx)), idx]
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        out[near_pi] = axis * theta[near_pi, None]
    return out


def _errors(chain, q, target):
    """Errors ``[p_t - p; log(R_t R^T)]`` (..., 6) and the Jacobian (..., 6, n) of ``q`` (..., n) against ``target``
    (..., 4, 4), broadcast together."""
    kin = chain_kinematics(chain, q)
    T = kin.T
    e = np.concatenate([target[..., :3, 3] - T[..., :3, 3],
                        _log3(target[..., :3, :3] @ np.swapaxes(T[..., :3, :3], -1, -2))], -1)
    return e, kin.J


def multistart_ik(chain, target, starts: int = 200, seed: int = 0, iterations: int = 60, tol: float = 1e-10,
                  fixed: dict[int, float] | None = None, dup_tol: float = 1e-6) -> np.ndarray:
    """Distinct converged configurations (k, n) of an unconstrained multi-start Levenberg-Marquardt IK (see the module docstring)."""
    target = np.asarray(target, float).reshape(1, 4, 4)
    return multistart_ik_each(chain, target, starts, [seed], iterations, tol, fixed, dup_tol)[0]


def multistart_ik_each(chain, targets, starts: int = 200, seeds=None, iterations: int = 60, tol: float = 1e-10,
                       fixed: dict | None = None, dup_tol: float = 1e-6) -> list[np.ndarray]:
    """:func:`multistart_ik` for each of ``targets`` (m, 4, 4) at once: one list entry (k, n) per target, each the
    result of ``multistart_ik(chain, targets[i], starts, seeds[i], ..., {c: values[i]})``. ``seeds``: m seeds
    (default 0 for every target); ``fixed``: ``{coordinate: value}`` with a value per target (m,) or one for all.
    The targets' starts are solved as one batch (m * starts configurations), each start on its own."""
    n = int(chain.n)
    targets = np.asarray(targets, float).reshape(-1, 4, 4)
    m = len(targets)
    seeds = [0] * m if seeds is None else [int(s) for s in seeds]
    if len(seeds) != m:
        raise ValueError(f"multistart_ik_each: {len(seeds)} seeds for {m} targets")
    rev = revolute_mask(chain)
    L = reach(chain)
    q = np.empty((m, starts, n))
    for i, seed in enumerate(seeds):
        rng = np.random.default_rng(seed)
        q[i] = np.where(rev, rng.uniform(-np.pi, np.pi, (starts, n)), rng.uniform(-L, L, (starts, n)))
    free = np.ones(n, bool)
    for c, v in (fixed or {}).items():
        q[:, :, c] = np.broadcast_to(np.asarray(v, float), (m,))[:, None]
        free[c] = False
    q = q.reshape(m * starts, n)
    target = np.repeat(targets, starts, axis=0)  # each start's own target (m * starts, 4, 4)
    W = np.concatenate([np.full(3, 1.0 / L), np.ones(3)])  # position in reaches, rotation in radians
    e, J = _errors(chain, q, target)
    cost = np.sum((W * e) ** 2, -1)
    mu = np.full(len(q), 1e-3)
    # a start whose weighted error is a thousandth of tol has converged for good (a step is accepted only when
    # it lowers the error, so later steps would move it by about that much): it stops taking steps
    settled = (1e-3 * tol) ** 2
    for _ in range(iterations):
        k = np.flatnonzero(cost > settled)
        if k.size == 0:
            break
        A = (W[:, None] * J[k]) * free
        g = np.einsum("kij,ki->kj", A, W * e[k])
        H = np.einsum("kij,kil->kjl", A, A) + mu[k, None, None] * np.eye(n)
        dq = np.linalg.solve(H, g[..., None])[..., 0]
        step = np.linalg.norm(dq, axis=-1, keepdims=True)
        dq = dq * np.minimum(1.0, 1.0 / np.maximum(step, 1e-300))
        e2, J2 = _errors(chain, q[k] + dq, target[k])
        cost2 = np.sum((W * e2) ** 2, -1)
        better = cost2 < cost[k]
        q[k] = np.where(better[:, None], q[k] + dq, q[k])
        e[k] = np.where(better[:, None], e2, e[k])
        J[k] = np.where(better[:, None, None], J2, J[k])
        cost[k] = np.where(better, cost2, cost[k])
        mu[k] = np.where(better, np.maximum(mu[k] / 3.0, 1e-12), np.minimum(mu[k] * 4.0, 1e8))
    pos, rot = pose_error(chain, q, target)
    converged = ((pos <= tol) & (rot <= tol)).reshape(m, starts)
    q = q.reshape(m, starts, n)
    results = []
    for i in range(m):
        # in start order, a configuration is kept unless it equals (see same) one kept before it
        left = _wrapped(q[i][converged[i]], rev)
        out: list[np.ndarray] = []
        while len(left):
            out.append(left[0])
            left = left[np.max(np.abs(_wrapped(left - left[0], rev)), axis=-1) > dup_tol]
        results.append(np.array(out).reshape(-1, n))
    return results


def _wrapped(d: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """``d`` (..., n) with its revolute entries taken into [-pi, pi)."""
    return np.where(revolute, (d + np.pi) % (2 * np.pi) - np.pi, d)


def same(a: np.ndarray, b: np.ndarray, revolute: np.ndarray, tol: float) -> bool:
    """``max |a - b| <= tol``, revolute differences taken modulo 2 pi."""
    return bool(np.max(np.abs(_wrapped(np.asarray(a, float) - np.asarray(b, float), revolute))) <= tol)


def missing(found: np.ndarray, reference: np.ndarray, revolute: np.ndarray, tol: float) -> np.ndarray:
    """Rows of ``reference`` with no row of ``found`` equal to them (see :func:`same`)."""
    rows = [r for r in np.asarray(reference).reshape(-1, len(revolute))
            if not any(same(f, r, revolute, tol) for f in np.asarray(found).reshape(-1, len(revolute)))]
    return np.array(rows).reshape(-1, len(revolute))


def hp_data(chain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """EAIK's product-of-exponentials data from the forward recursion at ``q = 0``: ``H`` (m, 3) unit axes,
    ``P`` (m + 1, 3) offsets (``P[0]`` base origin to joint 1's point, ``P[i]`` joint i's point to joint i+1's,
    ``P[m]`` to the tool origin), and ``R0`` (3, 3) the tool rotation at ``q = 0``."""
    kin = chain_kinematics(chain, np.zeros(int(chain.n)))
    H, O = kin.axes, kin.origins
    P = np.vstack([O[:1], np.diff(O, axis=0), kin.T[:3, 3][None] - O[-1:]])
    return H, P, kin.T[:3, :3]


def eaik_solutions(chain, target, fixed: dict[int, float] | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """EAIK's ``(Q (k, n), is_LS (k,))`` for ``target`` (4, 4), from :func:`hp_data` (revolute chains without
    mimic joints); ``fixed``: ``{joint index: value}`` locked joints (EAIK's ``fixed_axes``). ``None`` when EAIK
    is not installed."""
    try:
        from eaik.IK_HP import HPRobot
    except ImportError:
        return None
    H, P, R0 = hp_data(chain)
    # an axis parallel to an earlier one but pointing the other way is turned to point the same way (its joint's
    # value negated): EAIK 1.2's HPRobot answered a UR-like arm whose parallel axes point opposite ways with eight
    # solutions, none reproducing the target (a probe of reversed URDF axes)
    sign = np.ones(len(H))
    for i in range(len(H)):
        for j in range(i):
            if abs(abs(H[i] @ H[j]) - 1.0) <= 1e-12:
                sign[i] = sign[j] * np.sign(H[i] @ H[j])
                break
    H = H * sign[:, None]
    robot = HPRobot(H, P, fixed_axes=sorted((k, sign[k] * v) for k, v in (fixed or {}).items()))
    target = np.asarray(target, float).reshape(4, 4)
    pose = np.eye(4)
    pose[:3, :3] = target[:3, :3] @ R0.T
    pose[:3, 3] = target[:3, 3]
    sol = robot.IK(pose)
    Q = np.asarray(sol.Q, float)
    Q = Q.reshape(len(Q), -1) if Q.size else Q.reshape(0, len(H))
    return Q * sign[None, :], np.asarray(sol.is_LS, bool).reshape(-1)
