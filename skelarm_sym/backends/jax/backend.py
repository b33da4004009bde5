"""JAX backend: the context of ``templates/jax/module.py.j2`` from an IR module.

The emitted module depends on JAX (and NumPy). It has the PyTorch module's layers, as pure functions of
``jax.numpy``: ``_<name>_core`` (the straight-line program over lists of per-element arrays),
``<name>_unchecked`` (arrays in and out, nothing checked: what to ``jax.jit``, ``jax.vmap``,
``jax.jacfwd``) and ``<name>`` (converts and checks its inputs like the NumPy module, then calls the
unchecked function; value checks are skipped for tracers). Procedures are batched over problems in
masked form (:mod:`skelarm_sym.ir.predicate`) with ``lax`` control flow, and compiled once per input
shape with ``jax.jit``. Double precision needs ``jax_enable_x64`` (without it JAX computes in float32);
the random restarts need no 64-bit integers (32-bit halves).
"""

from __future__ import annotations

from ...ir.nodes import Module
from ..torch.backend import context
from .printer import JAX, JaxProcedurePrinter

LANGUAGE = "jax"
FILE_SUFFIXES = ("_jax.py",)
DTYPES = {"double": "jnp.float64", "float": "jnp.float32"}


def render(module: Module, stamp: str) -> dict[str, str]:
    """``{"_jax.py": text}``."""
    from ..templating import render_template

    ctx = context(module, JAX, JaxProcedurePrinter, DTYPES)
    return {FILE_SUFFIXES[0]: render_template("jax/module.py.j2", stamp=stamp, **ctx)}
