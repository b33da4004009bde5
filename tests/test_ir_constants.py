"""The per-function pass that adds consecutive constants once (skelarm_sym/ir/constants.py; with random bodies
also skelarm_sym/ir/factors.py's, which shares a factor): the same values to
rounding, an addition fewer per folded literal, and nothing folded where the local is read twice or its reader
is no sum with a literal. Values are judged by evaluating the body before and after with NumPy
(skelarm_sym/ir/evaluate.py) on random inputs; the chain's pose against its recursive reference."""

from __future__ import annotations

import sysconfig
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from skelarm_sym import reference
from skelarm_sym.build import load_python
from skelarm_sym.generate import generate
from skelarm_sym.ir.constants import fold_constants
from skelarm_sym.ir.factors import factor_sums
from skelarm_sym.ir.count import count_ops
from skelarm_sym.ir.nodes import Add, Const, Let, Mul, Neg, Store, Var
from skelarm_sym.models.chain.loader import load_robot

from test_ir_signs import C, S, TRIG, X, _body, assert_same_outputs, run


def _check(body, folded, fewer: int) -> None:
    assert count_ops(folded).arithmetic == count_ops(body).arithmetic - fewer
    for x in np.random.default_rng(8).uniform(-3, 3, (30, 4)):
        before, after = run(body, x), run(folded, x)
        assert after.keys() == before.keys()
        for key in before:
            assert after[key] == pytest.approx(before[key], rel=1e-14, abs=1e-15)


def test_a_chain_of_offsets_along_one_axis_adds_one_literal():
    """UR5's ``t16 = 0.093 + t13; t21 = t16 - 0.1197; t22 = 0.13585 + t21``: ``t22 = t13 + 0.10915``."""
    t13, t16, t21, t22 = (Var(f"t{i}") for i in (13, 16, 21, 22))
    body = (TRIG, Let(t13, Mul((C[0], X[2]))), Let(t16, Add((Const(0.093), t13))), Let(t21, Add((t16, Neg(Const(0.1197))))),
            Let(t22, Add((Const(0.13585), t21))), Store("y", 0, Mul((t22, S[0]))))
    folded = fold_constants(body)
    _check(body, folded, 2)
    assert [s.var.name for s in folded if type(s) is Let] == ["t13", "t22"]
    literal = folded[2].value.terms[-1]
    assert type(literal) is Const and literal.value == pytest.approx(0.10915, abs=1e-15)


def test_a_subtracted_local_moves_in_negated_and_cancelling_offsets_leave_a_copy():
    """``y = 0.5 - (x - s0 + 0.2)`` is ``0.3 - x + s0``; TIAGo's ``t39 = (0.027 + t31) - 0.027`` is ``t31``."""
    t0, t1, t2, t3 = (Var(f"t{i}") for i in range(4))
    body = (TRIG, Let(t0, Add((X[2], Neg(S[0]), Const(0.2)))), Let(t1, Add((Const(0.5), Neg(t0)))),
            Let(t2, Add((Const(0.027), Mul((C[1], X[3]))))), Let(t3, Add((t2, Neg(Const(0.027))))),
            Store("y", 0, Mul((t1, C[0]))), Store("y", 1, Mul((t3, S[1]))))
    folded = fold_constants(body)
    _check(body, folded, 3)  # one addition for t1, both of t3's
    assert folded[-2].value.factors[0] == Var("t1") and len(folded[1].value.terms) == 3
    assert type(folded[2].value) is Mul  # t3 = C1 x3: the copy holds the product


def test_a_local_read_twice_or_by_no_sum_with_a_literal_stays():
    t0, t1 = Var("t0"), Var("t1")
    twice = (TRIG, Let(t0, Add((X[2], Const(0.2)))), Let(t1, Add((t0, Const(0.1)))), Store("y", 0, t1), Store("y", 1, Mul((t0, S[0]))))
    no_literal = (TRIG, Let(t0, Add((X[2], Const(0.2)))), Let(t1, Add((t0, C[0]))), Store("y", 0, t1))
    two_literals = (TRIG, Let(t0, Add((X[2], Const(0.2), Neg(Const(0.1))))), Let(t1, Add((t0, Const(0.1)))), Store("y", 0, t1))
    for body in (twice, no_literal, two_literals):
        assert fold_constants(body) == body


def _robots() -> Path | None:
    path = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
    return path if path.is_dir() else None


