"""The per-function sign pass on the IR (skelarm_sym/ir/signs.py): the same values, never more operations,
and the negations it is there to remove.

Values are judged by evaluating the body before and after with NumPy (skelarm_sym/ir/evaluate.py) on random
inputs, operation counts by skelarm_sym/ir/count.py; the chain's functions against its recursive reference
(skelarm_sym/models/chain/reference.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from skelarm_sym.ir.count import count_ops
from skelarm_sym.ir.evaluate import evaluate
from skelarm_sym.ir.nodes import Add, Call1, Const, Div, Elem, If, Let, Mul, Neg, Store, TrigBlock, Type, Var
from skelarm_sym.ir.signs import _settled, _Signs, settle_signs

X = [Elem("x", Const(i, Type.INT)) for i in range(4)]
C = [Var(f"c{k}") for k in range(2)]
S = [Var(f"s{k}") for k in range(2)]
TRIG = TrigBlock((X[0], X[1]), tuple(C), tuple(S))


def run(body, x):
    """Outputs of a straight body at inputs ``x``: {(output, index): value}."""
    values = {"x": np.asarray(x, dtype=float)}
    out = {}
    for s in body:
        if type(s) is TrigBlock:
            for a, c, sn in zip(s.angles, s.cos, s.sin):
                angle = evaluate(a, values)
                values[c.name], values[sn.name] = np.cos(angle), np.sin(angle)
        elif type(s) is Let:
            values[s.var.name] = evaluate(s.value, values)
        elif type(s) is Store:
            out[(s.output, s.index)] = float(evaluate(s.value, values))
    return out


def assert_both_negations_go(body, seed: int) -> None:
    """``body`` pays two negations; the sign pass leaves none (two operations fewer), the outputs the same."""
    assert count_ops(body).neg == 2
    after = settle_signs(body)
    assert count_ops(after).neg == 0 and count_ops(after).arithmetic == count_ops(body).arithmetic - 2
    for x in np.random.default_rng(seed).uniform(-3, 3, (30, 4)):
        assert_same_outputs(body, after, x)


def assert_same_outputs(body, after, x) -> None:
    """``after`` stores what ``body`` stores at inputs ``x``, to rounding."""
    want, got = run(body, x), run(after, x)
    assert got.keys() == want.keys()
    for key in want:
        assert got[key] == pytest.approx(want[key], rel=1e-12, abs=1e-12)


def test_a_local_only_read_negated_is_stored_negated():
    t = Var("t0")
    body = (TRIG, Let(t, Add((Mul((Const(0.5), C[0])), Mul((S[0], X[2]))))), Store("y", 0, Neg(t)), Store("y", 1, Add((t, S[1]))))
    after = settle_signs(body)
    assert count_ops(body).neg == 1 and count_ops(after).neg == 0  # t = -0.5 c0 - s0 x2, y0 = t, y1 = s1 - t
    assert after[1].value == Add((Mul((Const(-0.5), C[0])), Neg(Mul((S[0], X[2])))))
    x = np.random.default_rng(1).uniform(-2, 2, 4)
    assert run(after, x) == pytest.approx(run(body, x), rel=1e-15, abs=0)


def test_a_negated_product_reads_an_earlier_negated_factor():
    n, t = Var("t0"), Var("t1")  # n = -s0 exists (the derivation hoisted it); y0 = -(s0 x2) can read it
    body = (TRIG, Let(n, Neg(S[0])), Let(t, Mul((C[1], n))), Store("y", 0, t), Store("y", 1, Neg(Mul((S[0], X[2])))))
    after = settle_signs(body)
    assert count_ops(body).neg == 2 and count_ops(after).neg == 1
    assert Store("y", 1, Mul((n, X[2]))) in after


def test_a_negation_nothing_reads_any_more_is_dropped():
    t, u = Var("t0"), Var("t1")  # u = -t feeds only y0: storing t negated makes u dead
    body = (TRIG, Let(t, Add((Mul((Const(2.0), C[0])), S[1]))), Let(u, Neg(t)), Store("y", 0, u), Store("y", 1, Add((t, C[1]))))
    after = settle_signs(body)
    assert count_ops(after).neg == 0
    assert all(not (type(s) is Let and s.var == u) for s in after)


def test_a_condition_reads_a_flipped_local_with_its_sign():
    """A select's condition, a logical term and a comparison read the local as stored: ``t > 0`` becomes ``-t > 0``
    when ``t`` holds ``-t`` (the closed-form IK's branches; a condition left as it was chose the other branch)."""
    from skelarm_sym.ir.nodes import Compare, Logic, Not, Select

    t = Var("t0")
    cond = Logic("and", (Compare(">", t, Const(0.0)), Not(Compare("<", t, Const(-5.0)))))
    body = (TRIG, Let(t, Add((Mul((Const(0.5), C[0])), S[1]))), Store("y", 0, Neg(t)), Store("y", 1, Neg(Mul((t, C[1])))),
            Store("y", 2, Neg(Mul((t, S[1])))), Store("y", 3, Select(cond, C[0], S[0])))
    after = settle_signs(body)
    assert count_ops(after).neg < count_ops(body).neg  # t is stored negated
    for x in np.random.default_rng(3).uniform(-3, 3, (40, 4)):
        assert run(after, x) == pytest.approx(run(body, x), rel=1e-15, abs=0)


def test_bodies_with_control_flow_and_bodies_with_nothing_to_gain_come_back_unchanged():
    t = Var("t0")
    body = (TRIG, Let(t, Mul((C[0], S[1]))), Store("y", 0, t))
    assert settle_signs(body) == body
    flow = (Let(t, Neg(X[0])), If(Const(True, Type.BOOL), (Store("y", 0, t),)))
    assert settle_signs(flow) == flow


# random straight-line bodies: sums and products of the inputs, trig values and earlier locals, some negated

def _body(draw_ops):
    lets, stores = [], []
    names = []
    for k, (kind, picks, neg, out) in enumerate(draw_ops):
        pool = X + C + S + [Var(n) for n in names] + [Const(0.75), Const(-1.5)]
        args = tuple(pool[p % len(pool)] for p in picks)
        args = tuple(Neg(a) if (neg >> i) & 1 and type(a) is not Const else a for i, a in enumerate(args))
        value = Add(args) if kind == "add" else (Mul(tuple(a.x if type(a) is Neg else a for a in args)) if kind == "mul" else Neg(args[0]))
        if kind == "mul" and any(type(a) is Neg for a in args):
            value = Neg(value)
        name = f"t{k}"
        names.append(name)
        lets.append(Let(Var(name), value))
        if out:
            stores.append(Store("y", len(stores), Neg(Var(name)) if out == 2 else Var(name)))
    return (TRIG, *lets, *stores)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["add", "mul", "neg"]), st.lists(st.integers(0, 40), min_size=2, max_size=3),
                          st.integers(0, 7), st.integers(0, 2)), min_size=1, max_size=12),
       st.lists(st.floats(-3, 3), min_size=4, max_size=4))
