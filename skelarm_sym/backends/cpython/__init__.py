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
    """The emitted C and its extension compiled into one library (strict flags, cached) and loaded: one
    method per public function, single configurations through the extension."""
    from ...build import compile_arm

    return compile_arm(generated, extension=True)


__all__ = ["EXTENSION_SUFFIX", "FILE_SUFFIXES", "LABEL", "LANGUAGE", "SUPPORTS", "load", "module_name", "render",
           "render_extension"]
