"""The structural derivation against direct differentiation and the reference."""

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from skelarm_sym import derive, reference
from skelarm_sym.derive import expand_steps


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_symbolically_equal_to_direct_differentiation(n):
    d = derive(n)
    t = sp.Symbol("t")
    assert (d.p.jacobian(d.q) - d.J).expand() == sp.zeros(2, n)
    # d/dt of J along q(t): chain rule with dq as the time derivative of q.
    dJdt = sum((d.J.diff(qi) * dqi for qi, dqi in zip(d.q, d.dq)), sp.zeros(2, n))
    assert (dJdt - d.H).expand() == sp.zeros(2, n)
    assert (d.J * sp.Matrix(d.dq) - d.v).expand() == sp.zeros(2, 1)
    assert (d.J * sp.Matrix(d.ddq) + d.H * sp.Matrix(d.dq) - d.a).expand() == sp.zeros(2, 1)
    assert d.phi == sum(d.q)
    assert d.J3[2, :] == sp.ones(1, n)
    assert t not in d.J.free_symbols


def test_two_link_closed_forms_are_the_seeds():
    d = derive(2)
    q1, q2 = d.q
    l1, l2 = d.l
    expected = sp.Matrix([[-l1 * sp.sin(q1) - l2 * sp.sin(q1 + q2), -l2 * sp.sin(q1 + q2)], [l1 * sp.cos(q1) + l2 * sp.cos(q1 + q2), l2 * sp.cos(q1 + q2)]])
    assert d.J == expected
    assert sp.trigsimp(sp.expand_trig(d.J.det()).expand()) == l1 * l2 * sp.sin(q2)


def test_numeric_lengths_are_numbers():
    d = derive(3, [1.0, 0.8, 0.5])
    assert all(isinstance(x, sp.Number) for x in d.l)
    assert "l" not in d.inputs
    assert d.J.free_symbols == set(d.q)


def test_steps_grow_linearly():
    sizes = [len(derive(n).steps) for n in (8, 16, 32)]
    assert sizes[2] - sizes[1] == 2 * (sizes[1] - sizes[0])


def _evaluate(d, names, q, dq, ddq, l):
    args = [*d.q, *d.dq, *d.ddq, *d.l]
    values = [*q, *dq, *ddq, *l]
    out = []
    for name in names:
        compact = d.compact[name]
        flat = expand_steps(d.steps, list(compact)) if d.n <= 4 else None
        fn = sp.lambdify(args, list(compact) if flat is None else flat, "math")
        if flat is None:  # larger n: evaluate through the steps themselves
            env = dict(zip(args, values))
            for sym, expr in d.steps:
                value = expr.xreplace(env)
                if value.free_symbols:  # needs inputs not given here (target, lambda, ...)
                    continue
                env[sym] = value if isinstance(value, sp.logic.boolalg.BooleanAtom) else float(value)
            vals = [float(e.xreplace(env)) for e in compact]
        else:
            vals = fn(*values)
        out.append(np.array(vals, dtype=float).reshape(compact.shape))
    return out


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 12), seed=st.integers(0, 2**31 - 1))
def test_symbolic_side_matches_reference(n, seed):
    rng = np.random.default_rng(seed)
    q, dq, ddq = rng.uniform(-np.pi, np.pi, (3, n))
    l = rng.uniform(0.2, 2.0, n)
    d = derive(n)
    p, J, H, v, a = _evaluate(d, ["p", "J", "H", "v", "a"], q, dq, ddq, l)
    k = reference.kinematics(q, dq, ddq, l)
    scale = 1 + np.abs(k.a).max()
    np.testing.assert_allclose(p[:, 0], k.p, atol=1e-12)
    np.testing.assert_allclose(J, k.J, atol=1e-12)
    np.testing.assert_allclose(H, k.H, atol=1e-11)
    np.testing.assert_allclose(v[:, 0], k.v, atol=1e-11)
    np.testing.assert_allclose(a[:, 0], k.a, atol=1e-12 * scale)


def test_large_n_derivation_matches_reference_numerically(rng):
    n = 64
    d = derive(n)
    q, dq, ddq = rng.uniform(-np.pi, np.pi, (3, n))
    l = rng.uniform(0.2, 2.0, n)
    (H,) = _evaluate(d, ["H"], q, dq, ddq, l)
    np.testing.assert_allclose(H, reference.kinematics(q, dq, ddq, l).H, atol=1e-10)


@pytest.mark.parametrize("terms", [["positive"] * 3, ["positive"] * 40, ["positive", "real"], ["positive", "number"]])
def test_nonzero_is_what_sympy_decides(terms):
    """``linalg.nonzero`` answers a sum of positive symbols without SymPy's assumption query: the same
    expression SymPy's comparison gives, for such sums and for the sums it must leave to SymPy."""
    import importlib

    linalg = importlib.import_module("skelarm_sym.derive.linalg")  # ``skelarm_sym.derive`` is also a function's name
    parts = [sp.Integer(2) if kind == "number" else sp.Symbol(f"x{i}", **{kind: True}) for i, kind in enumerate(terms)]
    value = sp.Add(*parts)
    by_sympy = sp.Piecewise((value, sp.StrictGreaterThan(value, 0)), (sp.S.One, True))
    got = linalg.nonzero(value)
    assert got == by_sympy and type(got) is type(by_sympy)


def test_unevaluated_shortcuts_build_what_sympy_evaluates():
    """``linalg.select`` and the planar sines and cosines skip SymPy's evaluation only where it would change
    nothing: the expressions equal the evaluated ones, and where evaluation does rewrite (equal branches,
    a constant condition, a zero or negated angle) they are the rewritten ones."""
    import importlib

    linalg = importlib.import_module("skelarm_sym.derive.linalg")
    planar = importlib.import_module("skelarm_sym.models.planar.derive")
    a, b, c = sp.symbols("a b c", real=True)
    x = sp.Symbol("x", positive=True)
    for cond, then, otherwise in [(c, a, b), (c, a * b, a + b), (c, a, a), (sp.true, a, b), (a > 0, a, b),
                                  (c, sp.Piecewise((a, c), (b, True)), b)]:
        got = linalg.select(cond, then, otherwise)
        assert got == sp.Piecewise((then, cond), (otherwise, True))
    assert linalg.select(c, a, a) == a
    for func in (sp.cos, sp.sin):
        for angle in (a, x, sp.S.Zero, -a, sp.pi / 2):
            assert planar._unevaluated(func, angle) == func(angle)
    assert planar._unevaluated(sp.cos, sp.S.Zero) == 1 and planar._unevaluated(sp.cos, -a) == sp.cos(a)


def test_a_step_label_names_one_expression():
    """SymPy makes equal symbols of equal names: a second, different expression under a label would share the
    first's symbol, and the lowering would keep one definition for both. The recorder refuses it; the same
    expression again gets its first name."""
    from skelarm_sym.derive import StepRecorder

    steps = StepRecorder("t")
    x, y = sp.symbols("x y")
    first = steps("a", x + y)
    assert steps("a", x + y) is first and steps("b", x + y) is first
    assert steps.definitions() == {first: x + y}
    with pytest.raises(ValueError, match="defined twice"):
        steps("a", x * y)
