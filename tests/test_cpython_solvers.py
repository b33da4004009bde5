"""The CPython extension's solver entries (``ik_all``, ``ik_nearest``, ``ik_solve``): one problem per call in
about a microsecond of overhead instead of tens through ctypes.

What a user relies on: through ``CompiledArm`` the fast entry gives exactly the ctypes path's record (bits,
statuses, Python numbers for the small outputs), omitted arguments with number defaults included; whatever the
entry does not take (lists, keywords, batches, other dtypes, defaults that depend on other arguments, values
outside their domain) goes the ordinary way with its result and message; an invalid target is the same
``ValueError``; inputs keep their reference counts; the ``.ext.c`` compiles strictly under gcc and clang."""

from __future__ import annotations

import functools
import shutil
import subprocess
import sys

import numpy as np
import pytest

from skelarm_sym.build import STRICT_FLAGS, compile_arm, python_headers
from skelarm_sym.generate import generate
from skelarm_sym.models import PlanarArm
from skelarm_sym.models.chain.lock import with_ik_lock
from skelarm_sym.models.chain.loader import load_robot

from closed_ik_support import ROBOTS, random_configurations, targets_of

HEADERS = python_headers()
COMPILERS = [cc for cc in ("gcc", "clang") if shutil.which(cc)]
pytestmark = pytest.mark.skipif(HEADERS is None, reason="no Python.h for this interpreter, or not Linux: no extension")


class Pair:
    """One generation compiled twice: with its extension (``fast``) and as the ctypes library alone (``plain``)."""

    def __init__(self, model, functions: str | None, precision: str = "double") -> None:
        self.model = model
        self.generated = generate(model, out=None, functions=functions, langs="c,cpython", precision=precision)
        self.fast = compile_arm(self.generated, extension=True)
        self.plain = compile_arm(self.generated, extension=False)
        self.dtype = self.fast.dtype


@functools.lru_cache(maxsize=None)
def pair(name: str, precision: str = "double") -> Pair:
    if name == "puma560":
        return Pair(load_robot(ROBOTS / "puma560.toml"), "ik_solve,ik_all,ik_nearest", precision)
    if name == "iiwa14_lock3":
        return Pair(with_ik_lock(load_robot(ROBOTS / "iiwa14.toml"), 3), "ik_all,ik_nearest", precision)
    return Pair(PlanarArm(3), "ik_solve", precision)


def same(a, b) -> bool:
    """Two records equal field by field: arrays bit for bit (NaN where NaN) with their dtype, other values by
    type and value."""
    if type(a).__name__ != type(b).__name__ or a._fields != b._fields:  # each library makes its own record class
        return False
    for x, y in zip(a, b):
        if isinstance(x, np.ndarray):
            if not (isinstance(y, np.ndarray) and x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y, equal_nan=True)):
                return False
        elif type(x) is not type(y) or x != y:
            return False
    return True


def chain_problems(p: Pair, m: int, seed: int):
    chain = p.model
    q = random_configurations(chain, m, np.random.default_rng(seed), within_limits=True)
    return q.astype(p.dtype), targets_of(chain, q).astype(p.dtype)


@pytest.mark.parametrize("precision", ["double", "float"])
def test_solver_entries_give_the_ctypes_records(precision):
    """PUMA 560: ik_all, ik_nearest and ik_solve (every argument, and the scalars left to their defaults) through
    the extension equal the ctypes path's records bit for bit, for reachable targets and a far one."""
    p = pair("puma560", precision)
    q, T = chain_problems(p, 8, 1)
    far = T[0].copy()
    far[:3, 3] *= 40.0
    calls = []
    for j in range(len(T)):
        calls += [("ik_all", (T[j],)), ("ik_all", (T[j].reshape(16),)), ("ik_nearest", (q[j], T[j])),
                  ("ik_solve", (q[j] + p.dtype(0.2), T[j])), ("ik_solve", (q[(j + 1) % len(q)], T[j], 1e-3, 1e-9, 50))]
    calls += [("ik_all", (far,)), ("ik_solve", (q[0], far))]
    for name, args in calls:
        defaults = [a.default.value for a in p.generated.module.function(name).inputs[len(args):]]
        raw = getattr(p.fast.extension, name)(*args, *defaults)
        assert raw is not NotImplemented, (name, [np.shape(a) for a in args])
        assert same(getattr(p.fast, name)(*args), getattr(p.plain, name)(*args)), (name, args)


def test_the_fast_path_is_taken_and_the_ordinary_one_is_not(monkeypatch):
    """Positional NumPy arrays of the module's type (defaults omitted or not) never reach the ordinary path;
    a list, a keyword or a batch does, with the same result."""
    p = pair("puma560")
    q, T = chain_problems(p, 3, 2)
    seen = []
    ordinary = p.fast._solve
    monkeypatch.setattr(p.fast, "_solve", lambda f, args: seen.append(f.name) or ordinary(f, args))
    p.fast.ik_all(T[0])
    p.fast.ik_nearest(q[0], T[0])
    p.fast.ik_solve(q[1], T[0])
    p.fast.ik_solve(q[1], T[0], 0.0)
    assert seen == []
    assert same(p.fast.ik_all(T[0].tolist()), p.plain.ik_all(T[0]))
    assert same(p.fast.ik_solve(q[1], target=T[0]), p.plain.ik_solve(q[1], T[0]))
    batch = p.fast.ik_all(T)
    assert seen == ["ik_all", "ik_solve", "ik_all"] and batch.q.shape == (3, 8, 6)


