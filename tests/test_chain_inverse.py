"""Chain inverse functions against NumPy (SVD, pinv, lstsq) and finite differences; singular poses; IK."""

from functools import lru_cache

import numpy as np
import pytest

from skelarm_sym.build import load_python
from skelarm_sym.generate import generate
from skelarm_sym.models.chain import reference_inverse as ref

from test_chain import MIMIC, PANDA, PRISMATIC, PUMA, STANFORD, UR5, dh_table


FUNCTIONS = ("pose,jacobian,jacobian_rpy,manipulability,manipulability_position,jacobian_hessian,manipulability_gradient,"
             "inverse_velocity,inverse_velocity_position,ik_solve,ik_solve_position")
"""The functions the tests below call: one set for every shared chain, so that each is derived once."""


@lru_cache(maxsize=None)
def module(chain, functions=FUNCTIONS):
    g = generate(chain, langs="python", out=None, functions=functions)
    return load_python(g.sources[f"{chain.name}.py"], chain.name)


def scales(chain):
    L = ref.reach_length(chain.numeric())
    return np.array([1 / L] * 3 + [1.0] * 3)


CHAINS = [UR5, PANDA, STANFORD, MIMIC, PRISMATIC]


@pytest.mark.parametrize("chain", CHAINS, ids=lambda c: c.name)
def test_manipulability_hessian_gradient_match_svd_and_differences(chain):
    m = module(chain)
    q = np.random.default_rng(2).uniform(-3, 3, (25, chain.n))
    J = m.jacobian(q)
    w = m.manipulability(q)[:, 0]
    np.testing.assert_allclose(w, ref.manipulability(J), rtol=0, atol=1e-14)
    # relative as well: with a prismatic joint (Stanford) the value reaches 9, where 1e-14 is 6 units in the last place
    np.testing.assert_allclose(m.manipulability_position(q)[:, 0], ref.manipulability(J[:, :3]), rtol=1e-14, atol=1e-14)
    Hs = m.jacobian_hessian(q)
    np.testing.assert_allclose(Hs, ref.jacobian_hessian(chain.numeric(), q), rtol=0, atol=1e-13)
    np.testing.assert_allclose(Hs[0], ref.central_difference(m.jacobian, q[0]), rtol=0, atol=1e-8)
    grad = m.manipulability_gradient(q)
    fd = ref.central_difference(lambda x: m.manipulability(x)[..., 0], q)
    regular = np.linalg.svd(J, compute_uv=False)[:, -1] > 1e-3
    assert regular.sum() >= 5
    np.testing.assert_allclose(grad[regular], fd[regular], rtol=0, atol=1e-7)


def test_manipulability_keeps_its_digits_near_a_singular_pose():
    m = module(UR5)
    for eps in (1e-3, 1e-6, 1e-9):
        q = np.array([0.3, -1.1, 1.4, 0.2, eps, 0.7])  # wrist singularity at q5 = 0
        J = m.jacobian(q)
        s = np.linalg.svd(J, compute_uv=False)
        w = m.manipulability(q)[0]
        assert abs(w - np.prod(s)) <= 1e-12 * s[0] ** 6, (eps, w, np.prod(s))
        assert abs(w / np.prod(s) - 1) < 1e-6  # relative, too (the product of det(JJ^T) loses it at eps=1e-9)


SINGULAR = [
    (UR5, [0.3, -1.1, 1.4, 0.2, 0.0, 0.7]),  # wrist: q5 = 0
    (UR5, [0.3, -1.1, 0.0, 0.2, 0.9, 0.7]),  # elbow: q3 = 0 (stretched)
    (PANDA, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),  # stretched Panda
]


