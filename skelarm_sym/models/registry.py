"""The one dispatcher on the kind of model: each kind registers a :class:`ModelKind` here.

Nothing outside ``models/`` asks which kind of model it holds; it asks :func:`kind_of` for the
model's :class:`ModelKind` and calls what the kind provides (derivation, iterative solvers, check
scenarios, ``show``, command-line options).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import InputError


@dataclass(frozen=True)
class ModelKind:
    """What one kind of model provides to the rest of the pipeline.

    ``derive(model, wanted)``: its :class:`~skelarm_sym.derive.core.Derivation` (``wanted``: the function
    names asked for, or ``None`` for all; a kind may skip costly parts nobody asked for).
    ``solvers(derivation, names)``: IR functions of its iterative solvers (procedures) for the emitted
    function names ``names``. ``solver_names``: names of those solvers and the derived functions each needs.
    ``scenarios(derivation, cases, seed, precision)``: check scenarios from its reference.
    ``solver_checks(generated, implementations, cases, seed, precision)``: rows judging its solvers.
    ``show(model, what, fmt, expand)``: closed forms as text. ``add_options(parser)`` and
    ``from_args(args)``: its command-line options and the model they describe (``None`` when the
    arguments describe another kind)."""

    name: str
    model_type: type
    derive: Callable[[Any, frozenset | None], Any]
    scenarios: Callable[..., list] | None = None
    solvers: Callable[..., list] | None = None
    solver_names: dict[str, tuple[str, ...]] = field(default_factory=dict)
    solver_checks: Callable[..., list] | None = None
    show: Callable[..., str] | None = None
    add_options: Callable[[Any], None] | None = None
    from_args: Callable[[Any], Any] | None = None


def kinds() -> tuple[ModelKind, ...]:
    """Every registered kind, in the order the command line tries them."""
    from .chain.kind import KIND as chain
    from .diffdrive.kind import KIND as diffdrive
    from .planar.kind import KIND as planar

    return (chain, diffdrive, planar)


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
