"""The compiled library seen from Python: one method per emitted function, taking NumPy arrays.

``CompiledArm(library, prefix, programs, precision, shared, domains)`` loads a shared library
built by :mod:`skelarm_sym.build` through ctypes; ``arm.jacobian(q, l)`` with ``q`` of shape
``(..., N)`` returns ``(..., 2, N)``; batches go through the ``_batch`` C functions.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from .backends.common import IK_STATUS
from .errors import InputError
from .program import Program


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