@pytest.mark.parametrize("chain, q", SINGULAR, ids=["ur5-wrist", "ur5-elbow", "panda-stretched"])
def test_undamped_inverse_velocity_at_singular_poses_is_the_pseudo_inverse(chain, q):
    m = module(chain)
    q = np.array(q)
    J = m.jacobian(q)
    s = np.linalg.svd(J, compute_uv=False)
    assert s[-1] < 1e-12 * s[0] or chain is PANDA  # really singular (Panda: rank 6 lost in the 6 x 7)
    twist = np.array([0.3, -0.2, 0.5, 0.4, -0.1, 0.2])
    dq = m.inverse_velocity(q, twist, 0.0)
    assert np.all(np.isfinite(dq))
    want = np.linalg.pinv(J, rcond=1e-10) @ twist
    np.testing.assert_allclose(dq, want, rtol=0, atol=1e-9 * max(1, np.abs(want).max()))
    lstsq = np.linalg.lstsq(J, twist, rcond=1e-10)[0]
    np.testing.assert_allclose(dq, lstsq, rtol=0, atol=1e-9 * max(1, np.abs(want).max()))
    vel = twist[:3]
    np.testing.assert_allclose(m.inverse_velocity_position(q, vel, 0.0), np.linalg.pinv(J[:3], rcond=1e-10) @ vel, atol=1e-9)
    for lam in (1e-3, 0.1):
        want = J.T @ np.linalg.solve(J @ J.T + lam**2 * np.eye(6), twist)
        np.testing.assert_allclose(m.inverse_velocity(q, twist, lam), want, rtol=0, atol=1e-9 * max(1, np.abs(want).max()))


@pytest.mark.parametrize("chain", CHAINS, ids=lambda c: c.name)
def test_inverse_velocity_regular_and_damped(chain):
    m = module(chain)
    rng = np.random.default_rng(4)
    q = rng.uniform(-3, 3, (20, chain.n))
    twist = rng.uniform(-1, 1, (20, 6))
    J = m.jacobian(q)
    for lam in (0.0, 0.05, 0.5):
        got = m.inverse_velocity(q, twist, lam)
        want = ref.damped_least_squares(J, twist, lam, 1e-12, scales(chain))
        cond = ref.solve_condition(J, lam, 1e-12, scales(chain))
        err = np.abs(got - want).max(axis=-1) / np.maximum(1, np.abs(want).max(axis=-1))
        assert np.all(err <= 1e-14 * cond + 1e-12), (lam, err.max())
        # normal equations of the damped problem hold in every case
        res = np.einsum("bri,br->bi", J, np.einsum("bri,bi->br", J, got) - twist) + lam**2 * got
        assert np.all(np.abs(res).max(axis=-1) <= 1e-9 * np.maximum(1, np.abs(got).max(axis=-1)))


def test_the_rank_rule_does_not_depend_on_the_unit_of_length():
    """Same robot in metres and millimetres at a singular pose: the same rates (in their units)."""
    from test_chain import dh_table

    rows = lambda k: [  # noqa: E731
        {"type": "revolute", "d": 0.089159 * k, "alpha": "pi/2"}, {"type": "revolute", "a": -0.425 * k},
        {"type": "revolute", "a": -0.39225 * k}, {"type": "revolute", "d": 0.10915 * k, "alpha": "pi/2"},
        {"type": "revolute", "d": 0.09465 * k, "alpha": "-pi/2"}, {"type": "revolute", "d": 0.0823 * k},
    ]
    metres = module(dh_table("urm", "standard", rows(1.0)), "jacobian,inverse_velocity")
    mm = module(dh_table("urmm", "standard", rows(1000.0)), "jacobian,inverse_velocity")
    q = np.array([0.3, -1.1, 1.4, 0.2, 0.0, 0.7])
    # a reachable twist (the least-squares residual itself weighs metres against radians)
    twist = metres.jacobian(q) @ np.array([0.3, -0.2, 0.5, 0.4, -0.1, 0.2])
    a = metres.inverse_velocity(q, twist, 0.0)
    b = mm.inverse_velocity(q, twist * np.array([1000.0] * 3 + [1.0] * 3), 0.0)
    np.testing.assert_allclose(a, b, atol=1e-9)
    np.testing.assert_allclose(a, np.linalg.pinv(metres.jacobian(q), rcond=1e-10) @ twist, atol=1e-9)


