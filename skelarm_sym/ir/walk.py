"""Questions printers ask of IR bodies: which names an expression or a body reads, and the
statements a set of names needs."""

from __future__ import annotations

from functools import lru_cache
from typing import Iterable

from .nodes import (
    Add, ArrayArg, Assign, Bits, Call1, Call2, CallFunction, Cast, Compare, Declare, Div, Elem, For, If, Let, Logic,
    Mul, Neg, Not, Return, Select, Store, TrigBlock, Var, While,
)


def expr_names(e, out: set[str]) -> set[str]:
    """Add to ``out`` the variable and array names ``e`` reads; returns ``out``."""
    stack = [e]
    while stack:
        x = stack.pop()
        t = type(x)
        if t is Var:
            out.add(x.name)
        elif t is Elem:
            out.add(x.array)
            stack.append(x.index)
        elif t is Add:
            stack.extend(x.terms)
        elif t is Mul:
            stack.extend(x.factors)
        elif t in (Neg, Not, Call1):
            stack.append(x.x)
        elif t is Div:
            stack.extend((x.num, x.den))
        elif t in (Call2, Compare, Bits):
            stack.extend((x.a, x.b))
        elif t is Logic:
            stack.extend(x.terms)
        elif t is Select:
            stack.extend((x.cond, x.then, x.otherwise))
        elif t is Cast:
            stack.append(x.x)
        elif t is ArrayArg:
            out.add(x.name)
            if not isinstance(x.offset, int):
                stack.append(x.offset)
    return out


def children(e) -> tuple:
    """The sub-expressions of expression ``e``, in field order (none for a leaf)."""
    t = type(e)
    if t is Add or t is Logic:
        return e.terms
    if t is Mul:
        return e.factors
    if t in (Neg, Not, Call1, Cast):
        return (e.x,)
    if t is Div:
        return (e.num, e.den)
    if t in (Call2, Compare, Bits):
        return (e.a, e.b)
    if t is Select:
        return (e.cond, e.then, e.otherwise)
    if t is Elem:
        return (e.index,)
    return ()


def with_children(e, parts: tuple):
    """``e`` with its sub-expressions (:func:`children`) replaced by ``parts``; ``e`` itself when they are the same."""
    if all(a is b for a, b in zip(parts, children(e))):
        return e
    t = type(e)
    if t is Add:
        return Add(parts)
    if t is Logic:
        return Logic(e.op, parts)
    if t is Mul:
        return Mul(parts)
    if t is Neg:
        return Neg(parts[0])
    if t is Not:
        return Not(parts[0])
    if t is Call1:
        return Call1(e.function, parts[0])
    if t is Cast:
        return Cast(e.type, parts[0])
    if t is Div:
        return Div(parts[0], parts[1], e.guarded)
    if t is Call2:
        return Call2(e.function, *parts)
    if t is Compare:
        return Compare(e.op, *parts)
    if t is Bits:
        return Bits(e.op, *parts)
    if t is Select:
        return Select(*parts)
    if t is Elem:
        return Elem(e.array, parts[0], e.type)
    return e


@lru_cache(maxsize=1 << 16)
def statement_reads(s) -> frozenset[str]:
    """The names a :class:`Let`, :class:`Store` or :class:`TrigBlock` reads (remembered: the functions of one
    derivation share their statements, and the passes of :mod:`.products` and :mod:`.signs` ask for each)."""
    names: set[str] = set()
    if type(s) in (Let, Store):
        expr_names(s.value, names)
    elif type(s) is TrigBlock:
        for a in s.angles:
            expr_names(a, names)
    return frozenset(names)


def body_names(body: Iterable, out: set[str] | None = None) -> set[str]:
    """Every variable and array name ``body`` reads or writes (arguments included)."""
    out = set() if out is None else out
    for s in body:
        t = type(s)
        if t in (Let, Declare):
            if s.value is not None:
                expr_names(s.value, out)
        elif t is Assign:
            expr_names(s.target, out)
            expr_names(s.value, out)
        elif t is Store:
            out.add(s.output)
            expr_names(s.value, out)
        elif t is TrigBlock:
            for a in s.angles:
                expr_names(a, out)
        elif t is If:
            expr_names(s.cond, out)
            body_names(s.then, out)
            body_names(s.otherwise, out)
        elif t is For:
            expr_names(s.start, out)
            expr_names(s.stop, out)
            body_names(s.body, out)
        elif t is While:
            expr_names(s.cond, out)
            body_names(s.body, out)
        elif t is Return and s.value is not None:
            expr_names(s.value, out)
        elif t is CallFunction:
            for a in s.args:
                expr_names(a, out)
            if s.result is not None:
                out.add(s.result.name)
    return out


def called(body: Iterable, out: set[str] | None = None) -> set[str]:
    """Names of the module functions ``body`` calls."""
    out = set() if out is None else out
    for s in body:
        t = type(s)
        if t is CallFunction:
            out.add(s.function)
        elif t is If:
            called(s.then, out)
            called(s.otherwise, out)
        elif t in (For, While):
            called(s.body, out)
    return out


def needed_lets(lets: list[Let], roots: set[str], reads=None) -> list[Let]:
    """The :class:`Let` statements among ``lets`` that names ``roots`` need, directly or through each
    other, in their order. ``reads(let)``: the names a Let's value reads (a caller may pass one that
    remembers them)."""
    reads = reads or (lambda s: expr_names(s.value, set()))
    by_name = {s.var.name: s for s in lets}
    keep: set[str] = set()
    todo = [r for r in roots if r in by_name]
    while todo:
        name = todo.pop()
        if name in keep:
            continue
        keep.add(name)
        todo.extend(n for n in reads(by_name[name]) if n in by_name and n not in keep)
    return [s for s in lets if s.var.name in keep]


def _expressions(body: Iterable):
    """Every top-level expression of ``body`` (statement values, conditions, bounds, arguments)."""
    for s in body:
        t = type(s)
        if t in (Let, Declare, Assign, Store, Return):
            if s.value is not None:
                yield s.value
        elif t is TrigBlock:
            yield from s.angles
        elif t is If:
            yield s.cond
            yield from _expressions(s.then)
            yield from _expressions(s.otherwise)
        elif t is For:
            yield s.start
            yield s.stop
            yield from _expressions(s.body)
        elif t is While:
            yield s.cond
            yield from _expressions(s.body)
        elif t is CallFunction:
            yield from (a for a in s.args if type(a) is not ArrayArg)


def named_constants(body: Iterable) -> set[str]:
    """Names of the :class:`NamedConst` ``body`` refers to: module constants (real or integer) and statuses
    (the caller keeps those it defines as constants)."""
    from .nodes import NamedConst

    found: set[str] = set()
    seen: set[int] = set()
    stack = list(_expressions(body))
    while stack:
        x = stack.pop()
        if id(x) in seen:
            continue
        seen.add(id(x))
        t = type(x)
        if t is NamedConst:
            found.add(x.name)
        elif t is Add:
            stack.extend(x.terms)
        elif t is Mul:
            stack.extend(x.factors)
        elif t in (Neg, Not, Call1, Cast):
            stack.append(x.x)
        elif t is Div:
            stack.extend((x.num, x.den))
        elif t in (Call2, Compare, Bits):
            stack.extend((x.a, x.b))
        elif t is Logic:
            stack.extend(x.terms)
        elif t is Select:
            stack.extend((x.cond, x.then, x.otherwise))
        elif t is Elem:
            stack.append(x.index)
    return found
