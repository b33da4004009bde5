"""The ``.cu`` as host C++: how its arithmetic is checked on machines without a GPU.

``compile_host(generated)`` compiles ``{prefix}.cu`` (with ``{prefix}.cuh`` beside it) with the system C++
compiler (``$CXX``, else ``c++``, ``g++`` or ``clang++``) as C++, where ``__host__ __device__`` are
defined away, strict (``-Wall -Wextra -Werror -pedantic``), at the optimisation level of the C
(:func:`skelarm_sym.build.default_flags`: ``-O2``, or the level of ``$SKELARM_SYM_OPT``), into a shared
library cached and verified exactly as :mod:`skelarm_sym.build` caches the C (private folder, SHA-256 sidecar, rebuilt when they
disagree). :class:`HostArm` loads it: a :class:`~skelarm_sym.wrapper.CompiledArm` (same methods,
signatures and input checks) whose single calls are the ``__host__ __device__`` functions and whose
batches run ``{prefix}_{name}_host``, the kernel's per-thread body in a loop over the batch, on arrays
laid out as the kernels read them (structure of arrays): a batch call checks the kernels' indexing
and the device functions' arithmetic against the single calls and the references.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Sequence

import numpy as np

from ...build import (
    CompilerNotFound, _durable_replace, _split_command, cache_folder, compile_failure, default_flags, file_sha256,
    private_folder, remove_stale_builds, remove_unused_libraries, reusable,
)
from ...errors import InputError
from ...ir.nodes import Function
from ...wrapper import CompiledArm
from .backend import STATUS, kernel_arguments
from ..c.printer import PRECISIONS

HOST_FLAGS = ("-x", "c++", "-std=c++11", "-Wall", "-Wextra", "-Werror", "-pedantic")
"""The .cu as strict C++11 (what ``__host__ __device__`` functions must be anyway); the optimisation level comes
from the ``flags`` of :func:`compile_host_library`."""


def find_cxx(preferred: str | None = None) -> str:
    """The C++ compiler: ``preferred``, else ``$CXX``, else c++, g++, clang++ on PATH (a named one must exist)."""
    for origin, named in (("compiler", preferred), ("CXX", os.environ.get("CXX"))):
        if named is None or (origin == "CXX" and not named.strip()):
            continue
        program = _split_command(named, origin)[0]
        if not shutil.which(program):
            raise CompilerNotFound(f"{origin} {named!r}: {program!r} is not an executable on PATH")
        return named
    for candidate in ("c++", "g++", "clang++"):
        if shutil.which(candidate):
            return candidate
    raise CompilerNotFound("no C++ compiler found: install g++ or clang++ (Debian/Ubuntu: apt-get install g++) or set CXX")


def cuda_sources(generated) -> dict[str, str]:
    """``{name: text}`` of the generated ``.cuh`` and ``.cu``; InputError when they are not there."""
    prefix = generated.module.prefix
    names = (prefix + ".cuh", prefix + ".cu")
    missing = [n for n in names if n not in generated.sources]
    if missing:
        raise InputError(f"nothing to compile: {', '.join(missing)} missing (generate with lang 'cuda')")
    return {n: generated.sources[n] for n in names}


def compile_host_library(sources: dict[str, str], flags: Sequence[str] | None = None,
                         compiler: str | None = None) -> Path:
    """Compile the ``.cu`` of ``sources`` as host C++ into a cached shared library; its path.

    ``flags`` follow :data:`HOST_FLAGS`; ``None`` for :func:`skelarm_sym.build.default_flags` (``-O2``, or the
    level of ``$SKELARM_SYM_OPT``, as for the C). The cache is :func:`skelarm_sym.build.cache_folder`, checked
    and trusted as for the C libraries."""
    if flags is None:
        flags = default_flags()
    cxx = find_cxx(compiler)
    words = _split_command(cxx, "compiler")
    all_flags = [*HOST_FLAGS, *flags, "-fPIC", "-shared"]
    digest = hashlib.sha256()
    for name in sorted(sources):
        digest.update(name.encode() + b"\0" + sources[name].encode() + b"\0")
    digest.update(" ".join([cxx, *all_flags]).encode())
    full_key = digest.hexdigest()
    cu = next(name for name in sources if name.endswith(".cu"))
    root = private_folder(cache_folder())
    target = root / full_key[:24] / f"lib{cu[:-3]}_cuda_host.so"
    private_folder(target.parent)
    if reusable(target, full_key):
        return target
    remove_stale_builds(root)
    remove_unused_libraries(root)
    work = Path(tempfile.mkdtemp(prefix=f".build-{os.getpid()}-", dir=target.parent))
    try:
        for name, text in sources.items():
            Path(work, name).write_text(text, encoding="utf-8")
        tmp_lib = Path(work, target.name)
        command = [*words, *all_flags, "-o", str(tmp_lib), str(Path(work, cu)), "-lm"]
        try:
            result = subprocess.run(command, capture_output=True, text=True)
        except OSError as exc:
            raise CompilerNotFound(f"cannot run the C++ compiler {cxx!r}: {exc.strerror or exc}") from None
        if result.returncode != 0:
            raise compile_failure(cu, command, result.returncode, result.stderr + result.stdout, str(work))
        tmp_sidecar = Path(work, "sidecar")
        tmp_sidecar.write_text(f"{full_key} {file_sha256(tmp_lib)}\n", encoding="ascii")
        _durable_replace(tmp_lib, target)
        _durable_replace(tmp_sidecar, target.with_name(target.name + ".sha256"))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return target


def compile_host(generated, flags: Sequence[str] | None = None, compiler: str | None = None) -> "HostArm":
    """Compile and load the ``.cu`` of a :class:`~skelarm_sym.generate.Generated` result as host C++."""
    return HostArm(compile_host_library(cuda_sources(generated), flags, compiler), generated.module)


class HostArm(CompiledArm):
    """The host build of the ``.cu``: :class:`CompiledArm`'s methods and checks; batches of straight-line
    functions run the kernels' per-thread body (``{prefix}_{name}_host``) over structure-of-arrays copies
    of the inputs, and :meth:`host_batch` runs any kernel's body (the solvers' too) on arrays laid out by
    the caller."""

    def _kernel_ctypes(self, f: Function) -> list:
        precision = PRECISIONS[self.module.precision]
        out = [ctypes.c_longlong]
        for k in kernel_arguments(f, precision):
            if k["how"] == "scalar":
                out.append(ctypes.c_int if k["int"] else self._ctype)
            else:
                out.append(ctypes.POINTER(ctypes.c_int) if k["int"] else self._pointer)
        return out

    def _bind_host(self, f: Function) -> None:
        host = getattr(self._lib, f"{self.prefix}_{f.name}_host")
        host.argtypes, host.restype = self._kernel_ctypes(f), None

    def _bind_straight(self, f: Function) -> None:
        single = getattr(self._lib, f"{self.prefix}_{f.name}")
        single.argtypes, single.restype = [self._ctype_of(a) for a in f.arguments], None
        self._c_functions[f.name] = single  # no _batch here: batches run the kernel's body (_call below)
        self._bind_host(f)

    def _bind_procedure(self, f: Function) -> None:
        super()._bind_procedure(f)
        self._bind_host(f)

    def host_batch(self, name: str, m: int, *arguments):
        """Run ``{prefix}_{name}_host`` (the kernel's per-thread body for i < m) with ``arguments`` in the
        kernel's order: NumPy arrays laid out SoA (``(size, m)``, C-contiguous, the module's dtype; ``int32``
        for integer outputs and the status) and numbers for scalars. Only types and sizes are checked."""
        f = self._functions[name]
        precision = PRECISIONS[self.module.precision]
        spec = kernel_arguments(f, precision)
        if len(arguments) != len(spec):
            raise TypeError(f"{name}: the kernel takes {len(spec)} arguments after m, got {len(arguments)}")
        c_args: list = [int(m)]
        for k, x in zip(spec, arguments):
            if k["how"] == "scalar":
                c_args.append(int(x) if k["int"] else float(x))
                continue
            dtype = np.intc if k["int"] else self.dtype
            want = k["size"] * (m if k["how"] in ("soa", "status") else 1)
            if not (isinstance(x, np.ndarray) and x.dtype == dtype and x.flags.c_contiguous and x.size == want):
                raise InputError(f"{name}: {k['name']} must be a C-contiguous {np.dtype(dtype).name} array of {want} elements")
            c_args.append(x.ctypes.data_as(ctypes.POINTER(ctypes.c_int) if k["int"] else self._pointer))
        getattr(self._lib, f"{self.prefix}_{name}_host")(*c_args)

    def _call(self, f: Function, args: tuple):
        """As :meth:`CompiledArm._call` (same checks and broadcasting), with batches through the kernel's body."""
        arrays, batch, per_config = self._checked_inputs(f, args)
        if not batch:
            return super()._call(f, tuple(arrays))  # the single __host__ __device__ function
        m = int(np.prod(batch))
        soa = []
        for i, (x, a) in enumerate(zip(arrays, f.inputs)):
            if a.is_scalar:
                soa.append(float(x))
            elif i in per_config:  # (..., size) -> (size, m): the kernels' layout
                soa.append(np.ascontiguousarray(np.broadcast_to(x, batch + (a.size,)).reshape(m, a.size).T))
            else:
                soa.append(np.ascontiguousarray(x))
        outputs = [np.empty((o.size, m), dtype=self.dtype) for o in f.outputs]
        self.host_batch(f.name, m, *soa, *outputs)
        shaped = []
        for o, out in zip(f.outputs, outputs):
            shaped.append(np.moveaxis(out.reshape(o.shape + batch), tuple(range(len(o.shape))), tuple(range(-len(o.shape), 0))))
        return shaped[0] if len(shaped) == 1 else tuple(shaped)


__all__ = ["HOST_FLAGS", "HostArm", "STATUS", "compile_host", "compile_host_library", "cuda_sources", "find_cxx"]
