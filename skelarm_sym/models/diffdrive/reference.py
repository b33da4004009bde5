"""Differential drive (seed 002) from rigid-body motion of the wheel contact points; NumPy only."""

from __future__ import annotations

import numpy as np

def diffdrive_wheel_speeds(rates: object, track: float) -> np.ndarray:
    """Ground speeds ``(v_L, v_R)`` of the wheels for body rates ``(v, omega)``, ``(..., 2)``.

    Rigid-body motion of the base: a point at ``r`` (body frame, x forward, y to the
    left) moves at ``(v, 0, 0) + (0, 0, omega) x r``; the left wheel touches the ground
    at ``r = (0, +track/2, 0)``, the right one at ``(0, -track/2, 0)``, and a wheel's
    ground speed is the forward (x) component of its contact point's velocity.
    """
    rates = np.asarray(rates, dtype=float)
    v, omega = rates[..., 0], rates[..., 1]
    out = []
    for side in (+0.5, -0.5):  # left, right
        r = np.array([0.0, side * track, 0.0])
        spin = np.stack([np.zeros_like(omega), np.zeros_like(omega), omega], axis=-1)
        velocity = np.stack([v, np.zeros_like(v), np.zeros_like(v)], axis=-1) + np.cross(spin, r)
        out.append(velocity[..., 0])
    return np.stack(out, axis=-1)


def diffdrive_body_rates(wheels: object, track: float) -> np.ndarray:
    """Body rates ``(v, omega)`` for wheel speeds ``(v_L, v_R)``: the wheel map's inverse, by NumPy."""
    columns = diffdrive_wheel_speeds(np.eye(2), track)  # row k: wheel speeds of the k-th unit twist
    return np.linalg.solve(columns.T, np.asarray(wheels, dtype=float)[..., None])[..., 0]


def diffdrive_pose_rate(pose: object, wheels: object, track: float) -> np.ndarray:
    """``(dx, dy, dheading)``: the body velocity ``(v, 0)`` turned by the heading, and ``omega``."""
    pose = np.asarray(pose, dtype=float)
    v, omega = np.moveaxis(diffdrive_body_rates(wheels, track), -1, 0)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    rotation = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    world = rotation @ np.stack([v, np.zeros_like(v)], -1)[..., None]
    return np.concatenate([world[..., 0], omega[..., None]], axis=-1)
