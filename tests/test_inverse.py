"""Manipulability, inverse velocity, IK step and solver: emitted C and NumPy against NumPy linear algebra."""

import numpy as np
import pytest

from skelarm_sym import InputError, reference
from skelarm_sym.build import compile_arm, load_python
from skelarm_sym import derive
from skelarm_sym.generate import generate
from skelarm_sym.ir.lower import lower as build_programs

TOL = 1e-14


@pytest.fixture(scope="module", params=[2, 3, 5])
def impls(request):
    """(n, compiled C, NumPy module) for symbolic lengths: the functions its tests call."""
    n = request.param
    g = generate(n, out=None, functions="manipulability,inverse_velocity,ik_step")
    return n, compile_arm(g), load_python(g.sources[f"arm{n}.py"], f"arm{n}")


def _both(impls):
    n, c, py = impls
    return n, (("C", c), ("Python", py))


# -- manipulability --------------------------------------------------------------------

def test_manipulability_matches_seed_closed_form_and_cauchy_binet(impls, rng):
    n, pairs = _both(impls)
    l = rng.uniform(0.3, 2.0, n)
    q = rng.uniform(-np.pi, np.pi, (50, n))
    J = reference.kinematics(q, lengths=l).J
    want = np.sqrt(np.linalg.det(J @ np.swapaxes(J, -1, -2)))
    for _, impl in pairs:
        w = impl.manipulability(q, l)[:, 0]
        np.testing.assert_allclose(w, want, rtol=1e-9)
        if n == 2:  # seed 002: |det J| = l1 l2 |sin q2|
            np.testing.assert_allclose(w, l[0] * l[1] * np.abs(np.sin(q[:, 1])), rtol=1e-12, atol=1e-15)


def test_manipulability_is_zero_and_accurate_at_singular_poses(impls):
    n, pairs = _both(impls)
    l = np.linspace(1.0, 0.5, n)
    for q in (np.zeros(n), np.r_[0.3, np.full(n - 1, np.pi)], np.r_[1.0, np.zeros(n - 1)]):
        for _, impl in pairs:
            # ac - b^2 would leave about sqrt(eps) * |J|^2 = 1e-8 here
            assert impl.manipulability(q, l)[0] < 1e-14


# -- inverse velocity ------------------------------------------------------------------

def test_inverse_velocity_exact_for_two_links_and_minimum_norm_beyond(impls, rng):
    n, pairs = _both(impls)
    l = rng.uniform(0.3, 2.0, n)
    q = rng.uniform(0.2, 2.9, (40, n))  # q2..qn away from 0 and pi: regular
    v = rng.uniform(-1, 1, (40, 2))
    J = reference.kinematics(q, lengths=l).J
    want = np.einsum("kij,kj->ki", np.linalg.pinv(J), v)
    for _, impl in pairs:
        dq = impl.inverse_velocity(q, v, l, 0.0)
        np.testing.assert_allclose(np.einsum("kij,kj->ki", J, dq), v, atol=1e-10)  # J dq = v
        np.testing.assert_allclose(dq, want, atol=1e-10)
        if n == 2:
            np.testing.assert_allclose(dq, np.linalg.solve(J, v[..., None])[..., 0], atol=1e-10)


def test_damped_inverse_velocity_matches_numpy_and_stays_bounded(impls, rng):
    n, pairs = _both(impls)
    l = rng.uniform(0.3, 2.0, n)
    q = rng.uniform(-np.pi, np.pi, (40, n))
    q[:5, 1:] = 1e-9  # next to the stretched singularity
    v = rng.uniform(-1, 1, (40, 2))
    lam = 0.05
    J = reference.kinematics(q, lengths=l).J
    A = J @ np.swapaxes(J, -1, -2) + lam**2 * np.eye(2)
    want = np.einsum("kji,kj->ki", J, np.linalg.solve(A, v[..., None])[..., 0])
    for _, impl in pairs:
        dq = impl.inverse_velocity(q, v, l, lam)
        np.testing.assert_allclose(dq, want, atol=1e-9)
        # |J^T (J J^T + lam^2)^-1 v| <= |v| / (2 lam): singular values s / (s^2 + lam^2) <= 1 / (2 lam)
        assert np.all(np.linalg.norm(dq, axis=1) <= np.linalg.norm(v, axis=1) / (2 * lam) * (1 + 1e-12))


