"""The NumPy backend (see :mod:`.backend`)."""

from __future__ import annotations

from .backend import FILE_SUFFIXES, LANGUAGE, render

LABEL = "Python"
"""How ``check`` names this backend's implementation."""
SUPPORTS = ("straight", "procedure")
"""The kinds of IR function this backend prints."""


def load(generated):
    """The emitted module executed from its text (the files' own, for ``check --from``)."""
    from ...build import load_python
    from ...errors import InputError

    name = generated.module.prefix + FILE_SUFFIXES[0]
    try:
        return load_python(generated.sources[name], generated.module.prefix)
    except SyntaxError as exc:  # a file edited by hand
        raise InputError(f"{name} does not load: {exc.msg} (line {exc.lineno})") from None


__all__ = ["FILE_SUFFIXES", "LABEL", "LANGUAGE", "SUPPORTS", "load", "render"]
