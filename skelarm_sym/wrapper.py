"""The compiled library seen from Python: one method per emitted function, taking NumPy arrays.

``CompiledArm(library, module)`` loads a shared library built by :mod:`skelarm_sym.build` through ctypes
and reads its functions from the IR :class:`~skelarm_sym.ir.nodes.Module` it was printed from.
Straight-line functions broadcast like the emitted NumPy module (``arm.jacobian(q, l)`` with ``q`` of
shape ``(..., N)`` returns ``(..., 2, N)``; batches go through the ``_batch`` C functions); solvers
take one problem and return the same named record as the NumPy module, or a batch of problems (arrays
``(..., *shape)`` whose batch shapes broadcast) and return that record over the batch, through the
solver's C ``_batch``.

Each method has the NumPy module's signature (``inspect.signature(arm.inverse_velocity)`` is
``(q, v, l, lambda_)``), accepts keywords, and checks what the header promises: shapes, real finite
values, positive lengths, ``lambda >= 0``; a wrong number of arguments is a ``TypeError`` that names the
signature, bad values an :class:`InputError` (a ``ValueError``).
"""

from __future__ import annotations

import ctypes
import inspect
import keyword
from collections import namedtuple
from pathlib import Path

import numpy as np

from .derive.core import matrix_shape
from .errors import InputError
from .ir.evaluate import evaluate
from .ir.nodes import Argument, Function, Module, Type

C_INT_MAX = 2**31 - 1
"""The largest ``max_iter`` the C ``int`` argument holds."""


def identifier(name: str) -> str:
    """The Python argument name of input ``name`` (keywords get a trailing ``_``: ``lambda_``)."""
    return name + "_" if keyword.iskeyword(name) else name


def iteration_count(value: object, name: str = "max_iter") -> int:
    """``value`` as an int in ``0..2**31 - 1`` (the C ``int`` range), else InputError."""
    try:
        whole = int(value)  # type: ignore[call-overload]
        ok = whole == value and not isinstance(value, bool)
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok or not 0 <= whole <= C_INT_MAX:
        raise InputError(f"{name} must be a whole number in 0..{C_INT_MAX}, got {value!r}")
    return whole


def _check_domain(array: np.ndarray, name: str, domain: str) -> None:
    if domain and not np.isfinite(array).all():
        raise InputError(f"{name} must be finite")
    if domain == "nonnegative" and (array < 0).any():
        raise InputError(f"{name} must be >= 0")
    if domain == "positive" and (array <= 0).any():
        raise InputError(f"{name} must be > 0")


def _real(value: object, name: str, dtype) -> np.ndarray:
    """``value`` as an array of ``dtype``; complex numbers, strings and objects are refused, and so are finite
    numbers beyond ``dtype``'s range (a float64 1e39 for a float library: not "must be finite")."""
    try:
        array = np.asarray(value)
    except ValueError:  # rows of different lengths
        raise InputError(f"{name} must be a rectangular array of numbers (rows of one length)") from None
    if array.dtype.kind == "O" and all(type(x) in (int, float) for x in array.flat):  # ints beyond int64 (10**40)
        try:
            array = np.asarray(value, dtype=np.float64)
        except OverflowError:
            raise InputError(f"{name} holds a number beyond the range of float64") from None
        except (TypeError, ValueError):
            pass
    if array.dtype.kind not in "biuf":
        raise InputError(f"{name} must hold real numbers, got {array.dtype}")
    if array.dtype.kind == "f" and array.dtype.itemsize > np.dtype(dtype).itemsize:
        with np.errstate(over="ignore"):
            narrowed = np.asarray(array, dtype=dtype)
        beyond = np.isinf(narrowed) & np.isfinite(array)
        if beyond.any():
            raise InputError(f"{name} holds {array[beyond].flat[0]:g}, beyond the range of {np.dtype(dtype).name} "
                             f"(|x| <= {np.finfo(dtype).max:g})")
        return narrowed
    return np.asarray(array, dtype=dtype)


def _signature(f: Function) -> inspect.Signature:
    """The Python signature of ``f``: its inputs; solver inputs with a default are keywords."""
    params = []
    for a in f.inputs:
        default = inspect.Parameter.empty
        if a.default is not None:
            default = a.default.value if type(a.default).__name__ == "Const" else None
        params.append(inspect.Parameter(identifier(a.name), inspect.Parameter.POSITIONAL_OR_KEYWORD, default=default))
    return inspect.Signature(params)


