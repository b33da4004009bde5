"""The Python wrappers (compiled and emitted) do what the headers promise (issue 12, part 2)."""

import inspect

import numpy as np
import pytest

from skelarm_sym.build import compile_arm, load_python
from skelarm_sym.generate import generate


@pytest.fixture(scope="module")
def arms():
    g = generate(2, out=None)  # every function: test_compiled_and_emitted_signatures_agree compares them all
    return {"C": compile_arm(g), "Python": load_python(g.sources["arm2.py"], "arm2")}


@pytest.fixture(scope="module")
def float_arms():
    g = generate(2, out=None, precision="float", prefix="arm2f", functions="position,ik_solve")  # what its test calls
    return {"C": compile_arm(g), "Python": load_python(g.sources["arm2f.py"], "arm2f")}


Q, L = np.array([0.3, 0.5]), np.array([1.0, 0.8])
BAD = [np.nan, np.inf, -np.inf]


@pytest.mark.parametrize("impl", ["C", "Python"])
@pytest.mark.parametrize(
    "function, args, position, name",
    [
        ("jacobian", (Q, L), 0, "q"),
        ("velocity", (Q, Q, L), 1, "dq"),
        ("acceleration", (Q, Q, Q, L), 2, "ddq"),
        ("kinematics", (Q, Q, Q, L), 0, "q"),
        ("inverse_velocity", (Q, np.array([1.0, 0.0]), L, 0.1), 1, "v"),
        ("ik_step", (Q, np.array([1.0, 0.5]), L, 0.1), 1, "target"),
    ],
)
@pytest.mark.parametrize("bad", BAD)
def test_non_finite_input_raises_value_error_naming_it(arms, impl, function, args, position, name, bad):
    args = list(args)
    args[position] = args[position].copy()
    args[position][-1] = bad
    with pytest.raises(ValueError, match=rf"^{name} must be finite"):
        getattr(arms[impl], function)(*args)


@pytest.mark.parametrize("impl", ["C", "Python"])
@pytest.mark.parametrize("length, message", [(0.0, "l must be > 0"), (-1.0, "l must be > 0"), (np.nan, "l must be finite")])
def test_lengths_must_be_finite_and_positive(arms, impl, length, message):
    arm = arms[impl]
    l = np.array([1.0, length])
    for call in (lambda: arm.jacobian(Q, l), lambda: arm.kinematics(Q, Q, Q, l),
                 lambda: arm.ik_solve(Q, [1.0, 0.5], l, 0.1)):
        with pytest.raises(ValueError, match=message):
            call()


@pytest.mark.parametrize("impl", ["C", "Python"])
def test_twist_is_checked(impl):
    g = generate(3, out=None, functions="inverse_velocity3")
    arm = compile_arm(g) if impl == "C" else load_python(g.sources["arm3.py"], "arm3")
    with pytest.raises(ValueError, match="twist must be finite"):
        arm.inverse_velocity3(np.zeros(3), [0.0, np.nan, 0.0], np.ones(3), 0.1)
    np.testing.assert_allclose(
        arm.inverse_velocity3(q=[0.1, 0.2, 0.3], twist=[0.0, 0.0, 1.0], l=np.ones(3), lambda_=0.0).sum(), 1.0
    )


@pytest.mark.parametrize("impl", ["C", "Python"])
@pytest.mark.parametrize("max_iter", [2**32 + 5, 2**31, -1, 2.5, float("nan"), "5"])
def test_max_iter_outside_c_int_is_refused(arms, impl, max_iter):
    with pytest.raises(ValueError, match="max_iter must be a whole number in 0..2147483647"):
        arms[impl].ik_solve(np.zeros(2), [0.5, 1.2], L, 0.0, max_iter=max_iter)


@pytest.mark.parametrize("impl", ["C", "Python"])
def test_max_iter_at_the_c_int_limit_runs(arms, impl):
    result = arms[impl].ik_solve(Q, [0.5, 1.2], L, 0.0, max_iter=2**31 - 1)
    assert result.status == "converged" and result.error <= 1e-9 and 0 < result.iterations < 50


