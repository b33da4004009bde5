"""PyTorch backend: the context of ``templates/torch/module.py.j2`` from an IR module.

The emitted module depends on PyTorch (and NumPy, for converting array-likes). Each straight-line
function has three layers:

* ``_<name>_core(_c, *inputs)``: the straight-line program over lists of per-element tensors (``q[k]`` is
  a tensor of the batch shape), returning lists of output elements; plain tensor operations only, so
  autograd, ``torch.func`` transforms and ``torch.compile`` see through it;
* ``<name>_unchecked(*inputs)``: tensors in (``(..., size)``, numbers or tensors for scalars), tensors out
  (``(..., *shape)``), on the input's device and dtype; nothing checks values, so it is what to pass to
  ``torch.compile`` and ``torch.func.vmap``;
* ``<name>(*inputs)``: converts array-likes to tensors (the module's precision for Python numbers and
  NumPy arrays, a tensor's own floating dtype otherwise), checks shapes and domains like the NumPy
  module (a ``ValueError`` naming the argument) and calls the unchecked function. The value checks
  are skipped while ``torch.compile`` traces or under ``torch.func`` transforms.

Procedures (the iterative solvers) are batched over problems: the IR procedure is turned into masked
form by :mod:`skelarm_sym.ir.predicate` and printed by :class:`.printer.ProcedurePrinter`.
"""

from __future__ import annotations

from ...ir.nodes import Comment, Function, Let, Module, Store, TrigBlock, Type
from ...ir.predicate import predicate
from ..numpy.backend import constants_context
from ..text import py_string
from .printer import TORCH, Dialect, ProcedurePrinter, TensorPrinter, identifier

LANGUAGE = "torch"
FILE_SUFFIXES = ("_torch.py",)
DTYPES = {"double": "torch.float64", "float": "torch.float32"}


def core_name(f: Function) -> str:
    return f"_{f.name}_core"


def straight_lines(f: Function, printer: TensorPrinter) -> tuple[list[str], list[list[str]]]:
    """The body of a straight-line core (statements) and its outputs' element texts."""
    lines: list[str] = []
    stores: dict[str, dict[int, str]] = {o.name: {} for o in f.outputs}
    for s in f.body:
        t = type(s)
        if t is Let:
            lines.append(f"{identifier(s.var.name)} = {printer.expr(s.value)}")
        elif t is TrigBlock:
            for a, c, sn in zip(s.angles, s.cos, s.sin):
                x = printer.tensor(a)
                lines.append(f"{identifier(c.name)} = {printer.d.calls['cos']}({x})")
                lines.append(f"{identifier(sn.name)} = {printer.d.calls['sin']}({x})")
            if printer.d.shared:
                names = ", ".join(identifier(v.name) for pair in zip(s.cos, s.sin) for v in pair)
                lines.append(f"{names}, = {printer.d.shared}({names})")
        elif t is Store:
            stores[s.output][s.index] = printer.expr(s.value)
        elif t is Comment:
            continue
        else:
            raise TypeError(f"internal error: {f.name}: a straight-line function holds a {t.__name__}")
    outputs = [[stores[o.name].get(k, "0.0") for k in range(o.size)] for o in f.outputs]
    return lines, outputs


def argument_context(a) -> dict:
    return {"name": a.name, "py": identifier(a.name), "size": a.size, "shape": list(a.shape), "domain": a.domain,
            "scalar": a.is_scalar, "int": a.type is Type.INT, "doc": py_string(a.doc)}


def straight_context(f: Function, dialect: Dialect = TORCH) -> dict:
    printer = TensorPrinter(dialect)
    lines, outputs = straight_lines(f, printer)
    arrays = [a for a in f.inputs if not a.is_scalar]
    return {
        "name": f.name,
        "core": core_name(f),
        "summary": py_string(f.summary),
        "inputs": [argument_context(a) for a in f.inputs],
        "arrays": [argument_context(a) for a in arrays],
        "scalars": [argument_context(a) for a in f.inputs if a.is_scalar],
        "outputs": [{"name": o.name, "size": o.size, "shape": list(o.shape), "elements": elements}
                    for o, elements in zip(f.outputs, outputs)],
        "lines": lines,
        "ops": f.ops.as_dict(),
    }


def procedure_context(module: Module, f: Function, dialect: Dialect = TORCH, printer_class=ProcedurePrinter) -> dict:
    """A public procedure: its masked body, its wrappers' checks, defaults and result record."""
    calls = {g.name: core_name(g) for g in module.functions if g.kind == "straight"}
    p = predicate(module, f)
    body = printer_class(p, calls, dialect).statements(p.body, 1)
    defaults = TensorPrinter(dialect, elements="last")
    inputs = []
    for a in f.inputs:
        ctx = argument_context(a)
        default = None if a.default is None else defaults.expr(a.default)
        ctx.update(default=default, literal=default is not None and type(a.default).__name__ == "Const")
        inputs.append(ctx)
    outputs = [{"name": o.name, "py": identifier(o.name), "size": o.size, "shape": list(o.shape), "int": o.type is Type.INT,
                "fields": list(o.fields), "doc": py_string(o.doc)} for o in f.outputs]
    invalid = f.invalid_status
    return {
        "name": f.name,
        "core": core_name(f),
        "summary": py_string(f.summary),
        "doc": [py_string(line) for line in f.doc],
        "inputs": inputs,
        "outputs": outputs,
        "status": identifier(p.status.name) if p.status is not None else None,
        "body": body,
        "result": f.result or "".join(part.capitalize() for part in f.name.split("_")) + "Result",
        "fields": list(f.result_fields),
        "invalid": None if invalid is None else {"name": invalid[0], "value": invalid[1], "meaning": py_string(invalid[2])},
        "statuses": [{"name": name, "label": name.lower().removeprefix("ik_"), "value": value, "meaning": py_string(meaning)}
                     for name, value, meaning in f.statuses],
    }


def context(module: Module, dialect: Dialect = TORCH, printer_class=ProcedurePrinter, dtypes=DTYPES) -> dict:
    straight = [straight_context(f, dialect) for f in module.functions if f.kind == "straight"]
    procedures = [procedure_context(module, f, dialect, printer_class) for f in module.functions if f.kind == "procedure"]
    statuses: dict[str, dict] = {}
    names: dict[int, dict] = {}  # STATUS_NAMES: a code -> the name the first solver using it gives it
    for p in procedures:
        for s in p["statuses"]:
            statuses.setdefault(s["name"], s)
            names.setdefault(s["value"], s)
    return {
        "status_names": list(names.values()),
        "prefix": module.prefix,
        "notes": [py_string(line) for line in module.notes],
        "dtype": dtypes[module.precision],
        "precision": module.precision,
        "functions": straight,
        "procedures": procedures,
        "statuses": list(statuses.values()),
        **constants_context(module, "_INF"),
    }


def render(module: Module, stamp: str) -> dict[str, str]:
    """``{"_torch.py": text}``."""
    from ..templating import render_template

    return {FILE_SUFFIXES[0]: render_template("torch/module.py.j2", stamp=stamp, **context(module))}
