"""Python/NumPy backend: printer and the context of ``python_module.py.j2``.

The emitted module depends on NumPy only. Every function broadcasts over
leading batch dimensions: inputs of shape ``(..., size)``, outputs of shape
``(..., *shape)``; the arithmetic runs on whole batch arrays (no Python loop over
the batch) and the trigonometry in one ``np.cos``/``np.sin`` call each.
"""

from __future__ import annotations

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from ..program import Program
from .common import ANGLES, COSINES, SINES, ArrayPrinterMixin, MemoPrinter, render_template, storage_names

LANGUAGE = "python"
FILE_SUFFIXES = (".py",)
DTYPES = {"double": "np.float64", "float": "np.float32"}


class PythonArrayPrinter(ArrayPrinterMixin, PythonCodePrinter):
    """Python printer that writes each symbol as its array element or local."""

    sqrt_name = "np.sqrt"

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__(names)

    def literal(self, value: float) -> str:
        return repr(float(value))


def function_context(program: Program, memo: MemoPrinter | None = None) -> dict:
    """What the template needs to lay out one program as a NumPy function."""
    names = storage_names(program)
    printer = PythonArrayPrinter(names)
    memo = memo or MemoPrinter()
    return {
        "name": program.name,
        "summary": program.summary,
        "inputs": [{"name": a.name, "size": a.size} for a in program.inputs],
        "outputs": [{"name": o.name, "size": len(o.elements), "shape": o.shape} for o in program.outputs],
        "pre": [f"{names[s]} = {memo(printer, names, e)}" for s, e in program.pre],
        "post": [f"{names[s]} = {memo(printer, names, e)}" for s, e in program.post],
        "stores": [
            [f"{o.name}[{i}] = {memo(printer, names, e)}" for i, e in enumerate(o.elements)] for o in program.outputs
        ],
        "angle_count": len(program.angles),
        "ops": program.ops.as_dict(),
    }


def render(derivation, programs: list[Program], options) -> dict[str, str]:
    """Module text for ``programs``; the key is the file suffix."""
    memo = MemoPrinter()
    context = {
        "prefix": options.prefix,
        "header_lines": options.header_lines,
        "dtype": DTYPES[options.precision],
        "functions": [function_context(p, memo) for p in programs],
        "arrays": {"ang": ANGLES, "cs": COSINES, "sn": SINES},
    }
    return {".py": render_template("python_module.py.j2", **context)}
