"""IR expressions and masked statements as Python over an eager array library: PyTorch, NumPy (the
NumPy module's batches of solver problems), and JAX's expressions (JAX prints its procedures itself).

Values are arrays over the batch (``lanes``); an array of the IR is a Python list of such values, so
element ``k`` is ``x[k]`` and writing it rebinds a list slot (never an in-place write into an array,
which autograd, ``vmap`` and ``torch.compile`` would all dislike). Numbers the printed program knows
without data (constants, counters of loops over constant ranges, constant tables: see
:func:`skelarm_sym.ir.predicate.is_static`) stay Python numbers; where an operation needs an array of
the working precision, the printer asks ``constant`` for one (``(_c + 0.5)`` in straight-line code, a
full array over the lanes in procedures). Selects are ``where``; logic on masks is ``&``, ``|``, ``~``
(always parenthesised: Python's comparisons bind looser than they do). Integers that wrap modulo 2**64
(the random-number generator) are pairs of 32-bit halves, handled by the emitted module's ``_u64_*``
helpers: PyTorch has no wrapping unsigned 64-bit multiply and JAX has no 64-bit integers without x64.
Each library is a :class:`Dialect`: the names of its functions.
"""

from __future__ import annotations

import keyword
import math
from dataclasses import dataclass

from ..ir.nodes import (
    Add, Bits, Call1, Call2, Cast, Compare, Const, Div, Elem, Logic, Mul, NamedConst, Neg, Not, Select, Type, Var,
)
from ..ir.predicate import PArray, PCall, PComment, PDef, PFor, PGuard, PLoop, PSet, Predicated, Slice, is_static
from .python_syntax import PythonArithmetic
from .text import line_comment

FLOAT32_MAX = 3.4028234663852886e38
"""The largest finite float32: a literal beyond it prints as an infinity (see ``TensorPrinter._node``)."""

_ATOM, _UNARY, _POW, _MUL, _ADD, _SHIFT, _BITAND, _BITXOR, _BITOR, _REL, _NOT, _AND, _OR, _COND = (
    100, 90, 85, 80, 70, 65, 62, 61, 60, 50, 45, 40, 30, 20)


def identifier(name: str) -> str:
    """A legal Python name for ``name`` (keywords get a trailing ``_``: ``lambda_``)."""
    return name + "_" if keyword.iskeyword(name) else name


@dataclass(frozen=True)
class Dialect:
    """The array library's names."""

    where: str
    calls: dict
    int_dtype: str
    bool_dtype: str
    cast: str
    """``cast.format(x=..., dtype=...)``: an array converted to another dtype."""
    shared: str | None = None
    """A helper of the emitted module that computes values several outputs read once (``None``: plain
    assignments are enough)."""


