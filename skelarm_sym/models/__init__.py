"""Arm models: immutable descriptions of a mechanism plus validation."""

from .planar import MAX_LINKS, PlanarArm, validate_links, validate_lengths

__all__ = ["MAX_LINKS", "PlanarArm", "validate_links", "validate_lengths"]
