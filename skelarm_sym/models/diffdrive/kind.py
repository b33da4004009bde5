"""The differential drive's entry in the model registry."""

from __future__ import annotations

import argparse

from ...errors import InputError
from ...names import ascii_number
from ..kind import ModelKind
from .model import DiffDrive, validate_track


def _derive(model: DiffDrive, wanted):
    from .derive import derive_diffdrive

    return derive_diffdrive(model)


def _scenarios(derivation, cases, seed, precision):
    from .check import diffdrive_scenarios

    return diffdrive_scenarios(derivation, cases, seed, precision)


def _track(text: str) -> float:
    try:
        return validate_track(float(ascii_number(text)))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}") from None


def _add_options(parser) -> None:
    parser.add_argument("--track", type=_track, help="diffdrive: distance between the wheels baked in as a constant (default: run-time argument)")


def _from_args(args, folder=None):
    return DiffDrive(args.track) if args.model == "diffdrive" else None


def _show(model: DiffDrive, args) -> str:
    from .show import show_diffdrive

    if args.plot:
        raise InputError("--plot draws planar arms")
    if getattr(args, "expand", False):
        raise InputError("--expand applies to --robot: the differential drive's matrices are printed in full already")
    return show_diffdrive(model, args.what or "all", args.format)


KIND = ModelKind(
    "diffdrive", DiffDrive, _derive, scenarios=_scenarios, show=_show, add_options=_add_options, from_args=_from_args,
    options=(("--track", "track"),), title="a differential drive", model_option=True,
    prefix_rule="diffdrive for the differential drive",
)
