"""The differential-drive robot: model, derivation, reference."""

from .model import DiffDrive, validate_track

__all__ = ["DiffDrive", "validate_track"]
