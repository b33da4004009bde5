"""Independent NumPy references: the judges of the symbolic side.

Nothing here imports :mod:`skelarm_sym.derive`, :mod:`skelarm_sym.program` or the backends.
One module per model (``planar``, ``diffdrive``, ``chain``) plus ``linalg`` for the inverse
functions (NumPy eigen-decomposition and SVD, never the generator's rank rules).
"""

from .chain import ChainKinematics, chain_kinematics
from .diffdrive import diffdrive_body_rates, diffdrive_pose_rate, diffdrive_wheel_speeds
from .linalg import Solve, damped_least_squares, manipulability
from .planar import Kinematics, kinematics

__all__ = [
    "ChainKinematics", "Kinematics", "Solve", "chain_kinematics", "damped_least_squares", "diffdrive_body_rates",
    "diffdrive_pose_rate", "diffdrive_wheel_speeds", "kinematics", "manipulability",
]
