"""The planar serial arm: model, derivation, singularities, reference."""

from .model import MAX_LINKS, PlanarArm, validate_lengths, validate_links

__all__ = ["MAX_LINKS", "PlanarArm", "validate_lengths", "validate_links"]
