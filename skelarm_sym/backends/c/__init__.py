"""The C99 backend (see :mod:`.backend`)."""

from __future__ import annotations

from .backend import FILE_SUFFIXES, LANGUAGE, render

LABEL = "C"
"""How ``check`` names this backend's implementation."""
SUPPORTS = ("straight", "procedure")
"""The kinds of IR function this backend prints."""


def load(generated):
    """The emitted C compiled (strict flags, cached) and loaded through ctypes: one method per public function
    (the CPython extension's fast entries are the ``cpython`` backend's)."""
    from ...build import compile_arm

    return compile_arm(generated, extension=False)


__all__ = ["FILE_SUFFIXES", "LABEL", "LANGUAGE", "SUPPORTS", "load", "render"]
