"""Subproblems SP1-SP4 and the prismatic distance problem, evaluated from their steps on random data."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from skelarm_sym.closed_ik.subproblems import (DOUBLE_VALUES, Parts, Steps, choose_parts, sp1, sp2, sp3, sp4, sp_line,
                                               unit_disc)


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
    env = {**DOUBLE_VALUES, **dict(zip(inputs, values))}  # the tolerances at their double values
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


def atan2_count(steps: Steps) -> int:
    """The rational atans among the steps (one ``_Q`` step, the denominator polynomial, per atan2)."""
    return sum(1 for sym, _ in steps.steps if sym.name.endswith("_Q"))


@pytest.mark.parametrize("plane, mirrored", [("B = 0", "y"), ("A = 0", "x")])
def test_sp4_mirrored_branch_shares_its_atan2(plane, mirrored):
    """With B = 0 (h perpendicular to k x p) the roots are +-theta; with A = 0, theta and pi - theta: the second
    branch is written on the first's atan2 (one rational atan, not two), and both still solve h . R(k, t) p = d
    with their cosines and sines."""
    k, p = np.array([0.0, 0.0, 1.0]), np.array([0.7, 0.0, 0.2])
    Hs = [sp.Symbol("h0", real=True), sp.S.Zero, sp.Symbol("h2", real=True)] if plane == "B = 0" else \
        [sp.S.Zero, sp.Symbol("h1", real=True), sp.Symbol("h2", real=True)]
    free = [x for x in Hs if x.is_Symbol]
    steps = Steps("t")
    b0, b1 = sp4(steps, "a", Hs, p.tolist(), k.tolist(), D)
    assert atan2_count(steps) == 1
    general = Steps("g")
    sp4(general, "a", H, P, K, D)
    assert atan2_count(general) == 2
    rng = np.random.default_rng(8)
    for _ in range(20):
        h = np.array([float(x) if not x.is_Symbol else rng.normal() for x in Hs])
        th = rng.uniform(-np.pi, np.pi)
        d = h @ rot(k, th) @ p
        v = run(steps, free + [D], angle_outputs(b0) + angle_outputs(b1), [*h[[i for i, x in enumerate(Hs) if x.is_Symbol]], d])
        for t, c, s in ((v[0], v[1], v[2]), (v[5], v[6], v[7])):
            assert abs(h @ rot(k, t) @ p - d) < 1e-12
            assert abs(c - np.cos(t)) < 1e-14 and abs(s - np.sin(t)) < 1e-14
        assert min(abs(wrap(v[0] - th)), abs(wrap(v[5] - th))) < 1e-9
        if mirrored == "y":
            assert v[5] == -v[0] or v[0] == v[5] == np.pi
        else:
            assert abs(wrap(v[5] - (np.pi - v[0]))) < 1e-15


def test_choose_parts_selects_the_inputs_of_one_atan2():
    """``choose_parts`` then ``.angle``: one atan2 whose angle, cosine and sine are those of the chosen parts'
    own angle, for either choice."""
    x1, y1, x2, y2, pick = sp.symbols("x1 y1 x2 y2 pick", real=True)
    steps = Steps("t")
    one, two = Parts(x1, y1).angle(steps, "one"), Parts(x2, y2).angle(steps, "two")
    chosen = choose_parts(steps, "c", pick > 0, Parts(x1, y1), Parts(x2, y2), sp.S.One, sp.S.Zero).angle(steps, "c")
    assert chosen.ls == 1 and chosen.singular == 0
    rng = np.random.default_rng(4)
    for _ in range(10):
        values = list(rng.normal(size=4))
        for p_value in (1.0, 0.0):
            v = run(steps, [x1, y1, x2, y2, pick], [chosen.theta, chosen.c, chosen.s] + [one.theta, one.c, one.s]
                    + [two.theta, two.c, two.s], values + [p_value])
            assert v[:3] == (v[3:6] if p_value else v[6:9])


def test_steps_refuse_a_second_definition_of_a_name():
    """Two different expressions under one label: the lowering would keep one definition for both uses (a q4 SP1's
    singular flag once took the value of an unrelated test that way), so the recorder refuses."""
    steps = Steps("t")
    x, y = sp.symbols("x y")
    steps("a", x + y)
    assert steps("a", x + y) == sp.Symbol("_t_a")  # the same expression again: its first name
    with pytest.raises(ValueError, match="defined twice"):
        steps("a", x * y)


def test_principal_angles_are_recorded():
    """An SP angle, its negation and selects of such are known to lie in [-pi, pi]; a sum of two is not."""
    steps = Steps("t")
    a = sp1(steps, "a", K, P, Q)
    b = sp1(steps, "b", K, Q, P)
    assert steps.is_principal(a.theta) and steps.is_principal(-a.theta)
    sel = steps("s", sp.Piecewise((a.theta, D > 0), (-b.theta, True), evaluate=False))
    assert steps.is_principal(sel) and steps.is_principal(sp.Float(3.0)) and not steps.is_principal(sp.Float(3.2))
    assert not steps.is_principal(steps("sum", a.theta + b.theta))
    assert not steps.is_principal(steps("s2", sp.Piecewise((a.theta + b.theta, D > 0), (a.theta, True), evaluate=False)))
