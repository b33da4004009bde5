"""Velocity terms of the Jacobian's columns (step 6 of :mod:`skelarm_sym.models.chain.derive`)."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .algebra import Vector
from .joints import ZERO, add, cross
from .price import _price
from .steps import _Steps


@dataclass
class _Rates:
    """Velocity terms: per joint ``omega`` after it, ``d/dt`` of its column; the tool twist and acceleration."""

    d_linear: list[Vector]
    d_angular: list[Vector]
    twist: Vector
    acc: Vector


def _velocities(step: _Steps, joints, axes, linear, angular, dq, ddq, tag: str = "", axis_cross=None) -> _Rates:
    """``w_k = w_(k-1) + z_k dtheta_k``, ``u_k = sum_(j>k) Jv_j dtheta_j`` and the columns' derivatives
    (``tag`` tells apart the names of the steps of one set of columns from another's). ``axis_cross(j, k)``:
    ``z_j x z_k`` where it is known without a cross product (:func:`_axis_rates`), else ``None``."""
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
    turning = [any(x != 0 for x in j.motion.angular_rate(axes[k], rates[k])) for k, j in enumerate(joints)]
    axis_rates = _axis_rates(step, axes, linear, omega_before, rates, turning, axis_cross)
    d_linear, d_angular = [], []
    for k, joint in enumerate(joints):
        dv, dw = joint.motion.column_rate(omega_before[k], omega_after[k], axes[k], linear[k], angular[k], suffix[k],
                                          axis_rates[k])
        d_linear.append(step.vec(f"dJv{tag}{k + 1}", dv))
        d_angular.append(step.vec(f"dJw{tag}{k + 1}", dw))
    acc = [sp.Add(*[part[k][i] * accels[k] + d_part[k][i] * rates[k] for k in range(count)])
           for part, d_part in ((linear, d_linear), (angular, d_angular)) for i in range(3)]
    return _Rates(d_linear, d_angular, u + omega, acc)


def _axis_rates(step: _Steps, axes, linear, omega_before, rates, turning, axis_cross) -> list[Vector | None]:
    """Per joint ``d z_k/dt = w_(k-1) x z_k`` as ``sum_(j<k) dtheta_j (z_j x z_k)`` where every ``z_j x z_k`` is
    known without a cross product (``axis_cross``: a column of the next frame for consecutive segments, zero for
    parallel axes) and that needs fewer operations; ``None`` where not (the cross product with ``w_(k-1)``).
    Near the base ``w`` is a sum of few axes and ``z_j x z_k`` a column the frames carry anyway: Stanford's
    boom axis turns at ``dq1 (e_z x z_3) + dq2 x_2`` (7 operations instead of 10; the cross product with
    ``w`` pays for ``s1^2 + c1^2`` written out)."""
    out: list[Vector | None] = [None] * len(axes)
    if axis_cross is None:
        return out
    steps = step.definitions()
    paid = None
    for k in range(len(axes)):
        total = list(ZERO)
        for j in range(k):
            if not turning[j]:
                continue
            known = axis_cross(j, k)
            if known is None:
                break
            total = add(total, [x * rates[j] for x in known])
        else:
            if paid is None:
                paid = frozenset(_price(steps, [e for group in (axes, linear, omega_before) for v in group for e in v])[1])
            plain = cross(omega_before[k], axes[k])
            if _price(steps, total, paid)[0] < _price(steps, plain, paid)[0]:
                out[k] = total
    return out
