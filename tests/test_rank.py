"""Issue 13 (1): rank decisions independent of the unit of length; the 2 x 2 damped solve as accurate
as the damped problem allows. Emitted C and NumPy against NumPy's SVD/lstsq in double."""

import numpy as np
import pytest

from skelarm_sym import reference
from skelarm_sym.build import compile_arm, load_python
from skelarm_sym.generate import generate


def _impls(n, precision, functions):
    """Compiled C and the NumPy module of an n-link arm with symbolic lengths, holding ``functions``."""
    g = generate(n, out=None, precision=precision, functions=functions)
    return compile_arm(g), load_python(g.sources[f"arm{n}.py"], f"arm{n}")


def _scaled(J3, reach):
    D = np.array([1 / reach, 1 / reach, 1.0])
    return D, D[:, None] * J3


def _pinv3(J3, twist, reach):
    """Minimum-norm least squares with position errors measured in units of the reach (scale-free)."""
    D, S = _scaled(J3, reach)
    return np.linalg.lstsq(S, D * twist, rcond=1e-12)[0]


@pytest.mark.parametrize("precision, length", [("float", 500.0), ("float", 1e-3), ("double", 1e6), ("double", 1e-6)])
def test_inverse_velocity3_keeps_every_direction_in_any_unit(precision, length, rng):
    """Before: float with lengths 500 dropped the orientation direction (median relative error 0.84)."""
    dtype = np.float32 if precision == "float" else np.float64
    impls = _impls(3, precision, "inverse_velocity3")
    l = np.array([1.0, 0.8, 0.6]) * length
    reach = l.sum()
    checked = 0
    errors = []
    for _ in range(60):
        q = rng.uniform(-np.pi, np.pi, 3).astype(dtype)
        twist = (rng.uniform(-1, 1, 3) * [reach, reach, 1.0]).astype(dtype)
        J3 = reference.kinematics(q.astype(float), lengths=l.astype(dtype).astype(float)).J3
        s = np.linalg.svd(_scaled(J3, reach)[1], compute_uv=False)
        if s[-1] < 0.05 * s[0]:  # well away from the singular poses: every method must keep all directions
            continue
        want = np.linalg.solve(J3, twist.astype(float))
        for impl in impls:
            got = impl.inverse_velocity3(q, twist, l.astype(dtype), 0.0).astype(float)
            errors.append(np.linalg.norm(got - want) / np.linalg.norm(want))
        checked += 1
    assert checked > 20
    bound = 2e-4 if precision == "float" else 1e-11
    assert max(errors) < bound, (np.median(errors), max(errors))


