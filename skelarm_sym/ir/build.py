"""Writing procedural IR by hand: the iterative solvers are described once with this builder and
printed by every backend.

A :class:`Body` collects statements; blocks nest with ``with``::

    b = Body()
    err = b.var("err", 0.0)
    with b.for_("k", 0, n) as k:
        b.set(q[k], q0[k])
    with b.if_(err <= tol):
        b.return_(CONVERGED)
    with b.else_():
        ...

Python-level loops unroll at generation time (a fixed-size solve written with ``for r in range(6)``
becomes straight-line code); ``b.for_`` and ``b.while_`` emit run-time loops. :class:`Array` gives
element access (``q[k]``) and :meth:`Array.at` passes an array (or its tail) to a called function.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator, Sequence

from .nodes import (
    Add, ArrayArg, Assign, Break, Call1, Call2, CallFunction, Comment, Const, Declare, DeclareArray, Elem, For, If,
    Let, Mul, Return, Select, Stmt, Type, Var, While, _wrap,
)


class Array:
    """An array by name: ``a[i]`` is its element ``i`` (an int or an int expression)."""

    def __init__(self, name: str, size: int, type: Type = Type.REAL) -> None:
        self.name = name
        self.size = size
        self.type = type

    def __getitem__(self, index) -> Elem:
        return Elem(self.name, _wrap(index) if not isinstance(index, int) else Const(index, Type.INT), self.type)

    def at(self, offset: int = 0) -> ArrayArg:
        """The array from element ``offset`` on, as an argument of a called function."""
        return ArrayArg(self.name, offset)


class Body:
    """Collects the statements of a procedure (see the module docstring)."""

    def __init__(self) -> None:
        self._stack: list[list[Stmt]] = [[]]
        self._names: set[str] = set()

    @property
    def statements(self) -> tuple[Stmt, ...]:
        if len(self._stack) != 1:
            raise RuntimeError("internal error: an unclosed block")
        return tuple(self._stack[0])

    def emit(self, statement: Stmt) -> None:
        self._stack[-1].append(statement)

    def _new(self, name: str) -> str:
        if name in self._names:
            raise ValueError(f"internal error: {name!r} declared twice")
        self._names.add(name)
        return name

    # -- declarations -------------------------------------------------------------------------------
    def let(self, name: str, value, type: Type = Type.REAL) -> Var:
        """A constant local ``name = value``."""
        var = Var(self._new(name), type)
        self.emit(Let(var, _wrap(value)))
        return var

    def var(self, name: str, value=None, type: Type = Type.REAL) -> Var:
        """A mutable local, initialised to ``value`` when given."""
        var = Var(self._new(name), type)
        self.emit(Declare(var, None if value is None else _wrap(value)))
        return var

    def array(self, name: str, size: int, type: Type = Type.REAL, values: Sequence | None = None, const: bool = False) -> Array:
        """A local array of ``size`` elements (initialised from ``values`` when given)."""
        self.emit(DeclareArray(self._new(name), size, type, None if values is None else tuple(_wrap(v) for v in values), const))
        return Array(name, size, type)

    # -- actions --------------------------------------------------------------------------------------
    def set(self, target, value) -> None:
        """``target = value`` (a variable or an element)."""
        self.emit(Assign(target, _wrap(value)))

    def call(self, function: str, *args, result: Var | None = None) -> None:
        """Call ``function`` of the module; arrays pass as :meth:`Array.at` or :class:`Array`."""
        self.emit(CallFunction(function, tuple(a.at() if isinstance(a, Array) else _wrap(a) for a in args), result))

    def return_(self, value=None) -> None:
        self.emit(Return(None if value is None else _wrap(value)))

    def break_(self) -> None:
        self.emit(Break())

    def comment(self, text: str) -> None:
        self.emit(Comment(text))

    def norm(self, name: str, values: Sequence) -> Var:
        """``name = sqrt(sum of squares of values)``, without overflow: when the plain sum overflows (a
        far finite target in float), the values are scaled by their largest magnitude first."""
        values = [_wrap(v) for v in values]
        squares = self.var(f"{name}_squares", total([v * v for v in values]))
        out = self.var(name, sqrt(squares))
        with self.if_(~Call1("isfinite", squares)):
            largest = fabs(values[0])
            for v in values[1:]:
                largest = select(fabs(v) > largest, fabs(v), largest)
            top = self.var(f"{name}_top", largest)
            self.set(out, top * sqrt(total([(v / top) * (v / top) for v in values])))
        return out

    # -- blocks -----------------------------------------------------------------------------------------
    @contextmanager
    def _block(self) -> Iterator[list[Stmt]]:
        self._stack.append([])
        try:
            yield self._stack[-1]
        finally:
            self._stack.pop()

    @contextmanager
    def if_(self, cond) -> Iterator[None]:
        """``if cond:`` (an :meth:`else_` may follow at once)."""
        with self._block() as inner:
            yield
        self.emit(If(_wrap(cond), tuple(inner)))

    @contextmanager
    def else_(self) -> Iterator[None]:
        """The ``else`` of the :class:`If` emitted last in this block."""
        block = self._stack[-1]
        if not block or type(block[-1]) is not If or block[-1].otherwise:
            raise RuntimeError("internal error: else_ without an if_ before it")
        with self._block() as inner:
            yield
        last = block.pop()
        block.append(If(last.cond, last.then, tuple(inner)))

    @contextmanager
    def for_(self, name: str, start, stop) -> Iterator[Var]:
        """``for name in range(start, stop)``: yields the counter (an int)."""
        var = Var(name, Type.INT)
        with self._block() as inner:
            yield var
        self.emit(For(var, _wrap(start), _wrap(stop), tuple(inner)))

    @contextmanager
    def while_(self, cond=True) -> Iterator[None]:
        """``while cond:`` (``True``: left only by break or return)."""
        with self._block() as inner:
            yield
        self.emit(While(_wrap(cond), tuple(inner)))


# -- expression helpers -------------------------------------------------------------------------------

def sqrt(x) -> Call1:
    return Call1("sqrt", _wrap(x))


def fabs(x) -> Call1:
    return Call1("fabs", _wrap(x))


def atan2(y, x) -> Call2:
    return Call2("atan2", _wrap(y), _wrap(x))


def select(cond, then, otherwise) -> Select:
    """``cond ? then : otherwise``."""
    return Select(_wrap(cond), _wrap(then), _wrap(otherwise))


def fmax(a, b) -> Select:
    """``a > b ? a : b`` (a select: the same rounding and NaN behaviour in every backend)."""
    a, b = _wrap(a), _wrap(b)
    return Select(a > b, a, b)


def fmin(a, b) -> Select:
    """``a < b ? a : b``."""
    a, b = _wrap(a), _wrap(b)
    return Select(a < b, a, b)


def total(terms: Sequence) -> object:
    """``terms[0] + terms[1] + ...`` as one sum (``0.0`` when empty)."""
    terms = [_wrap(t) for t in terms]
    if not terms:
        return Const(0.0)
    return terms[0] if len(terms) == 1 else Add(tuple(terms))


def product(factors: Sequence) -> object:
    factors = [_wrap(f) for f in factors]
    return factors[0] if len(factors) == 1 else Mul(tuple(factors))


def real(x: float) -> Const:
    return Const(float(x))


def integer(x: int) -> Const:
    return Const(int(x), Type.INT)
