"""CUDA backend: the context of ``templates/cuda/header.cuh.j2``, ``source.cu.j2`` and ``launch.py.j2``.

The ``.cu`` holds, for every public function, a ``__host__ __device__`` function with the C99 body
(printed by :class:`~skelarm_sym.backends.c.printer.CPrinter`, the C backend's printer), and for every
straight-line function and solver an ``extern "C"`` batch kernel, one configuration (or IK target) per
thread, plus a host launcher and a host loop over the same per-thread body.

Layout of the batches: structure of arrays (SoA). Element ``k`` of configuration ``i`` of a batch of
``m`` is at ``[k*m + i]``: thread ``i`` of a warp reads and writes the words next to those of threads
``i - 1`` and ``i + 1``, so every load and store of a warp is one coalesced transaction (array of
structures, ``[i*size + k]``, would spread a warp's store of one output element over ``32*size*8``
bytes). Arguments shared by the batch (parameters) are one small array; scalars are passed by value.

Trigonometry: each angle's sine and cosine come from one ``sincos`` call (CUDA's shares the argument
reduction; on the host it is ``sin`` and ``cos``), written in the IR as a call of the module's
``{prefix}_sincos`` helper so that the C printer prints it unchanged.

The same ``.cu`` compiles three ways: with ``nvcc`` (kernels, launchers, host loops), with NVRTC
(CuPy's ``RawModule``: the kernels only) and as plain host C++ (``g++ -x c++``, the CUDA qualifiers
defined away: the single calls and the host loops, which is how the arithmetic is checked on
machines without a GPU).
"""

from __future__ import annotations

from ...ir.nodes import (
    ArrayArg, CallFunction, Const, Declare, DeclareArray, Elem, For, Function, If, Let, Module, Role, TrigBlock, Type, While, module_statuses,
)
from ...ir.walk import body_names, called, expr_names
from ..c.backend import Names, c_type, parameter
from ..c.printer import PRECISIONS, CPrecision, CPrinter
from ..numpy.printer import PythonPrinter, identifier
from ..text import c_comment, py_string

LANGUAGE = "cuda"
FILE_SUFFIXES = (".cuh", ".cu", "_cuda.py")
BLOCK = 128
"""Threads per block of every kernel (``{P}_BLOCK``; ``-D{P}_BLOCK=256`` changes it in nvcc builds)."""
INDEX = "long long"
"""The C type of batch sizes and indices (``m``, ``i``): 64 bits, so that ``k*m + i`` of a batch of 10^8
configurations of a 42-element Jacobian does not overflow."""
STATUS = "status"
"""The name of the kernels' extra output, the solver's return value per target."""




# -- trigonometry as sincos calls ---------------------------------------------------------------------

def sincos_body(body: tuple, taken: set[str]) -> tuple:
    """``body`` with every :class:`TrigBlock` replaced, angle by angle, by
    ``T sc_c[2]; prefix_sincos(angle, sc_c); const T s = sc_c[0]; const T c = sc_c[1];`` (nested bodies too).
    ``taken``: names in use (the new arrays avoid them and are added)."""
    out = []
    for s in body:
        t = type(s)
        if t is TrigBlock:
            for angle, c, sn in zip(s.angles, s.cos, s.sin):
                name = f"sc_{c.name}"
                while name in taken:
                    name += "_"
                taken.add(name)
                out += [
                    DeclareArray(name, 2),
                    CallFunction("sincos", (angle, ArrayArg(name))),
                    Let(sn, Elem(name, Const(0, Type.INT))),
                    Let(c, Elem(name, Const(1, Type.INT))),
                ]
        elif t is If:
            out.append(If(s.cond, sincos_body(s.then, taken), sincos_body(s.otherwise, taken)))
        elif t is For:
            out.append(For(s.var, s.start, s.stop, sincos_body(s.body, taken)))
        elif t is While:
            out.append(While(s.cond, sincos_body(s.body, taken)))
        else:
            out.append(s)
    return tuple(out)


def _defined_names(body, out: set[str]) -> set[str]:
    """Names the statements of ``body`` declare (locals), nested bodies included."""
    for s in body:
        t = type(s)
        if t in (Let, Declare):
            out.add(s.var.name)
        elif t is DeclareArray:
            out.add(s.name)
        elif t is If:
            _defined_names(s.then, out)
            _defined_names(s.otherwise, out)
        elif t in (For, While):
            if t is For:
                out.add(s.var.name)
            _defined_names(s.body, out)
    return out