def test_jacobian_rpy_matches_atan2_angles_and_is_finite_at_gimbal_lock():
    m = module(PUMA)
    rng = np.random.default_rng(5)
    q = rng.uniform(-3, 3, (20, 6))
    np.testing.assert_allclose(m.jacobian_rpy(q), ref.jacobian_rpy(m.pose(q), m.jacobian(q)), atol=1e-10)
    # rpy rates integrate the orientation: d(rpy)/dt = JA_w dq against differences of atan2 angles
    dq = rng.uniform(-1, 1, 6)
    h = 1e-6
    d = (ref.rpy(m.pose(q[0] + h * dq)[:3, :3]) - ref.rpy(m.pose(q[0] - h * dq)[:3, :3])) / (2 * h)
    np.testing.assert_allclose(m.jacobian_rpy(q[0])[3:] @ dq, d, atol=1e-6)
    # gimbal lock: a tool pitched by exactly pi/2 (R20 = -1 at every q: exact constants) gives a finite JA
    # whose roll and yaw rows are zero, as documented
    from test_chain import dh_table

    locked = dh_table("locked", "standard", [{"type": "revolute", "a": 0.3}, {"type": "revolute", "a": 0.2}],
                      tool={"xyz": [0.0, 0.0, 0.1], "rpy": [0.0, "pi/2", 0.0]})
    g = module(locked, "pose,jacobian,jacobian_rpy")
    for qq in (np.zeros(2), np.array([0.4, -1.1])):
        R = g.pose(qq)[:3, :3]
        assert R[2, 0] == -1.0  # z axes parallel, the tool pitched by exactly pi/2: at every q
        JA = g.jacobian_rpy(qq)
        assert np.all(np.isfinite(JA))
        np.testing.assert_array_equal(JA[3], 0.0)
        np.testing.assert_array_equal(JA[5], 0.0)
        np.testing.assert_array_equal(JA[:3], g.jacobian(qq)[:3])


def test_non_finite_inputs_are_refused():
    m = module(UR5)
    q = np.zeros(6)
    with pytest.raises(ValueError):
        m.manipulability(np.array([np.nan, 0, 0, 0, 0, 0]))
    with pytest.raises(ValueError):
        m.inverse_velocity(q, np.array([np.inf, 0, 0, 0, 0, 0]), 0.0)
    with pytest.raises(ValueError):
        m.inverse_velocity(q, np.zeros(6), -1.0)
    with pytest.raises(ValueError):
        m.ik_solve(q, np.full((4, 4), np.nan))


def test_ik_converges_and_out_of_reach_stalls_at_closest_reach():
    m = module(PUMA)
    rng = np.random.default_rng(7)
    converged = 0
    for _ in range(10):
        qt, q0 = rng.uniform(-np.pi, np.pi, 6), rng.uniform(-np.pi, np.pi, 6)
        r = m.ik_solve(q0, m.pose(qt))
        if r.status == "converged":
            converged += 1
            T = m.pose(r.q)
            assert np.abs(T[:3, 3] - m.pose(qt)[:3, 3]).max() < 1e-10
            assert np.abs(T[:3, :3] - m.pose(qt)[:3, :3]).max() < 1e-9
    assert converged >= 9
    far = m.ik_solve_position(np.zeros(6), np.array([5.0, 0.0, 0.0]))
    assert far.status in ("stalled", "max_iter")
    assert np.all(np.isfinite(far.q))
    assert abs(far.error - np.linalg.norm(np.array([5.0, 0.0, 0.0]) - m.pose(far.q)[:3, 3])) < 1e-9
    lower = np.array([-np.inf if x is None else x for x in PUMA.limits()["lower"]])
    upper = np.array([np.inf if x is None else x for x in PUMA.limits()["upper"]])
    assert np.all(far.q >= lower) and np.all(far.q <= upper)


