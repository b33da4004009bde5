"""The CPython extension backend (skelarm_sym/backends/cpython, templates/cpython/module.c.j2): a fast entry
per straight-line function for one configuration, everything else through CompiledArm's ordinary path.

What a user must be able to rely on: the fast path gives the ctypes path's bits; anything the fast entry
does not take (lists, keywords, other dtypes, batches, strided or misaligned buffers, values outside the
domain, odd scalars) gives exactly the ordinary path's result or exception and message; nothing leaks;
outputs are fresh arrays; the generated ``.ext.c`` is tied to its ``.c`` by the stamp and compiles
warning-free under the strict flags; the CLI generates, compiles and checks it; robot-file text reaches it
only escaped. A few small arms are generated and compiled once per module."""

from __future__ import annotations

import array
import dataclasses
import gc
import math
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym import InputError
from skelarm_sym.backends.cpython import SingleCalls
from skelarm_sym.build import STRICT_FLAGS, CompileError, compile_arm, python_headers
from skelarm_sym.cli import main
from skelarm_sym.generate import generate
from skelarm_sym.models import DiffDrive, PlanarArm
from skelarm_sym.models.chain.loader import load_robot
from skelarm_sym.wrapper import CompiledArm, load_extension

ROOT = Path(__file__).resolve().parents[1]
UR5 = ROOT / "examples" / "robots" / "ur5.toml"
FIXTURES = Path(__file__).resolve().parent / "fixtures" / "robots"
COMPILERS = [cc for cc in ("gcc", "clang") if shutil.which(cc)]
HEADERS = python_headers()

pytestmark = [
    pytest.mark.skipif(not COMPILERS and not shutil.which("cc"), reason="no C compiler on PATH"),
    pytest.mark.skipif(HEADERS is None, reason="no Python.h for this interpreter, or not Linux: the extension is not built"),
]

ARMS = {
    "planar3-double": (lambda: PlanarArm(3), "double", None),
    "planar3-float": (lambda: PlanarArm(3), "float", None),
    "diffdrive-double": (lambda: DiffDrive(None), "double", None),
    "diffdrive-float": (lambda: DiffDrive(None), "float", None),
    "ur5-double": (lambda: load_robot(UR5), "double", "pose,jacobian,kinematics"),
}


@dataclasses.dataclass
class Arm:
    name: str
    generated: object
    fast: CompiledArm  # with the extension
    plain: CompiledArm  # the same library through ctypes alone: the ordinary path

    @property
    def dtype(self):
        return self.fast.dtype

    @property
    def straight(self):
        return [f for f in self.generated.module.public if f.kind == "straight"]


@pytest.fixture(scope="module")
def arms() -> dict[str, Arm]:
    out = {}
    for name, (make, precision, functions) in ARMS.items():
        prefix = name.split("-")[0]
        g = generate(make(), langs="c,cpython", out=None, prefix=prefix, precision=precision, functions=functions)
        assert prefix + ".ext.c" in g.sources
        fast = compile_arm(g)  # the default takes the extension when the set has it
        assert fast.extension is not None, name
        out[name] = Arm(name, g, fast, CompiledArm(fast.path, g.module))
    return out


def valid_args(f, dtype, rng) -> list:
    """One configuration inside every domain: arrays of the real type, Python floats."""
    args = []
    for a in f.inputs:
        low, high = {"positive": (0.3, 1.5), "nonnegative": (0.0, 0.5)}.get(a.domain, (-2.0, 2.0))
        args.append(float(rng.uniform(low, high)) if a.is_scalar else rng.uniform(low, high, a.size).astype(dtype))
    return args


