"""If-conversion: an IR procedure as a batched, masked program (for array backends: PyTorch, JAX).

A procedure (:class:`~skelarm_sym.ir.nodes.Function` of kind ``procedure``) solves one problem per
call with loops and branches on data. :func:`predicate` turns it into a program over *lanes* (one lane
per problem of a batch) in which no control flow depends on data:

* every scalar is a value per lane, every local array a list of such values;
* branches become selects under an *active mask*: ``If(c, a, b)`` runs ``a`` with ``mask & c`` and ``b``
  with ``mask & ~c``, and each assignment becomes ``x = mask ? value : x`` (:class:`PSet`);
* ``Return`` clears the returning lanes from the function's ``alive`` mask and from the run masks of
  the loops around it (its value goes to the status under the mask); ``Break`` clears them from the
  innermost loop's run mask; after a statement that may have cleared lanes, the block's mask is
  narrowed to the lanes left;
* ``While`` and ``For`` loops whose bounds are data become :class:`PLoop`: ``while any(run)`` with a
  per-lane ``run`` mask re-evaluated at the end of each pass (a counter per lane for ``For``); ``For``
  loops with constant bounds (numbers, or the module's integer constants such as ``IK_MAX_SOLUTIONS``)
  stay loops over a number the printer knows (:class:`PFor`: unrolled or ``range``), a ``break`` on data
  leaving them by a run mask;
* helpers (kind ``helper``) are inlined: their arrays are the caller's (an argument with an offset is an
  alias, as a C pointer is), their locals get fresh names, and their ``Return`` leaves only the inlined
  body; calls of straight-line functions stay calls (:class:`PCall`) whose outputs are merged under the
  mask;
* an element read with an index that is data (``M[i]``, ``i`` per lane) becomes a chain of selects over
  the array, a write one masked assignment per element;
* a branch whose body is costly (a call or a loop) is wrapped in :class:`PGuard`: printers may skip it
  when no lane is active (every assignment in it is masked, so skipping changes nothing).

Lanes that are not active still compute (their results are discarded), so division by zero or a square
root of a negative number on them is harmless. Every construct of the IR vocabulary is supported; the
program ends with the status per lane in :attr:`Predicated.status`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Union

from .nodes import (
    Add, ArrayArg, Assign, Bits, Break, Call1, Call2, CallFunction, Cast, Comment, Compare, Const, Declare,
    DeclareArray, Div, Elem, Expr, For, Function, If, Let, Logic, Module, Mul, NamedConst, Neg, Not, Return, Select, Store,
    TrigBlock, Type, Var, While,
)

# -- the masked program -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Slice:
    """Elements ``offset .. offset + size - 1`` of array ``name`` (an argument of a call)."""

    name: str
    offset: int
    size: int


@dataclass(frozen=True)
class PDef:
    """``var = value`` for every lane (a new name; ``lanes``: the value is given the batch's full shape,
    as a variable that masked assignments update later must have)."""

    var: Var
    value: Expr
    lanes: bool = False


@dataclass(frozen=True)
class PArray:
    """A local array of ``size`` per-lane values (``values`` or zeros); ``const``: numbers known here,
    the same for every lane (never assigned)."""

    name: str
    size: int
    type: Type
    values: tuple[Expr, ...] | None = None
    const: bool = False


@dataclass(frozen=True)
class PSet:
    """``target = mask ? value : target`` (``mask`` ``None``: every lane). ``target`` is a variable or an
    element with a constant index."""

    target: Var | Elem
    value: Expr
    mask: Var | None


@dataclass(frozen=True)
class PCall:
    """Call straight-line ``function``: ``args`` its inputs in order (arrays as :class:`Slice`, numbers as
    expressions), ``outputs`` where its outputs go, merged under ``mask``."""

    function: str
    args: tuple[Union[Expr, Slice], ...]
    outputs: tuple[Slice, ...]
    mask: Var | None


@dataclass(frozen=True)
class PFor:
    """``for var in range(start, stop)`` with bounds known here. ``rollable``: the body is costly and ``var``
    reaches no call's array offset, so a printer may keep it a run-time loop whose counter is a value
    (indexing with it then picks among an array's elements; ``carried``: what the body assigns)."""

    var: Var
    start: int
    stop: int
    body: tuple
    rollable: bool = False
    carried: tuple[str, ...] = ()


@dataclass(frozen=True)
class PLoop:
    """``while any(run): body`` (the body ends by narrowing ``run``); ``carried``: the names the body
    assigns that live outside it (a functional loop's state)."""

    run: Var
    body: tuple
    carried: tuple[str, ...]


@dataclass(frozen=True)
class PGuard:
    """``body`` (every assignment in it masked by ``mask`` or a narrower mask), which a printer may skip
    when ``mask`` holds for no lane."""

    mask: Var
    body: tuple
    carried: tuple[str, ...]


@dataclass(frozen=True)
class PComment:
    text: str


PStmt = Union[PDef, PArray, PSet, PCall, PFor, PLoop, PGuard, PComment]


@dataclass(frozen=True)
class Predicated:
    """A procedure in masked form. ``arguments``: the function's (inputs as per-lane arrays and numbers,
    outputs as arrays the body fills); ``status``: the per-lane status variable (functions that return
    one); ``arrays``: name -> (size, type) of every array the body uses; ``statics``: names whose value
    is a number known to the printer's loop (:class:`PFor` counters); ``consts``: constant arrays."""

    function: Function
    body: tuple[PStmt, ...]
    status: Var | None
    arrays: dict[str, tuple[int, Type]]
    statics: frozenset[str]
    consts: frozenset[str]
    rollable: frozenset[str] = frozenset()


# -- questions about expressions -------------------------------------------------------------------------


def is_static(e, statics: frozenset[str] | set[str], consts: frozenset[str] | set[str] = frozenset()) -> bool:
    """Whether ``e`` is a number the printed program knows without data: constants, loop counters of
    :class:`PFor` (``statics``) and elements of constant arrays at such indices."""
    t = type(e)
    if t in (Const, NamedConst):
        return True
    if t is Var:
        return e.name in statics
    if t is Elem:
        return e.array in consts and is_static(e.index, statics, consts)
    if t in (Add, Logic):
        return all(is_static(x, statics, consts) for x in e.terms)
    if t is Mul:
        return all(is_static(x, statics, consts) for x in e.factors)
    if t in (Neg, Not, Call1, Cast):
        return is_static(e.x, statics, consts)
    if t is Div:
        return is_static(e.num, statics, consts) and is_static(e.den, statics, consts)
    if t in (Call2, Compare, Bits):
        return is_static(e.a, statics, consts) and is_static(e.b, statics, consts)
    if t is Select:
        return all(is_static(x, statics, consts) for x in (e.cond, e.then, e.otherwise))
    raise TypeError(f"internal error: {t.__name__} is not an expression")


def static_value(e, env: dict[str, int]) -> int | None:
    """The integer value of an index expression of constants and the counters in ``env``, or ``None``. The
    module's integer constants are in ``env`` too, as ``"#" + name`` (no variable's name starts with ``#``)."""
    t = type(e)
    if t is Const and e.type is Type.INT:
        return int(e.value)
    if t is Var and e.name in env:
        return env[e.name]
    if t is NamedConst and e.type is Type.INT:
        return env.get("#" + e.name)
    if t is Add:
        parts = [static_value(x, env) for x in e.terms]
        return None if None in parts else sum(parts)
    if t is Mul:
        out = 1
        for x in e.factors:
            v = static_value(x, env)
            if v is None:
                return None
            out *= v
        return out
    if t is Neg:
        v = static_value(e.x, env)
        return None if v is None else -v
    return None


def _congruence(e, env: dict[str, int]) -> tuple[int, int]:
    """``(m, c)`` such that the integer expression ``e`` equals ``c`` modulo ``m`` whatever its variables' values
    (``m`` 0: it is ``c``; 1: nothing is known). Only numbers and the module's integer constants are constants
    here: a loop counter the printer knows takes many values."""
    t = type(e)
    if t is Const and e.type is Type.INT:
        return 0, int(e.value)
    if t is NamedConst and e.type is Type.INT and "#" + e.name in env:
        return 0, env["#" + e.name]
    if t is Neg:
        m, c = _congruence(e.x, env)
        return m, -c
    if t is Add:
        m, c = 0, 0
        for x in e.terms:
            mx, cx = _congruence(x, env)
            m, c = math.gcd(m, mx), c + cx
        return m, (c % m if m else c)
    if t is Mul:
        m, c = 0, 1
        for x in e.factors:  # (c + m a)(cx + mx b) = c cx + c mx b + cx m a + m mx a b
            mx, cx = _congruence(x, env)
            m, c = math.gcd(math.gcd(c * mx, cx * m), m * mx), c * cx
        return m, (c % m if m else c)
    return 1, 0


def _names(e, out: set[str]) -> set[str]:
    t = type(e)
    if t is Var:
        out.add(e.name)
    elif t is Elem:
        out.add(e.array)
        _names(e.index, out)
    elif t in (Add, Logic):
        for x in e.terms:
            _names(x, out)
    elif t is Mul:
        for x in e.factors:
            _names(x, out)
    elif t in (Neg, Not, Call1, Cast):
        _names(e.x, out)
    elif t is Div:
        _names(e.num, out)
        _names(e.den, out)
    elif t in (Call2, Compare, Bits):
        _names(e.a, out)
        _names(e.b, out)
    elif t is Select:
        for x in (e.cond, e.then, e.otherwise):
            _names(x, out)
    return out


def _contains(body, kinds: tuple, into_loops: bool = True) -> bool:
    """Whether ``body`` (IR statements) holds a statement of ``kinds`` (not looking into loops unless
    ``into_loops``)."""
    for s in body:
        t = type(s)
        if t in kinds:
            return True
        if t is If and (_contains(s.then, kinds, into_loops) or _contains(s.otherwise, kinds, into_loops)):
            return True
        if t in (For, While) and into_loops and _contains(s.body, kinds, into_loops):
            return True
    return False


def _may_exit(s) -> bool:
    """Whether statement ``s`` may clear lanes of the block it stands in: a ``Return`` anywhere in it, or a
    ``Break`` that leaves the loop around it (not one inside a loop of its own)."""
    t = type(s)
    if t in (Return, Break):
        return True
    if t is If:
        return any(_may_exit(x) for x in s.then + s.otherwise)
    if t in (For, While):
        return _contains(s.body, (Return,))
    return False


def assigned(body) -> set[str]:
    """Names a masked body assigns (variables, arrays whose elements it sets, run masks)."""
    out: set[str] = set()
    for s in body:
        t = type(s)
        if t is PSet:
            out.add(s.target.name if type(s.target) is Var else s.target.array)
        elif t is PCall:
            out.update(o.name for o in s.outputs)
        elif t in (PFor, PLoop, PGuard):
            out |= assigned(s.body)
    return out


def defined(body) -> set[str]:
    """Names a masked body defines (:class:`PDef`, :class:`PArray`, loop counters), nested bodies included."""
    out: set[str] = set()
    for s in body:
        t = type(s)
        if t is PDef:
            out.add(s.var.name)
        elif t is PArray:
            out.add(s.name)
        elif t is PFor:
            out.add(s.var.name)
            out |= defined(s.body)
        elif t in (PLoop, PGuard):
            out |= defined(s.body)
    return out


def _carried(body) -> tuple[str, ...]:
    return tuple(sorted(assigned(body) - defined(body)))


def _costly(body) -> bool:
    for s in body:
        t = type(s)
        if t in (PCall, PLoop):
            return True
        if t in (PFor, PGuard) and _costly(s.body):
            return True
    return len(body) > 60


# -- the pass ------------------------------------------------------------------------------------------------


@dataclass
class _Scope:
    """One activation: the procedure itself or an inlined helper."""

    prefix: str | None = None
    """Prefix of the locals' new names (``None``: the procedure's own names)."""
    entry: Var | None = None
    """The mask the activation started with."""
    rename: dict[str, str] = field(default_factory=dict)
    sizes: dict[str, int] = field(default_factory=dict)
    """Array argument -> its size (how far an index into it may reach)."""
    alias: dict[str, tuple[str, int]] = field(default_factory=dict)
    """Array argument -> (the caller's array, offset)."""
    alive: Var | None = None
    result: Var | None = None
    lane_counters: set[str] = field(default_factory=set)
    """Counters of loops with data bounds now renamed in ``rename`` to a fresh name of their own (a counter is a
    value per lane there, and a number the printer knows in a loop with constant bounds: one name cannot be both)."""
    loops: list[Var] = field(default_factory=list)
    """Run masks of the loops around the current statement, inside this scope (outermost first)."""
    guards: list[Var] = field(default_factory=list)
    """What narrows a block's mask after an exit: the innermost loop's run mask, else ``alive``."""

    @property
    def guard(self) -> Var | None:
        return self.guards[-1] if self.guards else self.alive


class _Pass:
    def __init__(self, functions: tuple[Function, ...], integers: tuple[tuple[str, int], ...]) -> None:
        self.functions = {f.name: f for f in functions}  # the callees, by name
        self.count = 0
        self.arrays: dict[str, tuple[int, Type]] = {}
        self.consts: set[str] = set()
        self.statics: set[str] = set()
        self.rollable: set[str] = set()
        # a static loop counter -> a sample value (to tell static indices); "#NAME" -> a module integer's value
        self.env: dict[str, int] = {"#" + name: value for name, value in integers}
        self.out: list = []

    # -- names and emission ----------------------------------------------------------------------------
    def fresh(self, base: str) -> str:
        self.count += 1
        return f"_{base}{self.count}"

    def emit(self, s) -> None:
        self.out.append(s)

    def capture(self, fn) -> tuple:
        saved, self.out = self.out, []
        try:
            fn()
            return tuple(self.out)
        finally:
            self.out = saved

    def define(self, base: str, value, type_: Type = Type.BOOL, lanes: bool = False) -> Var:
        var = Var(self.fresh(base), type_)
        self.emit(PDef(var, value, lanes))
        return var

    def narrow(self, mask: Var | None, cond) -> Var:
        return self.define("m", cond if mask is None else Logic("and", (mask, cond)))

    # -- expressions -----------------------------------------------------------------------------------
    def resolve(self, array: str, scope: _Scope) -> tuple[str, int]:
        if array in scope.alias:
            return scope.alias[array]
        return scope.rename.get(array, array), 0

    def index(self, name: str, offset: int, index, scope: _Scope):
        """``(array, constant index)`` or ``(array, None, index expression)`` of element ``index``."""
        idx = self.expr(index, scope)
        if offset:
            idx = Add((idx, Const(offset, Type.INT)))
        value = static_value(idx, self.env)
        return idx, value

    def expr(self, e, scope: _Scope):
        t = type(e)
        if t in (Const, NamedConst):
            return e
        if t is Var:
            return Var(scope.rename.get(e.name, e.name), e.type)
        if t is Elem:
            name, offset = self.resolve(e.array, scope)
            idx, value = self.index(name, offset, e.index, scope)
            if value is not None:
                return Elem(name, idx, e.type)
            return self.pick(name, idx, e.type, scope, e.array, offset)
        if t is Add:
            return Add(tuple(self.expr(x, scope) for x in e.terms))
        if t is Mul:
            return Mul(tuple(self.expr(x, scope) for x in e.factors))
        if t is Neg:
            return Neg(self.expr(e.x, scope))
        if t is Not:
            return Not(self.expr(e.x, scope))
        if t is Div:
            return Div(self.expr(e.num, scope), self.expr(e.den, scope), e.guarded)
        if t is Call1:
            return Call1(e.function, self.expr(e.x, scope))
        if t is Call2:
            return Call2(e.function, self.expr(e.a, scope), self.expr(e.b, scope))
        if t is Compare:
            return Compare(e.op, self.expr(e.a, scope), self.expr(e.b, scope))
        if t is Logic:
            return Logic(e.op, tuple(self.expr(x, scope) for x in e.terms))
        if t is Select:
            return Select(self.expr(e.cond, scope), self.expr(e.then, scope), self.expr(e.otherwise, scope))
        if t is Bits:
            return Bits(e.op, self.expr(e.a, scope), self.expr(e.b, scope))
        if t is Cast:
            return Cast(e.type, self.expr(e.x, scope))
        raise TypeError(f"internal error: {t.__name__} is not an expression")

    def span(self, name: str, original: str, offset: int, scope: _Scope) -> range:
        """The elements an index into ``original`` (seen as ``name`` from ``offset``) may reach."""
        size = self.arrays[name][0]
        if original in scope.alias:
            size = scope.sizes[original]
        return range(offset, min(offset + size, self.arrays[name][0]))

    def cells(self, name: str, idx, original: str, offset: int, scope: _Scope) -> list[int]:
        """The elements of :meth:`span` that ``idx``, an integer index, can equal: those congruent to it modulo
        the stride its form fixes (``6*r + 2``: every sixth from 2), as an index must be in range to be read."""
        stride, rest = _congruence(idx, self.env)
        cells = [j for j in self.span(name, original, offset, scope) if (j - rest) % stride == 0] if stride \
            else [rest]
        return cells or list(self.span(name, original, offset, scope))

    def pick(self, name: str, idx, type_: Type, scope: _Scope, original: str, offset: int):
        """``name[idx]`` for an index that is data: a chain of selects over the elements it can reach."""
        cells = self.cells(name, idx, original, offset, scope)
        i = idx if type(idx) is Var else self.define("i", idx, Type.INT)
        out = Elem(name, Const(cells[-1], Type.INT), type_)
        for j in reversed(cells[:-1]):
            out = Select(Compare("==", i, Const(j, Type.INT)), Elem(name, Const(j, Type.INT), type_), out)
        return out

    # -- statements ----------------------------------------------------------------------------------------
    def block(self, body, mask: Var | None, scope: _Scope) -> None:
        for s in body:
            t = type(s)
            if t is Return:
                self.return_(s, mask, scope)
                return
            if t is Break:
                self.break_(mask, scope)
                return
            self.statement(s, mask, scope)
            if _may_exit(s):
                guard = scope.guard
                # the guard only loses lanes, and it started as the scope's (or loop's) mask
                mask = guard if mask is None or mask == guard or mask == scope.entry else self.narrow(mask, guard)

    def return_(self, s: Return, mask: Var | None, scope: _Scope) -> None:
        if s.value is not None:
            if scope.result is None:
                raise TypeError("internal error: a value returned by a function whose caller keeps none")
            self.emit(PSet(scope.result, self.expr(s.value, scope), mask))
        leaving = mask
        for var in [scope.alive, *scope.loops]:
            if var is None:
                continue
            self.emit(PSet(var, Const(False, Type.BOOL) if leaving is None else Logic("and", (var, Not(leaving))), None))

    def break_(self, mask: Var | None, scope: _Scope) -> None:
        run = scope.loops[-1]
        self.emit(PSet(run, Const(False, Type.BOOL) if mask is None else Logic("and", (run, Not(mask))), None))

    def statement(self, s, mask: Var | None, scope: _Scope) -> None:
        t = type(s)
        if t is Let:
            name = self.local(s.var.name, scope)
            self.emit(PDef(Var(name, s.var.type), self.expr(s.value, scope)))
        elif t is Declare:
            name = self.local(s.var.name, scope)
            value = self.expr(s.value, scope) if s.value is not None else _zero(s.var.type)
            self.emit(PDef(Var(name, s.var.type), value, lanes=True))
        elif t is DeclareArray:
            name = self.local(s.name, scope)
            self.arrays[name] = (s.size, s.type)
            values = None if s.values is None else tuple(self.expr(v, scope) for v in s.values)
            const = s.const and values is not None and all(type(v) is Const for v in values)
            if const:
                self.consts.add(name)
            self.emit(PArray(name, s.size, s.type, values, const))
        elif t is Assign:
            self.assign(s.target, s.value, mask, scope)
        elif t is Store:
            self.assign(Elem(s.output, Const(s.index, Type.INT)), s.value, mask, scope)
        elif t is TrigBlock:
            for a, c, sn in zip(s.angles, s.cos, s.sin):
                angle = self.expr(a, scope)
                self.emit(PDef(Var(self.local(c.name, scope), Type.REAL), Call1("cos", angle)))
                self.emit(PDef(Var(self.local(sn.name, scope), Type.REAL), Call1("sin", angle)))
        elif t is If:
            self.if_(s, mask, scope)
        elif t is For:
            self.for_(s, mask, scope)
        elif t is While:
            self.while_(s, mask, scope)
        elif t is CallFunction:
            self.call(s, mask, scope)
        elif t is Comment:
            self.emit(PComment(s.text))
        else:
            raise TypeError(f"internal error: no masked form of {t.__name__}")

    def local(self, name: str, scope: _Scope) -> str:
        new = scope.rename.get(name)
        if new is not None:
            return new
        if scope.prefix is None:
            return name
        new = scope.rename[name] = f"_{scope.prefix}_{name}"
        return new

    def assign(self, target, value, mask: Var | None, scope: _Scope) -> None:
        v = self.expr(value, scope)
        if type(target) is Var:
            self.emit(PSet(Var(scope.rename.get(target.name, target.name), target.type), v, mask))
            return
        name, offset = self.resolve(target.array, scope)
        idx, static = self.index(name, offset, target.index, scope)
        if static is not None:
            self.emit(PSet(Elem(name, idx, target.type), v, mask))
            return
        cells = self.cells(name, idx, target.array, offset, scope)
        i = idx if type(idx) is Var else self.define("i", idx, Type.INT)
        if not (type(v) in (Const, Var)):
            v = self.define("v", v, target.type)
        for j in cells:
            hit = Compare("==", i, Const(j, Type.INT))
            self.emit(PSet(Elem(name, Const(j, Type.INT), target.type), v, self.narrow(mask, hit)))

    def if_(self, s: If, mask: Var | None, scope: _Scope) -> None:
        cond = self.define("c", self.expr(s.cond, scope))
        then_mask = self.narrow(mask, cond)
        else_mask = self.narrow(mask, Not(cond)) if s.otherwise else None
        for body, m in ((s.then, then_mask), (s.otherwise, else_mask)):
            if not body:
                continue
            inner = self.capture(lambda: self.block(body, m, scope))
            if _costly(inner):
                self.emit(PGuard(m, inner, _carried(inner)))
            else:
                self.out.extend(inner)

    def for_(self, s: For, mask: Var | None, scope: _Scope) -> None:
        start = static_value(self.expr(s.start, scope), self.env)
        stop = static_value(self.expr(s.stop, scope), self.env)
        if start is not None and stop is not None:
            if s.var.name in scope.lane_counters:  # the name a loop with data bounds lent it: back to its own
                scope.lane_counters.discard(s.var.name)
                del scope.rename[s.var.name]
            var = Var(self.local(s.var.name, scope), Type.INT)
            exits = _contains(s.body, (Return,)) or _contains(s.body, (Break,), into_loops=False)
            run = self.define("run", mask if mask is not None else Const(True, Type.BOOL), lanes=True) if exits else None
            if run is not None:
                scope.loops.append(run)
                scope.guards.append(run)
            self.statics.add(var.name)
            had = self.env.get(var.name)
            self.env[var.name] = start
            body = self.capture(lambda: self.block(s.body, run if run is not None else mask, scope))
            if had is None:
                del self.env[var.name]
            else:
                self.env[var.name] = had
            if run is not None:
                scope.loops.pop()
                scope.guards.pop()
            rollable = _costly(body) and not _offsets(s.body, s.var.name)
            if rollable:
                self.rollable.add(var.name)
            self.emit(PFor(var, start, stop, body, rollable, _carried(body) if rollable else ()))
            return
        # bounds that are data: a counter per lane, under a fresh name (until the next loop over this counter)
        first, stop_expr = self.expr(s.start, scope), self.expr(s.stop, scope)
        var = Var(self.fresh(s.var.name.lstrip("_") or "k"), Type.INT)
        scope.rename[s.var.name] = var.name
        scope.lane_counters.add(s.var.name)
        self.emit(PDef(var, first, lanes=True))
        test = Compare("<", var, stop_expr)
        run = self.define("run", test if mask is None else Logic("and", (mask, test)), lanes=True)
        scope.loops.append(run)
        scope.guards.append(run)

        def body() -> None:
            self.block(s.body, run, scope)
            self.emit(PSet(var, Add((var, Const(1, Type.INT))), run))
            self.emit(PSet(run, Logic("and", (run, Compare("<", var, stop_expr))), None))

        inner = self.capture(body)
        scope.loops.pop()
        scope.guards.pop()
        self.emit(PLoop(run, inner, _carried(inner)))

    def while_(self, s: While, mask: Var | None, scope: _Scope) -> None:
        forever = type(s.cond) is Const and s.cond.value is True
        first = Const(True, Type.BOOL) if forever else self.expr(s.cond, scope)
        start = first if mask is None else (mask if forever else Logic("and", (mask, first)))
        run = self.define("run", start, lanes=True)
        scope.loops.append(run)
        scope.guards.append(run)

        def body() -> None:
            self.block(s.body, run, scope)
            if not forever:
                self.emit(PSet(run, Logic("and", (run, self.expr(s.cond, scope))), None))

        inner = self.capture(body)
        scope.loops.pop()
        scope.guards.pop()
        self.emit(PLoop(run, inner, _carried(inner)))

    def call(self, s: CallFunction, mask: Var | None, scope: _Scope) -> None:
        callee = self.functions[s.function]
        if callee.kind == "straight":
            args, outputs = [], []
            for a, arg in zip(callee.arguments, s.args):
                if a.is_scalar and not a.is_output:
                    args.append(self.expr(arg, scope))
                    continue
                if type(arg) is not ArrayArg:
                    raise TypeError(f"internal error: {s.function}'s {a.name} needs an array")
                name, offset = self.resolve(arg.name, scope)
                extra = arg.offset if isinstance(arg.offset, int) else static_value(self.expr(arg.offset, scope), self.env)
                if extra is None:
                    raise NotImplementedError(f"{s.function}: an array passed from an offset that is data")
                (outputs if a.is_output else args).append(Slice(name, offset + extra, a.size))
            self.emit(PCall(s.function, tuple(args), tuple(outputs), mask))
            return
        self.inline(callee, s, mask, scope)

    def inline(self, callee: Function, s: CallFunction, mask: Var | None, scope: _Scope) -> None:
        self.count += 1
        inner = _Scope(prefix=f"{callee.name}{self.count}")
        for a, arg in zip(callee.arguments, s.args):
            if type(arg) is ArrayArg:
                name, offset = self.resolve(arg.name, scope)
                extra = arg.offset if isinstance(arg.offset, int) else static_value(self.expr(arg.offset, scope), self.env)
                if extra is None:
                    raise NotImplementedError(f"{callee.name}: an array passed from an offset that is data")
                inner.alias[a.name] = (name, offset + extra)
                inner.sizes[a.name] = a.size
            else:
                var = Var(self.local(a.name, inner), a.type)
                self.emit(PDef(var, self.expr(arg, scope), lanes=True))
        if s.result is not None:
            inner.result = Var(scope.rename.get(s.result.name, s.result.name), s.result.type)
        if _contains(callee.body, (Return,)):
            inner.alive = self.define("alive", mask if mask is not None else Const(True, Type.BOOL), lanes=True)
        inner.entry = mask
        self.block(callee.body, mask, inner)


def _offsets(body, name: str) -> bool:
    """Whether loop counter ``name`` reaches an array offset of a call in ``body`` (or a helper's number,
    which it might index with): the loop must then unroll, each pass with its own offsets."""
    found = False

    def look(e) -> None:
        nonlocal found
        t = type(e)
        if t is Elem:
            look(e.index)
        elif t is ArrayArg:
            if not isinstance(e.offset, int) and name in _names(e.offset, set()):
                found = True
        elif t in (Add, Logic):
            for x in e.terms:
                look(x)
        elif t is Mul:
            for x in e.factors:
                look(x)
        elif t in (Neg, Not, Call1, Cast):
            look(e.x)
        elif t is Div:
            look(e.num)
            look(e.den)
        elif t in (Call2, Compare, Bits):
            look(e.a)
            look(e.b)
        elif t is Select:
            look(e.cond)
            look(e.then)
            look(e.otherwise)

    def walk(stmts) -> None:
        nonlocal found
        for s in stmts:
            t = type(s)
            if t in (Let, Declare):
                if s.value is not None:
                    look(s.value)
            elif t is Assign:
                look(s.target)
                look(s.value)
            elif t is If:
                look(s.cond)
                walk(s.then)
                walk(s.otherwise)
            elif t is For:
                look(s.start)
                look(s.stop)
                walk(s.body)
            elif t is While:
                look(s.cond)
                walk(s.body)
            elif t is Return and s.value is not None:
                look(s.value)
            elif t is CallFunction:
                for a in s.args:
                    look(a)
                    if type(a) is not ArrayArg and name in _names(a, set()):
                        found = True  # a helper may index with it
            elif t is TrigBlock:
                for a in s.angles:
                    look(a)

    walk(body)
    return found


def _zero(t: Type):
    return {Type.REAL: Const(0.0), Type.INT: Const(0, Type.INT), Type.BOOL: Const(False, Type.BOOL),
            Type.UINT64: Const(0, Type.UINT64)}[t]


def predicate(module: Module, function: Function) -> Predicated:
    """The masked form of procedure ``function`` of ``module`` (see the module docstring). Remembered for the
    module's functions: the NumPy, PyTorch and JAX printers of one generation mask the same procedures, and so do
    a session's generations of one derivation. The result is shared: printers only read it. A loop bounded by
    one of the module's integer constants (``IK_MAX_SOLUTIONS``) has constant bounds."""
    integers = tuple((c.name, c.value) for c in module.constants if type(c.value) is int)
    return _predicated(module.functions, function, integers)


@lru_cache(maxsize=16)  # a generation masks a handful of procedures; each key holds its module's functions alive
def _predicated(functions: tuple[Function, ...], function: Function, integers: tuple[tuple[str, int], ...]) -> Predicated:
    p = _Pass(functions, integers)
    scope = _Scope()
    for a in function.arguments:
        if not a.is_scalar:
            p.arrays[a.name] = (a.size, a.type)
    status = None

    def body() -> None:
        nonlocal status
        for a in function.outputs:
            p.emit(PArray(a.name, a.size, a.type))
        if function.returns is not None:
            status = scope.result = p.define("status", Const(0, function.returns), function.returns, lanes=True)
        if _contains(function.body, (Return,)):
            scope.alive = p.define("alive", Const(True, Type.BOOL), lanes=True)
        p.block(function.body, None, scope)

    out = p.capture(body)
    return Predicated(function, out, status, dict(p.arrays), frozenset(p.statics), frozenset(p.consts), frozenset(p.rollable))
