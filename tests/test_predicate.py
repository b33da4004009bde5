"""skelarm_sym/ir/predicate.py on a procedure written for the purpose (not a solver): loops whose bounds
are data, ``break`` and ``return`` inside loops and inside an inlined helper, a helper that returns a
value, array elements read and written at indices that are data, a 64-bit word. The batched PyTorch and
JAX programs must give every lane exactly what the NumPy backend (which prints the IR statement by
statement, one problem per call, with no masking) gives that problem alone. A loop bounded by a module constant
has constant bounds (its counter is the same number in every lane)."""

from __future__ import annotations

import numpy as np
import pytest

from skelarm_sym.backends import BACKENDS
from skelarm_sym.build import load_python
from skelarm_sym.ir.build import Array, Body, fabs, select
from skelarm_sym.ir.nodes import Argument, Bits, Call1, Cast, Const, ConstantDef, Function, Module, NamedConst, Role, Type, Var
from skelarm_sym.ir.predicate import PLoop, _congruence, predicate


def _module() -> Module:
    # helper: halve x[0] and return early when it is positive, else change x[1] and x[0]
    h = Body()
    x = Array("x", 4)
    with h.if_(x[0] > 0.0):
        h.set(x[0], x[0] * 0.5)
        h.return_()
    h.set(x[1], x[1] + 1.0)
    h.set(x[0], x[0] * -0.25)
    halve = Function("halve", "halve", (Argument("x", Role.OUTPUT, (4,)),), h.statements, kind="helper")

    # helper returning a value: a step of a 64-bit generator, its top bits as a number in [0, 1)
    r = Body()
    state = Array("state", 1, Type.UINT64)
    s = r.var("s", state[0], Type.UINT64)
    r.set(s, Bits("^", s, Bits("<<", s, Const(13, Type.INT))))
    r.set(s, Bits("^", s, Bits(">>", s, Const(7, Type.INT))))
    r.set(state[0], s)
    r.return_(Cast(Type.REAL, Bits(">>", Bits("*", s, Const(0x2545F4914F6CDD1D, Type.UINT64)), Const(11, Type.INT)))
              * (1.0 / 9007199254740992.0))
    draw = Function("draw", "draw", (Argument("state", Role.OUTPUT, (1,), Type.UINT64),), r.statements, kind="helper",
                    returns=Type.REAL)

    b = Body()
    v, out, count = Array("v", 4), Array("out", 4), Array("count", 1, Type.INT)
    limit, steps = Var("limit"), Var("steps", Type.INT)
    acc = b.var("acc", 0.0)
    i = b.var("i", 0, Type.INT)
    j = b.var("j", 0, Type.INT)
    u = b.var("u", 0.0)
    gen = b.array("gen", 1, Type.UINT64, values=[Const(0x9E3779B97F4A7C15, Type.UINT64)])
    with b.for_("k", 0, 4) as k:
        b.set(out[k], v[k])
    b.set(count[0], 0)
    with b.if_(~Call1("isfinite", limit)):
        b.return_(Const(2, Type.INT))
    b.set(i, select(v[0] > 0.0, Const(3, Type.INT), Const(1, Type.INT)))
    with b.for_("m", 0, i) as m:  # a bound that is data; an index that is data
        b.set(acc, acc + v[m])
        with b.if_(acc > limit):
            b.break_()
    with b.while_(j < steps):
        b.call("halve", out)
        b.call("draw", gen, result=u)
        b.set(out[2], out[2] + u)
        with b.if_(out[3] > 0.0):  # both branches inside a loop: lanes that left it keep their values
            b.set(out[3], out[3] - 0.5)
        with b.else_():
            b.set(out[3], out[3] + 0.25)
        b.set(acc, acc + out[3])
        b.set(j, j + Const(1, Type.INT))
        with b.if_(fabs(out[0]) < 1e-3):
            b.set(count[0], j)
            b.return_(Const(1, Type.INT))
        with b.if_(out[1] > 2.5):
            b.break_()
    b.set(count[0], j)
    b.set(out[3], out[3] + acc)
    with b.for_("n", 0, NamedConst("TOY_N", Type.INT)) as n:  # a bound that is a module constant, left by data
        with b.if_(n >= i):
            b.break_()
        b.set(out[3], out[3] + 0.125 * out[n])
    b.set(out[i], out[i] + 1.0)  # a write at an index that is data
    w = b.array("w", 8, values=[Const(0.5 * k) for k in range(8)])
    b.set(w[i * Const(2, Type.INT)], acc)  # strided: the write reaches the even elements only, the reads the odd
    b.set(out[1], out[1] + w[i * Const(2, Type.INT) + Const(1, Type.INT)] - 0.25 * w[i * Const(2, Type.INT)])
    b.return_(Const(0, Type.INT))
    toy = Function(
        "toy", "a procedure of every construct",
        (Argument("v", Role.STATE, (4,), domain="finite", batched=False),
         Argument("limit", Role.SCALAR, (), batched=False),
         Argument("steps", Role.SCALAR, (), Type.INT, batched=False),
         Argument("out", Role.OUTPUT, (4,)),
         Argument("count", Role.OUTPUT, (1,), Type.INT, fields=("count",))),
        b.statements, kind="procedure", returns=Type.INT,
        statuses=(("TOY_DONE", 0, "done"), ("TOY_SMALL", 1, "small"), ("TOY_BAD", 2, "bad")), result="ToyResult",
    )
    return Module("toy", "double", ("a test module",), (ConstantDef("TOY_N", 4, "a loop bound"),), (), (halve, draw, toy))


