"""Operation counts of IR bodies, as the printers write them.

An :class:`~skelarm_sym.ir.nodes.Add` of k terms is k - 1 additions or subtractions (plus one negation
when every term is negated); a :class:`Mul` of k factors k - 1 multiplications (a negative literal
factor costs nothing); a :class:`Neg` outside a sum one negation; a :class:`Div` one division; a
:class:`Select` one select; a :class:`Compare` one comparison; :class:`TrigBlock` one sine and one
cosine per angle; ``sqrt`` and ``atan2`` calls by name. Loops count once (their body as written)."""

from __future__ import annotations

from collections import Counter
from typing import Iterable

from .nodes import (
    Add, Assign, Bits, Call1, Call2, CallFunction, Cast, Compare, Declare, DeclareArray, Div, Elem, For, If, Let, Logic,
    Mul, Neg, Not, OpCount, Return, Select, Store, TrigBlock, While,
)


def _expr(e, counts: Counter, negation_paid: bool = False) -> None:
    t = type(e)
    if t is Add:
        negated = [type(x) is Neg for x in e.terms]
        counts["add"] += len(e.terms) - 1
        if all(negated):
            counts["neg"] += 1
        for x, n in zip(e.terms, negated):
            _expr(x.x if n else x, counts)
    elif t is Mul:
        counts["mul"] += len(e.factors) - 1
        for x in e.factors:
            _expr(x, counts)
    elif t is Neg:
        if not negation_paid:
            counts["neg"] += 1
        _expr(e.x, counts)
    elif t is Div:
        counts["div"] += 1
        _expr(e.num, counts)
        _expr(e.den, counts)
    elif t is Call1:
        if e.function in ("sqrt", "sin", "cos"):
            counts[e.function] += 1
        _expr(e.x, counts)
    elif t is Call2:
        if e.function == "atan2":
            counts["atan2"] += 1
        else:
            counts["cmp"] += 1
            counts["select"] += 1
        _expr(e.a, counts)
        _expr(e.b, counts)
    elif t is Compare:
        counts["cmp"] += 1
        _expr(e.a, counts)
        _expr(e.b, counts)
    elif t is Select:
        counts["select"] += 1
        _expr(e.cond, counts)
        _expr(e.then, counts)
        _expr(e.otherwise, counts)
    elif t is Logic:
        for x in e.terms:
            _expr(x, counts)
    elif t is Not:
        _expr(e.x, counts)
    elif t is Elem:
        _expr(e.index, counts)
    elif t in (Bits, Cast):
        pass


def _statements(body: Iterable, counts: Counter) -> None:
    for s in body:
        t = type(s)
        if t in (Let, Assign, Store):
            _expr(s.value, counts)
        elif t is Declare:
            if s.value is not None:
                _expr(s.value, counts)
        elif t is TrigBlock:
            counts["sin"] += len(s.angles)
            counts["cos"] += len(s.angles)
        elif t is If:
            _expr(s.cond, counts)
            _statements(s.then, counts)
            _statements(s.otherwise, counts)
        elif t is For:
            _statements(s.body, counts)
        elif t is While:
            _expr(s.cond, counts)
            _statements(s.body, counts)
        elif t is Return and s.value is not None:
            _expr(s.value, counts)
        elif t in (DeclareArray, CallFunction):
            pass


def count_ops(body: Iterable) -> OpCount:
    """The :class:`OpCount` of a function body (see the module docstring)."""
    counts: Counter = Counter()
    _statements(body, counts)
    return OpCount(**{k: counts.get(k, 0) for k in OpCount.__dataclass_fields__})
