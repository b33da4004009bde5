"""Every backend, registered in one place: a language name -> its module.

A backend is a folder ``backends/<lang>/`` whose package exposes ``LANGUAGE`` (its ``--lang`` name),
``FILE_SUFFIXES`` (the files it writes, after the prefix) and ``render(module, stamp) -> {suffix: text}``
for an IR :class:`~skelarm_sym.ir.nodes.Module`. Adding a language is a new folder and one line here
(``docs/architecture.md`` says how)."""

from __future__ import annotations

from . import c, cpython, cuda, jax, numpy, torch

BACKENDS = {backend.LANGUAGE: backend for backend in (c, numpy, cpython, torch, jax, cuda)}
"""Language name -> backend, in the order files are written."""