def test_random_bodies_keep_their_values_and_never_pay_more(ops, x):
    body = _body(ops)
    after = settle_signs(body)
    before_ops, after_ops = count_ops(body), count_ops(after)
    assert after_ops.neg <= before_ops.neg
    assert (after_ops.add, after_ops.mul) == (before_ops.add, before_ops.mul)
    assert_same_outputs(body, after, x)


def test_stanford_jacobian_pays_only_its_two_unavoidable_negations():
    """Stanford arm: J[19] = -sin q1 and J[34] = -sin q2 cos q4 need a negation each; the others (J[0], J[13]) are
    taken by storing q3 sin q2 and the first column's sum negated. Values against the recursive reference."""
    from pathlib import Path

    from skelarm_sym.generate import generate
    from skelarm_sym.models.chain.loader import load_robot
    from skelarm_sym.models.chain.reference import chain_kinematics

    chain = load_robot(Path(__file__).resolve().parents[1] / "examples" / "robots" / "stanford.toml")
    g = generate(chain, langs="python", functions="jacobian", out=None)
    function = next(f for f in g.module.functions if f.name == "jacobian")
    assert function.ops.neg == 2
    namespace: dict = {}
    exec(g.sources["stanford.py"], namespace)  # noqa: S102 - the module this test generated
    q = np.array([0.3, -0.7, 0.5, 1.1, -0.4, 0.9])
    assert namespace["jacobian"](q) == pytest.approx(chain_kinematics(chain.numeric(), q).J, abs=1e-12)


