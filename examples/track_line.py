"""A 3-link arm's endpoint tracks a straight line, driven by the emitted inverse velocity.

Resolved-rate control: at each step the joint rates are
``dq = inverse_velocity(q, v_line + gain * (p_line - p), l, lambda)``, i.e. the damped
least-squares inverse of J applied to the line's velocity plus a correction of the
position error; the joints are integrated with explicit Euler steps.

Run: ``python examples/track_line.py`` (compiles the C on first use; about a second).
"""

from __future__ import annotations

import numpy as np

from skelarm_sym.build import compile_arm
from skelarm_sym.generate import generate


def track_line(start=(1.2, 0.4), end=(0.2, 1.5), seconds=2.0, steps=2000, lam=1e-3, gain=20.0):
    """Follow the line; return (times, endpoint path, desired path, joint path)."""
    arm = compile_arm(generate(3, out=None, langs="c"))
    l = np.array([1.0, 0.8, 0.5])
    q = arm.ik_solve(np.array([0.2, 0.9, 0.6]), np.array(start), l, 0.01).q  # start on the line
    start, end = np.asarray(start, float), np.asarray(end, float)
    velocity = (end - start) / seconds
    dt = seconds / steps
    times, actual, desired, joints = [], [], [], []
    for k in range(steps + 1):
        t = k * dt
        goal = start + velocity * t
        p = arm.position(q, l)
        times.append(t), actual.append(p), desired.append(goal), joints.append(q.copy())
        dq = arm.inverse_velocity(q, velocity + gain * (goal - p), l, lam)
        q = q + dt * dq
    return np.array(times), np.array(actual), np.array(desired), np.array(joints)


def main() -> float:
    times, actual, desired, joints = track_line()
    error = np.linalg.norm(actual - desired, axis=1)
    print(f"{'t [s]':>6}  {'x':>7}  {'y':>7}  {'|error|':>9}  q [rad]")
    for k in range(0, len(times), len(times) // 8):
        q = ", ".join(f"{x:+.3f}" for x in joints[k])
        print(f"{times[k]:6.2f}  {actual[k, 0]:7.4f}  {actual[k, 1]:7.4f}  {error[k]:9.2e}  {q}")
    print(f"largest tracking error: {error.max():.2e}")
    return float(error.max())


if __name__ == "__main__":
    main()