def test_undamped_inverse_velocity_at_a_singular_pose_is_the_pseudo_inverse(impls):
    n, pairs = _both(impls)
    l = np.linspace(1.0, 0.6, n)
    v = np.array([0.3, -0.7])
    for q in (np.zeros(n), np.r_[0.4, np.full(n - 1, np.pi) * (np.arange(1, n) % 2)]):
        J = reference.kinematics(q, lengths=l).J
        want = np.linalg.pinv(J) @ v
        for _, impl in pairs:
            dq = impl.inverse_velocity(q, v, l, 0.0)
            assert np.all(np.isfinite(dq))
            np.testing.assert_allclose(dq, want, atol=1e-12)


def test_inverse_velocity3_with_orientation_row(rng):
    g = generate(3, out=None, functions="inverse_velocity3")
    c, py = compile_arm(g), load_python(g.sources["arm3.py"], "arm3")
    l = np.array([1.0, 0.7, 0.4])
    twist = np.array([0.2, -0.5, 0.8])
    for q in (rng.uniform(0.3, 2.5, 3), np.zeros(3), np.array([0.5, np.pi, 0.0])):
        J3 = reference.kinematics(q, lengths=l).J3
        regular = abs(np.linalg.det(J3)) > 1e-9
        want = np.linalg.solve(J3, twist) if regular else np.linalg.pinv(J3) @ twist
        for impl in (c, py):
            dq3 = impl.inverse_velocity3(q, twist, l, 0.0)
            np.testing.assert_allclose(dq3, want, atol=1e-12)
            damped = impl.inverse_velocity3(q, twist, l, 0.1)
            np.testing.assert_allclose(damped, J3.T @ np.linalg.solve(J3 @ J3.T + 0.01 * np.eye(3), twist), atol=1e-12)
    assert "inverse_velocity3" not in [p.name for p in build_programs(derive(2))]


@pytest.mark.parametrize("bad", [-0.1, np.nan, np.inf, [0.1, 0.2]])
def test_bad_lambda_is_refused(impls, bad):
    n, pairs = _both(impls)
    for _, impl in pairs:
        with pytest.raises(ValueError, match="lambda"):
            impl.inverse_velocity(np.zeros(n), [1.0, 0.0], np.ones(n), bad)


def test_non_finite_velocity_or_target_is_refused(impls):
    n, pairs = _both(impls)
    for _, impl in pairs:
        with pytest.raises(ValueError, match="v must be finite"):
            impl.inverse_velocity(np.zeros(n), [np.nan, 0.0], np.ones(n), 0.1)
        with pytest.raises(ValueError, match="target must be finite"):
            impl.ik_step(np.zeros(n), [np.inf, 0.0], np.ones(n), 0.1)
    assert issubclass(InputError, ValueError)


# -- inverse kinematics -----------------------------------------------------------------

@pytest.mark.parametrize("n", range(2, 9))
def test_ik_converges_to_random_reachable_targets(n, rng):
    g = generate(n, out=None, functions="ik_solve")
    c, py = compile_arm(g), load_python(g.sources[f"arm{n}.py"], f"arm{n}")
    l = rng.uniform(0.4, 1.5, n)
    for _ in range(10):
        target = reference.kinematics(rng.uniform(-np.pi, np.pi, n), lengths=l).p
        q0 = rng.uniform(-np.pi, np.pi, n)
        for impl in (c, py):
            result = impl.ik_solve(q0, target, l, 0.0, tol=1e-9, max_iter=200)
            assert result.status == "converged", result
            assert result.error <= 1e-9
            np.testing.assert_allclose(reference.kinematics(result.q, lengths=l).p, target, atol=1e-9)


def test_ik_step_moves_toward_the_target(rng):
    n = 4
    g = generate(n, out=None, functions="ik_step")
    py = load_python(g.sources["arm4.py"], "arm4")
    l = np.ones(n)
    q = rng.uniform(-1, 1, n)
    for offset in (0.01, 0.001):  # undamped steps are Gauss-Newton: the error roughly squares
        target = reference.kinematics(q + offset, lengths=l).p
        q_next = py.ik_step(q, target, l, 0.0)
        before = np.linalg.norm(target - reference.kinematics(q, lengths=l).p)
        after = np.linalg.norm(target - reference.kinematics(q_next, lengths=l).p)
        assert after < 0.5 * before**2


