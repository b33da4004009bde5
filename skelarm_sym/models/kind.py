"""What one kind of model provides to the rest of the pipeline (see :mod:`skelarm_sym.models.registry`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable


@dataclass(frozen=True)
class ModelKind:
    """What one kind of model provides to the rest of the pipeline.

    ``derive(model, wanted)``: its :class:`~skelarm_sym.derive.core.Derivation` (``wanted``: the function
    names asked for, or ``None`` for all; a kind may skip costly parts nobody asked for).
    ``solvers(derivation, names)``: IR functions of its iterative solvers (procedures) for the emitted
    function names ``names``. ``solver_names``: names of those solvers and the derived functions each needs.
    ``scenarios(derivation, cases, seed, precision)``: check scenarios from its reference.
    ``solver_checks(generated, implementations, cases, seed, precision)``: rows judging its solvers.
    ``show(model, args)``: closed forms (or a plot) for ``skelarm-sym show``, as text. ``add_options(parser)`` and
    ``from_args(args, folder)``: its command-line options and the model they describe (``None`` when the
    arguments describe another kind; relative files are found in ``folder`` when it is given)."""

    name: str
    model_type: type
    derive: Callable[[Any, frozenset | None], Any]
    scenarios: Callable[..., list] | None = None
    solvers: Callable[..., list] | None = None
    solver_names: dict[str, tuple[str, ...]] = field(default_factory=dict)
    solver_extras: dict[str, tuple[str, ...]] = field(default_factory=dict)
    """Derived functions a solver calls where the derivation has them (and does without otherwise)."""
    solver_checks: Callable[..., list] | None = None
    show: Callable[..., str] | None = None
    add_options: Callable[[Any], None] | None = None
    from_args: Callable[[Any], Any] | None = None
    options: tuple[tuple[str, str], ...] = ()
    """``(flag, argparse dest)`` of the options ``add_options`` adds (another kind's are refused)."""
    title: str = ""
    """How messages name the kind (``a planar arm``)."""
    model_option: bool = False
    """Chosen by ``--model NAME`` (otherwise by options of its own, such as ``--robot``)."""
    prefix_rule: str = ""
    """How the default prefix (file name, C prefix) of this kind's models is chosen, for ``--help``."""
    preview: Callable[[Any], str | None] | None = None
    """``show``'s answer that needs no model (a URDF's link tree, to choose the chain), or ``None``."""