def _printed_body(f: Function, precision: CPrecision, names: Names) -> list[str]:
    """``f``'s statements as C lines (one indent), ``(void)`` for the arguments it does not read."""
    taken = body_names(f.body) | _defined_names(f.body, set()) | {a.name for a in f.arguments}
    body = sincos_body(f.body, taken)
    printer = CPrinter(precision, macro=names.macro, function_name=names.function)
    used = body_names(body)
    lines = [f"    (void){a.name};" for a in f.arguments if a.name not in used]
    return lines + printer.statements(body)


# -- the batch kernels -----------------------------------------------------------------------------------

def _batched(f: Function, a) -> bool:
    """Whether each configuration (target) of a kernel has its own ``a``: straight functions say so in
    the IR; a solver's kernel batches its joint state and data (q0, target), shares parameters and scalars."""
    if a.is_output:
        return True
    if f.kind == "straight":
        return a.batched and not a.is_scalar
    return a.role in (Role.STATE, Role.DATA) and not a.is_scalar


def kernel_arguments(f: Function, precision: CPrecision) -> list[dict]:
    """Every argument of ``f``'s kernel, in order: ``how`` is ``soa`` (one column per configuration),
    ``shared`` (one array for the batch), ``scalar`` (by value) or ``status`` (the solver's return value)."""
    from ...derive.core import matrix_shape

    out = []
    for a in f.arguments:
        t = c_type(precision, a.type)
        how = "scalar" if a.is_scalar and not a.is_output else ("soa" if _batched(f, a) else "shared")
        matrix = matrix_shape(a.name, a.size) if f.kind == "straight" and how == "soa" and not a.is_output else None
        shape = list(matrix) if matrix is not None else (list(a.shape) or [1])
        out.append({"name": a.name, "type": t, "size": a.size, "how": how, "output": a.is_output,
                    "role": a.role.name.lower(), "domain": a.domain, "shape": shape,
                    "int": a.type is not Type.REAL})
    if f.returns is not None:
        if any(a.name == STATUS for a in f.arguments):
            raise ValueError(f"internal error: {f.name} has an argument named {STATUS!r}")
        out.append({"name": STATUS, "type": c_type(precision, f.returns), "size": 1, "how": "status", "output": True,
                    "role": "output", "domain": "", "shape": [], "int": True})
    return out


def _kernel_param(k: dict) -> str:
    if k["how"] == "scalar":
        return f"{k['type']} {k['name']}"
    const = "" if k["output"] else "const "
    return f"{const}{k['type']} *{k['name']}"


def function_context(f: Function, precision: CPrecision, names: Names) -> dict:
    """What the templates need for one function: its single call (signature, body), and for public
    functions the kernel's arguments."""
    optional = [a for a in f.outputs if a.optional]
    run = f.kind != "helper" and bool(optional)
    returns = "void" if f.returns is None else c_type(precision, f.returns)
    kargs = kernel_arguments(f, precision) if f.kind != "helper" else []
    return {
        "name": f.name,
        "cname": names.function(f.name),
        "kind": f.kind,
        "helper": f.kind == "helper",
        "summary": c_comment(f.summary),
        "doc": [c_comment(line) for line in f.doc],
        "returns": returns,
        "params": [parameter(a, precision) for a in f.arguments],
        "run": run,
        "run_params": [parameter(a, precision, required=True) for a in f.arguments],
        "run_args": [f"{a.name} ? {a.name} : {a.name}_local" if a.optional and a.is_output else a.name for a in f.arguments],
        "locals": [{"name": a.name, "type": c_type(precision, a.type), "size": a.size} for a in optional],
        "body": _printed_body(f, precision, names),
        "calls": sorted(called(f.body)),
        "ops": f.ops.as_dict(),
        "kernel": kargs,
        "kernel_params": [_kernel_param(k) for k in kargs],
        "core": names.function(f.name) + ("_run" if run else ""),
        "statuses": [{"macro": names.macro(name), "value": value, "meaning": c_comment(meaning)} for name, value, meaning in f.statuses],
    }


