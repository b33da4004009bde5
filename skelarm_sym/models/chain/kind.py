"""The 3-D serial chain's entry in the model registry."""

from __future__ import annotations

import os

from ...errors import InputError
from ..kind import ModelKind
from ...names import path_option
from .loader import PREFIX_RULE
from .ik_scope import refusal
from .lock import LOCK_OPTION, ik_lock, lock_index, with_ik_lock
from .model import Chain

SOLVERS = ("ik_solve", "ik_solve_position")
CLOSED = ("ik_candidates", "ik_all", "ik_nearest", "ik_nearest_weighted", "ik_continuum_members")
"""The closed-form IK functions: emitted when the chain is in a closed-form family (docs/closed-form-ik.md)."""
def _derive(model: Chain, wanted):
    """A chain whose wanted functions are all forward or closed-form ones is derived without the inverse
    functions (they take most of the generation time); any other name (an inverse function, a solver, or an
    unknown one, which the error then lists among all) needs the whole derivation. The closed-form IK is added
    when the chain is in a closed-form family; asked for by name (or with a lock) on a chain in none, the
    one-line reason is the error. A name that is none of these is derived as if nothing were named, so that the
    error that follows lists every function the chain has."""
    from .derive import CHAIN_FUNCTIONS, derive_chain

    forward = {f.name for f in CHAIN_FUNCTIONS} | set(CLOSED)
    derivation = derive_chain(model, inverse=wanted is None or not set(wanted) <= forward)
    if wanted is not None and not set(wanted) & set(CLOSED):
        if set(wanted) <= {f.name for f in derivation.functions} | set(SOLVERS):
            return derivation
        wanted = None  # an unknown name: the error lists every function, the closed-form ones where the chain has them
    lock = lock_index(model, ik_lock(model))
    if wanted is None and lock is None and refusal(model, lock) is not None:
        return derivation  # in no family, as derive_ik_all would find, without importing it (and NumPy)
    from ...closed_ik.classify import ClosedFormError
    from ...closed_ik.derive import derive_ik_all, with_candidates

    try:
        ik = derive_ik_all(model, lock)
    except ClosedFormError:
        if wanted is None and lock is None:
            return derivation  # no family: no closed-form functions (X_ik_solve remains the arm's IK)
        raise
    return with_candidates(derivation, ik)


def _solvers(derivation, names, precision):
    from .solver import chain_solvers

    iterative = chain_solvers(derivation, names, precision) if set(names) & set(SOLVERS) else []
    if not set(names) & {"ik_all", "ik_nearest", "ik_nearest_weighted"}:  # the closed-form procedures (they import NumPy) are not asked for
        return iterative
    from .solver_closed import closed_solvers

    return iterative + closed_solvers(derivation, names, precision)


def _scenarios(derivation, cases, seed, precision):
    from .check import chain_scenarios

    return chain_scenarios(derivation, cases, seed, precision)


def _solver_checks(generated, implementations, cases, seed, precision):
    from .check import chain_ik

    return chain_ik(generated.derivation, implementations, cases, seed, precision)


def _add_options(parser) -> None:
    parser.add_argument("--robot", metavar="FILE", type=path_option, help="a 3-D serial chain: a TOML DH robot file or a URDF")
    parser.add_argument("--base", metavar="LINK", help="URDF: the chain's first link (default: the root link)")
    parser.add_argument("--tip", metavar="LINK", help="URDF: the chain's last link (default: the only leaf below --base)")
    parser.add_argument(LOCK_OPTION, dest="ik_lock", metavar="JOINT",
                        help="7-joint robots: the joint (number 1..N, base to tip, or name) the closed-form IK holds at a "
                        "value given at run time (ik_all's scalar lock), e.g. 3 for a KUKA iiwa, 7 for a Panda")


def _from_args(args, folder=None):
    if getattr(args, "robot", None) is None:
        return None
    if args.model is not None:
        raise InputError("--robot describes the whole robot: drop --model")
    from .loader import load_robot

    path = args.robot if folder is None or os.path.isabs(args.robot) else os.path.join(folder, args.robot)
    chain = load_robot(path, base=args.base, tip=args.tip)
    lock = getattr(args, "ik_lock", None)
    return chain if lock is None else with_ik_lock(chain, lock)


def _preview(args) -> str | None:
    """``show --robot X.urdf --what links``: the link tree, to choose --base and --tip."""
    if getattr(args, "what", None) != "links" or getattr(args, "robot", None) is None:
        return None
    if not str(args.robot).lower().endswith(".urdf"):
        raise InputError(f"{args.robot}: --what links lists a URDF file's link tree (to choose --base and --tip); a "
                         "TOML robot file is one chain: show its closed forms with --what T, J, ...")
    from .urdf import urdf_tree

    return "\n".join(urdf_tree(args.robot, getattr(args, "base", None))) + "\n"


def _show(model: Chain, args) -> str:
    from .derive import derive_chain
    from .show import show_chain

    if args.plot:
        raise InputError("--plot draws planar arms")
    if args.what == "ik":
        from .show import show_ik

        return show_ik(model, lock_index(model, ik_lock(model)), args.format)
    return show_chain(derive_chain(model, inverse=False), args.what or "J", args.format, True if args.expand else None)


KIND = ModelKind(
    "chain", Chain, _derive, scenarios=_scenarios, solvers=_solvers,
    solver_names={"ik_solve": ("ik_terms", "pose"), "ik_solve_position": ("ik_terms", "pose"), "ik_all": ("ik_candidates",),
                  "ik_nearest": ("ik_candidates",), "ik_nearest_weighted": ("ik_candidates",)},
    solver_extras={"ik_nearest": ("ik_continuum_members",), "ik_nearest_weighted": ("ik_continuum_members",)},
    solver_checks=_solver_checks, show=_show, add_options=_add_options, from_args=_from_args,
    options=(("--robot", "robot"), ("--base", "base"), ("--tip", "tip"), (LOCK_OPTION, "ik_lock")), title="a robot file's chain",
    preview=_preview, prefix_rule="for a robot file: " + PREFIX_RULE.removeprefix("default prefix: "),
)
