"""Closed forms as text: the formats every model's ``show`` prints in."""

from __future__ import annotations

import sympy as sp
from sympy.printing.pretty.pretty import PrettyPrinter
from sympy.printing.pretty.stringpict import prettyForm

FORMATS = ("pretty", "latex", "text")


class _VerbatimNames(PrettyPrinter):
    """SymPy's Unicode art with every symbol's name as it is written (``G4_01``, not ``G₄ ₀₁``)."""

    def _print_Symbol(self, e, bold_name=False):  # noqa: ARG002 - SymPy's signature
        return prettyForm(e.name)


def render(expr, fmt: str, verbatim: bool = False) -> str:
    """``expr`` in format ``fmt`` (``pretty``: Unicode art, ``latex``, ``text``: SymPy's plain text).
    ``verbatim``: in ``pretty``, names are printed as written, without subscripts (names of steps that a
    listing prints in text above)."""
    if fmt == "latex":
        return sp.latex(expr)
    if fmt == "text":
        return sp.sstr(expr)
    if verbatim:
        return _VerbatimNames({"use_unicode": True, "wrap_line": False}).doprint(expr)
    return sp.pretty(expr, use_unicode=True, wrap_line=False)
