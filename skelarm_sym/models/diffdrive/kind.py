"""The differential drive's entry in the model registry."""

from __future__ import annotations

from ..registry import ModelKind
from .model import DiffDrive


def _derive(model: DiffDrive, wanted):
    from .derive import derive_diffdrive

    return derive_diffdrive(model)


KIND = ModelKind("diffdrive", DiffDrive, _derive)
