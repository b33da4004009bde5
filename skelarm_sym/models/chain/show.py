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
"""Outputs of the derivation ``show`` prints; ``ik`` (:func:`show_ik`) is the closed-form IK."""
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
        raise InputError(f"unknown --what {unknown[0]!r} for a robot; choose from {', '.join(WHAT + ('all', 'ik', 'links'))}")
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


def show_ik(chain, lock: int | None = None, fmt: str = "pretty") -> str:
    """The closed-form IK of ``chain`` (``lock``: the 0-based index of a held joint): its family and chain of
    subproblems, the special points, then every step in order and the candidates ``Q`` and ``flags`` in their
    terms (the code ``ik_candidates`` is lowered from). InputError (the classifier's one line) when the chain
    is in no closed-form family."""
    from ...closed_ik import classify, derive_ik_all

    if fmt not in FORMATS:
        raise InputError(f"unknown --format {fmt!r}; choose from {', '.join(FORMATS)}")
    family = classify(chain, lock)
    ik = derive_ik_all(chain, lock)
    S, N = ik.Q.shape
    step_fmt = "text" if fmt == "pretty" else fmt
    lines = [f"# {chain.name}: {family.describe()}", "# subproblems, in order (solver joint numbering):"]
    lines += [f"#   {k + 1}. {sub}" for k, sub in enumerate(family.subproblems)]
    for name, point in family.special_points:
        lines.append(f"# {name} (base frame, q = 0): ({', '.join(sp.sstr(x) for x in point)})")
    if lock is not None:
        lines.append(f"# joint {lock + 1} ({chain.joints[lock].name}) is held at the input lock; lock_c, lock_s: its cosine and sine")
    lines.append("# target0..target15: the tool pose T, row-major; RG, tG: the motion T M^-1 the joints make (M = T(0));")
    lines.append("# NAME_x, NAME_y: the atan2 arguments of angle NAME; _disc: a discriminant (clamped at 0);")
    lines.append("# _ls, _sg: its least-squares and singular flags (0/1)")
    steps, rename = _readable(ik.steps, list(ik.Q) + list(ik.flags))
    lines.append(f"# {len(steps)} steps, in order:")
    for symbol, expr in steps:
        lines.append(f"{_render(symbol, step_fmt)} = {_render(expr, step_fmt)}")
    lines.append("")
    lines.append(f"# Q: {S} candidates (rows) x {N} joints ({', '.join(chain.coordinates)}); flags: 1 least squares + 2 singular")
    for r in range(S):
        row = ", ".join(_render(ik.Q[r, c].xreplace(rename), step_fmt) for c in range(N))
        lines.append(f"Q[{r}] = ({row});  flags[{r}] = {_render(ik.flags[r].xreplace(rename), step_fmt)}")
    lines.append("")
    return "\n".join(lines)