# the sign pass takes a statement it finds settled as it is, without writing its normal form: that must be exactly
# what the normal form would have been (sign +1, the same tree, nothing paid), on any expression

_LEAVES = X + C + S + [Var("u"), Var("t0"), Const(0.75), Const(-1.5)]  # u = -x0 is a negated copy


def _expressions():
    leaf = st.sampled_from(_LEAVES)

    def grow(inner):
        parts = st.lists(inner, min_size=2, max_size=4).map(tuple)
        return st.one_of(parts.map(Add), parts.map(Mul), inner.map(Neg), st.tuples(inner, inner).map(lambda ab: Div(*ab)),
                         inner.map(lambda a: Call1("sqrt", a)))

    return st.recursive(leaf, grow, max_leaves=12)


@settings(max_examples=400, deadline=None)
@given(_expressions())
def test_what_the_sign_pass_takes_as_settled_is_its_own_normal_form(value):
    body = (TRIG, Let(Var("u"), Neg(X[0])), Let(Var("t0"), Add((X[1], Neg(S[0])))), Let(Var("t1"), value))
    signs = _Signs(body)
    if _settled(value, signs.alias_of):
        sign, written, paid = signs.normal(value, 3)
        assert (sign, written, paid) == (1, value, 0)
        assert signs.cost[3] == 0 and not signs.reads[3]


def test_a_negation_moved_along_a_chain_of_locals_to_a_subtraction():
    """``u = -x0 x1 - x2 x3`` pays a negation that no single flip removes: flipping ``u`` moves it to ``v``, then
    to ``w``, whose reader subtracts it for free (TALOS's arm: its pose 109 -> 108 so). The chase flips the three
    together; the values are the same."""
    from skelarm_sym.ir import signs

    u, v, w = Var("t0"), Var("t1"), Var("t2")
    body = (TRIG, Let(u, Add((Neg(Mul((X[0], X[1]))), Neg(Mul((X[2], X[3])))))),
            Let(v, Add((Mul((u, C[0])), Neg(Mul((X[1], S[0])))))), Let(w, Add((Mul((v, C[1])), Neg(Mul((X[0], S[1])))))),
            Store("y", 0, Add((X[3], Mul((w, S[0]))))))
    assert count_ops(body).neg == 1
    after = settle_signs(body)
    assert count_ops(after).neg == 0 and count_ops(after).arithmetic == count_ops(body).arithmetic - 1
    for x in np.random.default_rng(12).uniform(-3, 3, (30, 4)):
        assert run(after, x) == pytest.approx(run(body, x), rel=1e-15, abs=0)
    with pytest.MonkeyPatch.context() as patch:  # the greedy flips alone leave it
        patch.setattr(signs, "CHASE_DEPTH", 0)
        assert count_ops(settle_signs(body)).neg == 1


