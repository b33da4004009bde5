"""skelarm-sym: closed-form differential kinematics of serial arms as fast, checked code."""

from .derive import Derivation, derive
from .errors import InputError
from .models import PlanarArm

__version__ = "0.1.0"

__all__ = ["Derivation", "InputError", "PlanarArm", "__version__", "derive"]
