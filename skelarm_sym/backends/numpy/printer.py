"""IR expressions and statements as Python text over NumPy.

Two modes. ``vector`` (straight-line functions): every value is an array over the leading batch
dimensions, an element of an argument is ``x[..., k]``, a select is ``np.where`` and logic is
element-wise (``&``, ``|``, ``~``); both sides of a select are evaluated, so the function runs under
``np.errstate(divide="ignore", invalid="ignore")``. ``scalar`` (procedures: the iterative solvers,
one problem per call): elements are ``x[k]``, selects are conditional expressions and logic is
Python's. Reals print as Python float literals, which NumPy (>= 2) keeps in the array's precision.
"""

from __future__ import annotations

import keyword

from ...ir.nodes import (
    Add, ArrayArg, Assign, Bits, Break, Call1, Call2, CallFunction, Cast, Comment, Compare, Const, Declare,
    DeclareArray, Div, Elem, For, If, Let, Logic, Mul, NamedConst, Neg, Not, Return, Select, Store, TrigBlock, Type,
    Var, While,
)
from ..python_syntax import PythonArithmetic

_ATOM, _UNARY, _MUL, _ADD, _SHIFT, _BITAND, _BITXOR, _BITOR, _REL, _NOT, _AND, _OR, _COND = (
    100, 90, 80, 70, 65, 62, 61, 60, 50, 45, 40, 30, 20)

VECTOR_CALLS = {"sqrt": "np.sqrt", "sin": "np.sin", "cos": "np.cos", "fabs": "np.abs", "floor": "np.floor", "nearbyint": "np.rint",
                "atan2": "np.arctan2", "fmin": "np.minimum", "fmax": "np.maximum", "isfinite": "np.isfinite"}


def identifier(name: str) -> str:
    """A legal Python name for ``name`` (keywords get a trailing ``_``: ``lambda_``)."""
    return name + "_" if keyword.iskeyword(name) else name