@pytest.mark.parametrize("copied", [False, True], ids=["negated store", "negated copy"])
def test_a_chase_flips_what_a_paying_local_reads(copied):
    """TALOS's arm ends its pose with ``T[2] = -t34``, ``T[6] = -t36`` and ``t41 = t34*t37 - t35*t36``: flipping
    ``t34`` alone moves a negation into ``t41``, flipping ``t41`` moves it to its store. Flipping ``t36`` (which
    ``t41`` reads) and ``t17`` (which ``t36`` reads) too leaves no negation (its pose 108 -> 106). The chase takes
    the reads of a paying local as next flips and the cheapest of them; the values are the same. Where the
    derivation wrote the negations as copies (``t99 = -t34; T[2] = t99``: the arm's pose generated with the
    other functions), no statement pays one itself, and the chase starts from the locals the copies negate."""
    from skelarm_sym.ir import signs

    t = {k: Var(f"t{k}") for k in (17, 34, 35, 36, 37, 41, 42, 98, 99)}
    c5, s5, c6, s6 = C[0], S[0], C[1], S[1]
    body = (
        TRIG,
        Let(t[17], Add((Mul((X[3], c5)), Neg(Mul((X[0], s5)))))),
        Let(t[34], Add((Mul((X[0], s6)), Neg(Mul((X[1], c6)))))),
        *((Let(t[99], Neg(t[34])), Store("T", 2, t[99])) if copied else (Store("T", 2, Neg(t[34])),)),
        Let(t[35], Add((Mul((X[0], c6)), Mul((X[1], s6))))),
        Store("T", 1, t[35]),
        Let(t[36], Add((Mul((X[2], s6)), Mul((t[17], c6))))),
        *((Let(t[98], Neg(t[36])), Store("T", 6, t[98])) if copied else (Store("T", 6, Neg(t[36])),)),
        Let(t[37], Add((Mul((X[2], c6)), Neg(Mul((t[17], s6)))))),
        Store("T", 5, t[37]),
        Let(t[41], Add((Mul((t[34], t[37])), Neg(Mul((t[35], t[36])))))),
        Store("T", 8, t[41]),
        Let(t[42], Add((Mul((X[1], t[36])), Neg(Mul((X[2], t[34])))))),
        Store("T", 9, t[42]),
    )
    assert_both_negations_go(body, seed=13)
    with pytest.MonkeyPatch.context() as patch:  # following only the paying local's own flip leaves both
        patch.setattr(signs, "CHASE_OPTIONS", 1)
        assert count_ops(settle_signs(body)).neg == 2


def test_a_chase_goes_on_from_what_an_earlier_flip_left_paying():
    """The simple humanoid's pose ends with ``T[6] = -t31``, ``T[10] = -t33`` and ``t35 = t31*t34 - t32*t33``.
    Flipping ``t31`` moves a negation into its own sum and one into ``t35``; flipping ``t28`` (which ``t31`` reads)
    takes the first back, and nothing that flip moved pays: the chase goes on from ``t35``, which the first flip
    left paying, through ``t33`` and ``t30``. No negation is left (its pose 138 -> 135); the values are the same."""
    t = {k: Var(f"t{k}") for k in (24, 26, 28, 30, 31, 32, 33, 34, 35, 36)}
    c8, s8, c9, s9 = C[0], S[0], C[1], S[1]
    body = (
        TRIG,
        Let(t[24], Add((Mul((X[0], c8)), Neg(Mul((X[1], s8)))))),
        Let(t[26], Add((Mul((X[2], c8)), Neg(Mul((X[3], s8)))))),
        Let(t[28], Add((Mul((X[1], c8)), Neg(Mul((X[0], s8)))))),
        Let(t[30], Add((Mul((X[3], c8)), Neg(Mul((X[2], s8)))))),
        Let(t[31], Add((Mul((t[28], c9)), Mul((t[24], s9))))),
        Store("T", 6, Neg(t[31])),
        Let(t[32], Add((Mul((t[24], c9)), Neg(Mul((t[28], s9)))))),
        Store("T", 5, t[32]),
        Let(t[33], Add((Mul((t[30], c9)), Mul((t[26], s9))))),
        Store("T", 10, Neg(t[33])),
        Let(t[34], Add((Mul((t[26], c9)), Neg(Mul((t[30], s9)))))),
        Store("T", 9, t[34]),
        Let(t[35], Add((Mul((t[31], t[34])), Neg(Mul((t[32], t[33])))))),
        Store("T", 0, t[35]),
        Let(t[36], Add((Mul((X[0], t[33])), Neg(Mul((X[1], t[31])))))),
        Store("T", 1, t[36]),
    )
    assert_both_negations_go(body, seed=14)
