"""Readable closed forms of a 3-D chain: the named intermediate steps, then the outputs in their terms.

A 6-joint robot's fully expanded Jacobian runs to pages; written as the derivation's steps
(rotations, origins, axis cross products, velocity sums) each line stays short and they read
in order. The expanded form is printed on request (``expand=True``) or for chains of up to
``EXPAND_UP_TO`` joints.
"""

from __future__ import annotations

import re

import sympy as sp

from ...errors import InputError
from ...show import FORMATS
from ...show import render as _render
from .derive import ChainDerivation

_TAG = r"(?:[a-z]{1,2}\d+_*)?"
"""The tag a step's name may carry between its letters and its joint number (a candidate's, as ``rc0_7x``)."""


def _named(*prefixes: str) -> str:
    return rf"(?:{'|'.join(prefixes)}){_TAG}\d"


LEGEND = (
    (r"th\d", "th_k: the angle of the frames after joint k about their segment's z axis (q_k, or a sum of q along "
               "consecutive parallel axes, which share one frame)"),
    (r"[cs]\d", "c_k, s_k: cosine and sine of th_k (or of q_k)"),
    (_named("G", "Gy", "Gz", "H"), "G<k>_<ij>, Gy, Gz, H: entry (row i, column j; 0-based) of a frame's rotation in "
                                  "base axes after joint k turned it (Gy, Gz: with columns scaled; docs/robots.md)"),
    (_named("F", "Fy", "Fz"), "F<s>_<ij>: entry (i, j) of the rotation of segment s's frame in base axes"),
    (_named("B"), "B<s>_<ij>: entry (i, j) of the rotation from segment s's frame to the tool frame"),
    (r"Ge", "Ge_<ij>: entry (i, j) of the last frame's rotation after the last joint (R before the tool's constant "
            "rotation)"),
    (r"Rx", "Rx<d><a>: a rotation row as the cross product of the other two rows (d: the row, a: x, y, z the column)"),
    (_named("W", "Wm"), "W<k>x, W<k>y, W<k>z: the tool position relative to joint k's origin, p - o_k, in the axes of "
                        "joint k's segment frame, built from the tool to the base (Horner's rule)"),
    (r"p[esmb]", "pe, ps, pm, pb: the tool position p in base axes (Horner's rule from the tool, or summed joint by "
                 "joint)"),
    (_named("r"), "r<k>: the tool position relative to joint k's origin, p - o_k, in base axes"),
    (_named("Jv", "Jb", "Jn"), "Jv<k>, Jb, Jn: the linear part of Jacobian column k (z_k x (p - o_k), or z_k for a "
                               "slide) in base axes"),
    (_named("Jw"), "Jw<k>: the angular part of Jacobian column k (z_k, or 0 for a slide) in base axes"),
    (_named("Jtv", "Jtw"), "Jtv<k>, Jtw<k>: Jacobian column k in the tool's axes (J_tool)"),
    (_named("w"), "w<k>: the angular velocity of the frame after joint k, in base axes"),
    (_named("u"), "u<k>: the sum of Jv_j dq_j over joints j >= k (the tool's linear velocity from joints k..n), in "
                  "base axes"),
    (_named("dJv", "dJw"), "dJv<k>, dJw<k>: column k of dJ/dt (linear, angular part), in base axes"),
    (r"neg_", "neg_<name>: minus <name>, a step of its own where several outputs use it"),
)
"""Names of ``show``'s intermediate steps and what they stand for: the legend lists those a listing uses
(by the pattern matched at the start of a step's name, ``<k>`` a joint, ``<s>`` a segment of parallel axes,
both 1-based)."""

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


def legend(names: list[str]) -> list[str]:
    """The :data:`LEGEND` lines whose names occur in ``names`` (step names as ``show`` prints them), in order."""
    return [text for pattern, text in LEGEND if any(re.match(pattern, name) for name in names)]


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
    lines.append(f"# {len(steps)} intermediate steps, in order; their names:")
    lines += [f"#   {text}" for text in legend([symbol.name for symbol, _ in steps])]
    lines.append("# Frames: every vector is in base axes unless its name says otherwise; T is the tool pose in the base frame.")
    for symbol, expr in steps:
        lines.append(f"{_render(symbol, 'text' if fmt == 'pretty' else fmt)} = {_render(expr, 'text' if fmt == 'pretty' else fmt)}")
    lines.append("")
    for name, matrix in matrices.items():
        lines += [f"{name} =", _render(matrix.xreplace(rename), fmt, verbatim=True), ""]
    return "\n".join(lines)


def show_ik(chain, lock: int | None = None, fmt: str = "pretty") -> str:
    """The closed-form IK of ``chain`` (``lock``: the 0-based index of a held joint): its family and chain of
    subproblems, the special points, then every step in order and the candidates ``Q`` and ``flags`` in their
    terms (the code ``ik_candidates`` is lowered from). InputError (the classifier's one line) when the chain
    is in no closed-form family."""
    from ...closed_ik import classify, derive_ik_all
    from ...closed_ik.derive import STEP_TOLERANCES

    if fmt not in FORMATS:
        raise InputError(f"unknown --format {fmt!r}; choose from {', '.join(FORMATS)}")
    family = classify(chain, lock)
    ik = derive_ik_all(chain, lock, atan2="libm")  # the emitted code writes atan2 in arithmetic; here it reads as atan2
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
    used = {str(x) for _, expr in steps for x in expr.free_symbols}
    for constant in STEP_TOLERANCES:
        if constant.symbol.name in used:
            lines.append(f"# {constant.symbol.name} = {constant.values['double']:g} (float: {constant.values['float']:g}): "
                         f"{constant.doc}")
    lines.append("# atan2 is printed as the call; the emitted code computes it in arithmetic (within 2 ulp, no call)")
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
