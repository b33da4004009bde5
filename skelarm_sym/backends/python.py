"""Python/NumPy backend: printer and the context of ``python_module.py.j2``.

The emitted module depends on NumPy only. Every function broadcasts over
leading batch dimensions: inputs of shape ``(..., size)``, outputs of shape
``(..., *shape)``, element k read and written as ``x[..., k]`` in the caller's layout.
The arithmetic runs on whole arrays of configurations, in slices of ``CHUNK`` so that
temporaries stay in cache, and the trigonometry in one ``np.cos``/``np.sin`` call each.
"""

from __future__ import annotations

import keyword

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from ..program import Program
from .common import ANGLES, COSINES, IK_SETTINGS, SINES, ArrayPrinterMixin, MemoPrinter, render_template, storage_names

LANGUAGE = "python"
FILE_SUFFIXES = (".py",)
DTYPES = {"double": "np.float64", "float": "np.float32"}


def identifier(name: str) -> str:
    """A legal Python argument name for input ``name`` (keywords get a trailing ``_``: ``lambda_``)."""
    return name + "_" if keyword.iskeyword(name) else name


class PythonArrayPrinter(ArrayPrinterMixin, PythonCodePrinter):
    """Python printer that writes each symbol as its array element or local."""

    sqrt_name = "np.sqrt"
    select_form = "np.where({cond}, {then}, {otherwise})"

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__(names)

    def literal(self, value: float) -> str:
        return repr(float(value))


def function_context(program: Program, domains: dict[str, str], memo: MemoPrinter | None = None) -> dict:
    """What the template needs to lay out one program as a NumPy function."""
    names = storage_names(program, element="{name}[..., {index}]", identifier=identifier)
    printer = PythonArrayPrinter(names)
    memo = memo or MemoPrinter()
    exprs = [e for _, e in program.pre + program.post] + [e for o in program.outputs for e in o.elements]
    return {
        "name": program.name,
        "summary": program.summary,
        "args": [identifier(a.name) for a in program.inputs],
        "inputs": [
            {"name": a.name, "py": identifier(a.name), "size": a.size, "domain": domains.get(a.name, "")}
            for a in program.inputs if not a.is_scalar
        ],
        "scalars": [
            {"name": a.name, "py": identifier(a.name), "domain": domains.get(a.name, "")}
            for a in program.inputs if a.is_scalar
        ],
        "quiet": any(e.has(sp.Piecewise) for e in exprs),
        "outputs": [{"name": o.name, "size": len(o.elements), "shape": o.shape} for o in program.outputs],
        "pre": [f"{names[s]} = {memo(printer, names, e)}" for s, e in program.pre],
        "post": [f"{names[s]} = {memo(printer, names, e)}" for s, e in program.post],
        "stores": [
            [f"{o.name}[..., {i}] = {memo(printer, names, e)}" for i, e in enumerate(o.elements)] for o in program.outputs
        ],
        "angle_count": len(program.angles),
        "ops": program.ops.as_dict(),
    }


def render(derivation, programs: list[Program], options) -> dict[str, str]:
    """Module text for ``programs``; the key is the file suffix."""
    memo = MemoPrinter()
    functions = [function_context(p, derivation.domains, memo) for p in programs]
    constants = {c.name: c for p in programs for c in p.constants}
    by_name = {f["name"]: f for f in functions}
    context = {
        "prefix": options.prefix,
        "header_lines": options.header_lines,
        "dtype": DTYPES[options.precision],
        "functions": functions,
        "arrays": {"ang": ANGLES, "cs": COSINES, "sn": SINES},
        "constants": [{"name": c.name, "value": repr(c.values[options.precision]), "doc": c.doc} for c in constants.values()],
        "ik": _ik_context(by_name, options.precision, getattr(derivation.model, "lengths", None)),
        "tables": [
            {"name": t.name, "doc": t.doc,
             "values": [repr(float(v)) if v is not None else ("np.inf" if t.sign > 0 else "-np.inf") for v in t.values]}
            for t in derivation.tables
        ],
    }
    return {".py": render_template("python_module.py.j2", **context)}


def _ik_context(functions: dict[str, dict], precision: str, lengths=None) -> dict | None:
    """The iterative IK solver's layout, when the module has ``position`` and ``ik_step``."""
    if "position" not in functions or "ik_step" not in functions:
        return None
    step = functions["ik_step"]
    damping = step["scalars"][0]["py"] if step["scalars"] else None
    settings = IK_SETTINGS[precision]
    return {
        "params": [a for a in step["args"] if a != "q"],
        "checks": [a for a in step["inputs"] if a["name"] != "q" and a["domain"]],
        "tol": repr(settings["tol"]),
        "reach": repr(float(sum(lengths))) if lengths else "1.0",
        "step_args": ["mu" if a == damping else a for a in step["args"]],
        "position_args": ["trial" if a == "q" else a for a in functions["position"]["args"]],
        "lambda": damping,
        "halvings": settings["halvings"],
        "error_damping": repr(settings["error_damping"]),
        "shrink": repr(settings["shrink"]),
        "c_min": repr(settings["c_min"]),
        "c_max": repr(settings["c_max"]),
        "stall": repr(settings["stall"]),
        "probe": repr(settings["probe"]),
    }
