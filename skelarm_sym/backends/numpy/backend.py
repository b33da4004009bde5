"""NumPy backend: the context of ``templates/numpy/module.py.j2`` from an IR module.

The emitted module depends on NumPy only. Straight-line functions broadcast over leading batch
dimensions: inputs of shape ``(..., size)``, outputs ``(..., *shape)``, element k read and written as
``x[..., k]``; the arithmetic runs on whole arrays of configurations in slices of ``CHUNK`` so that
temporaries stay in cache, and each trigonometric block is one ``np.cos``/``np.sin`` call. Procedures
(the solvers) run one problem per call, statement by statement, calling the straight-line functions on
single configurations; each gets a public wrapper that checks its inputs, fills in the defaults and returns
a named tuple. Given a batch of problems (arrays ``(..., *shape)``), the wrapper runs the procedure's
masked form instead (:mod:`skelarm_sym.ir.predicate`, printed by :class:`..array_syntax.ProcedurePrinter`
with NumPy's names): every problem at once, one array per value over the problems, the straight-line
functions called on all of them through ``_<name>_on_lanes`` adapters.
"""

from __future__ import annotations

from ...ir.nodes import Function, Let, Module, Store, TrigBlock, Type, module_statuses
from ...ir.predicate import PCall, PFor, PGuard, PLoop, predicate
from ..text import py_string
from ..array_syntax import Dialect, ProcedurePrinter
from .printer import VECTOR_CALLS, PythonPrinter, identifier

LANGUAGE = "python"
FILE_SUFFIXES = (".py",)
DTYPES = {"double": "np.float64", "float": "np.float32"}
NUMPY = Dialect(where="np.where", calls=VECTOR_CALLS, int_dtype="np.int64", bool_dtype="np.bool_", cast="{x}.astype({dtype})")
"""NumPy's names for the masked (batched) form of the procedures."""


def _function_names(module: Module) -> dict[str, str]:
    return {f.name: (f"_{f.name}_core" if f.kind == "straight" else f"_{f.name}") for f in module.functions}


def straight_context(f: Function, calls: dict[str, str], printers: dict | None = None) -> dict:
    """A straight-line function as vectorised NumPy: its core (statements) and public signature.

    ``printers``: one printer per storage layout, shared by the functions of a module (their statements
    are shared objects, printed once)."""
    storage: dict[str, str] = {}
    blocks = [s for s in f.body if type(s) is TrigBlock]
    suffix = (lambda b: "") if len(blocks) == 1 else (lambda b: str(b))
    for b, block in enumerate(blocks):
        for k, (a, c, s) in enumerate(zip(block.angles, block.cos, block.sin)):
            storage[a.name] = f"ang{suffix(b)}[..., {k}]"
            storage[c.name] = f"cs{suffix(b)}[..., {k}]"
            storage[s.name] = f"sn{suffix(b)}[..., {k}]"
    printers = {} if printers is None else printers
    key = tuple(sorted(storage.items()))
    printer = printers.get(key)
    if printer is None:
        printer = printers[key] = PythonPrinter(True, storage, constant=lambda name: name, function_name=calls.get)
    first_output = f.outputs[0].name
    lines: list[str] = []
    b = 0
    for s in f.body:
        t = type(s)
        if t is TrigBlock:
            lines.append(f"cs{suffix(b)} = np.cos(ang{suffix(b)})")
            lines.append(f"sn{suffix(b)} = np.sin(ang{suffix(b)})")
            b += 1
            if b < len(blocks):
                lines.append(f"ang{suffix(b)} = np.empty({first_output}.shape[:-1] + ({len(blocks[b].angles)},), dtype=DTYPE)")
        elif t is Let:
            lines.append(f"{printer.name(s.var.name)} = {printer.expr(s.value)}")
        elif t is Store:
            lines.append(f"{s.output}[..., {s.index}] = {printer.expr(s.value)}")
    if blocks:
        lines.insert(0, f"ang{suffix(0)} = np.empty({first_output}.shape[:-1] + ({len(blocks[0].angles)},), dtype=DTYPE)")
    return {
        "name": f.name,
        "summary": f.summary,
        "args": [identifier(a.name) for a in f.inputs],
        "inputs": [{"name": a.name, "py": identifier(a.name), "size": a.size, "domain": a.domain} for a in f.inputs if not a.is_scalar],
        "scalars": [{"name": a.name, "py": identifier(a.name), "domain": a.domain} for a in f.inputs if a.is_scalar],
        "quiet": any("np.where" in line for line in lines),
        "outputs": [{"name": o.name, "size": o.size, "shape": o.shape} for o in f.outputs],
        "lines": lines,
        "ops": f.ops.as_dict(),
    }


