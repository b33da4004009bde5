"""A per-function pass: a factor that several products of one sum share, multiplied once.

The angular velocity and acceleration sum ``z_k dq_k`` over the joints; joints whose axes are parallel (a
planar segment, UR5's joints 2-4, a quadruped's knee and hip) share ``z_k``, and the sum pays one
multiplication per joint: ``c0*ddq[1] + c0*ddq[2]``. Written ``c0*(ddq[1] + ddq[2])`` it pays one for all. Where
two or more products of a statement's sum share a factor (a local, an input or a literal), the factor
shared by the most is taken out of them (first seen on a tie), and again in what is left and inside.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace
from typing import Sequence

from .nodes import Add, Let, Mul, Neg, Store, TrigBlock, signed_sum


def _product(term):
    """``(negated, factors)`` of a product term (``x y`` or ``-(x y)``), else ``None``."""
    negated = type(term) is Neg
    inner = term.x if negated else term
    return (negated, inner.factors) if type(inner) is Mul else None


def _without(factors: tuple, factor) -> object:
    rest = list(factors)
    rest.remove(factor)
    return rest[0] if len(rest) == 1 else Mul(tuple(rest))


def _factored(e):
    """``e`` with shared factors taken out of its sum's products (``e`` itself where none is shared)."""
    if type(e) is not Add or sum(1 for t in e.terms if type(t) is Mul or (type(t) is Neg and type(t.x) is Mul)) < 2:
        return e
    terms = list(e.terms)
    changed = False
    while True:
        counts: Counter = Counter()
        for term in terms:
            product = _product(term)
            if product is not None:
                counts.update(list(dict.fromkeys(product[1])))  # each factor once, in order (a set's order is the hash's)
        shared = [f for f, c in counts.items() if c >= 2]
        if not shared:
            break
        factor = max(shared, key=lambda f: counts[f])  # Counter keeps first-seen order: a tie takes the first
        group = [t for t in terms if (p := _product(t)) is not None and factor in p[1]]
        inner = []
        for term in group:
            negated, factors = _product(term)
            rest = _without(factors, factor)
            inner.append(Neg(rest) if negated else rest)
        outside = all(type(t) is Neg for t in inner)  # -(f x) - (f y) = -(f (x + y)): the sum's own negation kept
        if outside:
            inner = [t.x for t in inner]
        product = Mul((factor, _factored(signed_sum(inner))))
        first = terms.index(group[0])
        terms = [t for t in terms if t not in group]
        terms.insert(first, Neg(product) if outside else product)
        changed = True
    if not changed:
        return e
    return signed_sum(terms)


def factor_sums(body: Sequence) -> tuple:
    """``body`` (straight-line: lets, trigonometry blocks, stores) with every statement's sum written with its
    shared factors taken out (:func:`_factored`); any other body comes back as it is."""
    if not all(type(s) in (Let, TrigBlock, Store) for s in body):
        return tuple(body)
    out = []
    for s in body:
        if type(s) is not TrigBlock and type(s.value) is Add:
            value = _factored(s.value)
            if value is not s.value:
                s = replace(s, value=value)
        out.append(s)
    return tuple(out)