def python_function(f: Function, kargs: list[dict]) -> dict:
    """The Python entry's view of a public function: its argument table and its method's signature.

    A default that is a constant is the method's default; one computed from other inputs (the planar
    solver's ``tol`` from ``l``) is printed as Python (the NumPy backend's printer) over host copies of
    the shared inputs it reads; one that reads per-configuration inputs is not offered (``None``: the
    method asks for the value)."""
    shared = {k["name"] for k in kargs if k["how"] in ("shared", "scalar")}
    inputs = []
    for a in f.inputs:
        default, expr, hosts = None, None, []
        if a.default is not None:
            if type(a.default) is Const:
                default = repr(a.default.value)
            else:
                reads = sorted(expr_names(a.default, set()))
                if set(reads) <= shared:
                    storage = {n: f"_h_{n}" for n in reads}
                    default, expr, hosts = "None", PythonPrinter(False, storage, constant=lambda n: n).expr(a.default), reads
        inputs.append({"name": a.name, "py": identifier(a.name), "default": default, "expr": expr,
                       "hosts": [{"py": identifier(n), "name": n} for n in hosts], "required": False})
    # an input without a default after one with a default gets None, and the method refuses None for it
    seen_default = False
    for i in inputs:
        if i["default"] is not None:
            seen_default = True
        elif seen_default:
            i["default"], i["required"] = "None", True
    spec = [repr((k["name"], k["how"], k["size"], tuple(k["shape"]), k["output"], k["int"], k["domain"])) for k in kargs]
    outs = f.outputs
    shapes = {"scalar": lambda k: "a number", "shared": lambda k: f"({k['size']},) shared by the batch",
              "soa": lambda k: "(..., " + ", ".join(map(str, k["shape"])) + ")"}
    input_doc = [f"{identifier(k['name'])} {shapes[k['how']](k)}" for k in kargs if not k["output"]]
    return {
        "input_doc": input_doc,
        "name": f.name,
        "kind": f.kind,
        "summary": py_string(f.summary),
        "doc": [py_string(line) for line in f.doc],
        "inputs": inputs,
        "spec": spec,
        "outputs": [{"name": o.name, "shape": list(o.shape)} for o in outs],
        "result": f.result,
        "fields": list(f.result_fields),
        "split": [(o.name, list(o.fields)) for o in outs[1:]],
    }


def context(module: Module) -> dict:
    """Everything the three templates print."""
    precision = PRECISIONS[module.precision]
    names = Names(module.prefix)
    functions = [function_context(f, precision, names) for f in module.functions]
    statuses = [{"macro": names.macro(name), "value": value, "meaning": c_comment(meaning)}
                for name, value, meaning in module_statuses(module.functions)]
    big = {"double": 1e300, "float": 1e30}[module.precision]
    P = module.prefix.upper()
    return {
        "prefix": module.prefix,
        "P": P,
        "guard": P + "_CUH",
        "notes": [c_comment(line) for line in module.notes],
        "py_notes": [py_string(line) for line in module.notes],
        "precision": precision,
        "T": precision.ctype,
        "I": INDEX,
        "block": BLOCK,
        "functions": functions,
        "straight": [f for f in functions if f["kind"] == "straight"],
        "solvers": [f for f in functions if f["kind"] == "procedure"],
        "public": [f for f in functions if not f["helper"]],
        "python": [python_function(f, fc["kernel"]) for f, fc in zip(module.functions, functions) if f.kind != "helper"],
        "statuses": statuses,
        "py_statuses": list({name: {"name": name, "value": value, "meaning": py_string(meaning)}
                             for f in module.functions for name, value, meaning in f.statuses}.values()),
        "finite": any("_FINITE(" in line for f in functions for line in f["body"]),
        "constants": [{"macro": names.macro(c.name), "value": precision.literal(c.value), "doc": c_comment(c.doc)} for c in module.constants],
        "tables": [
            {"macro": names.macro(t.name), "doc": c_comment(t.doc),
             "values": [precision.literal(v if v is not None else t.sign * big) for v in t.values]}
            for t in module.tables
        ],
    }


TEMPLATES = {".cuh": "cuda/header.cuh.j2", ".cu": "cuda/source.cu.j2", "_cuda.py": "cuda/launch.py.j2"}


def render(module: Module, stamp: str) -> dict[str, str]:
    """``{suffix: text}`` of the header, the CUDA source and the Python entry."""
    from ..templating import render_template

    ctx = context(module)
    return {suffix: render_template(name, stamp=stamp, **ctx) for suffix, name in TEMPLATES.items()}