def outcome(call):
    """What a call gives, comparable bit for bit: the returned arrays (type, dtype, shape, bytes) or the
    exception's type and message, and the warnings either way."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = call()
        except Exception as exc:  # noqa: BLE001 - the exception is what is compared
            return ("raised", type(exc), str(exc), [str(w.message) for w in caught])
    if not isinstance(result, (np.ndarray, tuple)):
        return ("returned", type(result), (), [str(w.message) for w in caught])
    outs = result if isinstance(result, tuple) else (result,)
    shown = tuple((type(o), o.dtype.str, o.shape, o.tobytes()) for o in outs)
    return ("returned", type(result), shown, [str(w.message) for w in caught])


def flat(result) -> list[np.ndarray]:
    return list(result) if isinstance(result, tuple) else [result]


# -- the fast path gives the ctypes path's bits ------------------------------------------------------------


def test_fast_equals_ctypes_bit_for_bit(arms, rng):
    for arm in arms.values():
        for f in arm.straight:
            entry = getattr(arm.fast.extension, f.name)
            for k in range(6):
                args = valid_args(f, arm.dtype, rng)
                if k == 0:  # zero angles and rates: the singular corner
                    args = [x * 0 if a.domain == "finite" else x for x, a in zip(args, f.inputs)]
                direct = entry(*args)
                assert direct is not NotImplemented, (arm.name, f.name)
                want = outcome(lambda: getattr(arm.plain, f.name)(*args))
                assert want[0] == "returned"
                assert outcome(lambda: direct) == want, (arm.name, f.name)
                assert outcome(lambda: getattr(arm.fast, f.name)(*args)) == want, (arm.name, f.name)


def test_fast_equals_a_library_built_without_the_extension(arms, rng):
    """The ordinary path of the other tests shares the extension's library; this one is built alone, as
    ``compile_arm(..., extension=False)`` builds it (what users had before the extension)."""
    arm = arms["planar3-double"]
    alone = compile_arm(arm.generated, extension=False)
    assert alone.extension is None and alone.path != arm.fast.path
    for f in arm.straight:
        args = valid_args(f, arm.dtype, rng)
        assert outcome(lambda: getattr(arm.fast.extension, f.name)(*args)) == outcome(lambda: getattr(alone, f.name)(*args))


def test_the_fast_path_is_taken_and_the_ordinary_one_is_not(arms, rng, monkeypatch):
    arm = arms["planar3-double"]
    calls = []
    ordinary = arm.fast._call
    monkeypatch.setattr(arm.fast, "_call", lambda f, args: calls.append(f.name) or ordinary(f, args))
    for f in arm.straight:
        args = valid_args(f, arm.dtype, rng)
        assert all(isinstance(x, np.ndarray) for x in flat(getattr(arm.fast.extension, f.name)(*args)))
        getattr(arm.fast, f.name)(*args)
    assert calls == []
    f = arm.straight[0]
    args = valid_args(f, arm.dtype, rng)
    getattr(arm.fast, f.name)(*[x.tolist() if isinstance(x, np.ndarray) else x for x in args])
    assert calls == [f.name]  # and a list goes the ordinary way


# -- every fall-back gives the ordinary path's result or exception, message and warnings -----------------


class Sub(np.ndarray):
    pass


class F(float):
    pass


def _first(f, want):
    return next((i for i, a in enumerate(f.inputs) if want(a)), None)


SKIP = object()
"""What a change returns where it does not apply (an array of length 1 cannot be strided)."""


def on_array(change, want=lambda a: True):
    """A case that changes the first array input satisfying ``want`` (None: not applicable)."""
    def case(f, args, dtype):
        i = _first(f, lambda a: not a.is_scalar and want(a))
        if i is None:
            return None
        new = change(args[i], dtype)
        return None if new is SKIP else args[:i] + [new] + args[i + 1:]
    return case


def on_scalar(change, want=lambda a: True):
    def case(f, args, dtype):
        i = _first(f, lambda a: a.is_scalar and want(a))
        if i is None:
            return None
        return args[:i] + [change(args[i])] + args[i + 1:]
    return case


def with_value(value):
    def change(x, dtype):
        y = x.copy()
        with np.errstate(over="ignore"):  # 1e300 into float32: inf, as intended
            y[-1] = value
        return y
    return change


def misaligned(x, dtype):
    raw = bytearray(x.nbytes + 1)
    y = np.frombuffer(raw, dtype=x.dtype, count=x.size, offset=1)
    y[:] = x
    assert y.ctypes.data % x.itemsize != 0
    return y


def misaligned_memoryview(x, dtype):
    """A buffer of the right format ('d', 'f') one byte off its alignment (NumPy says '=d' for its own
    misaligned arrays, which the format check already refuses; memoryview says 'd')."""
    view = memoryview(bytearray(x.nbytes + 1))[1:].cast(x.dtype.char)
    view[:] = array.array(x.dtype.char, x.tolist())
    assert view.format == x.dtype.char
    return view


def strided(x, dtype):
    if x.size < 2:
        return SKIP
    y = np.repeat(x, 2)[::2]
    assert not y.flags.c_contiguous
    return y


def readonly(x, dtype):
    y = x.copy()
    y.setflags(write=False)
    return y


finite = lambda a: a.domain != ""  # noqa: E731
positive = lambda a: a.domain == "positive"  # noqa: E731
nonnegative = lambda a: a.domain == "nonnegative"  # noqa: E731
batched = lambda a: a.batched  # noqa: E731
shared = lambda a: not a.batched  # noqa: E731
other = {np.dtype(np.float64): np.float32, np.dtype(np.float32): np.float64}

# (name, change(f, args, dtype) -> args or None when not applicable, whether the fast entry takes it:
#  True, False, "double" (in double code only: the value leaves its domain when cast to float), None:
#  keywords, which the fast entry is never given)
CASES = [
    ("list", on_array(lambda x, d: x.tolist()), False),
    ("tuple", on_array(lambda x, d: tuple(x.tolist())), False),
    ("keywords", lambda f, args, d: args, None),
    ("no arguments", lambda f, args, d: [], False),
    ("one argument missing", lambda f, args, d: args[:-1], False),
    ("one argument too many", lambda f, args, d: args + [args[0]], False),
    ("the other float dtype", on_array(lambda x, d: x.astype(other[x.dtype])), False),
    ("int array", on_array(lambda x, d: np.arange(1, x.size + 1)), False),
    ("int32 array", on_array(lambda x, d: np.arange(1, x.size + 1, dtype=np.int32)), False),
    ("bool array", on_array(lambda x, d: np.ones(x.size, bool)), False),
    ("complex array", on_array(lambda x, d: x.astype(complex)), False),
    ("object array", on_array(lambda x, d: x.astype(object)), False),
    ("big-endian", on_array(lambda x, d: x.astype(x.dtype.newbyteorder(">"))), False),
    ("step slice", on_array(strided), False),
    ("reversed view", on_array(lambda x, d: x[::-1] if x.size > 1 else SKIP), False),
    ("one-row batch", on_array(lambda x, d: x[None, :], batched), False),
    ("batch of four", on_array(lambda x, d: np.stack([x, x * 0.5, x * 0.25, x]), batched), False),
    ("shared input as a batch", on_array(lambda x, d: x[None, :], shared), False),
    ("column", on_array(lambda x, d: x[:, None]), False),
    ("too short", on_array(lambda x, d: x[:-1]), False),
    ("too long", on_array(lambda x, d: np.append(x, x[:1])), False),
    ("0-d array", on_array(lambda x, d: x[0].reshape(())), False),
    ("NaN where finite", on_array(with_value(np.nan), finite), False),
    ("inf where finite", on_array(with_value(np.inf), finite), False),
    ("-inf where finite", on_array(with_value(-np.inf), finite), False),
    ("zero where positive", on_array(with_value(0.0), positive), False),
    ("negative where positive", on_array(with_value(-1.0), positive), False),
    ("tiny where positive", on_array(with_value(1e-50), positive), "double"),  # float: 0 after the cast
    ("huge where positive", on_array(with_value(1e300), positive), "double"),  # float: inf after the cast
    ("string", on_array(lambda x, d: "0.1, 0.2"), False),
    ("None", on_array(lambda x, d: None), False),
    ("ndarray subclass", on_array(lambda x, d: x.view(Sub)), True),
    ("readonly", on_array(readonly), True),
    ("misaligned", on_array(misaligned), False),
    ("misaligned memoryview", on_array(misaligned_memoryview), False),
    ("array.array", on_array(lambda x, d: array.array(x.dtype.char, x.tolist())), True),
    ("memoryview", on_array(lambda x, d: memoryview(x)), True),
    ("scalar NaN", on_scalar(lambda v: math.nan), False),
    ("scalar inf", on_scalar(lambda v: math.inf), False),
    ("scalar zero where positive", on_scalar(lambda v: 0.0, positive), False),
    ("scalar -0.0 where positive", on_scalar(lambda v: -0.0, positive), False),
    ("scalar -0.0 where nonnegative", on_scalar(lambda v: -0.0, nonnegative), True),
    ("scalar negative", on_scalar(lambda v: -1.0, lambda a: a.domain in ("positive", "nonnegative")), False),
    ("scalar 1e300", on_scalar(lambda v: 1e300), "double"),  # float: out of range, the ordinary path says
    ("numpy float64 scalar", on_scalar(lambda v: np.float64(v)), True),
    ("float subclass", on_scalar(lambda v: F(v)), True),
    ("numpy float32 scalar", on_scalar(lambda v: np.float32(v)), False),
    ("numpy int64 scalar", on_scalar(lambda v: np.int64(2)), False),
    ("int scalar", on_scalar(lambda v: 2), True),
    ("int above 2**24", on_scalar(lambda v: 2**60 + 2**36 + 1), True),  # rounded once in float code
    ("bool scalar", on_scalar(lambda v: True), False),
    ("int 2**63 (uint64)", on_scalar(lambda v: 2**63), False),
    ("int 2**64", on_scalar(lambda v: 2**64), False),
    ("int -2**63 - 1", on_scalar(lambda v: -(2**63) - 1), False),
    ("int 10**400", on_scalar(lambda v: 10**400), False),
    ("0-d array scalar", on_scalar(lambda v: np.array(v)), False),
    ("one-element array scalar", on_scalar(lambda v: np.array([v])), False),
    ("string scalar", on_scalar(lambda v: "1"), False),
]


@pytest.mark.parametrize("name, change, fast", CASES, ids=[c[0] for c in CASES])
def test_what_the_fast_entry_does_not_take_goes_the_ordinary_way(arms, name, change, fast):
    rng = np.random.default_rng(7)
    applied = 0
    for arm in arms.values():
        for f in arm.straight:
            args = change(f, valid_args(f, arm.dtype, rng), arm.dtype)
            if args is None:
                continue
            applied += 1
            method, ordinary = getattr(arm.fast, f.name), getattr(arm.plain, f.name)
            if fast is None:
                kwargs = dict(zip(method.__signature__.parameters, args))
                assert outcome(lambda: method(**kwargs)) == outcome(lambda: ordinary(**kwargs)), (arm.name, f.name)
                continue
            want = outcome(lambda: ordinary(*args))
            direct = outcome(lambda: getattr(arm.fast.extension, f.name)(*args))
            if fast is True or fast == arm.fast.precision:
                assert direct == want, (arm.name, f.name)  # taken, with the ordinary path's bits
            else:
                assert direct[:3] == ("returned", type(NotImplemented), ()), (arm.name, f.name, direct[:3])
            assert outcome(lambda: method(*args)) == want, (arm.name, f.name)
    assert applied, name


def test_fallbacks_keep_the_ordinary_messages(arms):
    """A few of the cases above spelled out, so that a change in both paths at once is seen too."""
    arm = arms["planar3-double"]
    q, l, v = np.zeros(3), np.ones(3), np.zeros(2)
    with pytest.raises(TypeError, match=r"^position\(q, l\): missing a required argument: 'l'$"):
        arm.fast.position(q)
    with pytest.raises(InputError, match="^q must be finite$"):
        arm.fast.position(np.array([0.0, np.nan, 0.0]), l)
    with pytest.raises(InputError, match="^l must be > 0$"):
        arm.fast.position(q, np.array([1.0, 0.0, 1.0]))
    with pytest.raises(InputError, match="^lambda must be >= 0$"):
        arm.fast.inverse_velocity(q, v, l, -1.0)
    with pytest.raises(InputError, match="^lambda must hold real numbers, got object$"):
        arm.fast.inverse_velocity(q, v, l, None)
    # an int beyond int64 is a number (it was refused as an object): a huge damping, rates near 0
    assert np.all(np.abs(arm.fast.inverse_velocity(q, v, l, 2**64)) < 1e-12)
    with pytest.raises(InputError, match=re.escape("q must have shape (..., 3), got (2,)")):
        arm.fast.position(q[:2], l)
    assert arm.fast.position(np.zeros((4, 3)), l).shape == (4, 2)


# -- nothing leaks -----------------------------------------------------------------------------------------


def _resident_bytes() -> int:
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * 4096


def _leak_inputs(arm: Arm, name: str):
    """``(valid args, [fall-back args])`` of one function: failures at each step of the entry (argument
    count, the first array, a later array after the first is held, the scalar after the arrays)."""
    f = arm.generated.module.function(name)
    args = valid_args(f, arm.dtype, np.random.default_rng(1))
    arrays = [i for i, a in enumerate(f.inputs) if not a.is_scalar]
    scalars = [i for i, a in enumerate(f.inputs) if a.is_scalar]
    bad = [args[:-1]]
    first, last = arrays[0], arrays[-1]
    bad.append(args[:first] + [args[first].astype(other[args[first].dtype])] + args[first + 1:])
    bad.append(args[:first] + [args[first].tolist()] + args[first + 1:])
    nan = args[last].copy()
    nan[0] = np.nan
    bad.append(args[:last] + [nan] + args[last + 1:])
    if scalars:
        s = scalars[-1]
        bad.append(args[:s] + [math.nan] + args[s + 1:])
        bad.append(args[:s] + [2**70] + args[s + 1:])
    return args, bad


LEAK_CALLS = 100_000


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the resident size from /proc")
def test_no_reference_or_memory_leaks(arms):
    cases = [(arms["planar3-double"], "inverse_velocity"), (arms["planar3-float"], "kinematics"),
             (arms["diffdrive-double"], "body_rates"), (arms["ur5-double"], "kinematics")]
    watched = (NotImplemented, np.empty, np.float32, np.ndarray, tuple)
    for arm, name in cases:  # a few calls first: a missing reference to NotImplemented would free it below
        entry = getattr(arm.fast.extension, name)
        for inputs in _leak_inputs(arm, name)[1]:
            before = sys.getrefcount(NotImplemented)
            for _ in range(10):
                assert entry(*inputs) is NotImplemented
            assert sys.getrefcount(NotImplemented) == before, (arm.name, name)
    for arm, name in cases:  # warm up: numpy's caches, the allocator's arenas
        entry = getattr(arm.fast.extension, name)
        args, bad = _leak_inputs(arm, name)
        for _ in range(2000):
            entry(*args)
            for b in bad:
                entry(*b)
    gc.collect()
    resident = _resident_bytes()
    for arm, name in cases:
        entry = getattr(arm.fast.extension, name)
        args, bad = _leak_inputs(arm, name)
        for inputs in [args, *bad]:
            counts = [sys.getrefcount(x) for x in inputs]
            globals_before = [sys.getrefcount(x) for x in watched]
            for _ in range(LEAK_CALLS):
                entry(*inputs)
            assert [sys.getrefcount(x) for x in inputs] == counts, (arm.name, name)
            assert [sys.getrefcount(x) for x in watched] == globals_before, (arm.name, name)
        result = entry(*args)
        assert sys.getrefcount(result) == 2  # ours and getrefcount's: no buffer of it still held
        if isinstance(result, tuple):
            assert [sys.getrefcount(result[k]) for k in range(len(result))] == [2] * len(result)  # the tuple's
    gc.collect()
    grown = _resident_bytes() - resident
    # a leaked output array per call would be 10 MB and more over these 2.4 million calls
    assert grown < 4 << 20, f"resident size grew by {grown / 2**20:.1f} MiB"


# -- outputs are fresh -------------------------------------------------------------------------------------


def test_outputs_are_fresh_writable_arrays_of_the_declared_shapes(arms, rng):
    for arm in arms.values():
        for f in arm.straight:
            entry = getattr(arm.fast.extension, f.name)
            args = valid_args(f, arm.dtype, rng)
            before = [x.tobytes() if isinstance(x, np.ndarray) else x for x in args]
            first, second = flat(entry(*args)), flat(entry(*args))
            assert [x.tobytes() if isinstance(x, np.ndarray) else x for x in args] == before  # inputs untouched
            assert len(first) == len(f.outputs)
            for o, a, b in zip(f.outputs, first, second):
                for x in (a, b):
                    assert type(x) is np.ndarray and x.dtype == arm.dtype and x.shape == tuple(o.shape)
                    assert x.flags.writeable and x.flags.owndata and x.flags.c_contiguous and x.flags.aligned
                    assert x.base is None
                assert a is not b and not np.shares_memory(a, b)
                assert all(not np.shares_memory(a, y) for y in first if y is not a)
                assert all(not np.shares_memory(a, x) for x in args if isinstance(x, np.ndarray))
                a[...] = 123.0
                assert not np.any(b == 123.0)
            again = flat(entry(*args))
            assert all(np.array_equal(x, y) for x, y in zip(again, second))


# -- compile_arm and the library ---------------------------------------------------------------------------


def test_compile_arm_extension_choices(arms, monkeypatch):
    g = generate(DiffDrive(None), langs="c", out=None, prefix="dd_c", functions="body_rates")
    built = compile_arm(g, extension=True)  # rendered from the module: the set has no .ext.c
    assert built.extension is not None and built.extension.__name__ == "dd_c_ext"
    assert compile_arm(g).extension is None  # the default: only when the set has the file
    assert compile_arm(arms["diffdrive-double"].generated, extension=False).extension is None
    import skelarm_sym.build as build

    monkeypatch.setattr(build, "python_headers", lambda: None)
    with pytest.raises(InputError, match="needs this Python's headers"):
        compile_arm(g, extension=True)
    assert compile_arm(arms["diffdrive-double"].generated).extension is None  # quietly ctypes alone


def test_an_extension_that_does_not_compile(arms):
    g = arms["diffdrive-double"].generated
    broken = dataclasses.replace(g, sources={**g.sources, "diffdrive.ext.c": "#error planted\n"})
    with pytest.raises(CompileError, match="compiling diffdrive.ext.c failed: .*planted"):
        compile_arm(broken, extension=True)
    with pytest.warns(RuntimeWarning, match="did not compile; single calls go through ctypes"):
        arm = compile_arm(broken)
    assert arm.extension is None
    assert np.array_equal(arm.body_rates(np.ones(2), 0.5), arms["diffdrive-double"].fast.body_rates(np.ones(2), 0.5))


def test_one_library_loaded_twice(arms):
    arm = arms["diffdrive-double"]
    one = CompiledArm(arm.fast.path, arm.generated.module, extension="diffdrive_ext")
    two = CompiledArm(arm.fast.path, arm.generated.module, extension="diffdrive_ext")
    assert one.extension is not two.extension
    wheels = np.array([0.25, -0.5])
    assert np.array_equal(one.body_rates(wheels, 0.4), two.extension.body_rates(wheels, 0.4))
    assert np.array_equal(one.body_rates(wheels, 0.4), arm.plain.body_rates(wheels, 0.4))


# -- the .ext.c file ---------------------------------------------------------------------------------------


def _write(generated, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in generated.sources.items():
        (folder / name).write_text(text)
    return folder


def _cc(compiler, folder: Path, prefix: str, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([compiler, *STRICT_FLAGS, *extra, *HEADERS, "-fPIC", "-shared", "-o", str(folder / f"{prefix}.so"),
                           str(folder / f"{prefix}.ext.c"), "-lm"], capture_output=True, text=True, cwd=folder)


def test_a_mismatched_stamp_does_not_compile(arms, tmp_path):
    compiler = (COMPILERS or ["cc"])[0]
    good = _write(arms["diffdrive-double"].generated, tmp_path / "good")
    assert _cc(compiler, good, "diffdrive", "-O0").returncode == 0  # the control
    text = (good / "diffdrive.ext.c").read_text()
    stamp = arms["diffdrive-double"].generated.stamp
    line = next(line for line in text.splitlines() if line.startswith("#if") and "STAMP" in line)
    assert stamp in line
    edited = _write(arms["diffdrive-double"].generated, tmp_path / "edited")
    (edited / "diffdrive.ext.c").write_text(text.replace(line, line.replace(stamp, "0x0badf00d")))
    mixed = _write(arms["diffdrive-double"].generated, tmp_path / "mixed")  # the C of another generation
    (mixed / "diffdrive.ext.c").write_text(arms["diffdrive-float"].generated.sources["diffdrive.ext.c"])
    for folder in (edited, mixed):
        result = _cc(compiler, folder, "diffdrive", "-O0")
        assert result.returncode != 0
        assert "are not those generated with this diffdrive.ext.c: regenerate them together" in result.stderr


@pytest.mark.parametrize("compiler", COMPILERS)
@pytest.mark.parametrize("precision", ["double", "float"])
def test_the_extension_compiles_strictly_without_warnings(arms, compiler, precision, tmp_path):
    arm = arms[f"diffdrive-{precision}"]
    folder = _write(arm.generated, tmp_path)
    result = _cc(compiler, folder, "diffdrive", "-O2")
    assert result.returncode == 0 and result.stderr == "" and result.stdout == "", result.stderr[:3000]
    # the two paths of this compiler's library agree bit for bit (another compiler may round otherwise)
    fast = CompiledArm(folder / "diffdrive.so", arm.generated.module, extension="diffdrive_ext")
    plain = CompiledArm(folder / "diffdrive.so", arm.generated.module)
    pose, wheels = np.array([0.1, 0.2, 0.3], arm.dtype), np.array([0.3, -0.1], arm.dtype)
    direct = fast.extension.pose_rate(pose, wheels, 0.5)
    assert isinstance(direct, np.ndarray)
    assert outcome(lambda: direct) == outcome(lambda: plain.pose_rate(pose, wheels, 0.5))


# -- the command line --------------------------------------------------------------------------------------


def test_cli_generate_compile_and_check_from(tmp_path, capsys):
    out = tmp_path / "ur5"
    assert main(["generate", "--robot", str(UR5), "--functions", "pose,jacobian", "--lang", "c,cpython", "--compile",
                 "--out", str(out), "--prefix", "ur5"]) == 0
    text = capsys.readouterr().out
    assert "compiled" in text
    assert sorted(p.name for p in out.iterdir()) == ["ur5.c", "ur5.ext.c", "ur5.h"]
    assert main(["check", "--from", str(out), "--cases", "5"]) == 0
    text = capsys.readouterr().out
    assert re.search(r"^CPython pose +T .* ok$", text, re.M) and re.search(r"^CPython jacobian +J .* ok$", text, re.M)
    assert "4 passed, 0 failed" in text


def test_check_calls_the_extension_one_configuration_at_a_time(arms, monkeypatch):
    arm = arms["planar3-double"]
    single = SingleCalls(arm.fast)
    monkeypatch.setattr(arm.fast, "_call", lambda f, args: pytest.fail("the ctypes path was taken"))
    q = np.random.default_rng(2).uniform(-1, 1, (2, 5, 3))
    l = np.array([1.0, 0.8, 0.5])
    got = single.kinematics(q, q, q, l)
    want = arm.plain.kinematics(q, q, q, l)
    assert all(x.shape == y.shape and np.array_equal(x, y) for x, y in zip(got, want))
    assert np.array_equal(single.position(q[0, 0], l), arm.plain.position(q[0, 0], l))
    monkeypatch.undo()  # from here the ordinary path may run: it judges what the extension refuses
    q[1, 2, 0] = np.nan
    with pytest.raises(ValueError, match="q must be finite"):  # bad input: the ordinary path's error
        single.position(q, l)
    monkeypatch.setattr(arm.fast.extension, "position", lambda *args: NotImplemented)
    with pytest.raises(RuntimeError, match=r"refused configuration \(0, 0\)"):  # good input refused: an error
        single.position(q[:1, :1], l)
    with pytest.raises(RuntimeError, match="without its CPython extension"):
        SingleCalls(arm.plain)


# -- robot-file text ---------------------------------------------------------------------------------------


def foreign_texts(chain) -> list[str]:
    """Every piece of robot-file text the model carries (as tests/test_foreign_text.py reads it)."""
    texts = [chain.name, chain.description, *chain.coordinates, *(j.name for j in chain.joints)]
    texts += [value for _, value in chain.load_options]
    return [t for t in texts if t]


@pytest.mark.parametrize("robot", ["hostile_names.urdf", "hostile_names.toml"])
def test_robot_file_text_reaches_the_extension_only_escaped(robot, tmp_path, monkeypatch):
    chain = load_robot(FIXTURES / robot)
    g = generate(chain, langs="c,cpython", out=None, prefix="fixture", functions="pose")
    text = g.sources["fixture.ext.c"]
    assert sorted({ch for ch in text if not (32 <= ord(ch) < 127 or ch == "\n")}) == []
    dangerous = [t for t in foreign_texts(chain) if any(s in t for s in ("*/", "/*", "??", "\\")) or not t.isascii()]
    assert dangerous, "the fixture lost its hostile text"
    for foreign in dangerous:
        assert foreign not in text, foreign
    stripped = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    assert "*/" not in stripped and "/*" not in stripped
    strings = re.findall(r'"((?:[^"\\\n]|\\.)*)"', stripped)
    assert all(re.fullmatch(r"[A-Za-z0-9_ .,()'/:-]*", s) for s in strings), strings
    folder = _write(g, tmp_path)
    monkeypatch.chdir(tmp_path)
    result = _cc((COMPILERS or ["cc"])[0], folder, "fixture", "-O0")
    assert result.returncode == 0, result.stderr[:3000]
    extension = load_extension(folder / "fixture.so", "fixture_ext")
    assert not any(p.name == "pwned" for p in tmp_path.iterdir())
    pose = extension.pose(*valid_args(g.module.function("pose"), np.float64, np.random.default_rng(0)))
    assert pose.shape == (4, 4) and np.isfinite(pose).all()
