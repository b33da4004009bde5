"""Subproblems SP1-SP4 and the prismatic distance problem, evaluated from their steps on random data."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from skelarm_sym.closed_ik.subproblems import Steps, sp1, sp2, sp3, sp4, sp_line, unit_disc


def rot(k, theta):
    k = np.asarray(k, float)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K


def unit(v):
    return v / np.linalg.norm(v)


def symbols(name):
    return list(sp.symbols(f"{name}0:3", real=True))


def run(steps: Steps, inputs: list, outputs: list, values: list) -> list[float]:
    """Evaluate ``outputs`` (written with the steps) at ``values`` of ``inputs``, in step order."""
    env = dict(zip(inputs, values))
    for sym, expr in steps.steps:
        env[sym] = expr.xreplace(env)
    return [float(sp.sympify(o).xreplace(env)) for o in outputs]


def angle_outputs(a):
    return [a.theta, a.c, a.s, a.ls, a.singular]


def wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


K, P, Q, H = symbols("k"), symbols("p"), symbols("q"), symbols("h")
D = sp.Symbol("d", real=True)


def test_sp1_exact_least_squares_and_singular():
    steps = Steps("t")
    a = sp1(steps, "a", K, P, Q)
    rng = np.random.default_rng(1)
    for _ in range(20):
        k, p, th = unit(rng.normal(size=3)), rng.normal(size=3), rng.uniform(-np.pi, np.pi)
        q = rot(k, th) @ p
        t, c, s, ls, sg = run(steps, K + P + Q, angle_outputs(a), [*k, *p, *q])
        assert abs(wrap(t - th)) < 1e-12 and abs(c - np.cos(t)) < 1e-14 and abs(s - np.sin(t)) < 1e-14
        assert (ls, sg) == (0, 0)
        # least squares: any q; the angle minimises |R p - q| (checked on a fine grid)
        q2 = rng.normal(size=3)
        t2 = run(steps, K + P + Q, [a.theta], [*k, *p, *q2])[0]
        grid = np.linspace(-np.pi, np.pi, 20001)
        best = min(np.linalg.norm(rot(k, g) @ p - q2) for g in grid[::50])
        assert np.linalg.norm(rot(k, t2) @ p - q2) <= best + 1e-9
    # singular: p on the axis -> representative 0, cos 1, sin 0, flagged, finite
    t, c, s, ls, sg = run(steps, K + P + Q, angle_outputs(a), [0, 0, 1, 0, 0, 2.0, 0.3, 0.1, 2.0])
    assert (t, c, s, ls, sg) == (0.0, 1.0, 0.0, 0, 1)


def test_sp4_both_branches_least_squares_and_singular():
    steps = Steps("t")
    b0, b1 = sp4(steps, "a", H, P, K, D)
    outs = angle_outputs(b0) + angle_outputs(b1)
    rng = np.random.default_rng(2)
    for _ in range(20):
        h, p, k, th = rng.normal(size=3), rng.normal(size=3), unit(rng.normal(size=3)), rng.uniform(-np.pi, np.pi)
        d = h @ rot(k, th) @ p
        v = run(steps, H + P + K + [D], outs, [*h, *p, *k, d])
        for t, c, s in ((v[0], v[1], v[2]), (v[5], v[6], v[7])):
            assert abs(h @ rot(k, t) @ p - d) < 1e-12 * np.linalg.norm(h) * np.linalg.norm(p)
            assert abs(c - np.cos(t)) < 1e-14 and abs(s - np.sin(t)) < 1e-14
        assert min(abs(wrap(v[0] - th)), abs(wrap(v[5] - th))) < 1e-9
        assert v[3] == 0 and v[8] == 0
    # unreachable plane: one least-squares angle (both branches), flagged, the best |h.Rp - d|
    h, p, k = np.array([1.0, 0, 0]), np.array([1.0, 0, 0.5]), np.array([0, 0, 1.0])
    v = run(steps, H + P + K + [D], outs, [*h, *p, *k, 3.0])
    assert v[3] == 1 and v[0] == v[5] and abs(v[0]) < 1e-15
    # singular: h along k -> any angle solves h.Rp = h.p: representative 0, flagged
    v = run(steps, H + P + K + [D], outs, [0, 0, 1.0, 1.0, 0.2, 0.5, 0, 0, 1.0, 0.5])
    assert v[0] == 0.0 and v[4] == 1 and v[3] == 0


def test_unit_disc_equals_the_plain_discriminant():
    rng = np.random.default_rng(3)
    for _ in range(20):
        h, p, k = unit(rng.normal(size=3)), unit(rng.normal(size=3)), unit(rng.normal(size=3))
        g = unit(rng.normal(size=3))
        plain = (np.linalg.norm(h - k * (h @ k)) * np.linalg.norm(p - k * (p @ k))) ** 2 - (h @ g - (h @ k) * (k @ p)) ** 2
        fast = float(unit_disc(h.tolist(), p.tolist(), k.tolist(), g.tolist()))
        assert abs(plain - fast) < 1e-13


def test_sp3_distance():
    steps = Steps("t")
    P1, P2, D2 = symbols("a"), symbols("b"), sp.Symbol("d2", real=True)
    b0, b1 = sp3(steps, "a", K, P1, P2, D2)
    rng = np.random.default_rng(4)
    for _ in range(20):
        k, p1, p2, th = unit(rng.normal(size=3)), rng.normal(size=3), rng.normal(size=3), rng.uniform(-np.pi, np.pi)
        d2 = np.sum((rot(k, th) @ p1 - p2) ** 2)
        t0, t1, ls = run(steps, K + P1 + P2 + [D2], [b0.theta, b1.theta, b0.ls], [*k, *p1, *p2, d2])
        for t in (t0, t1):
            assert abs(np.sum((rot(k, t) @ p1 - p2) ** 2) - d2) < 1e-12 * (1 + d2)
        assert ls == 0


def test_sp2_two_rotations():
    steps = Steps("t")
    K1, K2, P1, P2 = symbols("k"), symbols("m"), symbols("a"), symbols("b")
    (a0, b0), (a1, b1) = sp2(steps, "a", K1, P1, K2, P2)
    rng = np.random.default_rng(5)
    for _ in range(20):
        k1, k2, p1 = unit(rng.normal(size=3)), unit(rng.normal(size=3)), rng.normal(size=3)
        t1, t2 = rng.uniform(-np.pi, np.pi, 2)
        p2 = rot(k2, t2).T @ rot(k1, t1) @ p1
        v = run(steps, K1 + P1 + K2 + P2, [a0.theta, b0.theta, a1.theta, b1.theta, a0.ls], [*k1, *p1, *k2, *p2])
        for x, y in ((v[0], v[1]), (v[2], v[3])):
            assert np.linalg.norm(rot(k1, x) @ p1 - rot(k2, y) @ p2) < 1e-12 * (1 + np.linalg.norm(p1))
        assert min(abs(wrap(v[0] - t1)) + abs(wrap(v[1] - t2)), abs(wrap(v[2] - t1)) + abs(wrap(v[3] - t2))) < 1e-8
        assert v[4] == 0
    # no common point (cones do not meet): least squares, flagged, finite
    v = run(steps, K1 + P1 + K2 + P2, [a0.theta, b0.theta, a0.ls], [0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0])
    assert v[2] == 1 and all(np.isfinite(v))


def test_sp_line_quadratic():
    steps = Steps("t")
    X0, O, D2 = symbols("x"), symbols("o"), sp.Symbol("d2", real=True)
    r0, r1 = sp_line(steps, "a", K, X0, O, D2)
    rng = np.random.default_rng(6)
    for _ in range(10):
        h, x0, o, t = unit(rng.normal(size=3)), rng.normal(size=3), rng.normal(size=3), rng.normal()
        d2 = np.sum((x0 + t * h - o) ** 2)
        v = run(steps, K + X0 + O + [D2], [r0.theta, r1.theta, r0.ls], [*h, *x0, *o, d2])
        assert min(abs(v[0] - t), abs(v[1] - t)) < 1e-10 and v[0] >= v[1] and v[2] == 0
    v = run(steps, K + X0 + O + [D2], [r0.theta, r1.theta, r0.ls], [1, 0, 0, 0, 1, 0, 0, 0, 0, 0.25])
    assert v[0] == v[1] == 0.0 and v[2] == 1


@pytest.mark.parametrize("maker", [sp1, sp4])
def test_no_nan_on_zero_input(maker):
    steps = Steps("t")
    if maker is sp1:
        a = (maker(steps, "a", K, P, Q),)
        inputs, values = K + P + Q, [0, 0, 1] + [0] * 6
    else:
        a = maker(steps, "a", H, P, K, D)
        inputs, values = H + P + K + [D], [0] * 6 + [0, 0, 1, 0]
    outs = [x for b in a for x in angle_outputs(b)]
    assert all(np.isfinite(run(steps, inputs, outs, values)))