class PythonPrinter(PythonArithmetic):
    """Prints IR as Python (see the module docstring). ``storage`` maps names to text; ``constant``
    turns a module constant's name into its Python name; ``function_name`` a called function's name."""

    def __init__(self, vector: bool, storage: dict[str, str] | None = None, constant=lambda name: name,
                 function_name=lambda name: name, real: str = "DTYPE", indent: str = "    ") -> None:
        self.vector = vector
        self.storage = storage or {}
        self.constant = constant
        self.function_name = function_name
        self.real = real
        self.indent = indent
        self._memo: dict = {}

    def name(self, name: str) -> str:
        return self.storage.get(name, identifier(name))

    # -- expressions ---------------------------------------------------------------------------------
    def expr(self, e) -> str:
        return self._print(e)[0]

    def _print(self, e) -> tuple[str, int]:
        # memoised by identity (see CPrinter._print)
        hit = self._memo.get(id(e))
        if hit is None or hit[0] is not e:
            hit = self._memo[id(e)] = (e, self._node(e))
        return hit[1]

    def _wrap(self, e, above: int) -> str:
        text, prec = self._print(e)
        return text if prec > above else f"({text})"

    def _node(self, e) -> tuple[str, int]:
        t = type(e)
        if t is Const:
            if e.type is Type.REAL:
                text = repr(float(e.value))
                if text in ("inf", "-inf", "nan"):
                    text = {"inf": "np.inf", "-inf": "-np.inf", "nan": "np.nan"}[text]
                return text, (_UNARY if text.startswith("-") else _ATOM)
            if e.type is Type.BOOL:
                return ("True" if e.value else "False"), _ATOM
            if e.type is Type.UINT64:
                return f"{int(e.value):#x}", _ATOM
            return str(int(e.value)), (_UNARY if int(e.value) < 0 else _ATOM)
        if t is Var:
            return self.name(e.name), _ATOM
        if t is Elem:
            index = self.expr(e.index)
            return (f"{self.name(e.array)}[..., {index}]" if self.vector and e.array not in self._locals
                    else f"{self.name(e.array)}[{index}]"), _ATOM
        if t is NamedConst:
            return self.constant(e.name), _ATOM
        if t is Add:
            return self._add(e)
        if t is Mul:
            return self._mul(e)
        if t is Neg:
            return self._neg(e)
        if t is Div:
            num = self._wrap(e.num, _MUL - 1) if type(e.num) is not Div else f"({self.expr(e.num)})"
            return f"{num}/{self._wrap(e.den, _MUL)}", _MUL
        if t is Call1:
            return f"{VECTOR_CALLS[e.function]}({self.expr(e.x)})", _ATOM
        if t is Call2:
            return f"{VECTOR_CALLS[e.function]}({self.expr(e.a)}, {self.expr(e.b)})", _ATOM
        if t is Compare:
            return f"{self._wrap(e.a, _REL)} {e.op} {self._wrap(e.b, _REL)}", (_ATOM - 1 if self.vector else _REL)
        if t is Logic:
            if self.vector:
                op = " & " if e.op == "and" else " | "
                return op.join(f"({self.expr(x)})" for x in e.terms), _BITAND if e.op == "and" else _BITOR
            level = _AND if e.op == "and" else _OR
            return f" {e.op} ".join(self._wrap(x, level) for x in e.terms), level
        if t is Not:
            if self.vector:
                return f"~({self.expr(e.x)})", _UNARY
            return f"not {self._wrap(e.x, _NOT)}", _NOT
        if t is Select:
            if self.vector:
                return f"np.where({self.expr(e.cond)}, {self.expr(e.then)}, {self.expr(e.otherwise)})", _ATOM
            return f"{self._wrap(e.then, _COND)} if {self._wrap(e.cond, _COND)} else {self._wrap(e.otherwise, _COND - 1)}", _COND
        if t is Bits:
            if e.op == "*":
                return f"({self.expr(e.a)} * {self.expr(e.b)}) & 0xFFFFFFFFFFFFFFFF", _BITAND
            if e.op == "<<":
                return f"({self._wrap(e.a, _SHIFT)} << {self._wrap(e.b, _SHIFT)}) & 0xFFFFFFFFFFFFFFFF", _BITAND
            level = {"^": _BITXOR, ">>": _SHIFT, "%": _MUL}[e.op]
            return f"{self._wrap(e.a, level)} {e.op} {self._wrap(e.b, level)}", level
        if t is Cast:
            if e.type is Type.REAL:
                return f"{self.real}({self.expr(e.x)})", _ATOM
            return f"int({self.expr(e.x)})", _ATOM
        raise TypeError(f"internal error: no Python for {t.__name__}")

    _locals: frozenset = frozenset()

    # -- statements (scalar mode) --------------------------------------------------------------------
    def statements(self, body, depth: int = 1) -> list[str]:
        lines: list[str] = []
        for s in body:
            self._statement(s, depth, lines)
        if not lines:
            lines.append(self.indent * depth + "pass")
        return lines

    def _statement(self, s, depth: int, lines: list[str]) -> None:
        pad = self.indent * depth
        t = type(s)
        if t in (Let, Declare):
            if t is Declare and s.value is None:
                lines.append(f"{pad}{self.name(s.var.name)} = {self._zero(s.var.type)}")
            else:
                lines.append(f"{pad}{self.name(s.var.name)} = {self._typed(s.value, s.var.type)}")
        elif t is DeclareArray:
            dtype = {Type.REAL: self.real, Type.INT: "np.int64", Type.BOOL: "np.bool_", Type.UINT64: None}[s.type]
            if dtype is None:  # exact integers that wrap modulo 2**64: Python ints (masked where they grow)
                values = ", ".join(self.expr(v) for v in s.values) if s.values is not None else ", ".join(["0"] * s.size)
                lines.append(f"{pad}{self.name(s.name)} = [{values}]")
            elif s.values is None:
                lines.append(f"{pad}{self.name(s.name)} = np.zeros({s.size}, dtype={dtype})")
            else:
                values = ", ".join(self.expr(v) for v in s.values)
                lines.append(f"{pad}{self.name(s.name)} = np.array([{values}], dtype={dtype})")
            self._locals = self._locals | {s.name}
        elif t is Assign:
            lines.append(f"{pad}{self.expr(s.target)} = {self._typed(s.value, s.target.type)}")
        elif t is Store:
            index = f"..., {s.index}" if self.vector else str(s.index)
            lines.append(f"{pad}{self.name(s.output)}[{index}] = {self.expr(s.value)}")
        elif t is If:
            lines.append(f"{pad}if {self.expr(s.cond)}:")
            lines.extend(self.statements(s.then, depth + 1))
            otherwise = s.otherwise
            while len(otherwise) == 1 and type(otherwise[0]) is If:
                inner = otherwise[0]
                lines.append(f"{pad}elif {self.expr(inner.cond)}:")
                lines.extend(self.statements(inner.then, depth + 1))
                otherwise = inner.otherwise
            if otherwise:
                lines.append(f"{pad}else:")
                lines.extend(self.statements(otherwise, depth + 1))
        elif t is For:
            lines.append(f"{pad}for {self.name(s.var.name)} in range({self.expr(s.start)}, {self.expr(s.stop)}):")
            lines.extend(self.statements(s.body, depth + 1))
        elif t is While:
            cond = "True" if type(s.cond) is Const and s.cond.value is True else self.expr(s.cond)
            lines.append(f"{pad}while {cond}:")
            lines.extend(self.statements(s.body, depth + 1))
        elif t is Break:
            lines.append(f"{pad}break")
        elif t is Return:
            lines.append(f"{pad}return" if s.value is None else f"{pad}return {self.expr(s.value)}")
        elif t is CallFunction:
            args = ", ".join(self._argument(a) for a in s.args)
            call = f"{self.function_name(s.function)}({args})"
            lines.append(f"{pad}{call}" if s.result is None else f"{pad}{self.expr(s.result)} = {call}")
        elif t is Comment:
            lines.append(f"{pad}# {s.text}")
        elif t is TrigBlock:
            for a, c, sn in zip(s.angles, s.cos, s.sin):
                x = self.expr(a)
                lines.append(f"{pad}{self.name(c.name)} = np.cos({x})")
                lines.append(f"{pad}{self.name(sn.name)} = np.sin({x})")
        else:
            raise TypeError(f"internal error: no Python for {t.__name__}")

    def _zero(self, t: Type) -> str:
        return {Type.REAL: f"{self.real}(0.0)", Type.INT: "0", Type.BOOL: "False", Type.UINT64: "0"}[t]

    def _typed(self, value, t: Type) -> str:
        """A real assigned from a literal keeps the module's precision (``DTYPE(0.5)``)."""
        text = self.expr(value)
        if t is Type.REAL and type(value) is Const:
            return f"{self.real}({text})"
        return text

    def _argument(self, a) -> str:
        if type(a) is ArrayArg:
            name = self.name(a.name)
            return name if a.offset == 0 else f"{name}[{a.offset}:]"
        return self.expr(a)
