"""The CPython extension backend (see :mod:`.backend`): the C of :mod:`..c` plus ``{prefix}.ext.c``, a
CPython extension module whose functions call the emitted single-configuration C functions directly."""

from __future__ import annotations

from .backend import EXTENSION_SUFFIX, FILE_SUFFIXES, LANGUAGE, module_name, render, render_extension

LABEL = "CPython"
"""How ``check`` names this backend's implementation."""
SUPPORTS = ("straight", "procedure")
"""The kinds of IR function this backend serves: straight-line functions through the extension's fast
entries (anything they do not take, and every batch, goes the ctypes way of :mod:`..c`), procedures
through ctypes as in :mod:`..c`."""


def load(generated):
    """The emitted C and its extension compiled into one library (strict flags, cached) and loaded, seen
    as :class:`SingleCalls`: ``check`` hands every implementation batches, which would go the ctypes way
    of :mod:`..c` and leave the extension untested; here each configuration is one call of its fast entry."""
    from ...build import compile_arm

    return SingleCalls(compile_arm(generated, extension=True))


class SingleCalls:
    """A :class:`~skelarm_sym.wrapper.CompiledArm` with its extension, whose straight-line functions take a
    batch and call the extension's entry once per configuration (inputs made C-contiguous arrays of the
    real type and Python floats, as the ordinary path converts them), stacking the outputs. Input the
    ordinary path refuses (wrong count, shape, type or domain) gets its error and message; an entry that
    answers ``NotImplemented`` for a configuration the ordinary path takes is an error, not a quiet
    fall-back. Solvers and everything else are the arm's own."""

    def __init__(self, arm):
        if arm.extension is None:
            raise RuntimeError(f"{arm.prefix}: the library was loaded without its CPython extension")
        self.arm = arm

    def __getattr__(self, name: str):
        arm = self.__dict__["arm"]
        f = next((f for f in arm.module.public if f.name == name and f.kind == "straight"), None)
        if f is None:
            return getattr(arm, name)
        entry = getattr(arm.extension, name)

        ordinary = getattr(arm, name)

        def each(*args):
            import numpy as np

            if len(args) != len(f.inputs):
                return ordinary(*args)  # its TypeError, naming the signature
            try:
                values = [np.asarray(x) for x in args]
                if any(x.dtype.kind not in "biuf" for x in values):  # complex, strings, objects
                    return ordinary(*args)  # its ValueError, naming the argument
                values = [np.asarray(x, dtype=arm.dtype) for x in values]
            except (TypeError, ValueError, OverflowError):
                return ordinary(*args)  # its ValueError, naming the argument
            batch = np.broadcast_shapes(*(x.shape[:-1] for x, a in zip(values, f.inputs) if a.batched and not a.is_scalar))
            if batch:
                values = [x if a.is_scalar or not a.batched else np.broadcast_to(x, batch + x.shape[-1:])
                          for x, a in zip(values, f.inputs)]
            rows = []
            for index in np.ndindex(*batch):
                row = [float(x) if a.is_scalar else np.ascontiguousarray(x[index] if a.batched else x)
                       for x, a in zip(values, f.inputs)]
                out = entry(*row)
                if out is NotImplemented:
                    ordinary(*args)  # bad input: raises the ordinary path's error, naming the argument
                    raise RuntimeError(f"the CPython extension's {name} refused configuration {index} of the check")
                rows.append(out if isinstance(out, tuple) else (out,))
            if not batch:
                outs = rows[0]
            else:
                outs = tuple(np.stack([r[k] for r in rows]).reshape(batch + o.shape) for k, o in enumerate(f.outputs))
            return outs[0] if len(outs) == 1 else outs

        each.__name__ = name
        return each


__all__ = ["EXTENSION_SUFFIX", "FILE_SUFFIXES", "LABEL", "LANGUAGE", "SUPPORTS", "load", "module_name", "render",
           "render_extension", "SingleCalls"]
