"""Recursive NumPy reference for the planar chain (seed 000): the judge of the symbolic side.

This module deliberately imports nothing from the derivation or code generation,
so that it can check them independently. It follows the recursions as written:

* forward pass (base to endpoint), for i = 1..n::

      theta_i  = theta_{i-1} + q_i
      x_i      = x_{i-1} + l_i cos theta_i,           y_i = y_{i-1} + l_i sin theta_i
      dtheta_i = dtheta_{i-1} + dq_i
      dx_i     = dx_{i-1} - dtheta_i l_i sin theta_i,  dy_i = dy_{i-1} + dtheta_i l_i cos theta_i
      ddtheta_i = ddtheta_{i-1} + ddq_i
      ddx_i = ddx_{i-1} - dtheta_i^2 l_i cos theta_i - ddtheta_i l_i sin theta_i
      ddy_i = ddy_{i-1} - dtheta_i^2 l_i sin theta_i + ddtheta_i l_i cos theta_i

* backward pass (endpoint to base), for i = n..1::

      j_xi = j_x(i+1) - l_i sin theta_i,   j_yi = j_y(i+1) + l_i cos theta_i
      h_xi = -(dy_n - dy_{i-1}),           h_yi = dx_n - dx_{i-1}

  (``h_i = d j_i / dt``; the sum form of ``h`` printed in seed 000 is wrong for i >= 2.)

Shapes: ``q``, ``dq``, ``ddq`` are ``(..., n)``; ``lengths`` is ``(n,)`` or
broadcastable to ``(..., n)``. Leading dimensions are a batch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputError


@dataclass(frozen=True)
class Kinematics:
    """Result of :func:`kinematics`. ``...`` is the batch shape.

    Per joint (index 0 is the base, index i the far end of link i, index n the endpoint):
    ``joints`` ``(..., n+1, 2)`` positions, ``joint_velocities`` and
    ``joint_accelerations`` likewise. Per link: ``theta``, ``dtheta``, ``ddtheta``
    ``(..., n)`` absolute angle and its rates.
    Endpoint: ``p``, ``v``, ``a`` ``(..., 2)``; ``J`` and ``H`` ``(..., 2, n)`` with
    row 0 the x components and row 1 the y components.
    """

    theta: np.ndarray
    dtheta: np.ndarray
    ddtheta: np.ndarray
    joints: np.ndarray
    joint_velocities: np.ndarray
    joint_accelerations: np.ndarray
    J: np.ndarray
    H: np.ndarray

    @property
    def p(self) -> np.ndarray:
        """Endpoint position ``(..., 2)``."""
        return self.joints[..., -1, :]

    @property
    def v(self) -> np.ndarray:
        """Endpoint velocity ``(..., 2)``."""
        return self.joint_velocities[..., -1, :]

    @property
    def a(self) -> np.ndarray:
        """Endpoint acceleration ``(..., 2)``."""
        return self.joint_accelerations[..., -1, :]

    @property
    def phi(self) -> np.ndarray:
        """Endpoint orientation (absolute angle of the last link) ``(...)``."""
        return self.theta[..., -1]

    @property
    def J3(self) -> np.ndarray:
        """Planar Jacobian with the orientation row appended ``(..., 3, n)``."""
        ones = np.ones(self.J.shape[:-2] + (1, self.J.shape[-1]))
        return np.concatenate([self.J, ones], axis=-2)


def _as_joint_array(value: object, name: str, n: int | None) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.ndim < 1:
        raise InputError(f"{name} must have shape (..., n), got a scalar")
    if n is not None and array.shape[-1] != n:
        raise InputError(f"{name} must have shape (..., {n}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise InputError(f"{name} must be finite")
    return array


def kinematics(q: object, dq: object | None = None, ddq: object | None = None, lengths: object | None = None) -> Kinematics:
    """Run the forward and backward recursions of seed 000.

    ``q`` ``(..., n)`` relative joint angles in radians; ``dq``, ``ddq`` their
    first and second time derivatives (zeros when omitted); ``lengths`` ``(n,)``
    link lengths (ones when omitted). All inputs broadcast over leading dimensions.
    """
    q = _as_joint_array(q, "q", None)
    n = q.shape[-1]
    if n < 1:
        raise InputError("q must hold at least one joint angle")
    dq = np.zeros_like(q) if dq is None else _as_joint_array(dq, "dq", n)
    ddq = np.zeros_like(q) if ddq is None else _as_joint_array(ddq, "ddq", n)
    lengths = np.ones(n) if lengths is None else _as_joint_array(lengths, "lengths", n)
    if np.any(lengths <= 0):
        raise InputError("lengths must be positive")
    q, dq, ddq, lengths = np.broadcast_arrays(q, dq, ddq, lengths)
    batch = q.shape[:-1]

    theta = np.empty(batch + (n,))
    dtheta = np.empty(batch + (n,))
    ddtheta = np.empty(batch + (n,))
    pos = np.zeros(batch + (n + 1, 2))
    vel = np.zeros(batch + (n + 1, 2))
    acc = np.zeros(batch + (n + 1, 2))
    th = dth = ddth = np.zeros(batch)
    for i in range(n):
        th = th + q[..., i]
        dth = dth + dq[..., i]
        ddth = ddth + ddq[..., i]
        theta[..., i], dtheta[..., i], ddtheta[..., i] = th, dth, ddth
        lc = lengths[..., i] * np.cos(th)
        ls = lengths[..., i] * np.sin(th)
        pos[..., i + 1, 0] = pos[..., i, 0] + lc
        pos[..., i + 1, 1] = pos[..., i, 1] + ls
        vel[..., i + 1, 0] = vel[..., i, 0] - dth * ls
        vel[..., i + 1, 1] = vel[..., i, 1] + dth * lc
        acc[..., i + 1, 0] = acc[..., i, 0] - dth * dth * lc - ddth * ls
        acc[..., i + 1, 1] = acc[..., i, 1] - dth * dth * ls + ddth * lc

    J = np.empty(batch + (2, n))
    H = np.empty(batch + (2, n))
    jx = np.zeros(batch)
    jy = np.zeros(batch)
    for i in reversed(range(n)):
        jx = jx - lengths[..., i] * np.sin(theta[..., i])
        jy = jy + lengths[..., i] * np.cos(theta[..., i])
        J[..., 0, i] = jx
        J[..., 1, i] = jy
        H[..., 0, i] = -(vel[..., n, 1] - vel[..., i, 1])
        H[..., 1, i] = vel[..., n, 0] - vel[..., i, 0]
    return Kinematics(theta, dtheta, ddtheta, pos, vel, acc, J, H)