class TensorPrinter(PythonArithmetic):
    """Expressions as Python text over ``dialect``. ``statics``/``consts``: names whose values are Python
    numbers (loop counters, constant tables); ``constant(text, type)``: an array of the working precision
    holding the number ``text``; ``elements``: ``"list"`` (``x[k]``) or ``"last"`` (``x[..., k]``: an
    argument tensor, for the wrappers' defaults)."""

    def __init__(self, dialect: Dialect, statics=frozenset(), consts=frozenset(), constant=None,
                 elements: str = "list", real_cast: str = "_c.dtype") -> None:
        self.d = dialect
        self.statics = set(statics)
        self.consts = set(consts)
        self.constant = constant or (lambda text, type_: f"(_c + {text})")
        self.elements = elements
        self.real_cast = real_cast
        self._memo: dict = {}

    def static(self, e) -> bool:
        return is_static(e, self.statics, self.consts)

    def expr(self, e) -> str:
        return self._print(e)[0]

    def tensor(self, e, type_: Type = Type.REAL) -> str:
        """``e`` as an array even when it is a number known here."""
        text = self.expr(e)
        return self.constant(text, type_) if self.static(e) else text

    def _print(self, e) -> tuple[str, int]:
        hit = self._memo.get(e)
        if hit is None:
            hit = self._memo[e] = self._node(e)
        return hit

    def _wrap(self, e, above: int) -> str:
        text, prec = self._print(e)
        return text if prec > above else f"({text})"

    def _node(self, e) -> tuple[str, int]:  # noqa: C901 - one case per node type
        t = type(e)
        if t is Const:
            if e.type is Type.REAL:
                value = float(e.value)
                # beyond float32: infinite in the float32 tensors these modules take (torch.where refuses to
                # convert it); only the solvers' stand-in for an absent limit (1e300) is that large, compared
                # and clamped with, where an infinity does the same
                text = repr(value) if not FLOAT32_MAX < abs(value) < math.inf else ("-inf" if value < 0 else "inf")
                if text in ("inf", "-inf", "nan"):
                    text = {"inf": "_INF", "-inf": "-_INF", "nan": "_NAN"}[text]
                return text, (_UNARY if text.startswith("-") else _ATOM)
            if e.type is Type.BOOL:
                return ("True" if e.value else "False"), _ATOM
            if e.type is Type.UINT64:
                v = int(e.value)
                return f"({v >> 32:#x}, {v & 0xFFFFFFFF:#x})", _ATOM
            return str(int(e.value)), (_UNARY if int(e.value) < 0 else _ATOM)
        if t is Var:
            return identifier(e.name), _ATOM
        if t is NamedConst:
            return e.name, _ATOM
        if t is Elem:
            index = self.expr(e.index)
            if self.elements == "last":
                return f"{identifier(e.array)}[..., {index}]", _ATOM
            if not self.static(e.index):  # a counter of a loop kept rolled (JAX): pick among the elements
                return f"_pick({identifier(e.array)}, {index})", _ATOM
            return f"{identifier(e.array)}[{index}]", _ATOM
        if t is Add:
            return self._add(e)
        if t is Mul:
            return self._mul(e)
        if t is Neg:
            return self._neg(e)
        if t is Div:
            num = self._wrap(e.num, _MUL - 1) if type(e.num) is not Div else f"({self.expr(e.num)})"
            if e.guarded and not self.static(e.den):
                den = self.expr(e.den)
                return f"{num}/{self.d.where}({den} != 0, {den}, 1.0)", _MUL
            return f"{num}/{self._wrap(e.den, _MUL)}", _MUL
        if t is Call1:
            return f"{self.d.calls[e.function]}({self.tensor(e.x)})", _ATOM
        if t is Call2:
            return f"{self.d.calls[e.function]}({self.tensor(e.a)}, {self.tensor(e.b)})", _ATOM
        if t is Compare:
            return f"{self._wrap(e.a, _REL)} {e.op} {self._wrap(e.b, _REL)}", _REL
        if t is Logic:
            if self.static(e):
                level = _AND if e.op == "and" else _OR
                return f" {e.op} ".join(self._wrap(x, level) for x in e.terms), level
            op = " & " if e.op == "and" else " | "
            terms = [x for x in e.terms if not self.static(x)] + [x for x in e.terms if self.static(x)]
            return op.join(self._wrap(x, _ATOM - 1) for x in terms), (_BITAND if e.op == "and" else _BITOR)
        if t is Not:
            if self.static(e.x):
                return f"not {self._wrap(e.x, _NOT)}", _NOT
            return f"~{self._wrap(e.x, _ATOM - 1)}", _UNARY
        if t is Select:
            if self.static(e.cond):
                return (f"{self._wrap(e.then, _COND)} if {self._wrap(e.cond, _COND)} else "
                        f"{self._wrap(e.otherwise, _COND - 1)}"), _COND
            then = self.expr(e.then)
            if self.static(e.then) and self.static(e.otherwise):
                then = self.constant(then, _type_of(e.then))
            return f"{self.d.where}({self.expr(e.cond)}, {then}, {self.expr(e.otherwise)})", _ATOM
        if t is Bits:
            if e.op == "%":
                return f"{self._wrap(e.a, _MUL)} % {self._wrap(e.b, _MUL)}", _MUL
            name = {"^": "_u64_xor", "<<": "_u64_shl", ">>": "_u64_shr", "*": "_u64_mul"}[e.op]
            return f"{name}({self.expr(e.a)}, {self.expr(e.b)})", _ATOM
        if t is Cast:
            inner = _type_of(e.x)
            if e.type is Type.REAL and inner is Type.UINT64:
                return f"_u64_real({self.expr(e.x)}, {self.real_cast})", _ATOM
            if self.static(e.x):
                return f"{'float' if e.type is Type.REAL else 'int'}({self.expr(e.x)})", _ATOM
            dtype = self.real_cast if e.type is Type.REAL else self.d.int_dtype
            return self.d.cast.format(x=self._wrap(e.x, _ATOM - 1), dtype=dtype), _ATOM
        raise TypeError(f"internal error: no array code for {t.__name__}")


def _type_of(e) -> Type:
    """The scalar type of an expression (enough to pick an array's dtype)."""
    t = type(e)
    if t in (Const, Var, NamedConst, Elem):
        return e.type
    if t in (Compare, Logic, Not):
        return Type.BOOL
    if t is Call1:
        return Type.BOOL if e.function == "isfinite" else Type.REAL
    if t is Cast:
        return e.type
    if t is Bits:
        return _type_of(e.a)
    if t is Select:
        return _type_of(e.then)
    if t is Add:
        return _type_of(e.terms[0])
    if t is Mul:
        return _type_of(e.factors[0])
    if t is Neg:
        return _type_of(e.x)
    return Type.REAL


