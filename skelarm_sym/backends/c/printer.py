"""IR expressions and statements as C99 text in one precision.

Parentheses follow C precedence and keep the IR's evaluation order: a nested sum or product is
parenthesised, never reassociated. Reals print as literals of the module's precision (``0.5``,
``0.5f``), so no macro such as ``M_PI`` (not C99) and no constant of the standard library reaches
the output. A guarded division prints as ``x/(d != 0 ? d : 1)`` (see :class:`~skelarm_sym.ir.nodes.Div`).
Two values have no literal: an infinity prints as ``HUGE_VAL`` and a NaN as C99's ``NAN`` (both from
``<math.h>``; ``NAN`` is a float, cast in double code); a Python ``int`` (an integer module constant) prints as a whole number.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..text import c_comment

from ...ir.nodes import (
    Add, ArrayArg, Assign, Bits, Break, Call1, Call2, CallFunction, Cast, Comment, Compare, Const, Declare,
    DeclareArray, Div, Elem, For, If, Let, Logic, Mul, NamedConst, Neg, Not, Return, Select, Store, TrigBlock, Type,
    Var, While,
)

_ATOM, _UNARY, _MUL, _ADD, _SHIFT, _REL, _EQ, _BITXOR, _AND, _OR, _SELECT = 100, 90, 80, 70, 65, 60, 55, 50, 40, 30, 20


@dataclass(frozen=True)
class CPrecision:
    """Everything that changes between ``double`` and ``float`` code."""

    ctype: str
    suffix: str

    def literal(self, value: float | int) -> str:
        """A C literal of this precision for ``value`` (an infinity prints as ``HUGE_VAL``/``HUGE_VALF``, a NaN
        as ``NAN``, ``(double)NAN`` in double code, a Python ``int`` as a whole number)."""
        if type(value) is int:
            return str(value)
        if math.isinf(value):
            return ("-" if value < 0 else "") + "HUGE_VAL" + ("F" if self.suffix else "")
        if math.isnan(value):  # NAN is a float: cast where it meets double (quiet under -Wdouble-promotion)
            return "NAN" if self.suffix else "(double)NAN"
        if self.ctype == "double":
            text = repr(float(value))
        else:
            import numpy as np  # float code only: generating double code needs no NumPy

            text = str(np.float32(value))
        if not any(ch in text for ch in ".en"):
            text += ".0"
        return text + self.suffix

    def function(self, name: str) -> str:
        """The math function ``name`` of this precision (``sqrtf`` for float)."""
        return name + self.suffix

    @property
    def sin(self) -> str:
        return "sin" + self.suffix

    @property
    def cos(self) -> str:
        return "cos" + self.suffix

    @property
    def sqrt(self) -> str:
        return "sqrt" + self.suffix

    @property
    def sincos(self) -> str:
        return "sincos" + self.suffix


PRECISIONS = {"double": CPrecision("double", ""), "float": CPrecision("float", "f")}

_TYPES = {Type.INT: "int", Type.BOOL: "int", Type.UINT64: "unsigned long long"}


class CPrinter:
    """Prints IR for one function: ``storage`` maps a variable or array name to its C text
    (trigonometric slots to array elements, for instance); ``macro`` turns a constant's name into its
    macro; ``function_name`` a called function's name into its C name."""

    def __init__(self, precision: CPrecision, storage: dict[str, str] | None = None,
                 macro=lambda name: name, function_name=lambda name: name, indent: str = "    ") -> None:
        self.precision = precision
        self.storage = storage or {}
        self.macro = macro
        self.function_name = function_name
        self.indent = indent
        self._memo: dict = {}

    def ctype(self, t: Type) -> str:
        return self.precision.ctype if t is Type.REAL else _TYPES[t]

    # -- expressions ---------------------------------------------------------------------------------
    def expr(self, e) -> str:
        """``e`` as C text."""
        return self._print(e)[0]

    def _print(self, e) -> tuple[str, int]:
        # memoised by identity (the lowering shares one object per distinct expression): hashing an IR
        # node hashes its whole tree; the entry keeps ``e`` alive, so its id is not reused meanwhile
        hit = self._memo.get(id(e))
        if hit is None or hit[0] is not e:
            hit = self._memo[id(e)] = (e, self._node(e))
        return hit[1]

    def _wrap(self, e, above: int) -> str:
        """``e``, parenthesised unless it binds tighter than ``above``."""
        text, prec = self._print(e)
        return text if prec > above else f"({text})"

    def _node(self, e) -> tuple[str, int]:
        t = type(e)
        if t is Const:
            if e.type is Type.REAL:
                text = self.precision.literal(float(e.value))  # a whole-number literal only for module constants
                return text, (_UNARY if text.startswith("-") else _ATOM)
            if e.type is Type.BOOL:
                return ("1" if e.value else "0"), _ATOM
            if e.type is Type.UINT64:
                return f"{int(e.value):#x}ULL", _ATOM
            return str(int(e.value)), (_UNARY if e.value < 0 else _ATOM)
        if t is Var:
            return self.storage.get(e.name, e.name), _ATOM
        if t is Elem:
            name = self.storage.get(e.array, e.array)
            return f"{name}[{self.expr(e.index)}]", _ATOM
        if t is NamedConst:
            return self.macro(e.name), _ATOM
        if t is Add:
            parts = []
            for i, term in enumerate(e.terms):
                if type(term) is Neg and i > 0:
                    parts.append(" - " + self._wrap(term.x, _ADD))
                elif i > 0 and type(term) is Const and term.type is Type.REAL and term.value < 0:
                    parts.append(" - " + self._wrap(Const(-term.value), _ADD))
                else:
                    text = self._wrap(term, _ADD) if i > 0 else self._first_term(term)
                    parts.append((" + " if i else "") + text)
            return "".join(parts), _ADD
        if t is Mul:
            parts = []
            for i, f in enumerate(e.factors):
                text, prec = self._print(f)
                if i == 0 and prec >= _UNARY and type(f) is not Neg:
                    parts.append(text)
                else:
                    parts.append(text if prec == _ATOM else f"({text})")
            return "*".join(parts), _MUL
        if t is Neg:
            text, prec = self._print(e.x)
            if prec == _ATOM or (prec == _MUL and type(e.x) is Mul):
                return f"-{text}", _UNARY
            return f"-({text})", _UNARY
        if t is Div:
            num = self._wrap(e.num, _MUL - 1) if type(e.num) is not Div else f"({self.expr(e.num)})"
            if e.guarded:
                d = self.expr(e.den)
                return f"{num}/({d} != {self.precision.literal(0.0)} ? {d} : {self.precision.literal(1.0)})", _MUL
            return f"{num}/{self._wrap(e.den, _MUL)}", _MUL
        if t is Call1:
            if e.function == "isfinite":
                return f"{self.macro('FINITE')}({self.expr(e.x)})", _ATOM
            name = self.precision.function(e.function)
            return f"{name}({self.expr(e.x)})", _ATOM
        if t is Call2:
            name = self.precision.function(e.function)
            return f"{name}({self.expr(e.a)}, {self.expr(e.b)})", _ATOM
        if t is Compare:
            level = _EQ if e.op in ("==", "!=") else _REL
            return f"{self._wrap(e.a, level)} {e.op} {self._wrap(e.b, level)}", level
        if t is Logic:
            level, op = (_AND, " && ") if e.op == "and" else (_OR, " || ")
            return op.join(self._wrap(x, _AND) for x in e.terms), level
        if t is Not:
            return f"!{self._wrap(e.x, _UNARY - 1)}", _UNARY
        if t is Select:
            return f"({self.expr(e.cond)} ? {self.expr(e.then)} : {self.expr(e.otherwise)})", _ATOM
        if t is Bits:
            level = {"^": _BITXOR, "<<": _SHIFT, ">>": _SHIFT, "*": _MUL, "%": _MUL}[e.op]
            return f"{self._wrap(e.a, level)} {e.op} {self._wrap(e.b, level)}", level
        if t is Cast:
            return f"({self.ctype(e.type)}){self._wrap(e.x, _UNARY)}", _UNARY
        raise TypeError(f"internal error: no C for {t.__name__}")

    def _first_term(self, term) -> str:
        text, prec = self._print(term)
        return text if prec >= _ADD and type(term) is not Add else f"({text})"

    # -- statements ----------------------------------------------------------------------------------
    def statements(self, body, depth: int = 1) -> list[str]:
        """The C lines of ``body`` at indentation ``depth``."""
        lines: list[str] = []
        for s in body:
            self._statement(s, depth, lines)
        return lines

    def _statement(self, s, depth: int, lines: list[str]) -> None:
        pad = self.indent * depth
        t = type(s)
        if t is Let:
            target = self.storage.get(s.var.name)
            if target is not None:  # a slot of a local array (an angle)
                lines.append(f"{pad}{target} = {self.expr(s.value)};")
            else:
                lines.append(f"{pad}const {self.ctype(s.var.type)} {s.var.name} = {self.expr(s.value)};")
        elif t is Declare:
            init = "" if s.value is None else f" = {self.expr(s.value)}"
            lines.append(f"{pad}{self.ctype(s.var.type)} {s.var.name}{init};")
        elif t is DeclareArray:
            qualifier = "const " if s.const else ""
            init = "" if s.values is None else " = { " + ", ".join(self.expr(v) for v in s.values) + " }"
            lines.append(f"{pad}{qualifier}{self.ctype(s.type)} {s.name}[{s.size}]{init};")
        elif t is Assign:
            lines.append(f"{pad}{self.expr(s.target)} = {self.expr(s.value)};")
        elif t is Store:
            name = self.storage.get(s.output, s.output)
            lines.append(f"{pad}{name}[{s.index}] = {self.expr(s.value)};")
        elif t is If:
            lines.append(f"{pad}if ({self.expr(s.cond)}) {{")
            lines.extend(self.statements(s.then, depth + 1))
            otherwise = s.otherwise
            while len(otherwise) == 1 and type(otherwise[0]) is If:
                inner = otherwise[0]
                lines.append(f"{pad}}} else if ({self.expr(inner.cond)}) {{")
                lines.extend(self.statements(inner.then, depth + 1))
                otherwise = inner.otherwise
            if otherwise:
                lines.append(f"{pad}}} else {{")
                lines.extend(self.statements(otherwise, depth + 1))
            lines.append(f"{pad}}}")
        elif t is For:
            v = s.var.name
            lines.append(f"{pad}for (int {v} = {self.expr(s.start)}; {v} < {self.expr(s.stop)}; ++{v}) {{")
            lines.extend(self.statements(s.body, depth + 1))
            lines.append(f"{pad}}}")
        elif t is While:
            cond = s.cond
            head = "for (;;)" if type(cond) is Const and cond.value is True else f"while ({self.expr(cond)})"
            lines.append(f"{pad}{head} {{")
            lines.extend(self.statements(s.body, depth + 1))
            lines.append(f"{pad}}}")
        elif t is Break:
            lines.append(f"{pad}break;")
        elif t is Return:
            lines.append(f"{pad}return;" if s.value is None else f"{pad}return {self.expr(s.value)};")
        elif t is CallFunction:
            args = ", ".join(self._argument(a) for a in s.args)
            call = f"{self.function_name(s.function)}({args})"
            lines.append(f"{pad}{call};" if s.result is None else f"{pad}{self.expr(s.result)} = {call};")
        elif t is Comment:
            lines.append(f"{pad}/* {c_comment(s.text)} */")
        elif t is TrigBlock:
            for a, c, sn in zip(s.angles, s.cos, s.sin):
                x = self.expr(a)
                lines.append(f"{pad}const {self.precision.ctype} {c.name} = {self.precision.cos}({x});")
                lines.append(f"{pad}const {self.precision.ctype} {sn.name} = {self.precision.sin}({x});")
        else:
            raise TypeError(f"internal error: no C for {t.__name__}")

    def _argument(self, a) -> str:
        if type(a) is ArrayArg:
            name = self.storage.get(a.name, a.name)
            return name if a.offset == 0 else f"{name} + {a.offset}"
        return self.expr(a)
