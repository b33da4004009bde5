"""C99 backend: the context of ``templates/c/header.h.j2`` and ``source.c.j2`` from an IR module.

Emitted functions take caller-owned arrays (row-major), allocate nothing and use no globals.
Straight-line functions: the angles are computed first (``_angles``), their sines and cosines in one
helper over small arrays (double code: the source's own kernel, four angles at a time, but where GCC targets
x86-64 glibc with AVX2, whose ``sin``/``cos`` are declared with the ``simd`` attribute so that the helper's
loops call glibc's vector math, libmvec, found through plain ``-lm``; libm's ``sincos`` or ``sin``/``cos``
where the kernel cannot run), then the rest (``_finish``). Each has a ``_batch``
variant. Procedures (the iterative solvers) and their helpers are printed statement by statement.
"""

from __future__ import annotations

import re
from typing import Sequence

from ...ir.nodes import Const, Declare, DeclareArray, Elem, For, Function, If, Let, Module, Store, TrigBlock, Type, While, module_statuses
from ...ir.walk import body_names, called, expr_names, needed_lets
from ..text import c_comment
from .printer import _ATOM, PRECISIONS, CPrecision, CPrinter

LANGUAGE = "c"
FILE_SUFFIXES = (".h", ".c")
ANGLES, COSINES, SINES = "ang", "cs", "sn"
SIMD_LANES = 8
"""Trigonometric arrays are padded to a multiple of this (AVX-512 doubles) so loops vectorise whole."""
SHORT_LOOP = {"double": 4, "float": 8}
"""A single call with at most this many angles pads them to this (one 256-bit vector), longer ones to a
multiple of ``SIMD_LANES`` like the batches, whose loops are multiples of ``SIMD_LANES`` long. Single calls
and batches then evaluate the same ``cos``/``sin`` of the same angles in loops that GCC vectorises alike,
so with one set of compiler flags both call the same vector routine and a single call equals its batch
result bit for bit (tested with -O2, -O2 -march=native and -O0). Measured with GCC 12: loops of 2 angles
are left scalar, and loops of 4 floats get a narrower vector routine than the batch's."""
BLOCK_ANGLES = 512
"""Batch functions evaluate the trigonometry of up to this many angles (several configurations) at once."""
SOA_BLOCKS = (32, 16, 8)
"""Configurations per block of the vectorised batch path, largest first (multiples of the SIMD width)."""
SOA_BYTES = 32 * 1024
"""Largest stack a vectorised batch block may use; functions of larger arms use the per-configuration path."""


VECTOR_OUTPUTS = 12
"""Most output elements per element of a configuration's inputs in a function with a vectorised batch
path: 6 for a Jacobian (6 rows), 1.4 for planar kinematics, 42 for a 7-joint arm's Hessian (N^2 outputs),
whose vectorised body compiled in seconds and gained nothing."""


def vectorisable(f: Function) -> bool:
    """Whether the batch of ``f`` takes the vectorised block path: its body is plain arithmetic (sums,
    products and negations: no division, square root, comparison, select or atan2, which GCC's vectoriser
    masks or gives up on) and it has at most ``VECTOR_OUTPUTS`` outputs per input element. A vectorised
    body is a second copy for the compiler, in a loop; the other functions keep the per-configuration
    path (their trigonometry still batched) and compile once."""
    ops = f.ops
    inputs = sum(a.size for a in f.inputs if a.batched and not a.is_scalar)
    outputs = sum(o.size for o in f.outputs)
    return outputs <= VECTOR_OUTPUTS * max(1, inputs) and not (ops.div or ops.sqrt or ops.cmp or ops.select or ops.atan2)