FULL = {Type.REAL: "_fr", Type.INT: "_fi", Type.BOOL: "_fb", Type.UINT64: "_fu"}
"""The procedures' helpers that make a full array over the lanes, per type."""


class ProcedurePrinter:
    """A :class:`~skelarm_sym.ir.predicate.Predicated` procedure as statements of an eager array library
    (``dialect``: PyTorch, or NumPy for the NumPy module's batches): masked assignments are ``where``,
    loops over data are ``while`` loops that end when no lane runs (one host synchronisation per pass),
    guards skip a branch no lane takes."""

    def __init__(self, p: Predicated, calls: dict[str, str], dialect: Dialect, indent: str = "    ",
                 statics: set[str] | None = None) -> None:
        """``statics``: the names the printer may treat as plain numbers (``p.statics`` when ``None``)."""
        self.p = p
        self.calls = calls
        self.indent = indent
        self.printer = TensorPrinter(dialect, p.statics if statics is None else statics, p.consts, constant=self._full)

    def _full(self, text: str, type_: Type) -> str:
        return f"{FULL[type_]}({text})"

    def value(self, e, type_: Type, lanes: bool = True) -> str:
        """``e`` for an assignment to a variable of ``type_``: an array (over the lanes when a number).
        ``lanes``: whether the variable must hold a value per lane (an eager library broadcasts; see JAX's)."""
        if self.printer.static(e):
            return self._full(self.printer.expr(e), type_)
        return self.printer.expr(e)

    def statements(self, body, depth: int) -> list[str]:
        lines: list[str] = []
        for s in body:
            self.statement(s, depth, lines)
        if not lines:
            lines.append(self.indent * depth + "pass")
        return lines

    def target(self, target) -> tuple[str, Type]:
        if type(target) is Var:
            return identifier(target.name), target.type
        return f"{identifier(target.array)}[{self.printer.expr(target.index)}]", target.type

    def select(self, mask: str, new: str, old: str, type_: Type) -> str:
        if type_ is Type.UINT64:
            return f"_u64_where({mask}, {new}, {old})"
        return f"{self.printer.d.where}({mask}, {new}, {old})"

    def statement(self, s, depth: int, lines: list[str]) -> None:  # noqa: C901
        pad = self.indent * depth
        pr = self.printer
        t = type(s)
        if t is PDef:
            lines.append(f"{pad}{identifier(s.var.name)} = {self.value(s.value, s.var.type, s.lanes)}")
        elif t is PArray:
            name = identifier(s.name)
            if s.const:
                lines.append(f"{pad}{name} = [{', '.join(pr.expr(v) for v in s.values)}]")
            elif s.values is None:
                lines.append(f"{pad}{name} = [{self._full('0' if s.type is not Type.REAL else '0.0', s.type)}] * {s.size}")
            else:
                lines.append(f"{pad}{name} = [{', '.join(self.value(v, s.type) for v in s.values)}]")
        elif t is PSet:
            target, type_ = self.target(s.target)
            if s.mask is None:
                lines.append(f"{pad}{target} = {self.value(s.value, type_)}")
            else:
                new = pr.expr(s.value)
                if type_ is Type.UINT64 and pr.static(s.value):
                    new = self._full(new, type_)
                lines.append(f"{pad}{target} = {self.select(identifier(s.mask.name), new, target, type_)}")
        elif t is PCall:
            args = ", ".join(f"{identifier(a.name)}[{a.offset}:{a.offset + a.size}]" if type(a) is Slice else pr.tensor(a)
                             for a in s.args)
            lines.append(f"{pad}_o = {self.calls[s.function]}(_c, {args})")
            mask = "None" if s.mask is None else identifier(s.mask.name)
            for i, o in enumerate(s.outputs):
                lines.append(f"{pad}_merge({mask}, _o[{i}], {identifier(o.name)}, {o.offset}, _fr)")
        elif t is PFor:
            lines.append(f"{pad}for {identifier(s.var.name)} in range({s.start}, {s.stop}):")
            lines.extend(self.statements(s.body, depth + 1))
        elif t is PLoop:
            lines.append(f"{pad}while bool({identifier(s.run.name)}.any()):")
            lines.extend(self.statements(s.body, depth + 1))
        elif t is PGuard:
            lines.append(f"{pad}if bool({identifier(s.mask.name)}.any()):")
            lines.extend(self.statements(s.body, depth + 1))
        elif t is PComment:
            lines.append(f"{pad}# {line_comment(s.text)}")
        else:
            raise TypeError(f"internal error: no array code for {t.__name__}")
