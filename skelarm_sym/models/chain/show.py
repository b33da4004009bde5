"""Readable closed forms of a 3-D chain: the named intermediate steps, then the outputs in their terms.

A 6-joint robot's fully expanded Jacobian runs to pages; written as the derivation's steps
(rotations, origins, axis cross products, velocity sums) each line stays short and they read
in order. The expanded form is printed on request (``expand=True``) or for chains of up to
``EXPAND_UP_TO`` joints.
"""

from __future__ import annotations

import sympy as sp

from ...errors import InputError
from ...show import FORMATS
from ...show import render as _render
from .derive import ChainDerivation

WHAT = ("T", "J", "J_tool", "dJ", "twist", "acc")
EXPAND_UP_TO = 2


def _readable(steps, outputs) -> tuple[list[tuple[sp.Symbol, sp.Expr]], dict]:
    """Steps needed by ``outputs``, renamed without their internal prefix (``_ch_Jv3x`` -> ``Jv3x``)."""
    index = {s: i for i, (s, _) in enumerate(steps)}
    keep: set[int] = set()
    todo = [s for e in outputs for s in sp.sympify(e).free_symbols if s in index]
    while todo:
        i = index[todo.pop()]
        if i not in keep:
            keep.add(i)
            todo.extend(s for s in steps[i][1].free_symbols if s in index)
    rename = {s: sp.Symbol(s.name.split("_", 2)[-1], real=True) for s, _ in steps}
    return [(rename[steps[i][0]], steps[i][1].xreplace(rename)) for i in sorted(keep)], rename


def show_chain(derivation: ChainDerivation, what: str = "J", fmt: str = "pretty", expand: bool | None = None) -> str:
    """The output ``what`` (or ``all``) of a chain, as steps then outputs, or fully expanded."""
    if fmt not in FORMATS:
        raise InputError(f"unknown --format {fmt!r}; choose from {', '.join(FORMATS)}")
    names = WHAT if what == "all" else (what,)
    unknown = [w for w in names if w not in WHAT]
    if unknown:
        raise InputError(f"unknown --what {unknown[0]!r} for a robot; choose from {', '.join(WHAT + ('all',))}")
    expand = derivation.n <= EXPAND_UP_TO if expand is None else expand
    lines: list[str] = []
    if expand:
        for name in names:
            lines += [f"{name} =", _render(derivation.closed_form(name), fmt), ""]
        return "\n".join(lines)
    matrices = {name: derivation.compact[name] for name in names}
    steps, rename = _readable(derivation.steps, [e for m in matrices.values() for e in m])
    lines.append(f"# {len(steps)} intermediate steps, in order (c_k, s_k: cosine and sine of th_k):")
    for symbol, expr in steps:
        lines.append(f"{_render(symbol, 'text' if fmt == 'pretty' else fmt)} = {_render(expr, 'text' if fmt == 'pretty' else fmt)}")
    lines.append("")
    for name, matrix in matrices.items():
        lines += [f"{name} =", _render(matrix.xreplace(rename), fmt), ""]
    return "\n".join(lines)
