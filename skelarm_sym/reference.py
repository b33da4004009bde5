"""Independent NumPy references, the judges of the symbolic side, in one namespace.

Each lives with its model (``models/<kind>/reference.py``) and imports nothing of the derivation,
the IR or the backends; the inverse functions are judged by NumPy's SVD (:mod:`skelarm_sym.models.reference_linalg`),
never by the generator's rank rules.
"""

from .models.reference_linalg import Solve, damped_least_squares, manipulability
from .models.chain.reference import ChainKinematics, chain_kinematics
from .models.diffdrive.reference import diffdrive_body_rates, diffdrive_pose_rate, diffdrive_wheel_speeds
from .models.planar.reference import Kinematics, kinematics

__all__ = [
    "ChainKinematics", "Kinematics", "Solve", "chain_kinematics", "damped_least_squares", "diffdrive_body_rates",
    "diffdrive_pose_rate", "diffdrive_wheel_speeds", "kinematics", "manipulability",
]
