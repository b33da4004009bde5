"""Derivations: model -> closed forms as named steps. One module per model, shared pieces in ``core``.

``derive(n, lengths)`` is the planar arm's; ``derive_diffdrive``, the differential drive's;
:func:`derive_model` dispatches on any supported model.
"""

from .core import RANK_TOL, Constant, Derivation, FunctionSpec, StepRecorder, exact_number, expand_steps
from .diffdrive import derive_diffdrive
from .planar import PLANAR_FUNCTIONS, PlanarDerivation, derive

__all__ = [
    "PLANAR_FUNCTIONS", "RANK_TOL", "Constant", "Derivation", "FunctionSpec", "PlanarDerivation", "StepRecorder",
    "derive", "derive_diffdrive", "exact_number", "expand_steps",
]
