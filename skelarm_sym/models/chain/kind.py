"""The 3-D serial chain's entry in the model registry."""

from __future__ import annotations

from ..registry import ModelKind
from .model import Chain

SOLVERS = ("ik_solve", "ik_solve_position")


def _derive(model: Chain, wanted):
    """A chain whose wanted functions name none of the inverse functions is derived without them
    (they take most of the generation time)."""
    from .derive import derive_chain
    from .inverse import INVERSE_FUNCTIONS

    inverse = {f.name for f in INVERSE_FUNCTIONS} | set(SOLVERS)
    return derive_chain(model, inverse=wanted is None or bool(set(wanted) & inverse))


KIND = ModelKind("chain", Chain, _derive)
