"""The planar arm's entry in the model registry: derivation, solver, check, show and options."""

from __future__ import annotations

import argparse
import math

from ...errors import InputError
from ...names import ascii_number
from ..kind import ModelKind
from .model import PlanarArm, validate_links


def _derive(model: PlanarArm, wanted):
    from .derive import derive

    return derive(model)


def _solvers(derivation, names, precision):
    from .solver import planar_solvers

    return planar_solvers(derivation, names, precision)


def _scenarios(derivation, cases, seed, precision):
    from .check import planar_scenarios

    return planar_scenarios(derivation, cases, seed, precision)


def _solver_checks(generated, implementations, cases, seed, precision):
    from .check import planar_ik

    return planar_ik(generated.derivation, implementations, cases, seed, precision)


def _links(text: str) -> int:
    try:
        value = int(ascii_number(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
    try:
        return validate_links(value)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _numbers(what: str):
    def parse(text: str) -> tuple[float, ...]:
        values = []
        for item in text.split(","):
            try:
                values.append(float(ascii_number(item)))
            except ValueError:
                raise argparse.ArgumentTypeError(f"{what} must be comma-separated numbers, got {item.strip()!r}") from None
        return tuple(values)

    return parse


def _add_options(parser) -> None:
    parser.add_argument("--links", "-n", type=_links, help="planar arm: number of links N (1..1000)")
    parser.add_argument("--lengths", type=_numbers("link lengths"),
                        help="planar arm: comma-separated link lengths baked in as constants (default: run-time argument l)")


def _from_args(args, folder=None):
    if getattr(args, "robot", None) is not None or args.model not in (None, "planar"):
        return None
    if args.links is None:
        raise InputError("the following arguments are required: --links/-n (a planar arm), or --model diffdrive, or --robot FILE")
    return PlanarArm(args.links, args.lengths)


def _show(model: PlanarArm, args) -> str:
    from .show import WHAT, check_show_size, show

    what = args.what or "J"
    if getattr(args, "expand", False):
        raise InputError("--expand applies to --robot: a planar arm's closed forms are printed in full already")
    if what not in WHAT + ("all",):
        raise InputError(f"unknown --what {what!r}; choose from {', '.join(WHAT + ('all',))}")
    if args.plot:
        from .plot import plot_arm

        lengths = model.lengths or (1.0,) * model.n
        pose = args.pose if args.pose is not None else (math.pi / 6,) * model.n
        if len(pose) != model.n:
            raise InputError(f"--pose has {len(pose)} angles, expected {model.n}")
        summary = plot_arm(pose, lengths, args.plot)
        sigma = ", ".join(f"{s:.4g}" for s in summary.singular_values)
        return f"wrote {summary.path}: w = {summary.manipulability:.6g}, singular values of J: {sigma}\n"
    check_show_size(model.n)  # before deriving: closed forms of long chains take minutes
    return show(_derive(model, None), what, args.format)


KIND = ModelKind(
    "planar", PlanarArm, _derive, scenarios=_scenarios, solvers=_solvers, solver_names={"ik_solve": ("position", "ik_step")},
    solver_checks=_solver_checks, show=_show, add_options=_add_options, from_args=_from_args,
    options=(("--links", "links"), ("--lengths", "lengths")), title="a planar arm", model_option=True,
    prefix_rule="arm{N} for a planar arm of N links",
)
