"""The compiled library seen from Python: one method per emitted function, taking NumPy arrays.

``CompiledArm(library, prefix, programs, precision, shared, domains)`` loads a shared library
built by :mod:`skelarm_sym.build` through ctypes; ``arm.jacobian(q, l)`` with ``q`` of shape
``(..., N)`` returns ``(..., 2, N)``; batches go through the ``_batch`` C functions.

Each method has the emitted NumPy module's signature (``inspect.signature(arm.inverse_velocity)``
is ``(q, v, l, lambda_)``), accepts keywords, and checks what the header promises: shapes,
finite state and data, positive lengths, ``lambda >= 0``; a wrong number of arguments is a
``TypeError`` that names the signature, bad values an :class:`InputError` (a ``ValueError``).
"""

from __future__ import annotations

import ctypes
import functools
import inspect
import keyword
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from .backends.common import IK_SETTINGS, IK_STATUS, default_ik_tol
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


C_INT_MAX = 2**31 - 1
"""The largest ``max_iter`` the C ``int`` argument holds."""


def identifier(name: str) -> str:
    """The Python argument name of input ``name`` (keywords get a trailing ``_``: ``lambda_``)."""
    return name + "_" if keyword.iskeyword(name) else name


def signature_errors(function):
    """Wrap ``function`` so that calling it with the wrong arguments raises a ``TypeError`` that
    names its signature (``jacobian(q, l): ... takes 2 positional arguments but 3 were given``).
    Errors raised inside ``function`` pass through unchanged."""

    @functools.wraps(function)
    def call(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except TypeError as exc:
            if exc.__traceback__ is not None and exc.__traceback__.tb_next is None:  # binding the arguments
                raise TypeError(f"{function.__name__}{inspect.signature(function)}: {exc}") from None
            raise

    return call


def iteration_count(max_iter: object) -> int:
    """``max_iter`` as an int in ``0..2**31 - 1`` (the C ``int`` range), else InputError."""
    try:
        whole = int(max_iter)  # type: ignore[call-overload]
        ok = whole == max_iter and not isinstance(max_iter, bool)
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok or not 0 <= whole <= C_INT_MAX:
        raise InputError(f"max_iter must be a whole number in 0..{C_INT_MAX}, got {max_iter!r}")
    return whole


def _make_method(name: str, params: Sequence[str], defaults: dict[str, object], doc: str, target) -> object:
    """A function ``name(params...)`` (real signature, docstring) that calls ``target(args_tuple)``."""
    text = ", ".join(f"{p}=_defaults[{p!r}]" if p in defaults else p for p in params)
    source = f"def {name}({text}):\n    return _target(({''.join(p + ', ' for p in params)}))\n"
    namespace: dict = {"_target": target, "_defaults": defaults}
    exec(source, namespace)  # noqa: S102 - names are identifiers from the program
    function = namespace[name]
    function.__doc__ = doc
    return signature_errors(function)


def _docstring(program: Program, domains: dict[str, str], shared: Sequence[str]) -> str:
    lines = [f"{program.summary} (the emitted C {{prefix}}_{program.name}).", ""]
    for a in program.inputs:
        domain = domains.get(a.name, "")
        rule = {"finite": ", finite", "nonnegative": ", finite and >= 0", "positive": ", finite and > 0"}.get(domain, "")
        if a.is_scalar:
            lines.append(f"{identifier(a.name)}: a number{rule}, shared by the batch.")
        elif a.name in shared:
            lines.append(f"{identifier(a.name)}: array of shape ({a.size},){rule}, shared by the batch.")
        else:
            lines.append(f"{identifier(a.name)}: array of shape (..., {a.size}){rule}.")
    outs = ", ".join(f"{o.name} of shape (..., {', '.join(map(str, o.shape))})" for o in program.outputs)
    lines.append(f"Returns {outs}.")
    lines.append("Raises TypeError for a wrong number of arguments, InputError (a ValueError) for bad values.")
    return "\n".join(lines)


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
        domains: dict[str, str] | None = None, reach: float = 1.0,
    ):
        self.path = library
        self._fixed_reach = reach  # sum of fixed link lengths: scales the planar IK's default tol
        self.prefix = prefix
        self.dtype = np.float64 if precision == "double" else np.float32
        self._lib = ctypes.CDLL(str(library))
        ctype = ctypes.c_double if precision == "double" else ctypes.c_float
        pointer = ctypes.POINTER(ctype)
        self._ctype = ctype
        self._signatures: dict[str, _Signature] = {}
        self._methods: dict[str, object] = {}
        self.precision = precision
        domains = domains or {}
        for program in programs:
            sig = _Signature(
                program.name,
                tuple((a.name, a.size, a.name in shared, a.is_scalar) for a in program.inputs),
                tuple((o.name, o.shape) for o in program.outputs),
                {a.name: domains[a.name] for a in program.inputs if a.name in domains},
            )
            self._signatures[program.name] = sig
            self._methods[program.name] = _make_method(
                program.name, [identifier(a.name) for a in program.inputs], {},
                _docstring(program, domains, shared).replace("{prefix}", prefix),
                functools.partial(self._call, sig),
            )
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
            params = ["q0", *(identifier(name) for name, *_ in step.inputs if name != "q"), "tol", "max_iter"]
            defaults = {"tol": None, "max_iter": 200}
            self._methods["ik_solve"] = _make_method("ik_solve", params, defaults, _IK_DOC.format(
                prefix=prefix, tol=IK_SETTINGS[precision]["tol"]), self._ik_solve)

        if "ik_terms" in self._signatures and hasattr(self._lib, f"{prefix}_ik_solve_position"):
            self._chain_ik_setup(prefix, ctype, pointer)

    def _chain_ik_setup(self, prefix, ctype, pointer) -> None:
        """ik_solve_pose / ik_solve_position: the emitted chain IK (C {prefix}_ik_solve[_position])."""
        terms = self._signatures["ik_terms"]
        has_params = any(name == "params" for name, *_ in terms.inputs)
        n = terms.inputs[0][1]
        for method, c_name, size in (("ik_solve_pose", "ik_solve", 16), ("ik_solve_position", "ik_solve_position", 3)):
            solve = getattr(self._lib, f"{prefix}_{c_name}")
            solve.argtypes = [pointer, pointer] + [pointer] * has_params + [ctype, ctype, ctypes.c_int, pointer, pointer, ctypes.POINTER(ctypes.c_int)]
            solve.restype = ctypes.c_int

            def call(q0, target, params=None, lambda_=0.0, tol=None, max_iter=100, _solve=solve, _size=size):
                from .ik import DEFAULT_TOL, IKResult as ChainIKResult
                q0 = np.ascontiguousarray(np.asarray(q0, dtype=self.dtype))
                target = np.ascontiguousarray(np.asarray(target, dtype=self.dtype).reshape(-1))
                if q0.shape != (n,) or target.shape != (_size,):
                    raise InputError(f"q0 must have shape ({n},) and target {_size} numbers")
                tol = DEFAULT_TOL[self.precision] if tol is None else tol
                args = [q0.ctypes.data_as(self._pointer), target.ctypes.data_as(self._pointer)]
                if has_params:
                    params = np.ascontiguousarray(np.asarray(params, dtype=self.dtype))
                    args.append(params.ctypes.data_as(self._pointer))
                q = np.empty(n, dtype=self.dtype)
                error = np.zeros(2, dtype=self.dtype)
                iterations = ctypes.c_int(0)
                status = _solve(*args, self._ctype(float(lambda_)), self._ctype(float(tol)), iteration_count(max_iter),
                                q.ctypes.data_as(self._pointer), error.ctypes.data_as(self._pointer), ctypes.byref(iterations))
                if status == 3:
                    raise InputError("q0, target, params and lambda must be finite, lambda >= 0, tol > 0")
                return ChainIKResult(q, IK_STATUS_NAMES[status], float(error[0]), float(error[1]), iterations.value)

            call.__name__ = method
            call.__doc__ = (f"The emitted C {prefix}_{c_name}: {'pose (4 x 4)' if size == 16 else 'position (3)'} IK from q0; "
                            "returns skelarm_sym.ik.IKResult (q, status, position_error, rotation_error, iterations).")
            self._methods[method] = call

    @property
    def functions(self) -> tuple[str, ...]:
        """Names of the callable functions."""
        return tuple(self._signatures)

    def __getattr__(self, name: str):
        methods = self.__dict__.get("_methods", {})
        if name not in methods:
            if name == "ik_solve":
                raise AttributeError("this library has no ik_solve (it needs position and ik_step)")
            raise AttributeError(name)
        return methods[name]

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(self.__dict__.get("_methods", {})))

    def _call(self, sig: _Signature, args: tuple) -> np.ndarray | tuple[np.ndarray, ...]:
        if len(args) != len(sig.inputs):
            names = ", ".join(identifier(n) for n, *_ in sig.inputs)
            raise TypeError(f"{sig.name}({names}) takes {len(sig.inputs)} arguments, got {len(args)}")
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

    def _ik_solve(self, args: tuple) -> IKResult:
        step = self._signatures["ik_step"]
        n = step.inputs[0][1]
        q0, *args, tol, max_iter = args
        q0 = np.ascontiguousarray(np.asarray(q0, dtype=self.dtype))
        if q0.shape != (n,):
            raise InputError(f"q0 must have shape ({n},), got {q0.shape}")
        _check_domain(q0, "q0", "finite")
        others = [x for x in step.inputs if x[0] != "q"]
        if tol is None:
            lengths = dict(zip([x[0] for x in others], args)).get("l", self._fixed_reach)
            reach = float(np.sum(np.asarray(lengths, dtype=float))) if np.all(np.isfinite(lengths)) else 1.0
            tol = default_ik_tol(self.precision, reach)
        tol = float(tol)
        if not (np.isfinite(tol) and tol > 0):
            raise InputError(f"tol must be finite and > 0, got {tol!r}")
        max_iter = iteration_count(max_iter)
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
        status = self._ik(*c_args, self._ctype(tol), max_iter, q.ctypes.data_as(self._pointer),
                          error.ctypes.data_as(self._pointer), ctypes.byref(iterations))
        return IKResult(q, IK_STATUS_NAMES[status], float(error[0]), iterations.value)


_IK_DOC = """Inverse kinematics from q0 toward target by damped least-squares steps (the emitted C
{prefix}_ik_solve; same algorithm as the NumPy module's ik_solve).

q0: (N,) finite start pose; target: (2,) finite endpoint target; l (when lengths are symbolic):
(N,) lengths > 0; lambda_: damping >= 0; tol: stop when |target - p| <= tol (default {tol:g} times
the reach, the sum of the lengths, at least 1); max_iter: at most this many steps, 0..2**31 - 1.
Returns IKResult(q, status, error, iterations), status one of "converged", "stalled", "max_iter".
Raises TypeError for a wrong number of arguments, InputError (a ValueError) for bad values.
"""
