"""Code backends: a SymPy printer subclass and the context a Jinja template needs, per language.

Each backend module exposes ``LANGUAGE``, ``FILE_SUFFIXES`` and
``render(derivation, programs, options) -> dict[suffix, text]``.
"""

from . import c, python

BACKENDS = {c.LANGUAGE: c, python.LANGUAGE: python}
"""Language name -> backend module, in the order files are written."""

__all__ = ["BACKENDS"]
