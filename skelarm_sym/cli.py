"""Command line: ``skelarm-sym generate | show | check``. Parse, call, print; one-line errors.

Bad input prints ``skelarm-sym: error: <message>`` on standard error and exits with status 2; a failed
check exits with status 1, and so does a failed compile, whose message goes on with the compiler's
command and its first lines of output (indented). Nothing in the library imports this module.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import gc
import math
import sys
import unicodedata
import textwrap
from typing import Sequence

from . import __version__
from .errors import InputError
from .names import REFUSED_CATEGORIES, ascii_number
from .options import Default, Parser, add_generate_options, add_model_options, model_from_args, model_given, path_option


def _angles(text: str) -> tuple[float, ...]:
    """``--pose``: comma-separated radians, or degrees with a ``deg`` suffix (``30deg``); finite, within a turn.

    A plot draws the same arm for ``q`` and ``q + 2 pi``, so a value beyond a turn is degrees typed for radians."""
    values = []
    for item in text.split(","):
        written = item.strip()
        degrees = written.lower().endswith("deg")
        try:
            value = float(ascii_number(written[:-3] if degrees else written))
        except ValueError:
            raise argparse.ArgumentTypeError(f"joint angles must be comma-separated numbers (radians, or degrees as "
                                             f"30deg), got {written!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"joint angle {written!r} is not finite")
        value = math.radians(value) if degrees else value
        if abs(value) > 2 * math.pi * (1 + 1e-12):
            hint = "" if degrees else f": angles are in radians (for degrees write {written}deg)"
            raise argparse.ArgumentTypeError(f"joint angle {written!r} is more than a turn{hint}")
        values.append(value)
    return tuple(values)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = Parser(prog="skelarm-sym", description="Closed-form kinematics of robot arms as checked C and NumPy code.")
    parser.add_argument("--version", action="version", version=f"skelarm-sym {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)

    gen = sub.add_parser("generate", help="emit C and/or Python for a model")
    add_model_options(gen)
    add_generate_options(gen)
    gen.add_argument("--from", dest="source", metavar="DIR", type=path_option,
                     help="write the files in DIR again, with the model and options their header records (after an "
                     "upgrade, or where that line prints a character of a path escaped); --robot FILE names the robot "
                     "file of files moved away from it, --prefix chooses among several prefixes")

    show = sub.add_parser("show", help="print closed forms (or, for a URDF, its links)")
    add_model_options(show)
    show.add_argument("--what", help="planar: p, phi, J, J3, H, v, a, det, manipulability, singular or all (default J); "
                      "diffdrive: matrix, inverse or all (default all); robots: T, J, J_tool, dJ, twist, acc or all "
                      "(default J), ik: the closed-form IK's subproblems, or links: the link tree of a URDF (from --base "
                      "when given), to choose --base and --tip")
    show.add_argument("--format", default="pretty", help="pretty (default), latex or text")
    show.add_argument("--expand", action="store_true", help="robots: print the fully expanded closed form instead of the steps")
    show.add_argument("--plot", metavar="FILE", type=path_option, help="planar arms: draw the arm and its velocity ellipse to FILE (.png, .svg, .pdf; needs matplotlib)")
    show.add_argument("--pose", type=_angles, help="joint angles q1,...,qN for --plot, in radians or with a deg suffix (30deg); default pi/6 each")

    chk = sub.add_parser("check", help="generate, compile and compare with the independent reference")
    add_model_options(chk)
    chk.add_argument("--precision", help="double (default) or float")
    chk.add_argument("--lang", help="comma-separated languages (default c,python); with --from: which of the files to check "
                     "(default all)")
    chk.add_argument("--from", dest="source", metavar="DIR", type=path_option,
                     help="check the files generated earlier in DIR (their header records the model and options); "
                     "this runs their code (imports the .py files, compiles and loads the C): use it on folders you trust")
    chk.add_argument("--prefix", help="with --from: the files' prefix (default: the only one in DIR)")
    chk.add_argument("--cases", type=int, default=100, help="random configurations (default 100), plus singular and zero-velocity "
                     "poses; the IK rows solve at most 20 targets of them")
    chk.add_argument("--seed", type=int, default=0, help="seed of the random configurations (default 0): the same seed checks the "
                     "same cases")
    return parser


@contextlib.contextmanager
def _collector_paused(freeze: bool = False):
    """The cyclic garbage collector off for the block, then as it was.

    A derivation builds tens of thousands of SymPy and IR nodes that live until the files are written and
    form almost no reference cycles: the collections their allocations trigger find nothing and cost up to
    0.1 s of a ``generate`` command (128 planar links, a 7-joint arm's every function). With ``freeze``
    (the command as a program, which ends right after), what the block left is frozen (``gc.freeze``)
    before the collector is turned back on: else its next collection walks every node of the run once more
    (0.02-0.03 s). A program calling :func:`main` itself keeps its own objects collectable: nothing is
    frozen for it."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
        if freeze:
            gc.freeze()
    finally:
        if collecting:
            gc.enable()


def _generate(args, as_program: bool = False) -> int:
    with _collector_paused(freeze=as_program):
        return _generate_files(args)


def _generate_files(args) -> int:
    if args.source is not None:
        return _regenerate_files(args)
    return _write_files(model_from_args(args), args.lang, args.prefix, args.precision, args.out, args.functions,
                        args.cmake, args.force, args.compile)


def _regenerate_files(args) -> int:
    """``generate --from DIR``: the files in DIR written again from the command their header records."""
    from .check.load import read_recorded

    recorded_by_files = [flag for flag in model_given(args) if flag != "--robot"]
    recorded_by_files += [flag for flag, dest in (("--lang", "lang"), ("--precision", "precision"), ("--out", "out"))
                          if not isinstance(getattr(args, dest), Default)]
    recorded_by_files += [flag for flag, given in (("--functions", args.functions is not None), ("--cmake", args.cmake)) if given]
    if recorded_by_files:
        raise InputError(f"{', '.join(recorded_by_files)} with --from: the files' header records the options "
                         "(generate without --from to change them)")
    recorded = read_recorded(args.source, args.prefix, robot=args.robot, mixed=True)
    rec = recorded.args
    # the files replaced are the ones read: another robot file (--robot) changes the command, not what they are.
    # A file of the set that is damaged (no header: edited, half-written) is written again; but the command (which
    # anyone may have edited) may name a language none of whose files skelarm-sym wrote here, or --cmake: a file of
    # those that skelarm-sym did not write (a hand-written .py or CMakeLists.txt beside the set) is refused.
    from .backends import BACKENDS
    from .generate import refuse_foreign_files, validate_langs, written_by_skelarm_sym

    outside = ["CMakeLists.txt"] if rec.cmake else []
    for lang in validate_langs(rec.lang):
        names = [rec.prefix + suffix for suffix in BACKENDS[lang].FILE_SUFFIXES]
        if not any(written_by_skelarm_sym(recorded.root / name) for name in names):
            outside += names
    if not args.force:  # --force: replace them too, as a plain generate --force does
        refuse_foreign_files(recorded.root, outside)
    return _write_files(recorded.model, rec.lang, rec.prefix, rec.precision, str(recorded.root), rec.functions,
                        rec.cmake, True, args.compile)


def _write_files(model, lang, prefix, precision, out, functions, cmake, force, compile) -> int:
    """Generate ``model``'s files into ``out`` (compiled first with ``compile``) and report them."""
    from .generate import generate, validate_langs

    if compile and not {"c", "cpython"} & set(validate_langs(lang)):  # cpython writes the C it includes
        raise InputError("--compile builds the C: generate with lang 'c' (or 'cpython', which writes it too)")
    compiled = []

    def compile_first(result) -> None:
        """Compile before the files are written: a failed compile leaves none behind."""
        if any(name.endswith(".c") for name in result.sources):
            from .build import compile_arm  # (and NumPy) only when compiling

            compiled.append(compile_arm(result))

    result = generate(model, langs=lang, prefix=prefix, precision=precision, out=out, functions=functions, cmake=cmake,
                      force=force, before_writing=compile_first if compile else None)
    for line in model.summary():
        print(line)
    for path in result.paths:
        print(f"wrote {path}")
    kin = next((f for f in result.programs if f.name == "kinematics"), None)
    if kin is not None:
        o = kin.ops
        print(f"kinematics: {o.sin} sin, {o.cos} cos, {o.arithmetic} add/sub/mul/neg")
    for arm in compiled:
        print(f"compiled {arm.path}")
    return 0


def _show(args) -> int:
    from .models.registry import kind_of, kinds
    from .show import FORMATS

    if args.format not in FORMATS:
        raise InputError(f"unknown --format {args.format!r}; choose from {', '.join(FORMATS)}")
    if args.pose is not None and args.plot is None:
        raise InputError("--pose sets the joint angles of --plot: add --plot FILE")
    for kind in kinds():
        text = kind.preview(args) if kind.preview is not None else None
        if text is not None:
            sys.stdout.write(text)
            return 0
    model = model_from_args(args)
    sys.stdout.write(kind_of(model).show(model, args))
    return 0


def _check(args) -> int:
    from .check import TABLE_NOTE, check_solvers, compare, load_generated, load_implementations, table
    from .check.comparison import MAX_CASES
    from .generate import generate, validate_langs, validate_precision

    if not 1 <= args.cases <= MAX_CASES:
        raise InputError(f"--cases must be between 1 and {MAX_CASES}, got {args.cases}")
    if args.seed < 0:
        raise InputError(f"--seed must be a whole number >= 0, got {args.seed}")
    if args.source is not None:
        given = [flag for flag in model_given(args) if flag != "--robot"] + (["--precision"] if args.precision is not None else [])
        if given:
            raise InputError(f"--from reads the model and options from the files' header: drop {', '.join(given)} "
                             "(--robot names the robot file of files that moved)")
        # --lang: only these languages' files (a folder's PyTorch set, and no PyTorch here; a stale file of another)
        loaded = load_generated(args.source, args.prefix, None if args.lang is None else validate_langs(args.lang),
                                robot=getattr(args, "robot", None))
        generated, precision = loaded.generated, loaded.precision
        print(f"checking {', '.join(generated.sources)} in {args.source} ({loaded.command})")
        if loaded.edited:
            verb = "differs" if len(loaded.edited) == 1 else "differ"
            print(f"note: {', '.join(loaded.edited)} {verb} from what this version generates for that command")
        if loaded.missing:
            verb = "is" if len(loaded.missing) == 1 else "are"
            print(f"note: {', '.join(loaded.missing)} of that command {verb} not in {args.source} (removed, or replaced "
                  "by another prefix's file): not checked")
        if loaded.others:
            verb = "is" if len(loaded.others) == 1 else "are"
            print(f"note: {', '.join(loaded.others)} in {args.source} {verb} from another generation than the files "
                  "checked (a mixed folder): not checked; regenerate the set together")
    else:
        if args.prefix is not None:
            raise InputError("--prefix chooses files with --from")
        precision = validate_precision(args.precision or "double")
        langs = validate_langs(args.lang or "c,python")
        generated = generate(model_from_args(args), langs=langs, precision=precision, out=None)
    try:
        implementations = load_implementations(generated)
    except InputError as exc:
        if args.source is None or "is not installed" not in str(exc):
            raise
        # a folder's set for a library this environment lacks: name the languages that can be checked here
        from .backends import BACKENDS

        prefix = generated.module.prefix
        held = [lang for lang, backend in BACKENDS.items() if all(prefix + s in generated.sources for s in backend.FILE_SUFFIXES)]
        library = str(exc).split(" ", 1)[0]
        others = [lang for lang in held if lang != library]
        hint = f"; or check the folder's other languages: --lang {','.join(others)}" if others else ""
        raise InputError(f"{exc}{hint}") from None
    results = compare(generated, args.cases, args.seed, precision, implementations)
    for line in table(results):
        print(line)
    print("\n".join(textwrap.wrap(TABLE_NOTE, 100)))
    solver_rows = check_solvers(generated, implementations, args.cases, args.seed, precision)
    for row in solver_rows:
        print(row.row())
    constants = loaded.constants if args.source is not None else ()
    for entry in constants:  # a caller clamps with Q_MIN / Q_MAX: an edited one is a changed result
        print(f"constant {entry}: differs from what the recorded command gives  FAIL")
    failed = [r for r in results if not r.ok]
    solver_failed = [r for r in solver_rows if not r.ok]
    solver_line = f"; ik: {len(solver_rows) - len(solver_failed)} passed, {len(solver_failed)} failed" if solver_rows else ""
    constant_line = f"; constants: {len(constants)} differ" if constants else ""
    print(f"{len(results) - len(failed)} passed, {len(failed)} failed{solver_line}{constant_line}")
    return 1 if failed or solver_failed or constants else 0


_EXIT_FREEZE: list[bool] = []


def _freeze_at_exit() -> None:
    """Have the interpreter move every object to the collector's permanent generation when it exits.

    Shutting down, Python runs full collections while it clears the modules; after a derivation they walk
    SymPy's hundreds of thousands of objects again, 0.2-0.4 s of a ``generate`` command's CPU. Frozen objects
    are skipped (they are freed by reference counts as before). Nothing changes before the interpreter exits,
    so a program that calls :func:`main` itself keeps its collector as it was. Registered once.
    """
    if not _EXIT_FREEZE:
        _EXIT_FREEZE.append(True)
        atexit.register(gc.freeze)


def _escaped(text: str) -> str:
    """``text`` with what a terminal would act on or cannot print written as escapes: every character of
    :data:`~.names.REFUSED_CATEGORIES` (controls other than newline and tab, format characters such as the bidi
    controls, line separators; a file name's ESC sequence retitled the terminal) as ``\\x1b`` or ``\\u202e``, a file
    name's undecodable byte (Python's surrogate escape) as ``\\xff``."""
    if text.isascii() and text.isprintable():
        return text
    out = []
    for ch in text:
        if ch in "\n\t" or unicodedata.category(ch) not in REFUSED_CATEGORIES:
            out.append(ch)
        elif 0xDC80 <= ord(ch) <= 0xDCFF:
            out.append(f"\\x{ord(ch) - 0xDC00:02x}")
        else:
            out.append(ch.encode("unicode_escape", "backslashreplace").decode())
    return "".join(out)


class _EscapedStream:
    """``stream`` (stdout or stderr) writing :func:`_escaped` text, and characters its encoding lacks as escapes
    instead of failing (a file name that is not UTF-8 ended the command with a traceback after its files were
    written)."""

    def __init__(self, stream) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        text = _escaped(text)
        try:
            return self._stream.write(text)
        except UnicodeEncodeError:
            encoding = getattr(self._stream, "encoding", None) or "ascii"
            return self._stream.write(text.encode(encoding, "backslashreplace").decode(encoding))

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``skelarm-sym`` command; returns the exit status."""
    streams = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = _EscapedStream(sys.stdout), _EscapedStream(sys.stderr)
    try:
        return _main(argv)
    finally:
        sys.stdout, sys.stderr = streams


def _main(argv: Sequence[str] | None) -> int:
    _freeze_at_exit()
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command == "generate":
            return _generate(args, as_program=argv is None)  # no arguments: the skelarm-sym command itself
        return {"show": _show, "check": _check}[args.command](args)
    except InputError as exc:
        print(f"skelarm-sym: error: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # compiler failures: the first line says what failed
        lines = str(exc).splitlines() or [type(exc).__name__]
        print(f"skelarm-sym: error: {lines[0]}", file=sys.stderr)
        build = sys.modules.get(f"{__package__}.build")  # loaded if something was compiled
        if build is not None and isinstance(exc, build.CompileError):  # the command, the compiler's first lines
            for line in lines[1:]:
                print(f"  {line}", file=sys.stderr)
        return 1
    except OSError as exc:  # the file system refused something not checked before
        where = f": {exc.filename}" if exc.filename else ""
        print(f"skelarm-sym: error: {exc.strerror or exc}{where}"[:400], file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
