"""The one dispatcher on the kind of model: each kind registers a :class:`ModelKind` here.

Nothing outside ``models/`` asks which kind of model it holds; it asks :func:`kind_of` for the
model's :class:`ModelKind` and calls what the kind provides (derivation, iterative solvers, check
scenarios, ``show``, command-line options).
"""

from __future__ import annotations

from ..errors import InputError
from .chain.kind import KIND as CHAIN
from .diffdrive.kind import KIND as DIFFDRIVE
from .kind import ModelKind
from .planar.kind import KIND as PLANAR

KINDS: tuple[ModelKind, ...] = (CHAIN, DIFFDRIVE, PLANAR)
"""Every registered kind, in the order the command line tries them. A new kind: one line here."""


def kinds() -> tuple[ModelKind, ...]:
    """Every registered kind, in the order the command line tries them."""
    return KINDS


def kind_of(model: object) -> ModelKind:
    """The :class:`ModelKind` of ``model``; InputError for anything that is not a model."""
    for kind in kinds():
        if type(model) is kind.model_type:
            return kind
    raise InputError(f"not a model: {model!r} (a PlanarArm, DiffDrive or a chain from load_robot)")


def derive(model: object, functions=None):
    """The derivation of ``model`` (for the function names in ``functions``, or all)."""
    wanted = None if functions is None else frozenset(functions)
    return kind_of(model).derive(model, wanted)
