"""Compile emitted C with the system compiler, cache it by content hash, load it, check shapes.

``compile_sources(sources)`` takes the ``{name: text}`` of one generated C
header and source (as :func:`skelarm_sym.generate.generate` returns them) and
gives a :class:`CompiledArm` whose methods have the emitted functions' names and
take NumPy arrays: ``arm.jacobian(q, l)`` with ``q`` of shape ``(..., N)``
returns ``(..., 2, N)``; batches go through the ``_batch`` C functions.

The shared library lives in a cache folder (``$SKELARM_SYM_CACHE``, else
``~/.cache/skelarm-sym``) under the SHA-256 of the sources, compiler and flags,
so a second call with the same inputs reuses it.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from .backends.common import IK_STATUS
from .errors import InputError
from .program import Program

DEFAULT_FLAGS = ("-O2",)
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")


class CompilerNotFound(InputError):
    """No C compiler could be found."""


def find_compiler(preferred: str | None = None) -> str:
    """The C compiler to use: ``preferred``, ``$CC``, then cc, gcc, clang on PATH."""
    for candidate in (preferred, os.environ.get("CC"), "cc", "gcc", "clang"):
        if candidate and shutil.which(shlex.split(candidate)[0]):
            return candidate
    raise CompilerNotFound(
        "no C compiler found: install gcc or clang (Debian/Ubuntu: apt-get install gcc) or set CC"
    )


def cache_folder() -> Path:
    """Where compiled libraries are kept."""
    root = os.environ.get("SKELARM_SYM_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "skelarm-sym"


def compile_shared(
    sources: dict[str, str],
    flags: Sequence[str] = DEFAULT_FLAGS,
    compiler: str | None = None,
    strict: bool = True,
) -> Path:
    """Compile the ``.c`` file of ``sources`` (with its headers beside it) into a cached shared library."""
    cc = find_compiler(compiler)
    all_flags = [*(STRICT_FLAGS if strict else ("-std=c99",)), *flags, "-fPIC", "-shared"]
    digest = hashlib.sha256()
    for name in sorted(sources):
        digest.update(name.encode() + b"\0" + sources[name].encode() + b"\0")
    digest.update(" ".join([cc, *all_flags]).encode())
    key = digest.hexdigest()[:24]
    c_files = [name for name in sources if name.endswith(".c")]
    if len(c_files) != 1:
        raise InputError("compile needs exactly one generated .c file (generate with lang 'c')")
    stem = c_files[0][:-2]
    suffix = ".dll" if sys.platform == "win32" else ".so"
    target = cache_folder() / key / f"lib{stem}{suffix}"
    if target.exists():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as work:
        for name, text in sources.items():
            if name.endswith((".c", ".h")):
                Path(work, name).write_text(text, encoding="utf-8")
        tmp_lib = Path(work, target.name)
        command = [*shlex.split(cc), *all_flags, "-o", str(tmp_lib), str(Path(work, c_files[0])), "-lm"]
        result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"compiling {c_files[0]} failed:\n{' '.join(command)}\n{result.stderr}")
        os.replace(tmp_lib, target)
    return target


@dataclass(frozen=True)
class _Signature:
    name: str
    inputs: tuple[tuple[str, int, bool, bool], ...]  # name, size, shared across a batch, scalar
    outputs: tuple[tuple[str, tuple[int, ...]], ...]
    domains: dict[str, str]


IK_STATUS_NAMES = tuple(s.lower() for s in IK_STATUS)


@dataclass(frozen=True)
class IKResult:
    """Outcome of an IK solve: final pose ``q`` (N,), ``status`` (one of ``IK_STATUS_NAMES``),
    endpoint error ``|target - p|`` at ``q``, and the number of steps taken."""

    q: np.ndarray
    status: str
    error: float
    iterations: int


def _check_domain(array: np.ndarray, name: str, domain: str) -> None:
    if domain and not np.all(np.isfinite(array)):
        raise InputError(f"{name} must be finite")
    if domain == "nonnegative" and np.any(array < 0):
        raise InputError(f"{name} must be >= 0")
    if domain == "positive" and np.any(array <= 0):
        raise InputError(f"{name} must be > 0")


class CompiledArm:
    """A loaded shared library; one method per emitted function (see the module docstring)."""

    def __init__(
        self, library: Path, prefix: str, programs: Sequence[Program], precision: str, shared: Sequence[str],
        domains: dict[str, str] | None = None,
    ):
        self.path = library
        self.prefix = prefix
        self.dtype = np.float64 if precision == "double" else np.float32
        self._lib = ctypes.CDLL(str(library))
        ctype = ctypes.c_double if precision == "double" else ctypes.c_float
        pointer = ctypes.POINTER(ctype)
        self._ctype = ctype
        self._signatures: dict[str, _Signature] = {}
        domains = domains or {}
        for program in programs:
            sig = _Signature(
                program.name,
                tuple((a.name, a.size, a.name in shared, a.is_scalar) for a in program.inputs),
                tuple((o.name, o.shape) for o in program.outputs),
                {a.name: domains[a.name] for a in program.inputs if a.name in domains},
            )
            self._signatures[program.name] = sig
            args = [ctype if a.is_scalar else pointer for a in program.inputs] + [pointer] * len(sig.outputs)
            single = getattr(self._lib, f"{prefix}_{program.name}")
            single.argtypes = args
            single.restype = None
            batch = getattr(self._lib, f"{prefix}_{program.name}_batch")
            batch.argtypes = [ctypes.c_size_t] + args
            batch.restype = None
        self._pointer = pointer
        self._ik = None
        if "ik_step" in self._signatures and hasattr(self._lib, f"{prefix}_ik_solve"):
            step = self._signatures["ik_step"]
            solve = getattr(self._lib, f"{prefix}_ik_solve")
            solve.argtypes = (
                [pointer] + [ctype if scalar else pointer for name, _, _, scalar in step.inputs if name != "q"]
                + [ctype, ctypes.c_int, pointer, pointer, ctypes.POINTER(ctypes.c_int)]
            )
            solve.restype = ctypes.c_int
            self._ik = solve

    @property
    def functions(self) -> tuple[str, ...]:
        """Names of the callable functions."""
        return tuple(self._signatures)

    def __getattr__(self, name: str):
        signatures = self.__dict__.get("_signatures", {})
        if name not in signatures:
            raise AttributeError(name)
        sig = signatures[name]

        def call(*args):
            return self._call(sig, args)

        call.__name__ = name
        return call

    def _call(self, sig: _Signature, args: tuple) -> np.ndarray | tuple[np.ndarray, ...]:
        if len(args) != len(sig.inputs):
            names = ", ".join(n for n, _, _ in sig.inputs)
            raise InputError(f"{sig.name} takes {len(sig.inputs)} arrays ({names}), got {len(args)}")
        arrays = []
        for value, (name, size, shared, scalar) in zip(args, sig.inputs):
            array = np.asarray(value, dtype=self.dtype)
            if scalar:
                if array.ndim != 0:
                    raise InputError(f"{name} must be a single number, got shape {array.shape}")
            elif shared:
                if array.shape != (size,):
                    raise InputError(f"{name} must have shape ({size},), got {array.shape}")
            elif array.ndim == 0 or array.shape[-1] != size:
                raise InputError(f"{name} must have shape (..., {size}), got {array.shape}")
            _check_domain(array, name, sig.domains.get(name, ""))
            arrays.append(array)
        per_config = [i for i, (_, _, shared, _) in enumerate(sig.inputs) if not shared]
        try:
            batch = np.broadcast_shapes(*(arrays[i].shape[:-1] for i in per_config))
        except ValueError:
            shapes = ", ".join(f"{sig.inputs[i][0]} {arrays[i].shape}" for i in per_config)
            raise InputError(f"{sig.name}: batch shapes do not broadcast: {shapes}") from None
        for i in per_config:
            arrays[i] = np.broadcast_to(arrays[i], batch + arrays[i].shape[-1:])
        m = int(np.prod(batch)) if batch else 1
        arrays = [a if a.ndim == 0 else np.ascontiguousarray(a) for a in arrays]
        outputs = [np.empty(batch + shape, dtype=self.dtype) for _, shape in sig.outputs]
        pointers = [
            self._ctype(float(a)) if scalar else a.ctypes.data_as(self._pointer)
            for a, (_, _, _, scalar) in zip(arrays, sig.inputs)
        ] + [o.ctypes.data_as(self._pointer) for o in outputs]
        if batch:
            getattr(self._lib, f"{self.prefix}_{sig.name}_batch")(m, *pointers)
        else:
            getattr(self._lib, f"{self.prefix}_{sig.name}")(*pointers)
        return outputs[0] if len(outputs) == 1 else tuple(outputs)

    def ik_solve(self, q0, *args, tol: float = 1e-9, max_iter: int = 200) -> IKResult:
        """Run the emitted C ``{prefix}_ik_solve``: ``args`` are ``ik_step``'s inputs after ``q``
        (``l`` when lengths are symbolic, ``target``, ``lambda``). Bad input raises InputError."""
        if self._ik is None:
            raise AttributeError("this library has no ik_solve (it needs position and ik_step)")
        step = self._signatures["ik_step"]
        n = step.inputs[0][1]
        q0 = np.ascontiguousarray(np.asarray(q0, dtype=self.dtype))
        if q0.shape != (n,) or not np.all(np.isfinite(q0)):
            raise InputError(f"q0 must be {n} finite numbers, got shape {q0.shape}")
        others = [x for x in step.inputs if x[0] != "q"]
        if len(args) != len(others):
            raise InputError(f"ik_solve takes q0 and {', '.join(x[0] for x in others)}")
        if not tol > 0 or int(max_iter) != max_iter or max_iter < 0:
            raise InputError(f"tol must be > 0 and max_iter a whole number >= 0, got {tol!r}, {max_iter!r}")
        c_args = [q0.ctypes.data_as(self._pointer)]
        keep = []
        for value, (name, size, _, scalar) in zip(args, others):
            array = np.asarray(value, dtype=self.dtype)
            array = array if array.ndim == 0 else np.ascontiguousarray(array)
            if array.shape != (() if scalar else (size,)):
                raise InputError(f"{name} must have shape {(() if scalar else (size,))}, got {array.shape}")
            _check_domain(array, name, step.domains.get(name, ""))
            keep.append(array)
            c_args.append(self._ctype(float(array)) if scalar else array.ctypes.data_as(self._pointer))
        q = np.empty(n, dtype=self.dtype)
        error = np.empty(1, dtype=self.dtype)
        iterations = ctypes.c_int(0)
        status = self._ik(*c_args, self._ctype(tol), int(max_iter), q.ctypes.data_as(self._pointer),
                          error.ctypes.data_as(self._pointer), ctypes.byref(iterations))
        return IKResult(q, IK_STATUS_NAMES[status], float(error[0]), iterations.value)


def load_python(source: str, name: str):
    """Execute an emitted Python module's text and return it as a module object."""
    import types

    module = types.ModuleType(name)
    module.__file__ = f"<skelarm-sym {name}>"
    exec(compile(source, module.__file__, "exec"), module.__dict__)
    return module


def compile_arm(generated, flags: Sequence[str] = DEFAULT_FLAGS, compiler: str | None = None) -> CompiledArm:
    """Compile and load the C of a :class:`~skelarm_sym.generate.Generated` result."""
    sources = {k: v for k, v in generated.sources.items() if k.endswith((".c", ".h"))}
    if not sources:
        raise InputError("nothing to compile: generate with lang 'c'")
    library = compile_shared(sources, flags=flags, compiler=compiler)
    prefix = next(k for k in sources if k.endswith(".c"))[:-2]
    precision = "float" if "Precision: float." in sources[prefix + ".c"] else "double"
    derivation = generated.derivation
    return CompiledArm(library, prefix, generated.programs, precision, derivation.parameters, derivation.domains)
