"""Sums, products and negations of the IR in Python's syntax, shared by the printers that write Python
(the NumPy module, the PyTorch and JAX modules).

Precedences: an atom binds tighter than a unary minus, which binds tighter than ``*`` and ``/``, then
``+`` and ``-``; the printers number theirs the same way (:data:`ATOM` ... :data:`ADD`).
"""

from __future__ import annotations

from ..ir.nodes import Add, Const, Mul, Neg, Type

ATOM, UNARY, MUL, ADD = 100, 90, 80, 70


class PythonArithmetic:
    """Mixin: ``_add``, ``_mul``, ``_neg`` print an ``Add``, ``Mul`` or ``Neg`` node as ``(text, precedence)``
    through the printer's own ``_print`` and ``_wrap`` (so its memo and its other nodes apply)."""

    def _add(self, e) -> tuple[str, int]:
        parts = []
        for i, term in enumerate(e.terms):
            if type(term) is Neg and i > 0:
                parts.append(" - " + self._wrap(term.x, ADD))
            elif i > 0 and type(term) is Const and term.type is Type.REAL and term.value < 0:
                parts.append(" - " + self._wrap(Const(-term.value), ADD))
            elif i == 0:
                text, prec = self._print(term)
                parts.append(text if prec >= ADD and type(term) is not Add else f"({text})")
            else:
                parts.append(" + " + self._wrap(term, ADD))
        return "".join(parts), ADD

    def _mul(self, e) -> tuple[str, int]:
        parts = []
        for i, f in enumerate(e.factors):
            text, prec = self._print(f)
            parts.append(text if prec == ATOM or (i == 0 and prec >= UNARY and type(f) is not Neg) else f"({text})")
        return "*".join(parts), MUL

    def _neg(self, e) -> tuple[str, int]:
        text, prec = self._print(e.x)
        if prec == ATOM or type(e.x) is Mul:
            return f"-{text}", UNARY
        return f"-({text})", UNARY
