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
from dataclasses import replace
from typing import Sequence

from .nodes import LONG_SUM, Add, Const, Let, Mul, Neg, Store, TrigBlock, Var, signed_sum
from .walk import children


def _reads(e, counts: Counter) -> None:
    """Add to ``counts`` how many times ``e`` reads each variable (the common nodes first: this walks every
    statement of the body)."""
    stack = [e]
    while stack:
        x = stack.pop()
        t = type(x)
        if t is Var:
            counts[x.name] += 1
        elif t is Mul:
            stack.extend(x.factors)
        elif t is Add:
            stack.extend(x.terms)
        elif t is Neg:
            stack.append(x.x)
        elif t is not Const:
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
    sum left with one term that term); any other body comes back as it is.

    One pass in order: a fold moves the local's terms into its reader, so every other count of reads stays
    what it was, and a chain of such locals folds into its last reader one after the other."""
    if not all(type(s) in (Let, TrigBlock, Store) for s in body):
        return tuple(body)
    statements = list(body)
    counts: Counter = Counter()
    for s in statements:
        if type(s) is TrigBlock:
            for angle in s.angles:
                _reads(angle, counts)
        else:
            _reads(s.value, counts)
    defined = {s.var.name: i for i, s in enumerate(statements) if type(s) is Let}
    dropped: set[int] = set()
    for j, reader in enumerate(statements):
        if type(reader) is TrigBlock:
            continue
        while type(reader.value) is Add and (outer := _split(reader.value)) is not None:
            for term in outer[1]:
                local = term.x if type(term) is Neg else term
                i = defined.get(local.name, j) if type(local) is Var and counts[local.name] == 1 else j
                if i >= j or i in dropped or type(statements[i].value) is not Add:
                    continue
                inner = _split(statements[i].value)
                if inner is None:
                    continue
                sign = -1.0 if type(term) is Neg else 1.0
                value = outer[0] + sign * inner[0]
                moved = inner[1] if sign > 0 else [_negated(t) for t in inner[1]]
                terms = [t for t in outer[1] if t is not term] + moved + ([_literal_term(value)] if value != 0.0 else [])
                if len(terms) > LONG_SUM:
                    continue
                reader = replace(reader, value=signed_sum(terms))
                dropped.add(i)  # offsets that cancel leave a copy (TIAGo's t39 = (0.027 + t31) - 0.027)
                break
            else:
                break
        statements[j] = reader
    return tuple(s for i, s in enumerate(statements) if i not in dropped)
