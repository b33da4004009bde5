"""Models: immutable descriptions of a mechanism plus validation, one folder per kind of model."""

from .chain import Chain, load_robot, load_urdf
from .diffdrive import DiffDrive, validate_track
from .planar import MAX_LINKS, PlanarArm, validate_lengths, validate_links

__all__ = ["Chain", "DiffDrive", "MAX_LINKS", "PlanarArm", "load_robot", "load_urdf", "validate_links", "validate_lengths", "validate_track"]
