"""The per-function reuse of products on the IR (skelarm_sym/ir/products.py): the same values (to rounding),
never more operations, and the multiplications it is there to remove. Values are judged by evaluating the body
before and after with NumPy (skelarm_sym/ir/evaluate.py); operation counts by skelarm_sym/ir/count.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from skelarm_sym.ir.count import count_ops
from skelarm_sym.ir.nodes import Add, Const, Let, Mul, Neg, Store, Var
from skelarm_sym.ir.products import reuse_products

from test_ir_signs import C, S, TRIG, X, assert_same_outputs, run


def test_a_product_read_only_by_products_that_have_a_cheaper_partner_goes():
    """Stanford's second Jacobian column: u = c1 q3 feeds c0 u and s0 u, while c0 c1 and c1 s0 are already there
    for the rotation: (c0 c1) q3 and (c1 s0) q3 need u no more (4 multiplications instead of 5)."""
    a, b, u = Var("t0"), Var("t1"), Var("t2")
    body = (TRIG, Let(a, Mul((C[0], C[1]))), Let(b, Mul((C[1], S[0]))), Let(u, Mul((C[1], X[2]))),
            Store("y", 0, Mul((u, C[0]))), Store("y", 1, Mul((u, S[0]))), Store("y", 2, a), Store("y", 3, b))
    after = reuse_products(body)
    assert count_ops(body).mul == 5 and count_ops(after).mul == 4
    assert Store("y", 0, Mul((a, X[2]))) in after and Store("y", 1, Mul((b, X[2]))) in after
    assert all(not (type(s) is Let and s.var == u) for s in after)


def test_a_product_of_three_reads_an_earlier_product_of_two():
    a = Var("t0")
    body = (TRIG, Let(a, Mul((C[0], S[1]))), Store("y", 0, a), Store("y", 1, Add((Mul((S[1], X[3], C[0])), C[1]))))
    after = reuse_products(body)
    assert count_ops(after).mul == count_ops(body).mul - 1
    x = np.array([0.4, -1.2, 0.3, 2.5])
    assert run(after, x) == pytest.approx(run(body, x), rel=1e-15)


def test_a_product_read_elsewhere_than_in_products_stays():
    a, u = Var("t0"), Var("t1")
    body = (TRIG, Let(a, Mul((C[0], C[1]))), Let(u, Mul((C[1], X[2]))), Store("y", 0, Mul((u, C[0]))),
            Store("y", 1, Add((u, S[0]))), Store("y", 2, a))
    after = reuse_products(body)
    assert any(type(s) is Let and s.var == u for s in after)
    assert count_ops(after).mul <= count_ops(body).mul


def _body(draws):
    lets, stores, names = [], [], []
    for k, (kind, picks, out) in enumerate(draws):
        pool = X + C + S + [Var(n) for n in names] + [Const(1.5)]
        args = tuple(pool[p % len(pool)] for p in picks)
        value = Mul(args) if kind == "mul" else (Add(args) if kind == "add" else Neg(args[0]))
        names.append(f"t{k}")
        lets.append(Let(Var(names[-1]), value))
        if out:
            stores.append(Store("y", len(stores), Var(names[-1])))
    return (TRIG, *lets, *stores)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["mul", "mul", "add", "neg"]), st.lists(st.integers(0, 40), min_size=2, max_size=4),
                          st.booleans()), min_size=1, max_size=14),
       st.lists(st.floats(-2, 2), min_size=4, max_size=4))
def test_random_bodies_keep_their_values_and_never_pay_more(draws, x):
    body = _body(draws)
    after = reuse_products(body)
    before_ops, after_ops = count_ops(body), count_ops(after)
    assert after_ops.mul <= before_ops.mul
    assert (after_ops.add, after_ops.neg) == (before_ops.add, before_ops.neg)
    assert_same_outputs(body, after, x)