def pad(count: int, lanes: int) -> int:
    """``count`` rounded up to a multiple of ``lanes`` (at least ``lanes``)."""
    return max(lanes, -(-count // lanes) * lanes)


def padded_size(count: int, ctype: str) -> int:
    """Angle slots of a single call for ``count`` angles (see ``SHORT_LOOP``)."""
    if not count:
        return 0
    return SHORT_LOOP[ctype] if count <= SHORT_LOOP[ctype] else pad(count, SIMD_LANES)


STACK_HEADROOM = 1.1
"""The stated stack is the estimate times this (rounded up to 8 bytes): the estimate follows gcc -O0's frames
closely (within 2 % for the closed-form IK), and another compiler version may lay them out otherwise."""


def stack_text(size: int) -> str:
    """A stack size for the header, with :data:`STACK_HEADROOM`: bytes, or KB above 4 KB (rounded up)."""
    size = -(-int(size * STACK_HEADROOM) // 8) * 8
    return f"{size} bytes" if size < 4096 else f"{-(-size // 1024)} KB"


TRIG_CHAIN = {"double": 512, "float": 128}
"""Stack bytes of the trigonometry a function with angles calls, in an unoptimised build: the ``trigN`` helper, the
four-angle kernel and its exact reduction for huge angles (double: 64 + 288 + 120 = 472 bytes under gcc -O0 on
x86-64; float calls libm's ``sinf``/``cosf`` from the helper: 80), the C library's own ``sin`` and ``cos`` not
counted."""


def frame_bytes(parameters: int) -> int:
    """The fixed part of one call's frame in an unoptimised build: the return address and saved frame pointer
    (16 bytes) and a copy of each parameter (8 bytes: gcc -O0 spills every one), rounded up to 16."""
    return -(-(16 + 8 * parameters) // 16) * 16


STRIDE = "stride"
"""The last parameter of the body functions of a vectorised function: element k of a configuration's
arrays is at ``[k*stride]`` (1 in a single call; the block size in the vectorised batch path, where a block
of configurations is stored transposed). The statements index with the macro ``{PREFIX}_STRIDE``: the
parameter where GCC's vector math is used, the constant 1 elsewhere (every call there passes 1)."""


class StridedPrinter(CPrinter):
    """A :class:`CPrinter` for the body functions shared by single calls and batches: element ``k`` of the
    arrays in ``strided`` (a configuration's inputs and outputs) prints as ``name[k*STRIDE]``, ``stride``
    being the text of the stride."""

    def __init__(self, precision: CPrecision, storage: dict[str, str], macro, function_name, strided: set[str],
                 stride: str) -> None:
        super().__init__(precision, storage, macro, function_name)
        self.strided = strided
        self.stride = stride

    def _node(self, e):
        if type(e) is Elem and e.array in self.strided and type(e.index) is Const:
            return element(self.storage.get(e.array, e.array), int(e.index.value), self.stride), _ATOM
        return super()._node(e)

    def _statement(self, s, depth: int, lines: list[str]) -> None:
        if type(s) is Store and s.output in self.strided:
            lines.append(f"{self.indent * depth}{element(s.output, s.index, self.stride)} = {self.expr(s.value)};")
            return
        super()._statement(s, depth, lines)


def element(name: str, k: int, stride: str | None) -> str:
    """Element ``k`` of an array, strided by ``stride`` (the text of the stride, or ``None``)."""
    return f"{name}[{k}*{stride}]" if (k and stride) else f"{name}[{k}]"


class Names:
    """How module-level names print: constants and statuses as ``PREFIX_NAME`` macros, functions as
    ``prefix_name``."""

    def __init__(self, prefix: str, known: Sequence[str] = ()) -> None:
        self.prefix = prefix
        # the module's macro names as the tool's docs write them (IK_OK, Q_MIN): prefixed in the header's comments
        self._known = re.compile(r"(?<![A-Za-z0-9_])(" + "|".join(sorted(map(re.escape, known), key=len, reverse=True))
                                 + r")(?![A-Za-z0-9_])") if known else None

    def macro(self, name: str) -> str:
        return f"{self.prefix.upper()}_{name}"

    def doc(self, text: str) -> str:
        """A line of the tool's own documentation (a function's doc, a status's meaning, a constant's or table's doc;
        never the header notes, which carry the robot file's names and the command line) for a C comment, each
        macro it names spelt as the header defines it (``IK_OK``: ``UR5_IK_OK``)."""
        if self._known is not None:
            text = self._known.sub(lambda m: self.macro(m.group(1)), text)
        return c_comment(text)

    def function(self, name: str) -> str:
        return f"{self.prefix}_{name}"


def c_type(precision: CPrecision, t: Type) -> str:
    """The C type that holds a value of IR type ``t`` at ``precision``."""
    return precision.ctype if t is Type.REAL else {Type.INT: "int", Type.BOOL: "int", Type.UINT64: "unsigned long long"}[t]


def parameter(a, precision: CPrecision, required: bool = False) -> str:
    """The C parameter declaration of argument ``a``."""
    t = c_type(precision, a.type)
    if a.is_output:
        return f"{t} *{a.name}" if a.optional and not required else f"{t} {a.name}[{a.size}]"
    if a.is_scalar:
        return f"{t} {a.name}"
    return f"const {t} {a.name}[{a.size}]"


class Shared:
    """What the functions of one module share while their context is built: the names each statement
    reads (statements are shared objects across functions) and one printer per storage layout (so that
    a statement common to several functions is printed once)."""

    def __init__(self) -> None:
        self._reads: dict[int, tuple[object, frozenset[str]]] = {}
        self._printers: dict[tuple, CPrinter] = {}

    def reads(self, s) -> frozenset[str]:
        """The variable and array names statement ``s`` (a Let or Store) reads."""
        hit = self._reads.get(id(s))
        if hit is None or hit[0] is not s:
            hit = self._reads[id(s)] = (s, frozenset(expr_names(s.value, set())))
        return hit[1]

    def needed(self, lets: list[Let], roots: set[str]) -> list[Let]:
        """:func:`skelarm_sym.ir.walk.needed_lets`, with the names each Let reads looked up here."""
        return needed_lets(lets, roots, self.reads)

    def printer(self, precision: CPrecision, storage: dict[str, str], names: "Names", strided: set[str] | None,
                stride: str | None) -> CPrinter:
        key = (precision.ctype, tuple(sorted(storage.items())), None if strided is None else tuple(sorted(strided)), stride)
        printer = self._printers.get(key)
        if printer is None:
            if strided is None:
                printer = CPrinter(precision, storage, names.macro, names.function)
            else:
                printer = StridedPrinter(precision, storage, names.macro, names.function, strided, stride)
            self._printers[key] = printer
        return printer


def straight_context(f: Function, precision: CPrecision, names: Names, common: Shared | None = None) -> dict:
    """What the templates need to lay out one straight-line function (single call and batch); ``common``:
    what the functions of the module share (see :class:`Shared`)."""
    common = common or Shared()
    blocks = [i for i, s in enumerate(f.body) if type(s) is TrigBlock]
    ctype = precision.ctype
    inputs = f.inputs
    outputs = f.outputs
    if len(blocks) > 1:  # closed forms with angles of angles: printed whole, one configuration at a time
        printer = CPrinter(precision, macro=names.macro, function_name=names.function)
        return _common(f, precision, names) | {
            "general": printer.statements(f.body), "angle_count": 0, "padded": 0, "block": 1, "soa": None,
            "pre": [], "post": [], "pre_inputs": [], "post_inputs": [a.name for a in inputs],
            "post_uses": {"ang": False, "cs": False, "sn": False},
            **_general_stack(f, precision),
        }
    split = blocks[0] if blocks else 0
    trig = f.body[split] if blocks else TrigBlock((), (), ())
    pre = list(f.body[:split])
    rest = list(f.body[split + 1:]) if blocks else list(f.body)
    post = [s for s in rest if type(s) is Let]
    stores = [s for s in rest if type(s) is Store]
    count = len(trig.angles)
    padded = padded_size(count, ctype)
    block = max(1, BLOCK_ANGLES // padded) if count else 1
    shared = {a.name for a in inputs if not a.batched}
    per_config = sum(a.size for a in inputs if a.name not in shared) + sum(o.size for o in outputs) + 3 * count
    itemsize = 8 if ctype == "double" else 4
    soa = next((b for b in SOA_BLOCKS if b * per_config * itemsize <= SOA_BYTES), None) if vectorisable(f) else None
    stride = names.macro(STRIDE.upper()) if soa else None
    storage: dict[str, str] = {}
    for k, (a, c, s) in enumerate(zip(trig.angles, trig.cos, trig.sin)):
        storage[a.name] = element(ANGLES, k, stride)
        storage[c.name] = element(COSINES, k, stride)
        storage[s.name] = element(SINES, k, stride)
    angle_names = {a.name for a in trig.angles}
    strided = ({a.name for a in inputs if a.batched and not a.is_scalar} | {o.name for o in outputs}) if soa else None
    printer = common.printer(precision, storage, names, strided, stride)
    roots: set[str] = set()
    for s in post + stores:
        roots |= common.reads(s)
    recomputed = common.needed([s for s in pre if s.var.name not in angle_names], roots)
    post_all = recomputed + post
    post_read = set(roots)
    for s in recomputed:
        post_read |= common.reads(s)
    pre_read: set[str] = set()
    for s in pre:
        pre_read |= common.reads(s)
    temporaries = len(pre) + len(post_all)
    # an unoptimised build keeps every temporary and array on the stack: the function's own frame (angle,
    # cosine and sine slots, a loop counter, and the body functions inlined into it with their parameters and
    # temporaries), then the trigonometry it calls; a batch's block function holds the block's arrays besides
    # (see TRIG_CHAIN, frame_bytes)
    parameters = len(inputs) + len(outputs)
    own = frame_bytes(parameters + 8) + itemsize * temporaries + 16
    trig_chain = TRIG_CHAIN[ctype] if count else 0
    single_stack = own + itemsize * 3 * padded + trig_chain
    block_arrays = itemsize * (soa * per_config + per_config) if soa else itemsize * 3 * padded * block
    batch_stack = frame_bytes(parameters + 1) + 16 + own + block_arrays + trig_chain
    return _common(f, precision, names) | {
        "general": None,
        "pre_inputs": [a.name for a in inputs if a.name in pre_read],
        "post_inputs": [a.name for a in inputs if a.name in post_read],
        "post_uses": {
            "ang": bool(post_read & angle_names),
            "cs": bool(post_read & {c.name for c in trig.cos}),
            "sn": bool(post_read & {s.name for s in trig.sin}),
        },
        "pre": [line.strip() for line in printer.statements(pre)],
        "post": [line.strip() for line in printer.statements(interleave(post_all, stores, common))],
        "angle_count": count,
        "padded": padded,
        "block": block,
        "soa": soa,
        "stack_bytes": single_stack,
        "stack": stack_text(single_stack),
        "batch_stack": stack_text(batch_stack),
    }


def _general_stack(f: Function, precision: CPrecision) -> dict:
    """The stack figures of a straight-line function printed whole (:func:`straight_context`): its frame with a
    slot for each temporary, one call of the C library's trigonometry (not counted) below it."""
    itemsize = 8 if precision.ctype == "double" else 4
    lets = sum(1 for s in f.body if type(s) is Let) + sum(len(s.angles) * 3 for s in f.body if type(s) is TrigBlock)
    single = frame_bytes(len(f.inputs) + len(f.outputs)) + itemsize * lets
    return {"stack_bytes": single, "stack": stack_text(single),
            "batch_stack": stack_text(frame_bytes(len(f.inputs) + len(f.outputs) + 1) + 16 + single)}


def interleave(lets: list[Let], stores: list[Store], common: Shared) -> list:
    """``lets`` in order, each store right after the last of them it reads (before them all when it reads
    none): an output element leaves the registers as soon as it is known, instead of every one staying
    live until the end of the function (which made GCC spill half the temporaries of long chains)."""
    position = {s.var.name: i for i, s in enumerate(lets)}
    after: dict[int, list[Store]] = {}
    for store in stores:
        last = max((position[n] for n in common.reads(store) if n in position), default=-1)
        after.setdefault(last, []).append(store)
    out: list = list(after.get(-1, []))
    for i, let in enumerate(lets):
        out.append(let)
        out.extend(after.get(i, []))
    return out


def _common(f: Function, precision: CPrecision, names: Names) -> dict:
    ctype = precision.ctype
    return {
        "name": f.name,
        "cname": f"{names.prefix}_{f.name}",
        "summary": f.summary,
        "inputs": [
            {"name": a.name, "size": a.size, "shared": not a.batched, "scalar": a.is_scalar, "param": parameter(a, precision),
             "pointer_param": f"const {ctype} *restrict {a.name}"}
            for a in f.inputs
        ],
        "outputs": [{"name": o.name, "size": o.size, "shape": o.shape} for o in f.outputs],
        "params": [parameter(a, precision) for a in f.arguments],
        "ops": f.ops.as_dict(),
        "ctype": ctype,
    }


def procedure_context(f: Function, precision: CPrecision, names: Names) -> dict:
    """A procedure or helper: its signature and body lines; public procedures with optional outputs get
    a ``_run`` core that takes every output, behind a function that lends locals for the omitted ones."""
    printer = CPrinter(precision, macro=names.macro, function_name=names.function)
    used = body_names(f.body)
    body = [f"    (void){a.name};" for a in f.arguments if a.name not in used]
    body += printer.statements(f.body)
    returns = "int" if f.returns is Type.INT else ("void" if f.returns is None else c_type(precision, f.returns))
    optional = [a for a in f.outputs if a.optional]
    run = f.kind != "helper" and bool(optional)
    return {
        "name": f.name,
        "summary": f.summary,
        "helper": f.kind == "helper",
        "returns": returns,
        "params": [parameter(a, precision) for a in f.arguments],
        "run_params": [parameter(a, precision, required=True) for a in f.arguments],
        "body": body,
        "run": run,
        "locals": [{"name": a.name, "type": c_type(precision, a.type), "size": a.size} for a in optional],
        "run_args": [f"{a.name} ? {a.name} : {a.name}_local" if a.optional and a.is_output else a.name for a in f.arguments],
        "doc": [names.doc(line) for line in f.doc],
        "statuses": [{"macro": names.macro(name), "value": value, "meaning": names.doc(meaning)} for name, value, meaning in f.statuses],
        "calls": sorted(called(f.body)),
        "batch": None if f.kind == "helper" else procedure_batch(f, precision),
    }


def local_bytes(body, itemsize: int) -> int:
    """Bytes of the locals a procedure's body declares (arrays and numbers, nested blocks included; every
    number counted at the real type's size or 8, whichever is larger: an estimate, as for the straight-line
    functions)."""
    size = 0
    word = max(itemsize, 8)
    for s in body:
        t = type(s)
        if t is DeclareArray:
            size += s.size * (itemsize if s.type is Type.REAL else 8)
        elif t in (Let, Declare):
            size += word
        elif t is If:
            size += max(local_bytes(s.then, itemsize), local_bytes(s.otherwise, itemsize))
        elif t in (For, While):
            size += word + local_bytes(s.body, itemsize)
    return size


def procedure_stacks(module: Module, straight: list[dict], itemsize: int) -> dict[str, int]:
    """Stack bytes of each procedure and helper: its locals, its arguments' copies of lent outputs, and the
    deepest function it calls (straight-line functions: their own estimate)."""
    stacks = {f["name"]: f["stack_bytes"] for f in straight}
    by_name = {f.name: f for f in module.functions}

    def stack(name: str) -> int:
        if name not in stacks:
            f = by_name[name]
            lent = sum(a.size * (itemsize if a.type is Type.REAL else 8) for a in f.outputs if a.optional)
            own = frame_bytes(len(f.arguments)) + local_bytes(f.body, itemsize) + lent
            if lent:  # the public function lends locals to its _run core: two frames
                own += frame_bytes(len(f.arguments))
            stacks[name] = own + max((stack(g) for g in called(f.body)), default=0)
        return stacks[name]

    return {f.name: stack(f.name) for f in module.functions if f.kind != "straight"}


def procedure_batch(f: Function, precision: CPrecision) -> dict:
    """The ``_batch`` variant of a public procedure: one problem after another, each a call of the single
    function. Arrays (inputs and outputs) hold the problems one after another (element k of problem j at
    ``[j*size + k]``); scalars are shared by the batch; optional outputs may be NULL, and so may ``status``
    (the return value of each call)."""
    params, args = ["size_t m"], []
    for a in f.arguments:
        t = c_type(precision, a.type)
        if a.is_scalar and not a.is_output:
            params.append(f"{t} {a.name}")
            args.append(a.name)
        elif a.is_output:
            params.append(f"{t} *{a.name}")
            offset = f"{a.name} + j * {a.size}" if a.size > 1 else f"{a.name} + j"
            args.append(f"{a.name} ? {offset} : NULL" if a.optional else offset)
        else:
            params.append(f"const {t} *{a.name}")
            args.append(f"{a.name} + j * {a.size}")
    status = f.returns is Type.INT
    if status:
        params.append("int *status")
    return {
        "params": params,
        "args": args,
        "status": status,
        "optional": [a.name for a in f.outputs if a.optional] + (["status"] if status else []),
        "shared": [a.name for a in f.inputs if a.is_scalar],
    }


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


def context(module: Module) -> dict:
    """Everything both templates print."""
    precision = PRECISIONS[module.precision]
    known = [c.name for c in module.constants] + [t.name for t in module.tables]
    names = Names(module.prefix, known + [name for name, _, _ in module_statuses(module.functions)])
    shared = Shared()
    straight = [straight_context(f, precision, names, shared) for f in module.functions if f.kind == "straight"]
    procedures = [procedure_context(f, precision, names) for f in module.functions if f.kind != "straight"]
    stacks = procedure_stacks(module, straight, 8 if precision.ctype == "double" else 4)
    for p in procedures:
        p["stack"] = stack_text(stacks[p["name"]])
        p["batch_stack"] = stack_text(frame_bytes(len(p["params"]) + 3) + 16 + stacks[p["name"]])
    statuses = [{"macro": names.macro(name), "value": value, "meaning": names.doc(meaning)}
                for name, value, meaning in module_statuses(module.functions)]
    uses_finite = any("_FINITE(" in line for p in procedures for line in p["body"])
    big = {"double": 1e300, "float": 1e30}[module.precision]
    return {
        "prefix": module.prefix,
        "P": module.prefix.upper(),
        "guard": module.prefix.upper() + "_H",
        "notes": [c_comment(line) for line in module.notes],
        "precision": precision,
        "T": precision.ctype,
        "functions": straight,
        "procedures": procedures,
        "statuses": statuses,
        "finite": uses_finite,
        "trig_sizes": trig_helpers(straight),
        "constants": [{"macro": names.macro(c.name), "value": precision.literal(c.value), "doc": names.doc(c.doc)} for c in module.constants],
        "tables": [
            {"macro": names.macro(t.name), "doc": names.doc(t.doc),
             "values": [precision.literal(v if v is not None else t.sign * big) for v in t.values]}
            for t in module.tables
        ],
        "arrays": {"ang": ANGLES, "cs": COSINES, "sn": SINES},
        "stride": STRIDE,
    }


TEMPLATES = {".h": "c/header.h.j2", ".c": "c/source.c.j2"}


def render(module: Module, stamp: str) -> dict[str, str]:
    """``{suffix: text}`` of the header and the source."""
    from ..templating import render_template

    ctx = context(module)
    return {suffix: render_template(name, stamp=stamp, **ctx) for suffix, name in TEMPLATES.items()}
