"""The direct NumPy printer of the closed-form IK's steps (``closed_ik/numpy_source.py``) against SymPy's own
evaluation: every rule (sums, products with divisions, powers, selects, relationals, logic, calls, numbers), the
steps in order, a node without a rule refused, and the fallback to ``lambdify``."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from skelarm_sym.closed_ik.evaluate import _steps_function
from skelarm_sym.closed_ik.numpy_source import Unsupported, numpy_function

x, y, z = sp.symbols("x y z")
s1, s2 = sp.symbols("_ik_s1 _ik_s2")

EXPRESSIONS = [
    x + 2 * y - z,
    -x * y / z,
    x / (y * z**2),
    sp.Rational(1, 3) * x - sp.Float("0.12345678901234567", 17) * y,
    x**2 + y**3 - 1 / z,
    sp.sqrt(x**2 + y**2) / sp.sqrt(z**2 + 1),
    sp.Piecewise((x, x > y), (y, z <= 0), (z, True), evaluate=False),
    sp.Piecewise((sp.S.One, sp.And(x < 0.5, y >= -0.5)), (sp.S.Zero, True), evaluate=False),
    sp.Piecewise((x - y, sp.Or(x < y, sp.Not(z > 0))), (-x, True), evaluate=False),
    sp.Abs(x - y) + sp.Max(x, y, z) - sp.Min(x, z),
    sp.atan2(y, x) + sp.sin(z) * sp.cos(x),
    sp.Float(3.141592653589793, 17) - x,
]


@pytest.mark.parametrize("expr", EXPRESSIONS, ids=range(len(EXPRESSIONS)))
def test_every_rule_agrees_with_sympy(expr):
    """Each expression at random points against SymPy's exact evaluation of it (30 digits), rounded."""
    rng = np.random.default_rng(1)
    points = rng.uniform(-2, 2, (20, 3))
    got = numpy_function([x, y, z], [], [expr])(*points.T)[0]
    got = np.broadcast_to(np.asarray(got, dtype=float), (len(points),))
    want = np.array([float(expr.subs({x: sp.Float(a, 30), y: sp.Float(b, 30), z: sp.Float(c, 30)}).evalf(30))
                     for a, b, c in points])
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-14)


def test_steps_in_order_and_constants_to_the_last_digit():
    """Steps use the inputs and earlier steps; a Float constant keeps all 17 digits (0.1 + 2e-17 is not 0.1)."""
    c = sp.Float("0.10000000000000002", 17)
    steps = [(s1, x * y + c), (s2, s1**2 - x)]
    f = numpy_function([x, y], steps, [s2, c * x])
    out = f(np.array([1.5, -0.5]), np.array([2.0, 4.0]))
    np.testing.assert_array_equal(out[0], (np.array([1.5, -0.5]) * [2.0, 4.0] + 0.10000000000000002) ** 2 - [1.5, -0.5])
    assert float(f(1.0, 0.0)[1]) == 0.10000000000000002 != 0.1


def test_a_node_without_a_rule_is_refused_and_the_fallback_is_lambdify():
    with pytest.raises(Unsupported, match="exp"):
        numpy_function([x], [], [sp.exp(x)])
    f = _steps_function([x], [(s1, sp.exp(x))], [s1 + 1])
    assert float(f(np.float64(0.5))[0]) == pytest.approx(np.exp(0.5) + 1, rel=1e-15)
