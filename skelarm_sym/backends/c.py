"""C99 backend: printer, precision table and the context of ``c_header.h.j2``/``c_source.c.j2``.

Emitted functions take caller-owned arrays (row-major), allocate nothing and use
no globals. Sines and cosines are evaluated in one loop over small arrays; on
GCC with glibc (x86-64) ``sin``/``cos`` are declared with the ``simd`` attribute
so that loop calls glibc's vector math (libmvec, found through plain ``-lm``).
Other compilers get the same loop with plain calls.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter

from ..derive.core import UNBOUNDED
from ..program import Program
from . import c_ik
from .common import ANGLES, COSINES, IK_SETTINGS, IK_STATUS, SINES, ArrayPrinterMixin, MemoPrinter, pad, render_template, storage_names

LANGUAGE = "c"
FILE_SUFFIXES = (".h", ".c")
SIMD_LANES = 8
"""Trigonometric arrays are padded to a multiple of this (AVX-512 doubles) so loops vectorise whole."""
SHORT_LOOP = {"double": 4, "float": 8}
"""A single call with at most this many angles pads them to this (one 256-bit vector), longer
ones to a multiple of ``SIMD_LANES`` like the batches, whose loops are multiples of ``SIMD_LANES``
long. Single calls and batches then evaluate the same ``cos``/``sin`` of the same angles in loops
that GCC vectorises alike, so with one set of compiler flags both call the same vector routine
and a single call equals its batch result bit for bit (tested with -O2, -O2 -march=native and
-O0). Measured with GCC 12: loops of 2 angles are left scalar, and loops of 4 floats get a
narrower vector routine than the batch's, which breaks that equality. Earlier versions also
folded ``cos(a) = sin(a + pi/2)`` for few angles: the rounding of ``a + pi/2`` made those cosines
wrong by about ``|a|`` ulps (3e-5 relative at |a| = 100 in float) and differ from the batch."""
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
    sincos: str = "sincos"

    def literal(self, value: float) -> str:
        """A C literal of this precision for ``value``."""
        text = repr(float(value)) if self.ctype == "double" else str(np.float32(value))
        if not any(ch in text for ch in ".en"):
            text += ".0"
        return text + self.suffix


PRECISIONS = {
    "double": CPrecision("double", "", "sin", "cos", "sqrt"),
    "float": CPrecision("float", "f", "sinf", "cosf", "sqrtf", "sincosf"),
}


class CArrayPrinter(ArrayPrinterMixin, C99CodePrinter):
    """C99 printer that writes each symbol as its array element or local, in one precision.

    Every division by a computed value is printed with a safe denominator, ``x/(d != 0 ? d : 1)``:
    the straight-line program evaluates both sides of each select (``cond ? a : b``), and the
    quotients of the side not taken must not divide by zero (a trap under
    ``feenableexcept(FE_DIVBYZERO)``, an infinity times zero giving NaN otherwise). Where ``d`` is a
    Gram quantity of the Jacobian (a norm, a determinant) that is exactly zero, its numerator is
    zero too, so the quotient is the pseudo-inverse's zero. Divisions by an input (the track of
    the differential drive, which the header requires to be positive) print plainly.
    """

    def __init__(self, names: dict[sp.Symbol, str], precision: CPrecision, inputs: frozenset = frozenset()) -> None:
        super().__init__(names)
        self._precision = precision
        self._inputs = inputs
        self.sqrt_name = precision.sqrt

    def literal(self, value: float) -> str:
        return self._precision.literal(value)

    def _denominator(self, den: sp.Expr) -> str:
        """``den`` as a divisor: guarded unless it is a positive number or an input."""
        text = self.parenthesize(den, sp.printing.precedence.PRECEDENCE["Mul"], strict=True)
        if (den.is_Number and den.is_positive) or den in self._inputs:
            return text
        plain = self._print(den)
        return f"({plain} != {self.literal(0.0)} ? {plain} : {self.literal(1.0)})"

    def _print_Pow(self, expr: sp.Pow, rational: bool = False) -> str:
        base, exp = expr.args
        if exp.is_Rational and exp.is_negative:
            return f"{self.literal(1.0)}/{self._denominator(sp.Pow(base, -exp))}"
        return super()._print_Pow(expr, rational)

    def _print_Mul(self, expr: sp.Mul) -> str:
        factors = sp.Mul.make_args(expr)
        den = [f for f in factors if f.is_Pow and f.exp.is_Rational and f.exp.is_negative]
        if not den:
            return super()._print_Mul(expr)
        num = sp.Mul(*[f for f in factors if f not in den])
        num_text = self.parenthesize(num, sp.printing.precedence.PRECEDENCE["Mul"])
        return f"{num_text}/{self._denominator(sp.Mul(*[sp.Pow(f.base, -f.exp) for f in den]))}"


def padded_size(count: int, ctype: str) -> int:
    """Angle slots of a single call for ``count`` angles (see ``SHORT_LOOP``)."""
    if not count:
        return 0
    return SHORT_LOOP[ctype] if count <= SHORT_LOOP[ctype] else pad(count, SIMD_LANES)


def _params(args, ctype: str, const: bool) -> list[str]:
    qualifier = "const " if const else ""
    return [f"{ctype} {a.name}" if a.is_scalar else f"{qualifier}{ctype} {a.name}[{a.size}]" for a in args]


def constant_name(prefix: str, name: str) -> str:
    """The C macro of constant ``name`` (``ARM3_RANK_TOL``)."""
    return f"{prefix.upper()}_{name}"


def function_context(program: Program, precision: CPrecision, prefix: str, shared: frozenset[str], memo: MemoPrinter | None = None) -> dict:
    """What the templates need to lay out one program as C functions."""
    names = storage_names(program, constant=constant_name(prefix, "{name}"))
    printer = CArrayPrinter(names, precision, frozenset(e for a in program.inputs for e in a.elements))
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
    padded = padded_size(count, ctype)
    block = max(1, BLOCK_ANGLES // padded) if count else 1
    per_config = (
        sum(a.size for a in program.inputs if a.name not in shared)
        + sum(len(o.elements) for o in program.outputs)
        + 3 * count
    )
    itemsize = 8 if ctype == "double" else 4
    soa = next((b for b in SOA_BLOCKS if b * per_config * itemsize <= SOA_BYTES), None)
    temporaries = len(program.pre) + len(program.post)
    single_stack = itemsize * (3 * padded + temporaries)
    if soa:
        batch_stack = itemsize * (soa * per_config + temporaries + per_config)
    else:
        batch_stack = itemsize * (3 * padded * block + temporaries)
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
        "stack_bytes": single_stack,
        "stack": stack_text(single_stack),
        "batch_stack": stack_text(batch_stack),
    }


def stack_text(size: int) -> str:
    """A stack size for the header: bytes, or KB above 4 KB (an estimate from the array sizes and
    the number of temporaries, all of which an unoptimised build keeps on the stack)."""
    return f"{size} bytes" if size < 4096 else f"{-(-size // 1024)} KB"


def trig_helpers(functions: list[dict]) -> list[dict]:
    """The trigonometry helpers the functions call, by size, each with the condition under which it is
    used: single calls and per-configuration batches always; the transposed block path of a batch
    (``soa``) only with GCC's vector math, its per-configuration fallback only without. ``guard`` is
    ``""`` (always), ``"vector"`` or ``"scalar"``, so that no static helper is left unused."""
    always, vector, scalar = set(), set(), set()
    for f in functions:
        if not f["padded"]:
            continue
        always.add(f["padded"])
        plain = f["padded"] * f["block"]
        if f["soa"]:
            vector.add(f["angle_count"] * f["soa"])
            scalar.add(plain)
        else:
            always.add(plain)
    helpers = []
    for size in sorted(always | vector | scalar):
        guard = "" if size in always or (size in vector and size in scalar) else ("vector" if size in vector else "scalar")
        helpers.append({"size": size, "guard": guard})
    return helpers


def render(derivation, programs: list[Program], options) -> dict[str, str]:
    """Header and source text for ``programs``; keys are the file suffixes."""
    precision = PRECISIONS[options.precision]
    shared = frozenset(derivation.parameters)
    memo = MemoPrinter()
    functions = [function_context(p, precision, options.prefix, shared, memo) for p in programs]
    trig_sizes = trig_helpers(functions)
    constants = {c.name: c for p in programs for c in p.constants}
    context = {
        "prefix": options.prefix,
        "guard": options.prefix.upper() + "_H",
        "header_lines": options.header_lines,
        "precision": precision,
        "functions": functions,
        "trig_sizes": trig_sizes,
        "constants": [
            {"macro": constant_name(options.prefix, c.name), "value": precision.literal(c.values[options.precision]), "doc": c.doc}
            for c in constants.values()
        ],
        "ik": ik_context(programs, precision, options.prefix, derivation.domains, functions),
        "chain_ik": c_ik.context(derivation, programs, precision, options.prefix),
        "arrays": {"ang": ANGLES, "cs": COSINES, "sn": SINES},
        "tables": [
            {"macro": constant_name(options.prefix, t.name), "doc": t.doc,
             "values": [precision.literal(v if v is not None else t.sign * UNBOUNDED[options.precision]) for v in t.values]}
            for t in derivation.tables
        ],
    }
    placeholder = "@STAMP@"
    texts = {suffix: render_template(name, stamp=placeholder, **context) for suffix, name in ((".h", "c_header.h.j2"), (".c", "c_source.c.j2"))}
    stamp = "0x" + hashlib.sha256((texts[".h"] + "\0" + texts[".c"]).encode()).hexdigest()[:8] + "UL"
    return {suffix: text.replace(placeholder, stamp) for suffix, text in texts.items()}


def ik_context(programs: list[Program], precision: CPrecision, prefix: str, domains: dict[str, str], functions: list[dict]) -> dict | None:
    """The iterative IK solver's layout, when the programs include ``position`` and ``ik_step``."""
    by_name = {p.name: p for p in programs}
    if "position" not in by_name or "ik_step" not in by_name:
        return None
    step, position = by_name["ik_step"], by_name["position"]
    ctype = precision.ctype
    itemsize = 8 if ctype == "double" else 4
    n = next(a.size for a in step.inputs if a.name == "q")
    target = next(a for a in step.inputs if a.name == "target")
    others = [a for a in step.inputs if a.name != "q"]
    settings = IK_SETTINGS[precision.ctype]
    params = [f"const {ctype} q0[{n}]"] + _params(others, ctype, True) + [f"{ctype} tol", "int max_iter", f"{ctype} q[{n}]"]
    position_others = [a for a in position.inputs if a.name != "q"]
    error_args = ["target"] + [a.name for a in position_others]
    return {
        "name": f"{prefix}_ik_solve",
        "n": n,
        "target_size": target.size,
        "params": params + [f"{ctype} *error", "int *iterations"],
        "params_nullable": params + [f"{ctype} *error", "int *iterations"],
        "run_args": ["q0"] + [a.name for a in others] + ["tol", "max_iter", "q"],
        "error_params": [f"const {ctype} trial[{n}]", f"const {ctype} target[{target.size}]"] + _params(position_others, ctype, True),
        "error_args": ", ".join(["trial", *error_args]),
        "error_args_q": ", ".join(["q", *error_args]),
        "probe": precision.literal(settings["probe"]),
        "probe_error_args": ", ".join(["probe", *error_args]),
        "error_args_next": ", ".join(["q_next", *error_args]),
        "probe_step_call": f"{prefix}_ik_step(" + ", ".join("mu" if a.is_scalar else "probe" if a.name == "q" else a.name for a in step.inputs) + ", q_next)",
        "tol": repr(settings["tol"]),
        "stack": stack_text(itemsize * (2 * n + target.size + 8) + max(f["stack_bytes"] for f in functions if f["name"] in (f"{prefix}_ik_step", f"{prefix}_position"))),
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
