"""Every backend, registered in one place: a language name -> its module.

A backend is a folder ``backends/<lang>/`` whose package exposes ``LANGUAGE`` (its ``--lang`` name),
``LABEL`` (its name in check's tables), ``FILE_SUFFIXES`` (the files it writes, after the prefix),
``SUPPORTS`` (the kinds of function it prints: ``"straight"``, ``"procedure"``; generate refuses the others),
``render(module, stamp) -> {suffix: text}`` for an IR :class:`~skelarm_sym.ir.nodes.Module` and ``load(generated)``
(an object with one method per public function). Adding a language is a new folder and one line here
(``docs/architecture.md`` says how, and what the tests ask of it).

A backend's package is imported the first time it is looked up, not with this module: a command that
writes C and NumPy does not pay for the PyTorch, JAX, CUDA and CPython printers (parsing them is a
tenth of a ``generate`` command's start-up when Python keeps no bytecode)."""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping
from types import ModuleType

_PACKAGES = (
    ("c", "c"),
    ("python", "numpy"),
    ("cpython", "cpython"),
    ("torch", "torch"),
    ("jax", "jax"),
    ("cuda", "cuda"),
)
"""(language name, package under ``skelarm_sym.backends``), in the order files are written."""


class _Backends(Mapping):
    """Language name -> backend package, each imported on first lookup (the names need no import)."""

    def __init__(self, packages: tuple[tuple[str, str], ...]) -> None:
        self._packages = dict(packages)

    def __getitem__(self, language: str) -> ModuleType:
        module = importlib.import_module(f"{__package__}.{self._packages[language]}")
        if module.LANGUAGE != language:
            raise RuntimeError(f"internal error: backend {module.__name__} is {module.LANGUAGE!r}, registered as {language!r}")
        return module

    def __iter__(self) -> Iterator[str]:
        return iter(self._packages)

    def __len__(self) -> int:
        return len(self._packages)

    def __contains__(self, language: object) -> bool:
        return language in self._packages

    def __repr__(self) -> str:
        return f"BACKENDS({', '.join(self._packages)})"


BACKENDS: Mapping[str, ModuleType] = _Backends(_PACKAGES)
"""Language name -> backend, in the order files are written."""
