"""skelarm_sym/ir/nodes.py: expressions are values. Nodes built apart from the same parts are equal and hash
alike (the printers' memos and the common-subexpression tables rely on it), whatever order hashes and
comparisons happen in; nodes that differ anywhere, or differ only in their type, are unequal; a node keeps
its value through pickling and copying. The composite nodes remember their hash, so none of this may depend
on which of two equal nodes was hashed first."""

from __future__ import annotations

import copy
import pickle
import random

from skelarm_sym.ir.nodes import Add, Call1, Call2, Compare, Const, Div, Elem, Mul, Neg, Not, Select, Type, Var


def _tree(rng: random.Random, depth: int):
    """A random expression of the given depth over two variables and a few constants."""
    if depth == 0:
        return rng.choice([Var("x"), Var("y"), Const(0.5), Const(2), Elem("q", Const(1, Type.INT))])
    a, b = _tree(rng, depth - 1), _tree(rng, depth - 1)
    return rng.choice([
        lambda: Add((a, b)), lambda: Mul((a, b, a)), lambda: Neg(a), lambda: Div(a, b, rng.random() < 0.5),
        lambda: Call1("sin", a), lambda: Call2("atan2", a, b), lambda: Select(Compare("<", a, b), a, b),
    ])()


def test_equal_parts_make_equal_nodes_whichever_is_hashed_first():
    for seed in range(40):
        first, second = _tree(random.Random(seed), 6), _tree(random.Random(seed), 6)
        assert first is not second
        if seed % 2:
            hash(first)  # one side remembers its hash, the other not yet
        assert first == second and second == first
        assert hash(first) == hash(second)
        assert {first: seed}[second] == seed
        assert len({first, second, copy.deepcopy(first), pickle.loads(pickle.dumps(second))}) == 1


def test_nodes_that_differ_are_unequal():
    x, y = Var("x"), Var("y")
    base = Add((Mul((x, y)), Neg(x)))
    assert base != Add((Mul((x, y)), Neg(y)))  # a leaf deep inside
    assert base != Add((Neg(x), Mul((x, y))))  # the order of the terms
    assert Neg(x) != Not(x)  # same field, another node
    assert Div(x, y) != Div(x, y, guarded=True)
    assert Elem("q", Const(0, Type.INT)) != Elem("q", Const(0, Type.INT), Type.INT)
    trees = {_tree(random.Random(seed), 5) for seed in range(60)}
    assert len(trees) == len({repr(t) for t in trees})  # unequal exactly when they print differently


def test_a_number_is_equal_to_the_same_number_written_otherwise():
    # Python's own rule (1 == 1.0, equal hashes) carries through composite nodes
    assert Add((Var("x"), Const(1.0))) == Add((Var("x"), Const(1)))
    assert hash(Neg(Const(1.0))) == hash(Neg(Const(1)))
