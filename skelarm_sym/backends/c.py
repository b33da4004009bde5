"""C99 backend: printer, precision table and the context of ``c_header.h.j2``/``c_source.c.j2``.

Emitted functions take caller-owned arrays (row-major), allocate nothing and use
no globals. Sines and cosines are evaluated in one loop over small arrays; on
GCC with glibc (x86-64) ``sin``/``cos`` are declared with the ``simd`` attribute
so that loop calls glibc's vector math (libmvec, found through plain ``-lm``).
Other compilers get the same loop with plain calls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter

from ..program import Program
from .common import ANGLES, COSINES, IK_SETTINGS, IK_STATUS, SINES, ArrayPrinterMixin, MemoPrinter, pad, render_template, storage_names

LANGUAGE = "c"
FILE_SUFFIXES = (".h", ".c")
SIMD_LANES = 8
"""Trigonometric arrays are padded to a multiple of this (AVX-512 doubles) so loops vectorise whole."""
FOLD_UP_TO = 4
"""A single call waits for the latency of each vector math call, not for its width, so few
angles are evaluated with as few calls as possible: one angle by a scalar (sincos) pair;
two by one 4-wide ``sin`` over ``(a + pi/2, a)`` (cos(a) = sin(a + pi/2)); three or four
(padded to four) by two 4-wide ``sin`` calls. Measured here this about halves a 2- or
4-link kinematics call. The price is the rounding of ``a + pi/2``: an absolute error of
about ``|a| * 1e-16`` in those cosines. Without vector math the helpers call plain
``cos``/``sin``."""
BLOCK_ANGLES = 512
"""Batch functions evaluate the trigonometry of up to this many angles (several configurations) at once."""
SOA_BLOCKS = (32, 16, 8)
"""Configurations per block of the vectorised batch path, largest first (multiples of the SIMD width)."""
SOA_BYTES = 32 * 1024
"""Largest stack a vectorised batch block may use; functions of larger arms use the per-configuration path."""


@dataclass(frozen=True)
class CPrecision:
    """Everything that changes between ``double`` and ``float`` code."""

    ctype: str
    suffix: str
    sin: str
    cos: str
    sqrt: str

    def literal(self, value: float) -> str:
        """A C literal of this precision for ``value``."""
        text = repr(float(value)) if self.ctype == "double" else str(np.float32(value))
        if not any(ch in text for ch in ".en"):
            text += ".0"
        return text + self.suffix


PRECISIONS = {
    "double": CPrecision("double", "", "sin", "cos", "sqrt"),
    "float": CPrecision("float", "f", "sinf", "cosf", "sqrtf"),
}


class CArrayPrinter(ArrayPrinterMixin, C99CodePrinter):
    """C99 printer that writes each symbol as its array element or local, in one precision."""

    def __init__(self, names: dict[sp.Symbol, str], precision: CPrecision) -> None:
        super().__init__(names)
        self._precision = precision
        self.sqrt_name = precision.sqrt

    def literal(self, value: float) -> str:
        return self._precision.literal(value)


def _folded_size(count: int) -> int:
    """Angle slots for few angles: 1 (scalar sincos), 2 (one 4-wide call) or 4 (two 4-wide calls)."""
    return count if count <= 2 else 4


def trig_mode(size: int) -> str:
    """How the helper for ``size`` angle slots evaluates them (see ``FOLD_UP_TO``)."""
    return {1: "scalar", 2: "pair", 4: "quad"}.get(size, "vector") if size <= FOLD_UP_TO else "vector"


def _params(args, ctype: str, const: bool) -> list[str]:
    qualifier = "const " if const else ""
    return [f"{ctype} {a.name}" if a.is_scalar else f"{qualifier}{ctype} {a.name}[{a.size}]" for a in args]


def constant_name(prefix: str, name: str) -> str:
    """The C macro of constant ``name`` (``ARM3_RANK_TOL``)."""
    return f"{prefix.upper()}_{name}"


def function_context(program: Program, precision: CPrecision, prefix: str, shared: frozenset[str], memo: MemoPrinter | None = None) -> dict:
    """What the templates need to lay out one program as C functions."""
    names = storage_names(program, constant=constant_name(prefix, "{name}"))
    printer = CArrayPrinter(names, precision)
    memo = memo or MemoPrinter()
    ctype = precision.ctype
    angle_set = set(program.angles)

    def statement(symbol: sp.Symbol, expr: sp.Expr) -> str:
        target = names[symbol]
        code = memo(printer, names, expr)
        if symbol in angle_set:
            return f"{target} = {code};"
        kind = "int" if isinstance(expr, sp.core.relational.Relational) else ctype
        return f"const {kind} {target} = {code};"

    def used_inputs(statements_exprs) -> list:
        free = set().union(*(e.free_symbols for e in statements_exprs)) if statements_exprs else set()
        return [a for a in program.inputs if free & set(a.elements)]

    pre_exprs = [rhs for _, rhs in program.pre]
    post_exprs = [rhs for _, rhs in program.post] + [e for o in program.outputs for e in o.elements]
    post_free = set().union(*(e.free_symbols for e in post_exprs)) if post_exprs else set()
    count = len(program.angles)
    padded = _folded_size(count) if count <= FOLD_UP_TO else pad(count, SIMD_LANES)
    block = max(1, BLOCK_ANGLES // padded) if count else 1
    per_config = (
        sum(a.size for a in program.inputs if a.name not in shared)
        + sum(len(o.elements) for o in program.outputs)
        + 3 * count
    )
    itemsize = 8 if ctype == "double" else 4
    soa = next((b for b in SOA_BLOCKS if b * per_config * itemsize <= SOA_BYTES), None)
    return {
        "name": f"{prefix}_{program.name}",
        "summary": program.summary,
        "inputs": [
            {"name": a.name, "size": a.size, "shared": a.name in shared, "scalar": a.is_scalar,
             "param": _params([a], ctype, True)[0]}
            for a in program.inputs
        ],
        "outputs": [{"name": o.name, "size": len(o.elements), "shape": o.shape} for o in program.outputs],
        "params": _params(program.inputs, ctype, True) + _params(program.outputs, ctype, False),
        "pre_inputs": [a.name for a in used_inputs(pre_exprs)],
        "post_inputs": [a.name for a in used_inputs(post_exprs)],
        "post_uses": {
            "ang": bool(post_free & angle_set),
            "cs": bool(post_free & set(program.cos)),
            "sn": bool(post_free & set(program.sin)),
        },
        "pre": [statement(s, e) for s, e in program.pre],
        "post": [statement(s, e) for s, e in program.post],
        "stores": [f"{o.name}[{i}] = {memo(printer, names, e)};" for o in program.outputs for i, e in enumerate(o.elements)],
        "angle_count": count,
        "padded": padded,
        "block": block,
        "soa": soa,
        "ops": program.ops.as_dict(),
    }


def render(derivation, programs: list[Program], options) -> dict[str, str]:
    """Header and source text for ``programs``; keys are the file suffixes."""
    precision = PRECISIONS[options.precision]
    shared = frozenset(derivation.parameters)
    memo = MemoPrinter()
    functions = [function_context(p, precision, options.prefix, shared, memo) for p in programs]
    sizes = {f["padded"] for f in functions if f["padded"]}
    sizes |= {f["angle_count"] * f["soa"] if f["soa"] else f["padded"] * f["block"] for f in functions if f["padded"]}
    trig_sizes = [
        {"size": size, "mode": trig_mode(size)}
        for size in sorted(sizes)
    ]
    constants = {c.name: c for p in programs for c in p.constants}
    context = {
        "prefix": options.prefix,
        "guard": options.prefix.upper() + "_H",
        "header_lines": options.header_lines,
        "precision": precision,
        "functions": functions,
        "trig_sizes": trig_sizes,
        "half_pi": precision.literal(1.5707963267948966),
        "constants": [
            {"macro": constant_name(options.prefix, c.name), "value": precision.literal(c.values[options.precision]), "doc": c.doc}
            for c in constants.values()
        ],
        "ik": ik_context(programs, precision, options.prefix, derivation.domains),
        "arrays": {"ang": ANGLES, "cs": COSINES, "sn": SINES},
    }
    return {
        ".h": render_template("c_header.h.j2", **context),
        ".c": render_template("c_source.c.j2", **context),
    }


def ik_context(programs: list[Program], precision: CPrecision, prefix: str, domains: dict[str, str]) -> dict | None:
    """The iterative IK solver's layout, when the programs include ``position`` and ``ik_step``."""
    by_name = {p.name: p for p in programs}
    if "position" not in by_name or "ik_step" not in by_name:
        return None
    step, position = by_name["ik_step"], by_name["position"]
    ctype = precision.ctype
    n = next(a.size for a in step.inputs if a.name == "q")
    target = next(a for a in step.inputs if a.name == "target")
    others = [a for a in step.inputs if a.name != "q"]
    settings = IK_SETTINGS[precision.ctype]
    return {
        "name": f"{prefix}_ik_solve",
        "n": n,
        "target_size": target.size,
        "params": [f"const {ctype} q0[{n}]"] + _params(others, ctype, True)
        + [f"{ctype} tol", "int max_iter", f"{ctype} q[{n}]", f"{ctype} *error", "int *iterations"],
        "lambda": next((a.name for a in others if a.is_scalar), None),
        "checks": [{"name": a.name, "size": a.size} for a in others if not a.is_scalar and domains.get(a.name)],
        "step_call": f"{prefix}_ik_step(" + ", ".join("mu" if a.is_scalar else a.name for a in step.inputs) + ", q_next)",
        "position_call": f"{prefix}_position(" + ", ".join("trial" if a.name == "q" else a.name for a in position.inputs) + ", p)",
        "status": [{"macro": f"{prefix.upper()}_IK_{s}", "value": i} for i, s in enumerate(IK_STATUS)],
        "halvings": settings["halvings"],
        "error_damping": precision.literal(settings["error_damping"]),
        "shrink": precision.literal(settings["shrink"]),
        "c_min": precision.literal(settings["c_min"]),
        "c_max": precision.literal(settings["c_max"]),
        "two": precision.literal(2.0),
        "stall": precision.literal(settings["stall"]),
        "one": precision.literal(1.0),
        "half": precision.literal(0.5),
        "zero": precision.literal(0.0),
        "sqrt": precision.sqrt,
    }
