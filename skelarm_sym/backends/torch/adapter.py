"""What ``load`` returns for the array backends (PyTorch, JAX): the emitted module's public functions
taking array-likes and returning NumPy arrays, the form ``check`` and the conformance test compare.
Solvers' results keep their record, with the status as the NumPy module's name for a single problem
(an array of names for a batch)."""

from __future__ import annotations

import importlib
import os
import sys

import numpy as np


def require(name: str, extra: str):
    """Import ``name``; when it is missing, skip (inside a pytest run) or raise InputError naming the extra."""
    try:
        return importlib.import_module(name)
    except ImportError:
        reason = f"{name} is not installed: pip install 'skelarm-sym[{extra}]'"
        pytest = sys.modules.get("pytest")
        if pytest is not None and "PYTEST_CURRENT_TEST" in os.environ:
            pytest.skip(reason)
        from ...errors import InputError

        raise InputError(reason) from None


class ArrayAdapter:
    """One method per public function of ``ir_module``, calling ``module``'s (checked) function and
    turning what it returns into NumPy with ``to_numpy``. ``module``: the emitted module itself."""

    def __init__(self, module, ir_module, to_numpy) -> None:
        self.module = module
        self._to_numpy = to_numpy
        for f in ir_module.public:
            function = getattr(module, f.name)
            if f.kind == "straight":
                setattr(self, f.name, self._straight(function))
            else:  # each solver's own names (two solvers may give one code different names)
                names = {value: name.lower().removeprefix("ik_") for name, value, _ in f.statuses}
                setattr(self, f.name, self._procedure(function, names))

    def _numpy(self, x):
        return np.asarray(self._to_numpy(x))

    def _straight(self, function):
        def call(*args, **kwargs):
            out = function(*args, **kwargs)
            if isinstance(out, tuple):
                return tuple(self._numpy(x) for x in out)
            return self._numpy(out)

        call.__name__ = function.__name__
        return call

    def _procedure(self, function, names):
        def call(*args, **kwargs):
            result = function(*args, **kwargs)
            values = {}
            for field, value in zip(result._fields, result):
                value = self._numpy(value)
                if field == "status":
                    value = names[int(value)] if value.ndim == 0 else np.vectorize(names.get, otypes=[object])(value)
                elif field != result._fields[0] and value.ndim == 0:
                    value = value.item()
                values[field] = value
            return type(result)(**values)

        call.__name__ = function.__name__
        return call
