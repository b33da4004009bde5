"""Models: immutable descriptions of a mechanism plus validation."""

from .diffdrive import DiffDrive, validate_track
from .loader import load_robot
from .planar import MAX_LINKS, PlanarArm, validate_links, validate_lengths
from .urdf import load_urdf

__all__ = ["DiffDrive", "MAX_LINKS", "PlanarArm", "load_robot", "load_urdf", "validate_links", "validate_lengths", "validate_track"]
