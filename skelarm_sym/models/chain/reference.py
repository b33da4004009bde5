"""Recursive NumPy reference for the general serial chain: the judge of the symbolic side.

Imports NumPy only (nothing from :mod:`skelarm_sym.derive`, the program or the backends) and
reads a *numeric* chain, duck-typed: ``chain.joints`` (each with ``kind`` "revolute" or
"prismatic", ``before`` (4, 4), ``axis`` (3,), ``after`` (4, 4), ``coordinate``, ``offset``,
``multiplier``), ``chain.base``, ``chain.tool`` (4, 4) and ``chain.n`` (what
``Chain.numeric()`` returns).

Everything is in BASE axes. The forward recursion of seed 001, written for the general chain
``T = base * prod_k [before_k * M_k(theta_k) * after_k] * tool`` with
``theta_k = multiplier_k * q[coordinate_k] + offset_k``. The state carried along the chain is the
pose (R, p) of the current frame, the angular velocity ``w`` and acceleration ``dw`` of the link
it is fixed in, and the velocity ``v`` and classical acceleration ``a`` of its origin:

* a constant transform (``before``, ``after``, ``tool``) moves the origin by ``r`` within the
  same link::

      v' = v + w x r,    a' = a + dw x r + w x (w x r),    w, dw unchanged

* a revolute joint (unit axis ``z`` through the current origin ``o``) leaves the origin
  where it is and adds a relative rotation::

      w' = w + z dth,    dw' = dw + z ddth + w x z dth,    v, a unchanged

* a prismatic joint moves the origin by ``r = z th`` along the axis::

      v'  = v + w x r + z dth
      a'  = a + dw x r + w x (w x r) + 2 w x z dth + z ddth,    w, dw unchanged

The geometric Jacobian uses seed 003's columns (``o_k``, ``z_k``: origin and axis of joint
``k``'s frame after ``before_k``; ``p_e`` the tool origin)::

      revolute:  [z_k x (p_e - o_k); z_k]      prismatic: [z_k; 0]

scaled by ``multiplier_k`` and added into column ``coordinate_k`` (mimic joints add up). Its
time derivative comes from the recursion's velocities, never from differencing::

      d/dt z_k = w_{k-1} x z_k,    d/dt (p_e - o_k) = v_e - v(o_k)

``twist`` and ``acc`` are read off the recursion at the tool; that they equal ``J dq`` and
``J ddq + dJ dq`` is checked by the tests, not used here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ChainKinematics", "chain_kinematics", "rodrigues"]


@dataclass(frozen=True)
class ChainKinematics:
    """Result of :func:`chain_kinematics`; ``...`` is the batch shape of ``q``.

    ``T`` (..., 4, 4) tool pose in the base frame. ``J`` (..., 6, n) geometric Jacobian, rows
    vx vy vz wx wy wz in base axes, reference point the tool origin (LOCAL_WORLD_ALIGNED);
    ``J_tool`` the same in tool axes; ``dJ`` its time derivative (base axes). ``twist`` (..., 6)
    tool-origin velocity and angular velocity; ``acc`` (..., 6) classical acceleration of the tool
    origin and angular acceleration. ``origins``/``axes`` (..., m, 3): ``o_k`` and ``z_k`` per moving
    joint (m joints, base to tip), for diagnostics.
    """

    T: np.ndarray
    J: np.ndarray
    J_tool: np.ndarray
    dJ: np.ndarray
    twist: np.ndarray
    acc: np.ndarray
    origins: np.ndarray
    axes: np.ndarray


EYE3 = np.eye(3)


def rodrigues(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) by ``angle`` (...) about the unit ``axis`` (3,)."""
    k = np.asarray(axis, dtype=float)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    angle = np.asarray(angle, dtype=float)[..., None, None]
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis (broadcasting; np.cross is several times slower on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def _array(value: object, name: str, n: int) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.ndim < 1 or array.shape[-1] != n:
        raise ValueError(f"{name} must have shape (..., {n}), got {array.shape}")
    return array


def chain_kinematics(chain, q, dq=None, ddq=None) -> ChainKinematics:
    """Pose, Jacobian, its derivative, twist and acceleration of the tool by the forward recursion.

    ``q``, ``dq``, ``ddq`` (..., n) broadcast together; ``dq`` and ``ddq`` default to zeros. Without either,
    every rate is zero and the recursion carries only pose and axes (the rates' terms would add exact zeros).
    """
    n = int(chain.n)
    moving = dq is not None or ddq is not None
    q = _array(q, "q", n)
    dq = np.zeros_like(q) if dq is None else _array(dq, "dq", n)
    ddq = np.zeros_like(q) if ddq is None else _array(ddq, "ddq", n)
    q, dq, ddq = np.broadcast_arrays(q, dq, ddq)
    batch = q.shape[:-1]

    cross = _cross
    zero3 = np.zeros(batch + (3,))

    def rigid(state, transform):
        """Move along a constant transform: same link, origin displaced by R t. An exact identity rotation
        leaves R as it is, a zero displacement leaves p, v and a (the terms it skips are exact zeros)."""
        R, p, w, dw, v, a = state
        transform = np.asarray(transform, dtype=float)
        t = transform[:3, 3]
        if np.any(t):
            r = np.einsum("...ij,j->...i", R, t)
            p = p + r
            if moving:
                v, a = v + cross(w, r), a + cross(dw, r) + cross(w, cross(w, r))
        if not np.array_equal(transform[:3, :3], EYE3):
            R = R @ transform[:3, :3]
        return (R, p, w, dw, v, a)

    base = np.asarray(chain.base, dtype=float)
    # positions are carried relative to the first joint's origin, a point fixed in the base (nothing moves before
    # the first joint), and the tool's is moved back at the end: every result but T's translation depends on
    # differences of positions only, which an arm mounted far from the world origin (a map frame's 4.5e6 m) would
    # otherwise take between large numbers, losing their digits
    first = np.asarray(chain.joints[0].before, dtype=float) if chain.joints else np.eye(4)
    anchor = base[:3, 3] + base[:3, :3] @ first[:3, 3]
    state = (np.broadcast_to(base[:3, :3], batch + (3, 3)).copy(), np.broadcast_to(base[:3, 3] - anchor, batch + (3,)).copy(),
             zero3, zero3, zero3, zero3)

    origins, axes, kinds, coords, mults = [], [], [], [], []
    w_before, v_before = [], []
    for joint in chain.joints:
        state = rigid(state, joint.before)
        R, p, w, dw, v, a = state
        mult = float(joint.multiplier)
        c = int(joint.coordinate)
        th = mult * q[..., c] + float(joint.offset)
        dth = (mult * dq[..., c])[..., None]
        ddth = (mult * ddq[..., c])[..., None]
        axis = np.asarray(joint.axis, dtype=float)
        z = np.einsum("...ij,j->...i", R, axis)
        origins.append(p)
        axes.append(z)
        w_before.append(w)
        v_before.append(v)
        kinds.append(joint.kind)
        coords.append(c)
        mults.append(mult)
        if joint.kind == "revolute":
            if moving:
                w, dw = w + z * dth, dw + z * ddth + cross(w, z) * dth
            state = (R @ rodrigues(axis, th), p, w, dw, v, a)
        elif joint.kind == "prismatic":
            r = z * th[..., None]
            if moving:
                v, a = (v + cross(w, r) + z * dth,
                        a + cross(dw, r) + cross(w, cross(w, r)) + 2.0 * cross(w, z) * dth + z * ddth)
            state = (R, p + r, w, dw, v, a)
        else:
            raise ValueError(f"joint kind must be revolute or prismatic, got {joint.kind!r}")
        state = rigid(state, joint.after)
    state = rigid(state, chain.tool)
    R_e, p_e, w_e, dw_e, v_e, a_e = state

    J = np.zeros(batch + (6, n))
    dJ = np.zeros(batch + (6, n))
    for o, z, kind, c, mult, w, v_o in zip(origins, axes, kinds, coords, mults, w_before, v_before):
        if kind == "revolute":
            r = p_e - o
            J[..., :3, c] += mult * cross(z, r)
            J[..., 3:, c] += mult * z
        else:
            J[..., :3, c] += mult * z
        if not moving:
            continue  # dJ = 0
        dz = cross(w, z)
        if kind == "revolute":
            dJ[..., :3, c] += mult * (cross(dz, r) + cross(z, v_e - v_o))
            dJ[..., 3:, c] += mult * dz
        else:
            dJ[..., :3, c] += mult * dz

    T = np.zeros(batch + (4, 4))
    T[..., :3, :3] = R_e
    T[..., :3, 3] = p_e + anchor
    T[..., 3, 3] = 1.0
    Rt = np.swapaxes(R_e, -1, -2)
    J_tool = np.concatenate([Rt @ J[..., :3, :], Rt @ J[..., 3:, :]], axis=-2)
    twist = np.concatenate([v_e, w_e], axis=-1)
    acc = np.concatenate([a_e, dw_e], axis=-1)
    m = len(origins)
    return ChainKinematics(
        T, J, J_tool, dJ, twist, acc,
        np.stack(origins, axis=-2) + anchor if m else np.zeros(batch + (0, 3)),
        np.stack(axes, axis=-2) if m else np.zeros(batch + (0, 3)),
    )
