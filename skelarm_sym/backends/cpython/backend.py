"""CPython extension backend: ``{prefix}.ext.c``, a CPython extension module beside the emitted C.

Calling an emitted function from Python through ctypes costs tens of microseconds of argument
conversion for a function that runs in a fraction of one. The extension module (the Python and NumPy C
APIs) has one fast entry per function for the common case of one configuration: exactly the function's
inputs, positional, each array a C-contiguous, aligned, native-order NumPy array of the module's real
type and of the right length (a float64 array for double code; other C-contiguous buffers of that type
are read through the buffer protocol), each scalar a Python float or int, every value inside its domain
(finite, nonnegative, positive). It then allocates the outputs (``PyArray_SimpleNew``, no Python-level
call), calls the single-configuration C function and returns them as the ctypes wrapper would. Anything else (keywords, a wrong number of arguments, other
dtypes, lists, batches, a value outside its domain) returns ``NotImplemented`` with no exception set, and
the Python wrapper (:class:`skelarm_sym.wrapper.CompiledArm`) takes its ordinary path: the same checks,
the same messages, the same ``TypeError`` naming the signature.

``{prefix}.ext.c`` includes ``{prefix}.c``: the C and its extension are one translation unit and one
shared library, which ctypes (batches, solvers) and the import system (the extension) both load. The
file is named with a dot (``arm3.ext.c``) so that it can never be taken for the C of another prefix
(``robot_ext.c`` is the C of the prefix ``robot_ext``; prefixes have no dots).
"""

from __future__ import annotations

from ...ir.nodes import Function, Module, Type
from ..text import c_comment

LANGUAGE = "cpython"
EXTENSION_SUFFIX = ".ext.c"  # skelarm_sym.build.EXTENSION_SUFFIX, which compiles it
FILE_SUFFIXES = (".h", ".c", EXTENSION_SUFFIX)
DOMAINS = {"": 0, "finite": 1, "nonnegative": 2, "positive": 3}
"""The domain codes the extension's checks take (the argument's ``domain``; see ``wrapper._check_domain``)."""


def module_name(prefix: str) -> str:
    """The extension module's name (its init function is ``PyInit_{name}``)."""
    return f"{prefix}_ext"


def _outputs(f: Function, split: bool = False) -> list[dict]:
    """Each output's name, dimensions (``[]``: a 0-d array), whether it holds C ints, and (``split``: a
    procedure's outputs after the first that have ``fields``) ``numbers``, how many Python numbers it is
    returned as instead of an array (``0``: an array), and ``position``, its first place in the returned
    tuple after the status."""
    out, position = [], 1
    for index, o in enumerate(f.outputs):
        numbers = o.size if split and index and o.fields else 0
        if numbers and len(o.fields) != numbers:
            raise ValueError(f"{f.name}: output {o.name} has {numbers} elements and {len(o.fields)} field names")
        out.append({"name": o.name, "dims": list(o.shape), "int": o.type is Type.INT, "numbers": numbers,
                    "fields": list(o.fields), "position": position})
        position += numbers or 1
    return out


def function_context(f: Function) -> dict:
    """A straight-line function's entry: arrays (1-D, or a pose 4 x 4: :data:`~skelarm_sym.derive.core.MATRIX_INPUTS`)
    and real scalars in; real arrays out."""
    from ...derive.core import matrix_shape

    arrays = [a for a in f.inputs if not a.is_scalar]
    inputs = []
    for position, a in enumerate(f.inputs):
        matrix = None if a.is_scalar else matrix_shape(a.name, a.size)
        rows = matrix[0] if matrix is not None else 0
        inputs.append({
            "name": a.name, "position": position, "size": a.size, "scalar": a.is_scalar, "rows": rows,
            "domain": DOMAINS[a.domain], "buffer": None if a.is_scalar else arrays.index(a),
        })
    return {"name": f.name, "inputs": inputs, "arrays": len(arrays), "outputs": _outputs(f)}


def solver_context(f: Function) -> dict:
    """A public procedure's entry: arrays (1-D, or a matrix given as its rows: ``rows``), real scalars,
    counts (C ints in 0..INT_MAX); outputs of the real type or C int; it returns ``(status, *outputs)``
    with the outputs after the first that have ``fields`` as Python numbers, one per field: the record's
    fields in order but the status name (``wrapper.CompiledArm._fast_solver`` adds it)."""
    arrays = [a for a in f.inputs if not a.is_scalar]
    inputs = []
    for position, a in enumerate(f.inputs):
        kind = ("count" if a.type is Type.INT else "real") if a.is_scalar else "array"
        inputs.append({
            "name": a.name, "position": position, "size": a.size, "kind": kind, "domain": DOMAINS[a.domain],
            "rows": a.shape[0] if len(a.shape) == 2 else 0, "buffer": arrays.index(a) if kind == "array" else None,
        })
    outputs = _outputs(f, split=True)
    return {"name": f.name, "inputs": inputs, "arrays": len(arrays), "outputs": outputs, "status": f.returns is Type.INT,
            "tuple_size": 1 + sum(o["numbers"] or 1 for o in outputs)}


def context(module: Module) -> dict:
    ctype = "double" if module.precision == "double" else "float"
    functions = [function_context(f) for f in module.functions if f.kind == "straight"]
    solvers = [solver_context(f) for f in module.functions if f.kind == "procedure"]
    return {
        "prefix": module.prefix,
        "P": module.prefix.upper(),
        "module": module_name(module.prefix),
        "notes": [c_comment(line) for line in module.notes],
        "T": ctype,
        "format": "d" if ctype == "double" else "f",
        "npy_type": "NPY_DOUBLE" if ctype == "double" else "NPY_FLOAT",
        "functions": functions,
        "solvers": solvers,
        "uses_arrays": any(a["buffer"] is not None for f in [*functions, *solvers] for a in f["inputs"]),
        "uses_scalars": (any(a["scalar"] for f in functions for a in f["inputs"])
                         or any(a["kind"] == "real" for f in solvers for a in f["inputs"])),
        "uses_counts": any(a["kind"] == "count" for f in solvers for a in f["inputs"]),
    }


def render_extension(module: Module, stamp: str) -> str:
    """The text of ``{prefix}.ext.c``."""
    from ..templating import render_template

    return render_template("cpython/module.c.j2", stamp=stamp, **context(module))


def render(module: Module, stamp: str) -> dict[str, str]:
    """``{suffix: text}``: the C backend's header and source, and the extension."""
    from ..c import render as render_c

    return render_c(module, stamp) | {EXTENSION_SUFFIX: render_extension(module, stamp)}
