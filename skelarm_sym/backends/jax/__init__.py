"""The JAX backend (see :mod:`.backend`): ``--lang jax`` writes ``{prefix}_jax.py``."""

from __future__ import annotations

from .backend import FILE_SUFFIXES, LANGUAGE, render

LABEL = "JAX"
"""How ``check`` names this backend's implementation."""
SUPPORTS = ("straight", "procedure")
"""The kinds of IR function this backend prints (procedures batched over problems with lax control flow)."""


def load(generated):
    """The emitted module, loaded, behind an adapter that takes and returns NumPy arrays (for ``check``
    and the tests). A double-precision module turns on ``jax_enable_x64`` (JAX's float64). Without JAX:
    a skip inside a pytest run, else an InputError saying what to install."""
    from ...build import load_python
    from ...errors import InputError
    from ..torch.adapter import ArrayAdapter, require

    jax = require("jax", "jax")
    if generated.module.precision == "double":
        jax.config.update("jax_enable_x64", True)
    name = generated.module.prefix + FILE_SUFFIXES[0]
    try:
        module = load_python(generated.sources[name], generated.module.prefix + "_jax")
    except SyntaxError as exc:  # a file edited by hand
        raise InputError(f"{name} does not load: {exc.msg} (line {exc.lineno})") from None
    return ArrayAdapter(module, generated.module, lambda x: x)


__all__ = ["FILE_SUFFIXES", "LABEL", "LANGUAGE", "SUPPORTS", "load", "render"]