def test_slides_reach_far_targets_in_metres_and_millimetres():
    """A slide's move was capped at 1 m a step, and an attempt whose steps were slowed by the damping (mu2 = c |e|
    outweighs J J^T where |e| is large and J is a slide's unit column) was restarted as slow: the cartesian chain
    stalled on a target 10 m away, and in millimetres on one 3 m away."""
    mm = dh_table("cartesian_mm", "modified", [
        {"type": "prismatic", "alpha": 0.3, "a": 200, "theta": 0.4},
        {"type": "prismatic", "alpha": 1.1, "a": 100, "theta": -0.4},
        {"type": "prismatic", "alpha": -0.7, "d": 200},
    ])
    for chain, scale in ((PRISMATIC, 1.0), (mm, 1000.0)):
        m = module(chain)
        for far in (3.0, 10.0, 100.0, 1000.0):
            qt = np.array([1.0, -0.5, 0.8]) * far * scale
            target = m.pose(qt)[:3, 3]
            r = m.ik_solve_position(np.zeros(3), target)
            assert r.status == "converged", (chain.name, far, r.status, r.error)
            assert np.abs(m.pose(r.q)[:3, 3] - target).max() < 1e-10 * max(1.0, np.abs(target).max())
    m = module(STANFORD)  # the boom out 40 m: its revolute joints still move at most 1 rad a step
    qt = np.array([0.3, -0.4, 40.0, 0.2, 0.1, 0.3])
    r = m.ik_solve(np.zeros(6), m.pose(qt))
    assert r.status == "converged" and np.abs(m.pose(r.q) - m.pose(qt)).max() < 1e-9


def test_one_step_that_lowers_the_error_geometrically_is_not_called_stalled():
    """With max_iter = 1 the budget ends one step into the first window of the attempt: the judgement at the end
    asks that step for its share of the window's progress (|e| below PROGRESS ** (1 / WINDOW) of its start), not
    the whole window's. Judged by the whole PROGRESS, 9 of these 400 UR5 problems were called STALLED (a
    stationary point) after a step that cut |e| by 19-40 %."""
    from skelarm_sym.models.chain.solver import PROGRESS, WINDOW

    m = module(UR5)
    rng = np.random.default_rng(1)
    q = rng.uniform(-np.pi, np.pi, (400, 6))
    q0 = q + rng.normal(0.0, 0.5, (400, 6))
    T = m.pose(q)
    start, one = m.ik_solve(q0, T, 0.0, 1e-10, 0), m.ik_solve(q0, T, 0.0, 1e-10, 1)
    ratio = np.hypot(one.position_error, one.rotation_error) / np.hypot(start.position_error, start.rotation_error)
    status = np.asarray(one.status)
    assert set(status) == {"stalled", "max_iter"}
    share = PROGRESS ** (1 / WINDOW)
    assert np.all(ratio[status == "stalled"] > share) and np.all(ratio[status == "max_iter"] <= share)
    assert np.sum((ratio > PROGRESS) & (ratio <= share)) >= 5  # steps the whole window's rule called stalled


def test_a_float_header_says_whose_success_it_states():
    """The success figures are measured at tol 1e-10 in double; a float build converges to 1e-5 (a tol of 1e-10
    it reaches on few targets), so its header says they are the double build's."""
    double = generate(UR5, langs="c", out=None, functions="ik_solve").sources["ur5.h"]
    single = generate(UR5, langs="c", out=None, functions="ik_solve", precision="float").sources["ur5.h"]
    assert "Measured success (1000 random" in double and "double-precision build" not in double
    assert "Measured success of the double-precision build (1000 random" in single
    assert "A tol of 1e-05 is reachable in this precision" in single