def _docstring(f: Function, prefix: str) -> str:
    lines = [f"{f.summary} (the emitted C {prefix}_{f.name}).", ""]
    lines += list(f.doc)
    for a in f.inputs:
        rule = {"finite": ", finite", "nonnegative": ", finite and >= 0", "positive": ", finite and > 0"}.get(a.domain, "")
        if a.is_scalar:
            lines.append(f"{identifier(a.name)}: a number{rule}{', shared by the batch' if f.kind == 'straight' else ''}.")
        elif f.kind != "straight":
            lines.append(f"{identifier(a.name)}: array of shape {a.shape} (a batch of problems: (..., {', '.join(map(str, a.shape))})){rule}.")
        elif not a.batched:
            lines.append(f"{identifier(a.name)}: array of shape ({a.size},){rule}, shared by the batch.")
        else:
            lines.append(f"{identifier(a.name)}: array of shape (..., {a.size}){rule}.")
    if f.kind == "straight":
        outs = ", ".join(f"{o.name} of shape (..., {', '.join(map(str, o.shape))})" for o in f.outputs)
        lines.append(f"Returns {outs}.")
    else:
        lines.append(f"Returns {f.result}({', '.join(f.result_fields)}).")
    lines.append("Raises TypeError for a wrong number of arguments, InputError (a ValueError) for bad values.")
    return "\n".join(lines)


def _method(f: Function, prefix: str, target, fast=None) -> object:
    """A callable ``f.name(inputs...)`` with ``f``'s real signature and docstring that calls
    ``target(bound_arguments_in_order)``; binding errors are TypeErrors naming the signature.

    ``fast``: the CPython extension's entry for ``f``, tried first on positional arguments; it computes
    one configuration or returns ``NotImplemented`` (anything it does not take: ``target`` then checks,
    explains and computes as it would have without it)."""
    signature = _signature(f)
    count = len(signature.parameters)

    def method(*args, **kwargs):
        if not kwargs:
            if fast is not None:
                result = fast(*args)
                if result is not NotImplemented:
                    return result
            if len(args) == count:  # every argument, positional: binding would give them back in order
                return target(args)
        try:
            bound = signature.bind(*args, **kwargs)
        except TypeError as exc:
            raise TypeError(f"{f.name}{signature}: {exc}") from None
        bound.apply_defaults()
        return target(tuple(bound.arguments.values()))

    method.__name__ = method.__qualname__ = f.name
    method.__doc__ = _docstring(f, prefix)
    method.__signature__ = signature  # type: ignore[attr-defined]
    return method


def load_extension(library: Path, name: str):
    """The CPython extension module ``name`` in ``library`` (not entered in ``sys.modules``)."""
    from importlib.machinery import ExtensionFileLoader
    from importlib.util import module_from_spec, spec_from_loader

    loader = ExtensionFileLoader(name, str(library))
    spec = spec_from_loader(name, loader)
    extension = module_from_spec(spec)
    loader.exec_module(extension)
    return extension


