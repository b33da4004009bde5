"""Command line: ``skelarm-sym generate | show | check``. Parse, call, print; one-line errors.

Bad input prints ``skelarm-sym: error: <message>`` on standard error and exits
with status 2; a failed check exits with status 1.
"""

from __future__ import annotations

import argparse
import sys
from typing import Sequence

from . import __version__
from .errors import InputError
from .models.planar import validate_links


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, status 2, no usage dump
        raise InputError(message)


def _links(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
    try:
        return validate_links(value)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _lengths(text: str):
    from .generate import parse_lengths

    try:
        return parse_lengths(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _angles(text: str) -> tuple[float, ...]:
    from .generate import parse_numbers

    try:
        return parse_numbers(text, "joint angles")
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _track(text: str) -> float:
    from .models.diffdrive import validate_track

    try:
        return validate_track(float(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}") from None


MODELS = ("planar", "diffdrive")


def _add_model_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--model", default="planar", choices=MODELS, help="planar serial arm (default) or diffdrive")
    parser.add_argument("--links", "-n", type=_links, help="number of links N (1..1000); planar arms only, required there")
    parser.add_argument("--lengths", type=_lengths, help="comma-separated link lengths baked in as constants (default: run-time argument l)")
    parser.add_argument("--track", type=_track, help="diffdrive: distance between the wheels baked in as a constant (default: run-time argument)")
    parser.add_argument("--robot", metavar="FILE", help="a 3-D serial chain: a TOML DH robot file or a URDF")
    parser.add_argument("--base", metavar="LINK", help="URDF: the chain's first link (default: the root link)")
    parser.add_argument("--tip", metavar="LINK", help="URDF: the chain's last link (default: the only leaf below --base)")


def model_from_args(args):
    """The model an invocation describes; InputError when its options do not fit it."""
    from .models.diffdrive import DiffDrive
    from .models.planar import PlanarArm

    if getattr(args, "robot", None) is not None:
        if args.model != "planar" or args.links is not None or args.lengths is not None or args.track is not None:
            raise InputError("--robot describes the whole robot: drop --model, --links, --lengths and --track")
        from .models.chain.loader import load_robot

        return load_robot(args.robot, base=args.base, tip=args.tip)
    if getattr(args, "base", None) is not None or getattr(args, "tip", None) is not None:
        raise InputError("--base and --tip choose a chain inside a URDF given with --robot")
    if args.model == "diffdrive":
        if args.links is not None or args.lengths is not None:
            raise InputError("--links and --lengths describe planar arms; a diffdrive takes --track")
        return DiffDrive(args.track)
    if args.track is not None:
        raise InputError("--track is for --model diffdrive")
    if args.links is None:
        raise InputError("the following arguments are required: --links/-n")
    return PlanarArm(args.links, args.lengths)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = _Parser(prog="skelarm-sym", description="Closed-form differential kinematics of serial arms as checked C and NumPy code.")
    parser.add_argument("--version", action="version", version=f"skelarm-sym {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    gen = sub.add_parser("generate", help="emit C and/or Python for an arm")
    _add_model_options(gen)
    gen.add_argument("--lang", default="c,python", help="c, python or c,python (default)")
    gen.add_argument("--prefix", help="file name and C function prefix (default arm{N}, or diffdrive)")
    gen.add_argument("--precision", default="double", help="double (default) or float")
    gen.add_argument("--out", default="generated", help="output folder (default ./generated)")
    gen.add_argument("--compile", action="store_true", help="also compile the C with the strict flags and report the library path")
    gen.add_argument("--functions", help="comma-separated functions to emit (default all; ik_solve brings position and ik_step)")
    gen.add_argument("--cmake", action="store_true", help="also write CMakeLists.txt: a static library target named after the prefix")
    gen.add_argument("--force", action="store_true", help="replace files generated with other options")

    show = sub.add_parser("show", help="print closed forms")
    _add_model_options(show)
    show.add_argument("--what", help="planar: p, phi, J, J3, H, v, a, det, manipulability, singular or all (default J); "
                      "diffdrive: matrix, inverse or all (default all); robots: T, J, J_tool, dJ, twist, acc or all (default J)")
    show.add_argument("--format", default="pretty", help="pretty (default), latex or text")
    show.add_argument("--expand", action="store_true", help="robots: print the fully expanded closed form instead of the steps")
    show.add_argument("--plot", metavar="FILE", help="draw the arm and its velocity ellipse to FILE (.png, .svg, .pdf; needs matplotlib)")
    show.add_argument("--pose", type=_angles, help="joint angles q1,...,qN in radians for --plot (default pi/6 each)")

    chk = sub.add_parser("check", help="generate, compile and compare with the recursive reference")
    _add_model_options(chk)
    chk.add_argument("--precision", help="double (default) or float")
    chk.add_argument("--lang", help="c, python or c,python (default)")
    chk.add_argument("--from", dest="source", metavar="DIR",
                     help="check the files generated earlier in DIR (their header records the model and options)")
    chk.add_argument("--prefix", help="with --from: the files' prefix (default: the only one in DIR)")
    chk.add_argument("--cases", type=int, default=100, help="random configurations (default 100), plus singular and zero-velocity poses")
    chk.add_argument("--seed", type=int, default=0)
    return parser


def _generate(args) -> int:
    from .build import compile_arm
    from .generate import generate

    result = generate(model_from_args(args), langs=args.lang, prefix=args.prefix, precision=args.precision, out=args.out,
                      functions=args.functions, cmake=args.cmake, force=args.force)
    for path in result.paths:
        print(f"wrote {path}")
    kin = next((p for p in result.programs if p.name == "kinematics"), None)
    if kin is not None:
        o = kin.ops
        print(f"kinematics: {o.sin} sin, {o.cos} cos, {o.arithmetic} add/sub/mul/neg")
    if args.compile and any(name.endswith(".c") for name in result.sources):
        arm = compile_arm(result)
        print(f"compiled {arm.path}")
    return 0


def _show(args) -> int:
    from .display import FORMATS, WHAT, show, show_diffdrive
    from .models.diffdrive import DiffDrive
    from .models.planar import PlanarArm

    model = model_from_args(args)
    if args.format not in FORMATS:
        raise InputError(f"unknown --format {args.format!r}; choose from {', '.join(FORMATS)}")
    if isinstance(model, DiffDrive):
        if args.plot:
            raise InputError("--plot draws planar arms")
        sys.stdout.write(show_diffdrive(model, args.what or "all", args.format))
        return 0
    if not isinstance(model, PlanarArm):  # a 3-D chain from --robot
        if args.plot:
            raise InputError("--plot draws planar arms")
        from .models.chain.derive import derive_chain
        from .display_chain import show_chain

        sys.stdout.write(show_chain(derive_chain(model), args.what or "J", args.format, True if args.expand else None))
        return 0
    what = args.what or "J"
    if what not in WHAT + ("all",):
        raise InputError(f"unknown --what {what!r}; choose from {', '.join(WHAT + ('all',))}")
    if args.plot:
        import math

        from .plot import plot_arm

        lengths = model.lengths or (1.0,) * model.n
        pose = args.pose if args.pose is not None else (math.pi / 6,) * model.n
        if len(pose) != model.n:
            raise InputError(f"--pose has {len(pose)} angles, expected {model.n}")
        summary = plot_arm(pose, lengths, args.plot)
        sigma = ", ".join(f"{s:.4g}" for s in summary.singular_values)
        print(f"wrote {summary.path}: w = {summary.manipulability:.6g}, singular values of J: {sigma}")
        return 0
    from . import derive
    from .display import check_show_size

    check_show_size(model.n)  # before deriving: closed forms of long chains take minutes
    sys.stdout.write(show(derive(model), what, args.format))
    return 0


def _check(args) -> int:
    from .check import TABLE_NOTE, compare, load_generated, load_implementations, table
    from .check_ik import check_ik
    from .generate import generate, validate_langs, validate_precision

    if args.cases < 1:
        raise InputError(f"--cases must be at least 1, got {args.cases}")
    if args.seed < 0:
        raise InputError(f"--seed must be a whole number >= 0, got {args.seed}")
    if args.source is not None:
        given = [f"--{k}" for k in ("links", "lengths", "track", "robot", "base", "tip", "precision", "lang")
                 if getattr(args, k) is not None] + (["--model"] if args.model != "planar" else [])
        if given:
            raise InputError(f"--from reads the model and options from the files' header: drop {', '.join(given)}")
        loaded = load_generated(args.source, args.prefix)
        generated, precision = loaded.generated, loaded.precision
        print(f"checking {', '.join(generated.sources)} in {args.source} ({loaded.command})")
        if loaded.edited:
            verb = "differs" if len(loaded.edited) == 1 else "differ"
            print(f"note: {', '.join(loaded.edited)} {verb} from what this version generates for that command")
    else:
        if args.prefix is not None:
            raise InputError("--prefix chooses files with --from")
        precision = validate_precision(args.precision or "double")
        langs = validate_langs(args.lang or "c,python")
        generated = generate(model_from_args(args), langs=langs, precision=precision, out=None)
    implementations = load_implementations(generated)
    results = compare(generated, args.cases, args.seed, precision, implementations)
    for line in table(results):
        print(line)
    import textwrap

    print("\n".join(textwrap.wrap(TABLE_NOTE, 100)))
    ik = check_ik(generated, implementations, args.cases, args.seed, precision)
    for row in ik:
        print(row.row())
    failed = [r for r in results if not r.ok]
    ik_failed = [r for r in ik if not r.ok]
    ik_line = f"; ik: {len(ik) - len(ik_failed)} passed, {len(ik_failed)} failed" if ik else ""
    print(f"{len(results) - len(failed)} passed, {len(failed)} failed{ik_line}")
    return 1 if failed or ik_failed else 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``skelarm-sym`` command; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        handler = {"generate": _generate, "show": _show, "check": _check}[args.command]
        return handler(args)
    except InputError as exc:
        print(f"skelarm-sym: error: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # compiler failures: the first line says what failed
        print(f"skelarm-sym: error: {str(exc).splitlines()[0]}", file=sys.stderr)
        return 1
    except OSError as exc:  # the file system refused something not checked before
        where = f": {exc.filename}" if exc.filename else ""
        print(f"skelarm-sym: error: {exc.strerror or exc}{where}"[:400], file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