@pytest.mark.parametrize("length", [5e4, 1e6, 1e-6])
def test_inverse_velocity3_at_singular_poses_is_the_scaled_pseudo_inverse(length, rng):
    """Before: double with lengths >= 5e4 at singular poses was wrong by a factor of 600 (median)."""
    impls = _impls(3, "double", "inverse_velocity3")
    l = np.array([1.0, 0.7, 0.4]) * length
    reach = l.sum()
    for k in range(20):
        q = np.array([rng.uniform(-np.pi, np.pi), np.pi * (k % 2), np.pi * ((k // 2) % 2)])
        twist = rng.uniform(-1, 1, 3) * [reach, reach, 1.0]
        J3 = reference.kinematics(q, lengths=l).J3
        want = _pinv3(J3, twist, reach)
        for impl in impls:
            got = impl.inverse_velocity3(q, twist, l, 0.0)
            np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * np.linalg.norm(want))


@pytest.mark.parametrize("n", [2, 3, 4])
def test_rank_decisions_do_not_depend_on_the_unit_of_length(n, rng):
    """Scaling every length (and lambda, a length too) by k leaves all joint rates unchanged.

    (inverse_velocity3 only undamped: lambda^2 I adds the same lambda^2 to the length rows and to the
    orientation row, so the damped 3 x 3 problem itself changes with the unit.)"""
    c, py = _impls(n, "double", "inverse_velocity,inverse_velocity3" if n >= 3 else "inverse_velocity")
    l = rng.uniform(0.3, 1.5, n)
    poses = [rng.uniform(-np.pi, np.pi, n) for _ in range(10)] + [np.zeros(n), np.r_[0.4, np.full(n - 1, np.pi)]]
    poses += [np.r_[0.3, 1e-5, np.zeros(n - 2)]]  # near singular: the rule decides between the branches
    for q in poses:
        v = rng.uniform(-1, 1, 2)
        twist = rng.uniform(-1, 1, 3)
        for lam in (0.0, 1e-3, 0.2):
            base = [impl.inverse_velocity(q, v, l, lam) for impl in (c, py)]
            base3 = [impl.inverse_velocity3(q, twist, l, lam) for impl in (c, py)] if n >= 3 and lam == 0 else []
            for k in (1e-3, 2.0**20 / 3, 1e6):
                for impl, want in zip((c, py), base):
                    np.testing.assert_allclose(impl.inverse_velocity(q, k * v, k * l, k * lam), want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
                for impl, want in zip((c, py), base3):
                    # the 3 x 3 solve keeps about eps cond(S)^2 of its result (S: J3 with rows in reach units);
                    # a different rank decision would change the result completely
                    s = np.linalg.svd(_scaled(reference.kinematics(q, lengths=l).J3, l.sum())[1], compute_uv=False)
                    rtol = 1e-9 + 1e3 * 2.2e-16 * min(1e7, s[0] / max(s[-1], 1e-300)) ** 2
                    scaled = impl.inverse_velocity3(q, twist * [k, k, 1.0], k * l, k * lam)
                    np.testing.assert_allclose(scaled, want, rtol=rtol, atol=1e-10 * max(1.0, np.abs(want).max()))


def _damped(J, v, lam):
    n = J.shape[1]
    return np.linalg.lstsq(np.vstack([J, lam * np.eye(n)]), np.r_[v, np.zeros(n)], rcond=None)[0]


@pytest.mark.parametrize("precision, lam, bound", [("float", 0.01, 1e-4), ("double", 1e-4, 1e-12)])
def test_one_link_damped_solve_follows_the_damped_problem(precision, lam, bound, rng):
    """n = 1: J J^T is singular but the damped problem is well conditioned.
    Before: float, lambda = 0.01: 6e-2 relative; double, lambda = 1e-4: 1.3e-6."""
    dtype = np.float32 if precision == "float" else np.float64
    for impl in _impls(1, precision, "inverse_velocity"):
        errors = []
        for _ in range(200):
            q = rng.uniform(-np.pi, np.pi, 1).astype(dtype)
            l = np.array([rng.uniform(0.5, 2.0)], dtype=dtype)
            v = rng.uniform(-1, 1, 2).astype(dtype)
            J = reference.kinematics(q.astype(float), lengths=l.astype(float)).J
            want = _damped(J, v.astype(float), lam)
            got = impl.inverse_velocity(q, v, l, lam).astype(float)
            # relative to the size of the terms: J^T v / |J|^2 cancels when v is nearly normal to J
            errors.append(abs(got - want).max() / (np.linalg.norm(v) / np.linalg.norm(J)))
        assert max(errors) < bound, max(errors)


def test_two_link_undamped_solve_error_follows_cond_J_not_its_square(rng):
    """Near a singular pose (cond(J) about 1e6) the exact inverse keeps about eps cond(J)."""
    c, py = _impls(2, "double", "inverse_velocity")
    l = np.array([1.0, 0.8])
    for q2 in (1e-3, 1e-5, 1e-6):
        q = np.array([0.7, q2])
        J = reference.kinematics(q, lengths=l).J
        v = rng.uniform(-1, 1, 2)
        want = np.linalg.solve(J, v)
        s = np.linalg.svd(J, compute_uv=False)
        for impl in (c, py):
            got = impl.inverse_velocity(q, v, l, 0.0)
            assert np.linalg.norm(got - want) / np.linalg.norm(want) < 50 * 2.2e-16 * s[0] / s[1]


@pytest.mark.parametrize("n, function", [(2, "inverse_velocity"), (3, "inverse_velocity3")])
def test_a_well_posed_solve_keeps_every_direction_in_float(n, function, rng):
    """A probe found float inverse_velocity with l = (1, 1) at q = (0.3, 0.01) (cond(J) 500) returning the rank-one
    answer (0.38, 0.19) for the exact (30.5, -60.1), lambda = 1e-3 too, and inverse_velocity3 at cond(J3) 542 alike: the
    2 x 2 rule compared J J^T's eigenvalues with RANK_TOL (J's singular values at sqrt(RANK_TOL), 3.5e-3 in float),
    the 3 x 3 solve used the normal equations. Now a direction is dropped only where J's singular-value ratio and
    lambda are both below about RANK_TOL, as for 3-D chains, and the three-row solve is their two-stage QR: the error
    follows cond(J). Against NumPy's SVD (lstsq of the damped problem), C and NumPy, lambda = 0 and damped."""
    impls = _impls(n, "float", function)
    l = np.ones(n, dtype=np.float32)
    eps = float(np.finfo(np.float32).eps)
    cases = 0
    for bend in (3e-2, 1e-2, 3e-3, 1e-3):
        for _ in range(4):
            q = np.r_[rng.uniform(-np.pi, np.pi), np.full(n - 1, bend) * rng.choice([-1, 1], n - 1)].astype(np.float32)
            rates = rng.uniform(-1, 1, 2 if n == 2 else 3).astype(np.float32)
            k = reference.kinematics(q.astype(float), lengths=l.astype(float))
            J = k.J if n == 2 else k.J3
            s = np.linalg.svd(J, compute_uv=False)
            for lam in (0.0, 1e-3):
                want = _damped(J, rates.astype(float), lam) if lam else np.linalg.lstsq(J, rates.astype(float), rcond=None)[0]
                for impl in impls:
                    got = np.asarray(getattr(impl, function)(q, rates, l, lam), dtype=float)
                    assert np.linalg.norm(got - want) <= 50 * eps * (s[0] / s[-1]) * np.linalg.norm(want), (q, lam, got, want)
                cases += 1
    assert cases == 32


def _truncated_damped(J, rhs, lam, cut):
    """The damped solution over the singular triplets above ``cut`` times the largest (the rounding ones dropped)."""
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    keep = s > cut * s[0]
    return Vt[keep].T @ (s[keep] / (s[keep] ** 2 + lam**2) * (U[:, keep].T @ rhs))


@pytest.mark.parametrize("scale", [1e-12, 1e-10, 1e-8])
def test_a_small_damping_does_not_amplify_a_rounding_direction(scale, rng):
    """A probe: at an exactly singular pose a damping just above the rank rule's threshold kept the rounding direction
    (singular value about eps |J|), which it turned into eps |J| / lambda^2: the UR5 at q5 = 0 with lambda = 1e-12 gave
    |dq| 6698 for 2.97 (22 % off at 1e-10), the stretched planar arm 2e8 times its answer. A row of rounding is now
    dropped while lambda is at most sqrt(RANK_TOL) |J|: C and NumPy equal the damped solution without it."""
    from skelarm_sym.models.chain import load_robot
    from skelarm_sym.models.chain.reference import chain_kinematics

    root = __import__("pathlib").Path(__file__).resolve().parents[1]
    chain = load_robot(root / "examples" / "robots" / "ur5.toml")
    g = generate(chain, out=None, langs="c,python", functions="inverse_velocity")
    q = np.array([0.3, -1.2, 1.4, -1.8, 0.0, 0.7])  # the wrist aligned: rank 5
    J = chain_kinematics(chain.numeric(), q).J
    twist = rng.uniform(-1, 1, 6)
    lam = scale * np.linalg.norm(J, 2)
    want = _truncated_damped(J, twist, lam, 1e-12)
    for impl in (compile_arm(g), load_python(g.sources["ur5.py"], "ur5")):
        np.testing.assert_allclose(impl.inverse_velocity(q, twist, lam), want, rtol=1e-9, atol=1e-9 * np.linalg.norm(want))
    l = np.array([1.0, 0.75, 0.5])
    q3 = np.array([0.4, 0.0, 0.0])  # stretched: J has rank 1, J3 rank 2
    k = reference.kinematics(q3, lengths=l)
    v, twist3 = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 3) * [l.sum(), l.sum(), 1.0]
    lam = scale * l.sum()
    for impl in _impls(3, "double", "inverse_velocity,inverse_velocity3"):
        want = _truncated_damped(k.J, v, lam, 1e-12)
        np.testing.assert_allclose(impl.inverse_velocity(q3, v, l, lam), want, rtol=1e-9, atol=1e-9 * np.linalg.norm(want))
        want3 = _truncated_damped(k.J3, twist3, lam, 1e-12)
        np.testing.assert_allclose(impl.inverse_velocity3(q3, twist3, l, lam), want3, rtol=1e-8, atol=1e-8 * np.linalg.norm(want3))
    # folded: angles of whole turns round (sin(pi) = 1.2e-16), and 64 links' sums leave J's rounding at about 150 eps
    # (a re-run of the probe: |dq| 7.1e6 for 4.71 at lambda = 1e-11 of the largest singular value)
    n = 64
    l = np.random.default_rng(0).uniform(0.3, 1.5, n)
    q64 = np.r_[0.4, np.pi * (np.arange(n - 1) % 2)]
    v = np.array([0.3, -0.7]) * l.sum()
    J = reference.kinematics(q64, lengths=l).J
    lam = scale * np.linalg.norm(J, 2)
    want = _truncated_damped(J, v, lam, 1e-12)
    for impl in _impls(n, "double", "inverse_velocity"):
        np.testing.assert_allclose(impl.inverse_velocity(q64, v, l, lam), want, rtol=1e-8, atol=1e-8 * np.linalg.norm(want))


def test_inverse_velocity3_damped_in_any_unit_is_the_damped_solution(rng):
    """A probe: float inverse_velocity3 with links of a micrometre and lambda = the reach (a damping as large as the arm)
    answered (-0.55, -0.69, 1.54) for (-0.056, 0.094, 0.261): the test that the damping is negligible compared a
    length with a number, and then solved the scaled problem. The damping is now read in the scaled rows' units."""
    for precision, tol in (("float", 2e-5), ("double", 1e-9)):  # the rows' spread of units costs digits (1e6: 2e-10)
        dtype = np.float32 if precision == "float" else np.float64
        impls = _impls(3, precision, "inverse_velocity3")
        for length in (1e-6, 1.0, 1e3):
            l = (np.array([1.0, 0.8, 0.6]) * length).astype(dtype)
            for _ in range(5):
                q = rng.uniform(-np.pi, np.pi, 3).astype(dtype)
                twist = (rng.uniform(-1, 1, 3) * [length, length, 1.0]).astype(dtype)
                J3 = reference.kinematics(q.astype(float), lengths=l.astype(float)).J3
                lam = float(dtype(l.sum()))
                want = _damped(J3, twist.astype(float), lam)
                for impl in impls:
                    got = np.asarray(impl.inverse_velocity3(q, twist, l, lam), dtype=float)
                    assert np.linalg.norm(got - want) <= tol * np.linalg.norm(want), (precision, length, got, want)


def test_a_small_damping_keeps_a_real_direction_in_float():
    """A probe of the rule above in its first form (a row of the rank tolerance's size dropped up to the wider damping
    bound): float UR5 near its wrist singularity (q5 = 1e-4: the smallest singular value 77 eps of |J|, resolved to a
    percent) answered |dq| 6.1 for 229 at lambda = 1e-4, 100 % off, where the damping carries that direction. Only a
    row of rounding itself (a few eps) goes under a small damping now; C and NumPy against the SVD."""
    from skelarm_sym.models.chain import load_robot
    from skelarm_sym.models.chain.reference import chain_kinematics

    root = __import__("pathlib").Path(__file__).resolve().parents[1]
    chain = load_robot(root / "examples" / "robots" / "ur5.toml")
    g = generate(chain, out=None, langs="c,python", precision="float", functions="inverse_velocity")
    q = np.array([0.07092975, 2.70278215, -2.13504243, 2.69189668, 1e-4, -0.46004131], dtype=np.float32)
    twist = np.array([-0.13865532, 0.0330001, -1.425349, 0.33281362, -0.651281, 0.86244482], dtype=np.float32)
    J = chain_kinematics(chain.numeric(), q.astype(float)).J
    for lam in (1e-4, 1e-3, 1e-2):
        want = _truncated_damped(J, twist.astype(float), lam, 0.0)
        for impl in (compile_arm(g), load_python(g.sources["ur5.py"], "ur5")):
            got = np.asarray(impl.inverse_velocity(q, twist, np.float32(lam)), dtype=float)
            assert np.linalg.norm(got - want) <= 1e-3 * np.linalg.norm(want), (lam, np.linalg.norm(got), np.linalg.norm(want))
