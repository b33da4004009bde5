"""The planar arm's entry in the model registry."""

from __future__ import annotations

from ..registry import ModelKind
from .model import PlanarArm


def _derive(model: PlanarArm, wanted):
    from .derive import derive

    return derive(model)


KIND = ModelKind("planar", PlanarArm, _derive)