def procedure_context(f: Function, calls: dict[str, str], statuses: dict[int, str]) -> dict:
    """A procedure or helper in scalar Python, plus (public procedures) its wrapper's checks and defaults."""
    printer = PythonPrinter(False, constant=lambda name: name, function_name=calls.get)
    body = printer.statements(f.body)
    defaults = PythonPrinter(False, constant=lambda name: name)
    batch_defaults = PythonPrinter(True, constant=lambda name: name)
    inputs = []
    for a in f.inputs:
        default = batch_default = None
        if a.default is not None:
            default = defaults.expr(a.default)
            batch_default = batch_defaults.expr(a.default)
        inputs.append({
            "name": a.name, "py": identifier(a.name), "size": a.size, "shape": a.shape, "scalar": a.is_scalar,
            "int": a.type is Type.INT, "domain": a.domain, "default": default, "batch_default": batch_default,
            "literal": default is not None and a.default.__class__.__name__ == "Const", "doc": py_string(a.doc),
        })
    outputs = [{"name": o.name, "py": identifier(o.name), "size": o.size, "shape": list(o.shape), "int": o.type is Type.INT,
                "fields": list(o.fields), "doc": py_string(o.doc),
                "reshape": f".reshape({', '.join(map(str, o.shape))})" if len(o.shape) > 1 else ""} for o in f.outputs]
    invalid = f.invalid_status
    return {
        "name": f.name,
        "core": calls[f.name],
        "helper": f.kind == "helper",
        "summary": py_string(f.summary),
        "doc": [py_string(line) for line in f.doc],
        "params": [identifier(a.name) for a in f.arguments],
        "body": body,
        "inputs": inputs,
        "outputs": outputs,
        "result": f.result or f"{_camel(f.name)}Result",
        "fields": list(f.result_fields),
        "invalid": py_string(invalid[2]) if invalid else None,
        "invalid_value": invalid[1] if invalid else None,
        "statuses": [{"name": name, "label": name.lower().removeprefix("ik_"), "value": value, "meaning": py_string(meaning)}
                     for name, value, meaning in f.statuses],
        "labels": _labels(f.statuses),
    }


def _labels(statuses) -> list[str]:
    """Status names indexed by their codes (codes no status has: ``"?"``)."""
    labels = ["?"] * (max((value for _, value, _ in statuses), default=-1) + 1)
    for name, value, _ in statuses:
        labels[value] = name.lower().removeprefix("ik_")
    return labels


def lanes_context(module: Module, f: Function) -> dict:
    """A public procedure in masked form over a batch of problems (:mod:`skelarm_sym.ir.predicate`): every
    value is an array over the problems (the lanes), an array of the IR a list of such values; the
    straight-line functions it calls run on all lanes at once through their ``_<name>_on_lanes`` adapters."""
    p = predicate(module, f)
    calls = {g.name: f"_{g.name}_on_lanes" for g in module.functions if g.kind == "straight"}
    body = ProcedurePrinter(p, calls, NUMPY).statements(p.body, 1)
    return {
        "core": f"_{f.name}_lanes",
        "body": body,
        "status": identifier(p.status.name) if p.status is not None else None,
        "called": sorted(_called(p.body)),
    }


def _called(body) -> set[str]:
    """Names of the straight-line functions a masked program calls."""
    names: set[str] = set()
    for s in body:
        t = type(s)
        if t is PCall:
            names.add(s.function)
        elif t in (PFor, PLoop, PGuard):
            names |= _called(s.body)
    return names


def on_lanes_context(f: Function) -> dict:
    """The adapter through which masked programs call straight-line function ``f``: lists of per-lane
    values in (the order of ``f``'s IR arguments), lists out, one element per output element."""
    return {
        "name": f"_{f.name}_on_lanes",
        "core": f"_{f.name}_core",
        "args": [identifier(a.name) for a in f.inputs],
        "core_args": [identifier(a.name) if a.is_scalar else f"_stacked(_c, {identifier(a.name)})"
                      for a in [*(a for a in f.inputs if not a.is_scalar), *(a for a in f.inputs if a.is_scalar)]],
        "sizes": [o.size for o in f.outputs],
    }


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def context(module: Module) -> dict:
    calls = _function_names(module)
    printers: dict = {}
    straight = [straight_context(f, calls, printers) for f in module.functions if f.kind == "straight"]
    procedures = [procedure_context(f, calls, {}) for f in module.functions if f.kind != "straight"]
    called: set[str] = set()
    for f, p in zip([f for f in module.functions if f.kind != "straight"], procedures):
        if f.kind == "procedure":
            p["lanes"] = lanes_context(module, f)
            called |= set(p["lanes"]["called"])
    statuses = [{"name": name, "label": name.lower().removeprefix("ik_"), "value": value, "meaning": py_string(meaning)}
                for name, value, meaning in module_statuses(module.functions)]
    return {
        "prefix": module.prefix,
        "notes": [py_string(line) for line in module.notes],
        "dtype": DTYPES[module.precision],
        "functions": straight,
        "procedures": procedures,
        "on_lanes": [on_lanes_context(f) for f in module.functions if f.name in called],
        "statuses": statuses,
        **constants_context(module, "np.inf"),
    }


def matrix_inputs(module: Module) -> str:
    """The :data:`~skelarm_sym.derive.core.MATRIX_INPUTS` the module's straight-line functions take, as a Python
    literal (``""`` where none: the module then has no such table)."""
    from ...derive.core import MATRIX_INPUTS, matrix_shape

    inputs = [a for f in module.functions if f.kind == "straight" for a in f.inputs]
    used = {name: shape for name, shape in MATRIX_INPUTS.items()
            if any(a.name == name for a in inputs) and all(matrix_shape(a.name, a.size) for a in inputs if a.name == name)}
    return repr(used) if used else ""


def constants_context(module: Module, inf: str) -> dict:
    """The module's named constants and constant tables as Python literals (``inf``: how the module names
    infinity, for the limits a table leaves open)."""
    return {
        "matrix_inputs": matrix_inputs(module),
        "constants": [{"name": c.name, "value": repr(c.value if type(c.value) is int else float(c.value)), "doc": py_string(c.doc)}
                      for c in module.constants],
        "tables": [
            {"name": t.name, "doc": py_string(t.doc),
             "values": [repr(float(v)) if v is not None else (inf if t.sign > 0 else "-" + inf) for v in t.values]}
            for t in module.tables
        ],
    }


def render(module: Module, stamp: str) -> dict[str, str]:
    """``{".py": text}``."""
    from ..templating import render_template

    return {".py": render_template("numpy/module.py.j2", stamp=stamp, **context(module))}
