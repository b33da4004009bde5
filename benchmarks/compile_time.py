"""Compile time of the emitted C: CPU seconds of ``cc -O2 -c`` per function and for all functions.

    python benchmarks/compile_time.py                                   # Panda URDF (tip panda_hand_tcp)
    python benchmarks/compile_time.py --robots panda,ur5,planar6 --repeat 3
    python benchmarks/compile_time.py --before /path/to/other_python.sh --functions all,kinematics

Each function is generated alone (``--functions NAME``: a solver brings the functions it calls, so its row
includes them) and all functions together (row ``all``), by this checkout and, with ``--before``, by the
Python of another checkout (a script that runs Python on that checkout's code). Every file is compiled
``--repeat`` times with ``cc -O2 -c`` (``--flags``), and again with ``-DSKELARM_NO_SIMD`` (no vectorised
batch blocks), the before and after files in turn (A B A B ...), so that the load on the machine moves
both alike. Printed: the least CPU time (user + system of the compiler and its children, from
``getrusage``) of the repeats, in seconds, and the ratio after / before. CPU time, not wall time: a busy
machine stretches wall time much more. The load average is printed with the table.

Robots: ``panda`` (example-robot-data's Panda URDF, tip ``panda_hand_tcp``: the compile target's file),
``ur5`` (its UR5 URDF, tip ``tool0``), ``planarN`` (a planar arm of N links), or a path to a TOML or URDF
robot file.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

from skelarm_sym.build import find_compiler

ROOT = Path(__file__).resolve().parents[1]
ERD = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
URDFS = {"panda": (ERD / "panda_description" / "urdf" / "panda.urdf", "panda_hand_tcp"),
         "ur5": (ERD / "ur_description" / "urdf" / "ur5_robot.urdf", "tool0")}


def source_args(robot: str) -> list[str]:
    """The ``skelarm-sym generate`` arguments that select ``robot``."""
    if robot in URDFS:
        path, tip = URDFS[robot]
        if not path.is_file():
            raise SystemExit(f"{robot}: {path} is missing (pip install example-robot-data)")
        return ["--robot", str(path), "--tip", tip]
    if robot.startswith("planar"):
        return ["--links", robot[len("planar"):]]
    return ["--robot", str(Path(robot).resolve())]


def function_names(robot: str) -> list[str]:
    """Every function this checkout emits for ``robot``, straight-line functions and solvers (not helpers)."""
    from skelarm_sym.generate import generate
    from skelarm_sym.models import PlanarArm
    from skelarm_sym.models.chain.loader import load_robot
    args = source_args(robot)
    if args[0] == "--links":
        model = PlanarArm(int(args[1]))
    else:
        model = load_robot(args[1], tip=args[3] if len(args) > 2 else None)
    g = generate(model, langs="c", out=None)
    return [f.name for f in g.module.functions if f.kind != "helper"]


def emit(python: str, robot: str, function: str, folder: Path) -> Path:
    """Generate ``robot``'s C (``function`` alone, or every function for ``all``) into ``folder``; the .c path."""
    folder.mkdir(parents=True)
    extra = [] if function == "all" else ["--functions", function]
    subprocess.run([python, "-m", "skelarm_sym", "generate", *source_args(robot), "--lang", "c", "--prefix", "x",
                    *extra, "--out", str(folder), "--force"], check=True, capture_output=True,
                   cwd=folder)  # not this checkout's folder: -m would import its package first
    return folder / "x.c"


def cpu_of(command: list[str]) -> float:
    """CPU seconds (user + system) that ``command`` and its children took."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="panda", help="comma-separated: panda, ur5, planarN or robot files")
    parser.add_argument("--functions", default=None,
                        help="comma-separated function names and/or 'all' (default: every function and all)")
    parser.add_argument("--before", default=None, help="a Python that runs the other checkout's code")
    parser.add_argument("--flags", default="-O2", help="compiler flags (default -O2)")
    parser.add_argument("--repeat", type=int, default=3, help="compiles of each file and variant (the least is printed)")
    parser.add_argument("--no-nosimd", action="store_true", help="skip the -DSKELARM_NO_SIMD compiles")
    args = parser.parse_args()
    cc = find_compiler().split()
    flags = args.flags.split()
    variants = [("", [])] if args.no_nosimd else [("", []), ("NO_SIMD", ["-DSKELARM_NO_SIMD"])]
    generators = [("after", sys.executable)] if args.before is None else [("before", args.before), ("after", sys.executable)]
    print(f"compiler {' '.join(cc)}, flags {' '.join(flags)}; CPU seconds (user + sys), least of {args.repeat} "
          f"compiles, generators compiled in turn; load average at start {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for robot in args.robots.split(","):
            names = args.functions.split(",") if args.functions else [*function_names(robot), "all"]
            files = {}
            for name in names:
                for label, python in generators:
                    files[name, label] = emit(python, robot, name, work / robot.replace("/", "_") / name / label)
            print()
            head = "| robot | function | lines |"
            rule = "|---|---|---|"
            for v, _ in variants:
                tag = f" {v}" if v else ""
                if args.before is None:
                    head += f" -O2{tag} |"
                    rule += "---|"
                else:
                    head += f" before{tag} | after{tag} | ratio |"
                    rule += "---|---|---|"
            print(head)
            print(rule)
            for name in names:
                best: dict[tuple[str, str], float] = {}
                for _ in range(args.repeat):
                    for v, define in variants:
                        for label, _ in generators:
                            src = files[name, label]
                            t = cpu_of([*cc, *flags, *define, "-c", str(src), "-o", str(src.with_suffix(".o"))])
                            best[v, label] = min(best.get((v, label), float("inf")), t)
                lines = "/".join(str(files[name, label].read_text().count("\n")) for label, _ in generators)
                row = f"| {robot} | {name} | {lines} |"
                for v, _ in variants:
                    if args.before is None:
                        row += f" {best[v, 'after']:.2f} |"
                    else:
                        b, a = best[v, "before"], best[v, "after"]
                        row += f" {b:.2f} | {a:.2f} | {a / b:.2f} |"
                print(row, flush=True)
    print(f"\nload average at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
