"""Closed forms as text: the formats every model's ``show`` prints in."""

from __future__ import annotations

import sympy as sp

FORMATS = ("pretty", "latex", "text")


def render(expr, fmt: str) -> str:
    """``expr`` in format ``fmt`` (``pretty``: Unicode art, ``latex``, ``text``: SymPy's plain text)."""
    if fmt == "latex":
        return sp.latex(expr)
    if fmt == "text":
        return sp.sstr(expr)
    return sp.pretty(expr, use_unicode=True, wrap_line=False)
