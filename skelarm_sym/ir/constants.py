"""A per-function pass: constants added one after another through locals read once, added once.

Horner's rule adds each link's offset where its frame is reached; along a joint's axis (a component no turn
mixes) the offsets of consecutive links then meet in a chain of sums, one local apart: UR5's
``t16 = 0.093 + t13; t21 = t16 - 0.1197; t22 = 0.13585 + t21``. Where a local is a sum with a literal and the
one statement that reads it adds it as a term of a sum with a literal too, the local's terms go into that sum
and the two literals become one: ``t22 = 0.10915 + t13``, an addition fewer per link. The sum is the same but
for rounding (the literals add first, once, in double precision).
"""

from __future__ import annotations

from collections import Counter
from typing import Sequence

from .nodes import LONG_SUM, Add, Const, Let, Neg, Store, TrigBlock, Var
from .walk import children


def _reads(e, counts: Counter) -> None:
    stack = [e]
    while stack:
        x = stack.pop()
        if type(x) is Var:
            counts[x.name] += 1
        else:
            stack.extend(children(x))


def _literal(term) -> float | None:
    """The signed value of a literal term (``c`` or ``-c``), else ``None``."""
    if type(term) is Const and isinstance(term.value, float):
        return term.value
    if type(term) is Neg and type(term.x) is Const and isinstance(term.x.value, float):
        return -term.x.value
    return None


def _split(add: Add) -> tuple[float, list] | None:
    """``(literal, other terms)`` of a sum with exactly one literal term; else ``None``."""
    literals = [i for i, t in enumerate(add.terms) if _literal(t) is not None]
    if len(literals) != 1:
        return None
    return _literal(add.terms[literals[0]]), [t for i, t in enumerate(add.terms) if i != literals[0]]


def _negated(term):
    return term.x if type(term) is Neg else Neg(term)


def _literal_term(value: float):
    return Const(value) if value >= 0 else Neg(Const(-value))


def fold_constants(body: Sequence) -> tuple:
    """``body`` (straight-line: lets, trigonometry blocks, stores) with each sum ``x + c1`` that one sum
    ``... + c2`` reads once, as a term, folded into it (``... + x + (c1 + c2)``; a literal of 0 dropped, and a
    sum left with one term that term); any other body comes back as it is."""
    if not all(type(s) in (Let, TrigBlock, Store) for s in body):
        return tuple(body)
    statements = list(body)
    while True:
        counts: Counter = Counter()
        for s in statements:
            if type(s) is TrigBlock:
                for angle in s.angles:
                    _reads(angle, counts)
            else:
                _reads(s.value, counts)
        defined = {s.var.name: i for i, s in enumerate(statements) if type(s) is Let}
        folded = False
        for j, reader in enumerate(statements):
            if type(reader) is TrigBlock or type(reader.value) is not Add:
                continue
            outer = _split(reader.value)
            if outer is None:
                continue
            for term in outer[1]:
                inner_var = term.x if type(term) is Neg else term
                if type(inner_var) is not Var or counts[inner_var.name] != 1 or inner_var.name not in defined:
                    continue
                i = defined[inner_var.name]
                inner = statements[i].value if i < j else None
                if type(inner) is not Add:
                    continue
                split = _split(inner)
                if split is None:
                    continue
                sign = -1.0 if type(term) is Neg else 1.0
                value = outer[0] + sign * split[0]
                others = [t for t in outer[1] if t is not term]
                moved = split[1] if sign > 0 else [_negated(t) for t in split[1]]
                terms = [*others, *moved] + ([_literal_term(value)] if value != 0.0 else [])
                if len(terms) > LONG_SUM:
                    continue
                value = Add(tuple(terms)) if len(terms) > 1 else terms[0]  # offsets that cancel: a copy (TIAGo)
                statements[j] = type(reader)(**{**_fields(reader), "value": value})
                del statements[i]
                folded = True
                break
            if folded:
                break
        if not folded:
            return tuple(statements)


def _fields(statement) -> dict:
    return {name: getattr(statement, name) for name in statement.__dataclass_fields__}
