"""Code backends: one folder per language (printer, context, templates), registered in :mod:`.registry`."""

from .registry import BACKENDS

__all__ = ["BACKENDS"]
