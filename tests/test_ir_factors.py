"""The per-function pass that multiplies a shared factor once (skelarm_sym/ir/factors.py): the same values to
rounding, one multiplication fewer per product that gave up the factor, and sums without a shared factor left
as they are. Values are judged by evaluating the body before and after with NumPy (skelarm_sym/ir/evaluate.py);
a chain with parallel axes against its recursive reference."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from skelarm_sym import reference
from skelarm_sym.build import load_python
from skelarm_sym.generate import generate
from skelarm_sym.ir.count import count_ops
from skelarm_sym.ir.factors import factor_sums
from skelarm_sym.ir.nodes import Add, Const, Let, Mul, Neg, Store, Var
from skelarm_sym.models.chain.dh_file import load_robot_file

from test_ir_signs import C, S, TRIG, X, assert_same_outputs, run


def _same_values(body, after) -> None:
    for x in np.random.default_rng(10).uniform(-3, 3, (30, 4)):
        before, now = run(body, x), run(after, x)
        for key in before:
            assert now[key] == pytest.approx(before[key], rel=1e-14, abs=1e-14)


def test_products_sharing_a_factor_pay_it_once():
    """``c0 x2 + c0 x3 - s0 c1 x2 - s0 c1 x3 + 0.5 x2 + 0.5 s1``: the factor most products share first (``x2``, in
    three), then ``x3``: ``x2 (c0 - s0 c1 + 0.5) + x3 (c0 - s0 c1) + 0.5 s1``, 8 multiplications 5."""
    value = Add((Mul((C[0], X[2])), Mul((C[0], X[3])), Neg(Mul((S[0], C[1], X[2]))), Neg(Mul((S[0], C[1], X[3]))),
                 Mul((Const(0.5), X[2])), Mul((Const(0.5), S[1]))))
    body = (TRIG, Store("y", 0, value))
    after = factor_sums(body)
    assert count_ops(body).mul == 8 and count_ops(after).mul == 5
    assert count_ops(after).add == count_ops(body).add and count_ops(after).neg == 0
    _same_values(body, after)


def test_all_negated_products_keep_one_negation_and_unshared_sums_stay():
    t = Var("t0")
    negated = (TRIG, Let(t, Add((Neg(Mul((C[0], X[2]))), Neg(Mul((C[0], X[3])))))), Store("y", 0, Mul((t, S[1]))))
    after = factor_sums(negated)
    assert count_ops(after).mul == count_ops(negated).mul - 1 and count_ops(after).neg == count_ops(negated).neg
    _same_values(negated, after)
    plain = (TRIG, Store("y", 0, Add((Mul((C[0], X[2])), Mul((S[0], X[3])), Const(0.3)))))
    assert factor_sums(plain) == plain


TILTED = """[[joints]]
type = "revolute"
alpha = "0.3"
a = 0.3

[[joints]]
type = "revolute"
a = 0.25

[[joints]]
type = "revolute"
a = 0.2
"""
"""Joints 2 and 3 parallel, their axis tilted by 0.3 from joint 1's and turned by it: ``z_2 = z_3`` depends on q1."""


def test_parallel_axes_share_their_axis_in_the_angular_velocity_and_acceleration(tmp_path):
    """Two parallel axes tilted off the first: ``w = z_1 dq1 + z_2 (dq2 + dq3)`` and its rate pay the shared axis
    once (``kinematics`` fewer multiplications than without the pass), the values the reference's."""
    from skelarm_sym.ir import lower

    path = tmp_path / "tilted.toml"
    path.write_text(TILTED, encoding="utf-8")
    chain = load_robot_file(path)
    g = generate(chain, langs="python", out=None, functions="kinematics")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(lower, "factor_sums", lambda body: tuple(body))
        lower._per_function_passes.cache_clear()
        before = generate(chain, langs="python", out=None, functions="kinematics")
    lower._per_function_passes.cache_clear()
    assert g.programs[0].ops.mul < before.programs[0].ops.mul, (g.programs[0].ops, before.programs[0].ops)
    module = load_python(g.sources["tilted.py"], "tilted")
    rng = np.random.default_rng(11)
    q, dq, ddq = (rng.uniform(-2, 2, (20, chain.n)) for _ in range(3))
    ref = reference.chain_kinematics(chain.numeric(), q, dq, ddq)
    T, J, dJ, twist, acc = module.kinematics(q, dq, ddq)
    for got, expected in ((T, ref.T), (J, ref.J), (dJ, ref.dJ), (twist, ref.twist), (acc, ref.acc)):
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13)


_POOL = [X[1], X[2], C[0], S[0], C[1], Const(0.5), Const(2.0)]
_PRODUCTS = st.lists(st.tuples(st.lists(st.integers(0, len(_POOL) - 1), min_size=1, max_size=3), st.booleans()),
                     min_size=1, max_size=6)


@settings(max_examples=200, deadline=None)
@given(st.lists(_PRODUCTS, min_size=1, max_size=3), st.lists(st.floats(-3, 3), min_size=4, max_size=4))
def test_random_sums_of_products_keep_their_values_and_never_pay_more(sums, x):
    """Sums of up to six products of up to three factors from a pool of seven (so that factors repeat), each
    product maybe subtracted, stored or read by the next sum: the same outputs to rounding, and never an
    addition, multiplication or negation more."""
    body, previous = [TRIG], None
    for k, products in enumerate(sums):
        terms = []
        for picks, negated in products:
            factors = tuple(_POOL[p] for p in picks) + ((previous,) if previous is not None and k % 2 else ())
            term = factors[0] if len(factors) == 1 else Mul(factors)
            terms.append(Neg(term) if negated else term)
        local = Var(f"t{k}")
        body.append(Let(local, terms[0] if len(terms) == 1 else Add(tuple(terms))))
        previous = local
    body.append(Store("y", 0, previous))
    body = tuple(body)
    after = factor_sums(body)
    before_ops, after_ops = count_ops(body), count_ops(after)
    assert after_ops.add <= before_ops.add and after_ops.mul <= before_ops.mul and after_ops.neg <= before_ops.neg
    assert_same_outputs(body, after, x)
