"""The 3-D serial chain's entry in the model registry."""

from __future__ import annotations

import os

from ...errors import InputError
from ..kind import ModelKind
from .loader import PREFIX_RULE
from .model import Chain

def _derive(model: Chain, wanted):
    """A chain whose wanted functions are all forward ones is derived without the inverse functions
    (they take most of the generation time); any other name (an inverse function, a solver, or an
    unknown one, which the error then lists among all) needs the whole derivation."""
    from .derive import CHAIN_FUNCTIONS, derive_chain

    forward = {f.name for f in CHAIN_FUNCTIONS}
    return derive_chain(model, inverse=wanted is None or not set(wanted) <= forward)


def _solvers(derivation, names, precision):
    from .solver import chain_solvers

    return chain_solvers(derivation, names, precision)


def _scenarios(derivation, cases, seed, precision):
    from .check import chain_scenarios

    return chain_scenarios(derivation, cases, seed, precision)


def _solver_checks(generated, implementations, cases, seed, precision):
    from .check import chain_ik

    return chain_ik(generated.derivation, implementations, cases, seed, precision)


def _add_options(parser) -> None:
    parser.add_argument("--robot", metavar="FILE", help="a 3-D serial chain: a TOML DH robot file or a URDF")
    parser.add_argument("--base", metavar="LINK", help="URDF: the chain's first link (default: the root link)")
    parser.add_argument("--tip", metavar="LINK", help="URDF: the chain's last link (default: the only leaf below --base)")


def _from_args(args, folder=None):
    if getattr(args, "robot", None) is None:
        return None
    if args.model is not None:
        raise InputError("--robot describes the whole robot: drop --model")
    from .loader import load_robot

    path = args.robot if folder is None or os.path.isabs(args.robot) else os.path.join(folder, args.robot)
    return load_robot(path, base=args.base, tip=args.tip)


def _preview(args) -> str | None:
    """``show --robot X.urdf --what links``: the link tree, to choose --base and --tip."""
    if getattr(args, "what", None) != "links" or getattr(args, "robot", None) is None:
        return None
    from .urdf import urdf_tree

    return "\n".join(urdf_tree(args.robot)) + "\n"


def _show(model: Chain, args) -> str:
    from .derive import derive_chain
    from .show import show_chain

    if args.plot:
        raise InputError("--plot draws planar arms")
    return show_chain(derive_chain(model, inverse=False), args.what or "J", args.format, True if args.expand else None)


KIND = ModelKind(
    "chain", Chain, _derive, scenarios=_scenarios, solvers=_solvers,
    solver_names={"ik_solve": ("ik_terms",), "ik_solve_position": ("ik_terms",)}, solver_checks=_solver_checks,
    show=_show, add_options=_add_options, from_args=_from_args,
    options=(("--robot", "robot"), ("--base", "base"), ("--tip", "tip")), title="a robot file's chain", preview=_preview,
    prefix_rule="for a robot file: " + PREFIX_RULE.removeprefix("default prefix: "),
)
