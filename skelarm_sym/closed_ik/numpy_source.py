"""SymPy steps as the source of one NumPy function, printed directly (a faster ``sympy.lambdify`` for the
closed-form IK's evaluations in :mod:`.evaluate`).

``lambdify`` spends most of its time in SymPy's code printer (precedence, parenthesising and sign tests that
query the assumptions system for every product), about a second per arm. The steps here use a small set of
nodes (see :mod:`.derive`), each printed by one rule, every compound fully parenthesised:

* ``Add``: the terms in ``args`` order, summed left to right; ``Mul``: the factors with non-negative exponents
  multiplied in ``args`` order, divided once by the product of the others (as SymPy's printer does: ``x/rho``,
  not ``x*rho**-1``); ``Pow``: ``sqrt`` for 1/2, ``x**k`` for an integer ``k``;
* ``Piecewise``: nested ``where`` (every branch is evaluated, as with ``numpy.select``); relationals: ``<``, ... on
  arrays; ``And``/``Or``/``Not``: ``logical_and``/``logical_or``/``logical_not``;
* ``Abs``, ``Max``, ``Min``, ``sin``, ``cos``, ``atan2``: ``abs``, ``maximum``, ``minimum``, ``sin``, ``cos``,
  ``arctan2``;
* numbers: the nearest double (``repr``: every digit; ``lambdify`` prints a Float with its precision's digits,
  15 for a double, which moves a random constant by up to 1e-15 relative).

Any other node raises :class:`Unsupported` (the caller falls back to ``lambdify``).
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
import sympy as sp
from sympy.logic.boolalg import BooleanFalse, BooleanTrue

Step = tuple[sp.Symbol, sp.Expr]


class Unsupported(TypeError):
    """A node this printer has no rule for."""


_RELATIONS = {sp.StrictLessThan: "<", sp.LessThan: "<=", sp.StrictGreaterThan: ">", sp.GreaterThan: ">=",
              sp.Equality: "==", sp.Unequality: "!="}
_CALLS = {sp.Abs: "abs", sp.sin: "sin", sp.cos: "cos", sp.atan2: "arctan2"}
_NAMESPACE = {"abs": np.abs, "sin": np.sin, "cos": np.cos, "arctan2": np.arctan2, "sqrt": np.sqrt,
              "where": np.where, "maximum": np.maximum, "minimum": np.minimum, "logical_and": np.logical_and,
              "logical_or": np.logical_or, "logical_not": np.logical_not, "nan": np.nan, "inf": np.inf}


class _Printer:
    """Prints expressions with symbols renamed by ``names`` (a dict, symbol -> Python name)."""

    def __init__(self, names: dict) -> None:
        self.names = names

    def __call__(self, e) -> str:
        names = self.names
        name = names.get(e)
        if name is not None:
            return name
        if e.is_Number:
            if e.is_Integer:
                return f"({int(e)}.0)"
            return f"({float(e)!r})"
        if e.is_Add:
            return "(" + " + ".join(self(a) for a in e.args) + ")"
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(e.base, e.exp)
        t = type(e)
        if t is sp.Piecewise:
            out = None
            for value, cond in reversed(e.args):
                if out is None:
                    if cond is not sp.true:
                        return self._unsupported(e)  # no default: lambdify's NaN, not printed here
                    out = self(value)
                else:
                    out = f"where({self(cond)}, {self(value)}, {out})"
            return out
        op = _RELATIONS.get(t)
        if op is not None:
            return f"({self(e.lhs)} {op} {self(e.rhs)})"
        call = _CALLS.get(t)
        if call is not None:
            return f"{call}({', '.join(self(a) for a in e.args)})"
        if t is sp.And or t is sp.Or or t is sp.Max or t is sp.Min:
            fn = {sp.And: "logical_and", sp.Or: "logical_or", sp.Max: "maximum", sp.Min: "minimum"}[t]
            out = self(e.args[0])
            for a in e.args[1:]:
                out = f"{fn}({out}, {self(a)})"
            return out
        if t is sp.Not:
            return f"logical_not({self(e.args[0])})"
        if isinstance(e, BooleanTrue):
            return "True"
        if isinstance(e, BooleanFalse):
            return "False"
        return self._unsupported(e)

    @staticmethod
    def _unsupported(e) -> str:
        raise Unsupported(f"no NumPy rule for {type(e).__name__}")

    def _pow(self, base, exp) -> str:
        if exp == sp.S.Half:
            return f"sqrt({self(base)})"
        if exp == -sp.S.Half:
            return f"(1.0/sqrt({self(base)}))"
        if exp.is_Integer:
            k = int(exp)
            if k > 0:
                return f"({self(base)}**{k})"
            return f"(1.0/{self(base)})" if k == -1 else f"(1.0/({self(base)}**{-k}))"
        return self._unsupported(sp.Pow(base, exp, evaluate=False))

    def _mul(self, e) -> str:
        num, den = [], []
        for a in e.args:
            if a.is_Pow and a.exp.is_Rational and a.exp.p < 0:
                den.append(self(a.base) if a.exp == -1 else self._pow(a.base, -a.exp))
            else:
                num.append(a)
        sign = ""
        if num and num[0] == -1:
            sign, num = "-", num[1:]
        top = "*".join(self(a) for a in num) if num else "1.0"
        if den:
            top = f"{top}/{den[0]}" if len(den) == 1 else f"{top}/({'*'.join(den)})"
        return f"({sign}{top})"


def numpy_function(args: Sequence[sp.Symbol], steps: Sequence[Step], outs: Sequence[sp.Expr]) -> Callable[..., list]:
    """``f(*args) -> [outs]``: the steps (in order) and the outputs evaluated with NumPy, elementwise over arrays."""
    names: dict = {}
    params = []
    for i, a in enumerate(args):
        names[a] = f"a{i}"
        params.append(f"a{i}")
    printer = _Printer(names)
    lines = [f"def f({', '.join(params)}):"]
    for i, (symbol, expr) in enumerate(steps):
        text = printer(expr)
        names[symbol] = f"s{i}"
        lines.append(f" s{i} = {text}")
    lines.append(f" return [{', '.join(printer(sp.sympify(o)) for o in outs)}]")
    namespace = dict(_NAMESPACE)
    exec(compile("\n".join(lines), "<closed_ik numpy_function>", "exec"), namespace)
    return namespace["f"]