def test_a_locked_joint_and_a_default_that_depends_on_other_arguments():
    """iiwa 14 with joint 3 locked: the lock is a real scalar of the entry (an int lock is converted like NumPy
    would). A planar arm's ik_solve, whose tol default scales with the lengths: omitted, it goes the ordinary
    way; given, the fast one; both equal the ctypes records."""
    p = pair("iiwa14_lock3")
    q, T = chain_problems(p, 3, 3)
    for j in range(3):
        assert p.fast.extension.ik_all(T[j], float(q[j, 2])) is not NotImplemented
        assert same(p.fast.ik_all(T[j], float(q[j, 2])), p.plain.ik_all(T[j], float(q[j, 2])))
        assert same(p.fast.ik_nearest(q[j], T[j], float(q[j, 2])), p.plain.ik_nearest(q[j], T[j], float(q[j, 2])))
    assert same(p.fast.ik_all(T[0], 1), p.plain.ik_all(T[0], 1))
    planar = pair("planar3")
    l = np.array([0.5, 0.4, 0.3])
    target = np.array([0.6, 0.3])
    q0 = np.array([0.1, 0.2, 0.3])
    assert same(planar.fast.ik_solve(q0, target, l), planar.plain.ik_solve(q0, target, l))
    assert planar.fast.extension.ik_solve(q0, target, l, 0.0, 1e-9, 200) is not NotImplemented
    assert same(planar.fast.ik_solve(q0, target, l, 0.0, 1e-9, 200), planar.plain.ik_solve(q0, target, l, 0.0, 1e-9, 200))


def test_what_the_entry_does_not_take_gets_the_ordinary_answer():
    """Values outside their domain, wrong shapes and dtypes, a bool for max_iter, an invalid target: the entry
    answers NotImplemented (no exception set) and the wrapper gives the ordinary path's result or error."""
    p = pair("puma560")
    q, T = chain_problems(p, 1, 4)
    entry = p.fast.extension
    bad_rotation = T[0].copy()
    bad_rotation[:3, :3] *= 1.01
    nan_target = T[0].copy()
    nan_target[0, 3] = np.nan
    cases = [
        ("ik_solve", (q[0], T[0], -1.0, 1e-10, 100)),  # lambda < 0
        ("ik_solve", (q[0], T[0], 0.0, 0.0, 100)),  # tol must be > 0
        ("ik_solve", (q[0], T[0], 0.0, 1e-10, True)),  # a bool is not a count
        ("ik_solve", (q[0], T[0], 0.0, 1e-10, 2**40)),  # beyond a C int
        ("ik_solve", (q[0], T[0], 0.0, 1e-10, -1)),
        ("ik_all", (nan_target,)),
        ("ik_all", (T[0].astype(np.float32),)),
        ("ik_all", (T[0][:3],)),
        ("ik_nearest", (q[0][:5], T[0])),
    ]
    def outcome(call):
        try:
            return "returned", call()
        except ValueError as exc:
            return "raised", str(exc)

    raised = 0
    for name, args in cases:
        assert getattr(entry, name)(*args) is NotImplemented, (name, args)
        fast, plain = outcome(lambda: getattr(p.fast, name)(*args)), outcome(lambda: getattr(p.plain, name)(*args))
        assert fast[0] == plain[0], (name, args, fast, plain)
        assert fast[1] == plain[1] if fast[0] == "raised" else same(fast[1], plain[1])
        raised += fast[0] == "raised"
    assert raised >= 7  # the float32 target and the bool count are converted on the ordinary path
    status, *_ = entry.ik_all(bad_rotation)  # the entry solves; the wrapper turns INVALID into the error
    assert status == 3
    with pytest.raises(ValueError, match="not a rotation"):
        p.fast.ik_all(bad_rotation)


def test_entries_keep_reference_counts_and_give_fresh_arrays():
    """20 000 calls leave the inputs' reference counts as they were; two calls give different output arrays of the
    declared shapes and dtypes (flags: C ints, as through ctypes)."""
    p = pair("puma560")
    q, T = chain_problems(p, 1, 5)
    target, q_ref = T[0], q[0]
    before = (sys.getrefcount(target), sys.getrefcount(q_ref))
    for _ in range(10000):
        p.fast.extension.ik_all(target)
        p.fast.extension.ik_nearest(q_ref, target)
    assert (sys.getrefcount(target), sys.getrefcount(q_ref)) == before
    a, b = p.fast.ik_all(target), p.fast.ik_all(target)
    assert a.q is not b.q and a.q.shape == (8, 6) and a.q.flags.writeable and a.flags.dtype == np.intc
    assert isinstance(a.count, int) and a.status == "ok"


@pytest.mark.parametrize("compiler", [pytest.param(c, marks=pytest.mark.slow if c == "clang" else ()) for c in COMPILERS])
def test_the_solver_entries_compile_strictly(compiler, tmp_path):
    """The extension with solver entries (PUMA 560, double and float) compiles with -Werror under gcc and clang,
    at -O2 too (where GCC's flow analysis finds values that may be used uninitialized)."""
    for precision in ("double", "float"):
        g = generate(load_robot(ROBOTS / "puma560.toml"), out=tmp_path / precision, functions="ik_solve,ik_all,ik_nearest",
                     langs="c,cpython", precision=precision)
        source = next(path for path in g.paths if path.name.endswith(".ext.c"))
        for level in ("-O0", "-O2"):
            result = subprocess.run([compiler, *STRICT_FLAGS, level, *HEADERS, "-fPIC", "-c", str(source), "-o", str(tmp_path / "x.o")],
                                    capture_output=True, text=True)
            assert result.returncode == 0 and not result.stderr, (level, result.stderr[-2000:])