class CompiledArm:
    """A loaded shared library; one method per public emitted function (see the module docstring).

    ``extension``: the name of the CPython extension module the library also holds
    (:mod:`skelarm_sym.backends.cpython`), whose entries take single configurations first."""

    def __init__(self, library: Path, module: Module, extension: str | None = None):
        self.path = library
        self.module = module
        self.prefix = module.prefix
        self.precision = module.precision
        self.dtype = np.float64 if module.precision == "double" else np.float32
        self._lib = ctypes.CDLL(str(library))
        self.extension = load_extension(library, extension) if extension else None
        self._ctype = ctypes.c_double if module.precision == "double" else ctypes.c_float
        self._pointer = ctypes.POINTER(self._ctype)
        self._functions: dict[str, Function] = {}
        self._methods: dict[str, object] = {}
        self._c_functions: dict[str, object] = {}  # ctypes function objects, looked up once
        self._statuses: dict[str, tuple[dict[int, str], tuple[int, str] | None]] = {}  # procedures: labels, INVALID
        self._results = {f.name: namedtuple(f.result, f.result_fields) for f in module.public if f.kind != "straight"}
        for f in module.public:
            self._functions[f.name] = f
            fast = None
            if f.kind == "straight":
                self._bind_straight(f)
                target = lambda args, f=f: self._call(f, args)  # noqa: E731
                fast = getattr(self.extension, f.name, None)
            else:
                self._bind_procedure(f)
                target = lambda args, f=f: self._solve(f, args)  # noqa: E731
                fast = self._fast_solver(f, getattr(self.extension, f.name, None))
            self._methods[f.name] = _method(f, self.prefix, target, fast)
            if f.name not in self.__dict__ and not hasattr(type(self), f.name):
                self.__dict__[f.name] = self._methods[f.name]  # found without __getattr__: a call's lookup is a dict's

    # -- ctypes signatures -----------------------------------------------------------------------
    def _ctype_of(self, a: Argument):
        if a.type is Type.INT:
            return ctypes.c_int if a.is_scalar and not a.is_output else ctypes.POINTER(ctypes.c_int)
        return self._ctype if a.is_scalar and not a.is_output else self._pointer

    def _bind_straight(self, f: Function) -> None:
        args = [self._ctype_of(a) for a in f.arguments]
        single = getattr(self._lib, f"{self.prefix}_{f.name}")
        single.argtypes, single.restype = args, None
        batch = getattr(self._lib, f"{self.prefix}_{f.name}_batch")
        batch.argtypes, batch.restype = [ctypes.c_size_t] + args, None
        self._c_functions[f.name], self._c_functions[f.name + "_batch"] = single, batch

    def _bind_procedure(self, f: Function) -> None:
        function = getattr(self._lib, f"{self.prefix}_{f.name}")
        function.argtypes = [self._ctype_of(a) for a in f.arguments]
        function.restype = ctypes.c_int if f.returns is Type.INT else None
        self._c_functions[f.name] = function
        try:  # libraries of other generators (the CUDA host code) may have the single call alone
            batch = getattr(self._lib, f"{self.prefix}_{f.name}_batch")
        except AttributeError:
            batch = None
        else:
            batch.argtypes = [ctypes.c_size_t] + function.argtypes + ([ctypes.POINTER(ctypes.c_int)] if f.returns is Type.INT else [])
            batch.restype = None
        self._c_functions[f.name + "_batch"] = batch
        labels = {value: name.lower().removeprefix("ik_") for name, value, _ in f.statuses}
        invalid = None if f.invalid_status is None else f.invalid_status[1:]
        self._statuses[f.name] = (labels, invalid)

    @property
    def functions(self) -> tuple[str, ...]:
        """Names of the callable functions."""
        return tuple(self._functions)

    def __getattr__(self, name: str):
        methods = self.__dict__.get("_methods", {})
        if name not in methods:
            raise AttributeError(f"this library has no function {name!r}; it has {', '.join(methods) or 'none'}")
        return methods[name]

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(self.__dict__.get("_methods", {})))

    # -- calls -----------------------------------------------------------------------------------------
    def _checked_inputs(self, f: Function, args: tuple) -> tuple[list[np.ndarray], tuple[int, ...], list[int]]:
        """The inputs of a straight-line call as arrays of the library's type, checked (shape, real values,
        domain), their common batch shape and the positions of the per-configuration ones."""
        arrays = []
        for value, a in zip(args, f.inputs):
            array = _real(value, a.name, self.dtype)
            matrix = matrix_shape(a.name, a.size)
            if matrix is not None and array.ndim >= 2 and array.shape[-2:] == matrix:
                array = array.reshape(array.shape[:-2] + (a.size,))  # a pose as 4 x 4, as the solvers take it
            if a.is_scalar:
                if array.ndim != 0:
                    raise InputError(f"{a.name} must be a single number, got shape {array.shape}")
            elif array.ndim == 0 or array.shape[-1] != a.size:
                raise InputError(f"{a.name} must have shape (..., {a.size}), got {array.shape}")
            _check_domain(array, a.name, a.domain)
            arrays.append(array)
        # lengths and parameters are shared by a batch, or given per configuration as the NumPy module takes them
        per_config = [i for i, a in enumerate(f.inputs) if not a.is_scalar and (a.batched or arrays[i].ndim > 1)]
        try:
            batch = np.broadcast_shapes(*(arrays[i].shape[:-1] for i in per_config))
        except ValueError:
            shapes = ", ".join(f"{f.inputs[i].name} {arrays[i].shape}" for i in per_config)
            raise InputError(f"{f.name}: batch shapes do not broadcast: {shapes}") from None
        return arrays, batch, per_config

    def _call(self, f: Function, args: tuple) -> np.ndarray | tuple[np.ndarray, ...]:
        arrays, batch, per_config = self._checked_inputs(f, args)
        for i in per_config:
            arrays[i] = np.broadcast_to(arrays[i], batch + arrays[i].shape[-1:])
        m = int(np.prod(batch)) if batch else 1
        arrays = [x if x.ndim == 0 else np.ascontiguousarray(x) for x in arrays]
        outputs = [np.empty(batch + o.shape, dtype=self.dtype) for o in f.outputs]
        if any(not f.inputs[i].batched for i in per_config):  # lengths per configuration: the _batch C shares them
            rows = [x if x.ndim == 0 else x.reshape(m, -1) for x in arrays]
            flat = [o.reshape(m, -1) for o in outputs]
            single = self._c_functions[f.name]
            for j in range(m):
                single(*[self._ctype(float(x)) if a.is_scalar else x[j].ctypes.data_as(self._pointer) for x, a in zip(rows, f.inputs)],
                       *[o[j].ctypes.data_as(self._pointer) for o in flat])
            return outputs[0] if len(outputs) == 1 else tuple(outputs)
        pointers = [
            self._ctype(float(x)) if a.is_scalar else x.ctypes.data_as(self._pointer) for x, a in zip(arrays, f.inputs)
        ] + [o.ctypes.data_as(self._pointer) for o in outputs]
        if batch:
            self._c_functions[f.name + "_batch"](m, *pointers)
        else:
            self._c_functions[f.name](*pointers)
        return outputs[0] if len(outputs) == 1 else tuple(outputs)

    def _solve(self, f: Function, args: tuple):
        if is_batch(f, args):
            return self._solve_batch(f, args)
        values: dict[str, object] = {}
        for value, a in zip(args, f.inputs):
            array = self._solver_input(a, value, values)
            if array is None:
                continue
            if array.shape != a.shape and array.shape != (a.size,):
                batch = f" (a batch: (..., {', '.join(map(str, a.shape))}))" if not a.is_scalar else ""
                raise InputError(f"{a.name} must have shape {a.shape}{batch}, got {array.shape}")
            array = array.reshape(a.shape)
            _check_domain(array, a.name, a.domain)
            values[a.name] = array if a.is_scalar else np.ascontiguousarray(array).reshape(-1)
        outputs = {o.name: np.zeros(o.size, dtype=np.intc if o.type is Type.INT else self.dtype) for o in f.outputs}
        c_args = self._c_arguments(f, values, outputs)
        status = self._c_functions[f.name](*c_args)
        return self._record(f, status, [outputs[o.name] for o in f.outputs])

    def _c_arguments(self, f: Function, inputs: dict, outputs: dict, j: int | None = None) -> list:
        """The C arguments of solver ``f``: counts as C ints, real scalars as numbers (an array over a batch:
        its element ``j``), arrays and outputs as pointers to their data (``j``: to problem ``j``'s row of a
        batch's ``(m, size)`` array; ``None``: the whole array)."""
        c_args = []
        for a in f.inputs:
            x = inputs[a.name]
            if a.type is Type.INT:
                c_args.append(ctypes.c_int(x))
            elif a.is_scalar:
                c_args.append(self._ctype(float(x if np.ndim(x) == 0 else x[j, 0])))
            else:
                c_args.append((x if j is None else x[j]).ctypes.data_as(self._pointer))
        for o in f.outputs:
            out = outputs[o.name] if j is None else outputs[o.name][j]
            c_args.append(out.ctypes.data_as(ctypes.POINTER(ctypes.c_int) if o.type is Type.INT else self._pointer))
        return c_args

    def _solver_input(self, a: Argument, value, values: dict):
        """A solver's argument as an array of the library's type (its default, from the arguments before it in
        ``values``, when it is None and the signature's default is None: a default computed from them); a count goes
        into ``values`` checked, and gives None. A None where the signature shows a number is refused, as the
        emitted modules refuse it."""
        if value is None and a.default is not None and type(a.default).__name__ != "Const":
            value = evaluate(a.default, values)
        if a.type is Type.INT:
            values[a.name] = iteration_count(value, a.name)
            return None
        return _real(value, a.name, self.dtype)

    def _record(self, f: Function, status: int, outputs) -> tuple:
        """The named record of one solved problem from its status and output arrays (an INVALID status: an
        InputError with the header's meaning)."""
        labels, invalid = self._statuses[f.name]
        if invalid is not None and status == invalid[0]:
            raise InputError(f"{f.name}: {invalid[1]}")
        fields = []
        for i, (o, out) in enumerate(zip(f.outputs, outputs)):
            if out.shape != o.shape:
                out = out.reshape(o.shape)
            if i == 0:
                fields += [out, labels.get(status, str(status))]
            elif o.fields:
                fields += [out.item(k) for k in range(len(o.fields))]  # Python ints and floats
            else:
                fields.append(out)
        return self._results[f.name](*fields)

    def _fast_solver(self, f: Function, entry):
        """The extension's entry for solver ``f`` (``None``: none) as a fast path for ``_method``: one problem,
        positional arguments, the omitted ones filled in when their defaults are numbers; its ``(status,
        *fields)`` (the record's fields but the status name, small outputs already Python numbers) made the
        named record. ``NotImplemented`` where the entry does not take the call."""
        if entry is None:
            return None
        literal = [a.default.value if type(a.default).__name__ == "Const" else None for a in f.inputs]
        count = len(f.inputs)
        labels, invalid = self._statuses[f.name]
        invalid_code = None if invalid is None else invalid[0]
        record = self._results[f.name]
        new = tuple.__new__

        def fast(*args):
            if len(args) < count:
                rest = literal[len(args):]
                if None in rest:
                    return NotImplemented
                args = args + tuple(rest)
            raw = entry(*args)
            if raw is NotImplemented:
                return raw
            status = raw[0]
            if status == invalid_code:
                raise InputError(f"{f.name}: {invalid[1]}")
            return new(record, (raw[1], labels[status] if status in labels else str(status), *raw[2:]))

        return fast

    def _solve_batch(self, f: Function, args: tuple):
        """A batch of problems (arrays ``(..., *shape)``, real scalars numbers or arrays over the batch): one
        call of the C ``_batch`` when every scalar is one number, else one C call per problem. The record
        holds arrays over the batch: the first output ``(..., *shape)``, status an array of names."""
        values: dict[str, object] = {}
        shapes: dict[str, tuple[int, ...]] = {}
        for value, a in zip(args, f.inputs):
            array = self._solver_input(a, value, values)
            if array is None:
                continue
            if (len(a.shape) > 1 and array.ndim > 1 and array.shape[-1] == a.size
                    and array.shape[array.ndim - len(a.shape):] != a.shape):  # flat matrices: (m, 16) targets
                array = array.reshape(array.shape[:-1] + a.shape)
            if not a.is_scalar and array.shape[array.ndim - len(a.shape):] != a.shape:
                raise InputError(f"{a.name} must have shape (..., {', '.join(map(str, a.shape))}), got {array.shape}")
            _check_domain(array, a.name, a.domain)
            values[a.name] = array
            shapes[a.name] = array.shape if a.is_scalar else array.shape[:array.ndim - len(a.shape)]
        try:
            batch = np.broadcast_shapes(*shapes.values())
        except ValueError:
            listed = ", ".join(f"{n} {s}" for n, s in shapes.items())
            raise InputError(f"{f.name}: batch shapes do not broadcast: {listed}") from None
        m = int(np.prod(batch))
        inputs = {}
        for a in f.inputs:
            x = values[a.name]
            if a.type is Type.INT or (a.is_scalar and np.ndim(x) == 0):
                inputs[a.name] = x
            else:
                inputs[a.name] = np.ascontiguousarray(np.broadcast_to(x, batch + a.shape).reshape(m, a.size))
        outputs = {o.name: np.zeros((m, o.size), dtype=np.intc if o.type is Type.INT else self.dtype) for o in f.outputs}
        status = np.zeros(m, dtype=np.intc)
        batch_call = self._c_functions[f.name + "_batch"]
        if batch_call is not None and all(np.ndim(inputs[a.name]) == 0 for a in f.inputs if a.is_scalar):
            batch_call(m, *self._c_arguments(f, inputs, outputs), status.ctypes.data_as(ctypes.POINTER(ctypes.c_int)))
        else:
            for j in range(m):
                status[j] = self._c_functions[f.name](*self._c_arguments(f, inputs, outputs, j))
        status = status.reshape(batch)
        labels, invalid = self._statuses[f.name]
        if invalid is not None and np.any(status == invalid[0]):
            index = np.unravel_index(int(np.argmax(status.reshape(-1) == invalid[0])), batch)
            raise InputError(f"{f.name}: problem {tuple(int(i) for i in index)}: {invalid[1]}")
        names = np.array([labels.get(k, str(k)) for k in range(max(labels, default=0) + 1)])
        fields = []
        for i, o in enumerate(f.outputs):
            out = outputs[o.name]
            if o.type is Type.INT:
                out = out.astype(np.int64)
            if i == 0:
                fields += [out.reshape(batch + o.shape), names[status]]
            elif o.fields:
                fields += [out[:, k].reshape(batch) for k in range(len(o.fields))]
            else:
                fields.append(out.reshape(batch + o.shape))
        return self._results[f.name](*fields)


def is_batch(f: Function, args: tuple) -> bool:
    """Whether a solver call holds a batch of problems: an array with dimensions before its problem's
    shape (a matrix's elements may come flat: ``(m, 16)`` targets), or a real scalar that is not one number."""
    for value, a in zip(args, f.inputs):
        if a.type is Type.INT or value is None:
            continue
        dims = np.shape(value)
        if len(dims) > len(a.shape) or (len(a.shape) > 1 and len(dims) > 1 and dims[-1] == a.size):
            return True
    return False
