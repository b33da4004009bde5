"""``show`` for planar arms: closed forms as pretty text, LaTeX or plain SymPy text."""

from __future__ import annotations

import sympy as sp

from ...derive import Derivation
from ...errors import InputError
from ...show import FORMATS, render  # noqa: F401 - FORMATS re-exported
from . import singular

WHAT = ("p", "phi", "J", "J3", "H", "v", "a", "det", "manipulability", "singular")
SHOW_MAX_LINKS = 12
"""``show`` prints closed forms of chains up to this many links (n = 12: all forms in about 8 s).
They grow as n^2 terms and their printing faster still (n = 32: 11 s for J alone); longer chains
are refused with a message pointing at ``generate``, whose step form stays linear in n."""
_SIMPLIFY_UP_TO = 3
"""Up to this many links the shown forms are simplified (cheap there; never in generation)."""


def closed_form(derivation: Derivation, what: str) -> sp.Expr | sp.Matrix | str | None:
    """The object shown for ``what`` (see ``WHAT``); text for ``singular``."""
    if what == "det":
        return singular.determinant(derivation)
    if what == "manipulability":
        return singular.manipulability(derivation) if derivation.n > 1 else sp.S.Zero
    if what == "singular":
        return singular.singular_configurations(derivation).statement
    value = derivation.phi if what == "phi" else getattr(derivation, what)
    if derivation.n <= _SIMPLIFY_UP_TO and what in ("H", "a"):
        value = value.applyfunc(lambda e: sp.factor_terms(sp.collect(sp.expand(e), list(derivation.dq) + list(derivation.ddq))))
    return value


def check_show_size(n: int) -> None:
    """InputError when closed forms of an ``n``-link chain are too large to show (see SHOW_MAX_LINKS)."""
    if n > SHOW_MAX_LINKS:
        raise InputError(
            f"show prints closed forms up to {SHOW_MAX_LINKS} links (they grow as n^2 terms), got {n}; "
            f"use 'skelarm-sym generate --links {n}' for code in step form, or show --plot for a picture"
        )


def show(derivation: Derivation, what: str = "J", fmt: str = "pretty") -> str:
    """Text for ``skelarm-sym show``: one block per requested output."""
    check_show_size(derivation.n)
    names = WHAT if what == "all" else (what,)
    blocks = []
    for name in names:
        value = closed_form(derivation, name)
        if value is None:
            text = f"(det J is defined only where J is square: n = 2 for J, n = 3 for J3; n = {derivation.n})"
            if what != "all":
                blocks.append(f"{name} =\n{text}")
            continue
        if isinstance(value, str):
            blocks.append(f"singular configurations:\n{value}")
            continue
        label = {"manipulability": "w = sqrt(det(J J^T))", "det": "det J" if derivation.n == 2 else "det J3"}.get(name, name)
        blocks.append(f"{label} =\n{render(value, fmt)}")
    return "\n\n".join(blocks) + "\n"