@pytest.mark.parametrize("lengths, target, closest", [
    ((1.0, 0.8, 0.5), (3.0, 1.0), np.hypot(3.0, 1.0) - 2.3),  # beyond the outer reach
    ((2.0, 0.5, 0.3), (0.1, 0.0), 2.0 - 0.8 - 0.1),  # inside the hole the short links cannot fill
])
def test_unreachable_targets_stop_at_the_closest_reach(lengths, target, closest):
    g = generate(3, out=None, functions="ik_solve")
    c, py = compile_arm(g), load_python(g.sources["arm3.py"], "arm3")
    for impl in (c, py):
        for lam in (0.0, 0.05):
            result = impl.ik_solve(np.array([0.3, 0.5, -0.4]), np.array(target), np.array(lengths), lam, max_iter=500)
            assert result.status == "stalled", result
            assert np.all(np.isfinite(result.q))
            assert result.error == pytest.approx(closest, abs=1e-6)


def test_ik_bad_input():
    g = generate(2, out=None, functions="ik_solve")
    c, py = compile_arm(g), load_python(g.sources["arm2.py"], "arm2")
    for impl in (c, py):
        with pytest.raises(ValueError, match="target must be finite"):
            impl.ik_solve(np.zeros(2), [np.nan, 1.0], np.ones(2), 0.1)
        with pytest.raises(ValueError, match="lambda"):
            impl.ik_solve(np.zeros(2), [1.0, 1.0], np.ones(2), -1.0)
        with pytest.raises(ValueError):
            impl.ik_solve(np.zeros(2), [1.0, 1.0], np.ones(2), 0.1, tol=0.0)
        with pytest.raises(ValueError):
            impl.ik_solve(np.zeros(3), [1.0, 1.0], np.ones(2), 0.1)
        # max_iter = 0: nothing moves, the error is that of q0
        result = impl.ik_solve(np.zeros(2), [1.0, 1.0], np.ones(2), 0.1, max_iter=0)
        assert result.status == "max_iter" and result.iterations == 0
        assert result.error == pytest.approx(np.hypot(1.0, 1.0))


def test_c_ik_solve_reports_invalid_for_nan_target(tmp_path):
    """The C function itself (no Python checks in front): INVALID, q = q0, never NaN."""
    import ctypes

    g = generate(2, out=None, functions="ik_solve")
    arm = compile_arm(g)
    lib = ctypes.CDLL(str(arm.path))
    P = ctypes.POINTER(ctypes.c_double)
    fn = lib.arm2_ik_solve
    fn.restype = ctypes.c_int
    fn.argtypes = [P, P, P, ctypes.c_double, ctypes.c_double, ctypes.c_int, P, P, ctypes.POINTER(ctypes.c_int)]
    q0 = np.array([0.1, 0.2])
    l = np.ones(2)
    q = np.full(2, 7.0)
    err = np.zeros(1)
    its = ctypes.c_int(5)
    for target, lam in (([np.nan, 1.0], 0.1), ([1.0, 1.0], np.nan), ([1.0, 1.0], -0.5)):
        t = np.array(target)
        status = fn(q0.ctypes.data_as(P), t.ctypes.data_as(P), l.ctypes.data_as(P), lam, 1e-9, 50,
                    q.ctypes.data_as(P), err.ctypes.data_as(P), ctypes.byref(its))
        assert status == 3  # ARM2_IK_INVALID
        np.testing.assert_array_equal(q, q0)
        assert its.value == 0 and not np.isnan(err[0])


def test_solver_op_counts_grow_linearly():
    counts = {n: {p.name: p.ops.arithmetic for p in build_programs(derive(n))} for n in (8, 16, 32)}
    for name in ("manipulability", "inverse_velocity", "inverse_velocity3", "ik_step"):
        assert counts[32][name] - counts[16][name] == 2 * (counts[16][name] - counts[8][name]), name


def test_float_ik_solver_converges(rng):
    g = generate(4, out=None, precision="float", functions="ik_solve")
    c, py = compile_arm(g), load_python(g.sources["arm4.py"], "arm4")
    l = np.array([1.0, 0.8, 0.6, 0.4], dtype=np.float32)
    for _ in range(5):
        target = reference.kinematics(rng.uniform(-np.pi, np.pi, 4), lengths=l).p
        q0 = rng.uniform(-np.pi, np.pi, 4)
        results = [impl.ik_solve(q0, target, l, 0.0, tol=1e-4) for impl in (c, py)]
        for result in results:
            assert result.status == "converged" and result.q.dtype == np.float32, result
            np.testing.assert_allclose(reference.kinematics(result.q.astype(float), lengths=l).p, target, atol=2e-4)
