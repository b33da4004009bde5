"""Compile the C of random small chains with the strict flags at several optimisation levels: a sweep for the
warnings that only some chains or some compiler passes bring out (not a test: about 4 minutes of CPU for the default
28 chains and five flag sets).

Run from the repository root::

    python scripts/strict_sweep.py                      # 28 chains of 1-5 joints, seed 0, double
    python scripts/strict_sweep.py --seed 7 --chains 40 --precision float
    python scripts/strict_sweep.py --levels="-O1,-O3 -march=native"   # flag sets start with "-": use "="

Each chain is written as a DH robot file (revolute and prismatic joints; twists 0, +-pi/2, pi and two that are
none of those; offsets of 0 or not; a tool transform on some), every function is generated, and the C is
compiled with ``-std=c99 -Wall -Wextra -Werror -pedantic`` by each compiler found (gcc, clang) at each level
(``--levels``). Prints one line per failing compile (the chain's folder, compiler, flags, first error) and a
total; exits 1 when any compile failed. The folders are kept under ``--out`` (a temporary folder by default) so
that a failure can be read and reproduced. It found the unread local of a 2-joint chain (``ir/unread.py``) and
the folded bodies of a prismatic pair (``tests/test_robot_cli.py``).
"""

from __future__ import annotations

import argparse
import random
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from skelarm_sym.generate import generate
from skelarm_sym.models.chain.loader import load_robot

STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"]
TWISTS = ["0", "pi/2", "-pi/2", "pi", "0.3", "1.2"]


def random_chain(rng: random.Random) -> str:
    """A DH robot file's text: 1-5 joints, a third of them prismatic, sometimes a tool."""
    text = ""
    for _ in range(rng.randint(1, 5)):
        kind = rng.choice(["revolute", "revolute", "prismatic"])
        text += (f'[[joints]]\ntype = "{kind}"\nalpha = "{rng.choice(TWISTS)}"\n'
                 f"d = {rng.choice([0, 0.2])}\na = {rng.choice([0, 0.3])}\n\n")
    if rng.random() < 0.4:
        text += f"[tool]\nxyz = [0.0, {rng.choice([0.0, 0.1])}, 0.05]\nrpy = [0.0, {rng.choice([0.0, 0.4])}, 0.0]\n"
    return text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--chains", type=int, default=28)
    parser.add_argument("--precision", choices=["double", "float"], default="double")
    parser.add_argument("--levels", default="-O0,-O2,-O3 -march=native,-O2 -DSKELARM_NO_SIMD,-Os",
                        help="comma-separated flag sets, given as --levels=... (default: %(default)s)")
    parser.add_argument("--out", type=Path, default=None, help="folder for the chains (default: a new temporary one)")
    args = parser.parse_args(argv)
    compilers = [c for c in ("gcc", "clang") if shutil.which(c)]
    if not compilers:
        parser.error("no C compiler (gcc or clang) on PATH")
    out = args.out or Path(tempfile.mkdtemp(prefix="strict-sweep-"))
    rng = random.Random(args.seed)
    levels = [level.split() for level in args.levels.split(",")]
    compiles = failures = 0
    for i in range(args.chains):
        folder = out / f"chain{i}"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "robot.toml").write_text(random_chain(rng))
        generate(load_robot(folder / "robot.toml"), langs="c", out=folder, prefix="robot", precision=args.precision)
        for compiler in compilers:
            for flags in levels:
                compiles += 1
                done = subprocess.run([compiler, *STRICT, *flags, "-c", str(folder / "robot.c"), "-o", str(folder / "robot.o")],
                                      capture_output=True, text=True)
                if done.returncode != 0:
                    failures += 1
                    first = next((line for line in done.stderr.splitlines() if "error" in line), done.stderr.strip()[:200])
                    print(f"FAIL {folder} {compiler} {' '.join(flags)}: {first}")
    print(f"{compiles} compiles of {args.chains} chains ({args.precision}, seed {args.seed}, {', '.join(compilers)}): "
          f"{failures} failed; chains in {out}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