@pytest.mark.parametrize("impl", ["C", "Python"])
def test_wrong_argument_count_is_type_error_naming_the_signature(arms, impl):
    arm = arms[impl]
    with pytest.raises(TypeError, match=r"jacobian\(q, l\)"):
        arm.jacobian(Q, L, Q)
    with pytest.raises(TypeError, match=r"inverse_velocity\(q, v, l, lambda_\)"):
        arm.inverse_velocity(Q, [1.0, 0.0], L)
    with pytest.raises(TypeError, match=r"ik_solve\(q0, target, l, lambda_=0.0, tol=None, max_iter=200\)"):
        arm.ik_solve(Q, [1.0, 0.0], L, 0.1, 1e-9, 10, 3)
    with pytest.raises(TypeError, match=r"velocity\(q, dq, l\)"):
        arm.velocity(Q, dq=Q, length=L)


def test_compiled_and_emitted_signatures_agree(arms):
    c, py = arms["C"], arms["Python"]
    for name in (*py.__all__[:-2], "ik_solve"):
        assert str(inspect.signature(getattr(c, name))) == str(inspect.signature(getattr(py, name))), name
    assert str(inspect.signature(c.inverse_velocity)) == "(q, v, l, lambda_)"
    assert "arm2_jacobian" in c.jacobian.__doc__ and "(..., 2, 2)" in c.jacobian.__doc__
    assert "max_iter" in c.ik_solve.__doc__


@pytest.mark.parametrize("impl", ["C", "Python"])
def test_keyword_calls(arms, impl):
    arm = arms[impl]
    by_position = arm.inverse_velocity(Q, [0.3, -0.2], L, 0.05)
    by_keyword = arm.inverse_velocity(lambda_=0.05, l=L, v=[0.3, -0.2], q=Q)
    np.testing.assert_array_equal(by_position, by_keyword)
    J = arm.jacobian(Q, L)
    np.testing.assert_allclose(J @ by_position, [0.3, -0.2], atol=0.02)  # damped: close, not exact
    result = arm.ik_solve(q0=Q, target=[0.5, 1.2], l=L, lambda_=0.0, tol=1e-12, max_iter=100)
    assert result.status == "converged"
    np.testing.assert_allclose(arm.position(result.q, L), [0.5, 1.2], atol=1e-12)


@pytest.mark.parametrize("impl", ["C", "Python"])
def test_float_modules_default_tol_is_reachable(float_arms, impl):
    arm = float_arms[impl]
    assert inspect.signature(arm.ik_solve).parameters["tol"].default is None  # 1e-4 times the reach
    rng = np.random.default_rng(3)
    for lengths in (L, 500.0 * np.asarray(L)):  # float rounding at the endpoint grows with the arm
        for _ in range(20):
            target = arm.position(rng.uniform(-np.pi, np.pi, 2), lengths)
            result = arm.ik_solve(rng.uniform(-np.pi, np.pi, 2), target, lengths, 0.0)
            assert result.status == "converged", result
            assert result.error <= 1e-4 * max(1.0, float(np.sum(lengths)))


def test_compiled_chain_refuses_params_it_does_not_take_and_non_real_arrays():
    """Issue 16 (15): a robot without named parameters takes no params (an extra argument is a TypeError
    naming the signature, never silently ignored); complex and string arrays are refused, not cast."""
    from pathlib import Path

    from skelarm_sym.models.chain.dh_file import load_robot_file

    chain = load_robot_file(Path(__file__).resolve().parents[1] / "examples" / "robots" / "ur5.toml")
    arm = compile_arm(generate(chain, langs="c", out=None, prefix="ur5_contract", functions="pose,ik_solve"))
    q = np.zeros(6)
    with pytest.raises(TypeError, match=r"pose\(q\)"):
        arm.pose(q, np.ones(2))
    with pytest.raises(TypeError, match="ik_solve"):
        arm.ik_solve(q, np.eye(4), params=np.ones(2))
    with pytest.raises(ValueError, match="real numbers"):
        arm.pose(q.astype(complex))
    with pytest.raises(ValueError, match="real numbers"):
        arm.pose(np.array(["0"] * 6))
    with pytest.raises(ValueError, match="real numbers"):
        arm.ik_solve(q, np.eye(4).astype(complex))
