"""Models: immutable descriptions of a mechanism plus validation."""

from .diffdrive import DiffDrive, validate_track
from .planar import MAX_LINKS, PlanarArm, validate_links, validate_lengths

__all__ = ["DiffDrive", "MAX_LINKS", "PlanarArm", "validate_links", "validate_lengths", "validate_track"]