@pytest.mark.skipif(_robots() is None, reason="example-robot-data is optional (the oracle extra)")
def test_ur5_urdf_pose_pays_each_offset_along_the_shoulder_axis_once():
    """The UR5 URDF's shoulder, upper arm and forearm offsets (0.13585, -0.1197, 0.093 along one axis): pose 62
    -> 60 operations in the C text (63 -> 61 IR count), the values the reference's."""
    chain = load_robot(_robots() / "ur_description/urdf/ur5_robot.urdf", tip="tool0")
    g = generate(chain, langs="python", out=None, functions="pose")
    assert g.programs[0].ops.arithmetic <= 61, g.programs[0].ops
    module = load_python(g.sources["ur5_robot.py"], "ur5_robot")
    q = np.random.default_rng(9).uniform(-3, 3, (20, 6))
    np.testing.assert_allclose(module.pose(q), reference.chain_kinematics(chain.numeric(), q).T, rtol=0, atol=1e-14)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["add", "mul", "neg"]), st.lists(st.integers(0, 40), min_size=2, max_size=3),
                          st.integers(0, 7), st.integers(0, 2)), min_size=1, max_size=12),
       st.lists(st.floats(-3, 3), min_size=4, max_size=4))
def test_random_bodies_keep_their_values_and_never_pay_more(ops, x):
    """Random straight-line bodies (sums and products of inputs, sines, cosines, earlier locals and the literals
    0.75 and -1.5; test_ir_signs's): both passes, alone and in the lowering's order, keep every output to
    rounding, never add a multiplication, and never add to the additions and negations together (a sum whose
    literals cancel may leave a negation where it saved two additions: ``t6 = x0 - 1.5; t9 = -1.5 - t6`` folds
    to ``t9 = -x0``)."""
    body = _body(ops)
    for after in (fold_constants(body), factor_sums(body), factor_sums(fold_constants(body))):
        before_ops, after_ops = count_ops(body), count_ops(after)
        assert after_ops.mul <= before_ops.mul
        assert after_ops.add + after_ops.neg <= before_ops.add + before_ops.neg
        assert_same_outputs(body, after, x)


def test_literals_that_cancel_leave_one_negation_for_two_additions():
    """The example hypothesis found for the test above: two additions become one negation."""
    t0, t1 = Var("t0"), Var("t1")
    body = (TRIG, Let(t0, Add((X[0], Const(-1.5)))), Let(t1, Add((Neg(t0), Const(-1.5)))), Store("y", 0, t1))
    before_ops, after_ops = count_ops(body), count_ops(fold_constants(body))
    assert (before_ops.add, before_ops.neg) == (2, 0) and (after_ops.add, after_ops.neg) == (0, 1)
    assert_same_outputs(body, fold_constants(body), [0.3, -1.2, 2.0, 0.5])


_ATOMS = [X[1], X[2], C[0], S[1]]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(-2, 2, allow_nan=False).map(lambda v: round(v, 3)), st.booleans(), st.booleans(),
                          st.integers(0, 4), st.booleans()), min_size=1, max_size=8),
       st.lists(st.floats(-3, 3), min_size=4, max_size=4))
def test_random_chains_of_offsets_fold_to_the_same_values(links, x):
    """Chains of locals, each the one before (added or subtracted) plus a literal and maybe an atom, some also
    stored: folded, the same outputs to rounding, never an addition more nor more operations in all; a local
    stored as well stays."""
    body, previous, stored = [TRIG], X[0], []
    for k, (literal, subtract, literal_first, atom, store) in enumerate(links):
        term = Neg(previous) if subtract else previous
        extra = [_ATOMS[atom]] if atom < len(_ATOMS) else []
        lit = Const(literal) if literal >= 0 else Neg(Const(-literal))
        terms = [lit, term, *extra] if literal_first else [term, *extra, lit]
        local = Var(f"t{k}")
        body.append(Let(local, Add(tuple(terms))))
        if store:
            stored.append(local)
        previous = local
    body += [Store("y", i, v) for i, v in enumerate(stored + [previous])]
    body = tuple(body)
    after = fold_constants(body)
    before_ops, after_ops = count_ops(body), count_ops(after)
    # a fold saves an addition or two; offsets that cancel to 0 under a subtracted local may leave a sum of
    # subtractions only, which pays a negation (one of the two additions it saved)
    assert after_ops.add <= before_ops.add and after_ops.arithmetic <= before_ops.arithmetic
    assert {s.var.name for s in after if type(s) is Let} >= {v.name for v in stored}
    assert_same_outputs(body, after, x)
