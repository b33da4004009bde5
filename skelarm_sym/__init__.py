"""skelarm-sym: closed-form differential kinematics of serial arms as fast, checked code."""

from .derive import Derivation, derive
from .derive import derive_diffdrive
from .errors import InputError
from .models import DiffDrive, PlanarArm
from .models import load_robot

__version__ = "0.3.0"

__all__ = ["Derivation", "DiffDrive", "InputError", "PlanarArm", "__version__", "derive", "derive_diffdrive", "load_robot"]
