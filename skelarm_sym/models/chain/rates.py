"""Velocity terms of the Jacobian's columns (step 6 of :mod:`skelarm_sym.models.chain.derive`)."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .algebra import Vector
from .joints import add
from .steps import _Steps


@dataclass
class _Rates:
    """Velocity terms: per joint ``omega`` after it, ``d/dt`` of its column; the tool twist and acceleration."""

    d_linear: list[Vector]
    d_angular: list[Vector]
    twist: Vector
    acc: Vector


def _velocities(step: _Steps, joints, axes, linear, angular, dq, ddq, tag: str = "") -> _Rates:
    """``w_k = w_(k-1) + z_k dtheta_k``, ``u_k = sum_(j>k) Jv_j dtheta_j`` and the columns' derivatives
    (``tag`` tells apart the names of the steps of one set of columns from another's)."""
    count = len(joints)
    rates = [j.multiplier * dq[j.coordinate] for j in joints]
    accels = [j.multiplier * ddq[j.coordinate] for j in joints]
    omega_before, omega = [], [sp.S.Zero] * 3
    for k, joint in enumerate(joints):
        omega_before.append(omega)
        omega = step.vec(f"w{tag}{k + 1}", add(omega, joint.motion.angular_rate(axes[k], rates[k])))
    omega_after = omega_before[1:] + [omega]
    suffix: list[Vector] = [None] * count
    u = [sp.S.Zero] * 3
    for k in reversed(range(count)):
        suffix[k] = u
        u = step.vec(f"u{tag}{k + 1}", [u[i] + linear[k][i] * rates[k] for i in range(3)])
    d_linear, d_angular = [], []
    for k, joint in enumerate(joints):
        dv, dw = joint.motion.column_rate(omega_before[k], omega_after[k], axes[k], linear[k], angular[k], suffix[k])
        d_linear.append(step.vec(f"dJv{tag}{k + 1}", dv))
        d_angular.append(step.vec(f"dJw{tag}{k + 1}", dw))
    acc = [sp.Add(*[part[k][i] * accels[k] + d_part[k][i] * rates[k] for k in range(count)])
           for part, d_part in ((linear, d_linear), (angular, d_angular)) for i in range(3)]
    return _Rates(d_linear, d_angular, u + omega, acc)