def test_the_masked_form_has_a_loop_per_loop_over_data():
    module = _module()
    p = predicate(module, module.function("toy"))
    loops = [s for s in p.body if type(s) is PLoop]
    assert len(loops) == 2  # the For with a data bound and the While; the constant For stays a PFor
    assert "m" not in p.statics and "k" in p.statics
    assert "n" in p.statics  # bounded by TOY_N: a number the printer knows, not a counter per lane


def test_an_index_keeps_the_congruence_its_form_fixes():
    # the elements a data index can reach: 6 r + 3 is 3 modulo 6 whatever r; a product and a sum of such forms too
    r, k = Var("r", Type.INT), Var("k", Type.INT)
    n = lambda v: Const(v, Type.INT)  # noqa: E731
    assert _congruence(n(6) * r + n(3), {}) == (6, 3)
    assert _congruence((n(2) * r + n(1)) * n(3), {}) == (6, 3)
    assert _congruence(n(6) * r + n(4) * k + n(3), {}) == (2, 1)
    assert _congruence(NamedConst("N", Type.INT) * r + n(1), {"#N": 8}) == (8, 1)
    assert _congruence(r, {}) == (1, 0) and _congruence(n(5), {}) == (0, 5)
    assert _congruence(NamedConst("N", Type.INT) * r, {}) == (1, 0)  # a constant of unknown value: nothing known


@pytest.mark.parametrize("lang", ["torch", "jax"])
def test_every_lane_ends_as_the_scalar_program_ends(lang):
    pytest.importorskip(lang, reason=f"{lang} is not installed: pip install 'skelarm-sym[{lang}]'")
    if lang == "jax":
        import jax

        jax.config.update("jax_enable_x64", True)
    module = _module()
    numpy_text = BACKENDS["python"].render(module, "0")[".py"]
    batched_text = BACKENDS[lang].render(module, "0")[f"_{lang}.py"]
    scalar = load_python(numpy_text, "toy")
    batched = load_python(batched_text, f"toy_{lang}")
    rng = np.random.default_rng(21)
    v = rng.uniform(-3.0, 3.0, (300, 4))
    v[:20, 0] = rng.uniform(-1e-3, 1e-3, 20)  # lanes that return early
    for limit, steps in ((1.0, 12), (10.0, 40), (-5.0, 0)):
        result = batched.toy(v, limit, steps)
        singles = [scalar.toy(row, limit, steps) for row in v]
        statuses = [r.status for r in singles]
        assert len(set(statuses)) > 1 or steps == 0  # several exits taken
        np.testing.assert_array_equal(np.asarray(result.status), [{"toy_done": 0, "toy_small": 1, "toy_bad": 2}[s] for s in statuses])
        np.testing.assert_array_equal(np.asarray(result.count), [r.count for r in singles])
        np.testing.assert_array_equal(np.asarray(result.out), np.array([r.out for r in singles]))
