"""The C99 backend (see :mod:`.backend`)."""

from .backend import FILE_SUFFIXES, LANGUAGE, render

__all__ = ["FILE_SUFFIXES", "LANGUAGE", "render"]
