"""Derivations: model -> closed forms as named steps. One module per model, shared pieces in ``core``.

``derive(n, lengths)`` is the planar arm's; ``derive_diffdrive``, the differential drive's;
:func:`derive_model` dispatches on any supported model.
"""

from typing import Sequence

from .core import RANK_TOL, Constant, Derivation, FunctionSpec, StepRecorder, exact_number, expand_steps
from .diffdrive import derive_diffdrive
from .planar import PLANAR_FUNCTIONS, PlanarDerivation
from .planar import derive as derive_planar


def derive(model, lengths: Sequence[float] | None = None) -> Derivation:
    """The derivation of any model: a number of links or a ``PlanarArm`` (with ``lengths``: see
    :func:`skelarm_sym.derive.planar.derive`), a ``DiffDrive``, or a 3-D ``Chain`` (from
    :func:`skelarm_sym.load_robot`). Raises ``InputError`` (a ``ValueError``) on bad input."""
    from ..models.chain import Chain
    from ..models.diffdrive import DiffDrive

    if isinstance(model, Chain):
        from .chain import derive_chain

        return derive_chain(model)
    if isinstance(model, DiffDrive):
        return derive_diffdrive(model)
    return derive_planar(model, lengths)

__all__ = [
    "PLANAR_FUNCTIONS", "RANK_TOL", "Constant", "Derivation", "FunctionSpec", "PlanarDerivation", "StepRecorder",
    "derive", "derive_diffdrive", "derive_planar", "exact_number", "expand_steps",
]
