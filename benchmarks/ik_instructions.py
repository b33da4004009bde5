"""Instructions per call of the emitted closed-form ``ik_all`` and ``ik_nearest`` (valgrind's callgrind, gcc -O2).

Instruction counts do not depend on the load of a shared machine, so two versions compare in one run each:
generate with this checkout, count, then do the same at the other commit (``git worktree``) and compare. Targets:
the poses of configurations drawn within the limits (5 % to 95 % of each range, revolute ranges clipped to
[-pi, pi]; seed 0); ``ik_nearest`` from references 0.01 rad off the sources; ``--aligned`` puts joint 5 at 0 for
every target (an aligned wrist: a continuum). Per call: (instructions for M targets - for none) / M.

    python benchmarks/ik_instructions.py --robots puma560,ur5 --targets 300 [--aligned]
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from skelarm_sym import reference  # noqa: E402
from skelarm_sym.generate import generate  # noqa: E402
from skelarm_sym.models.chain.loader import load_robot  # noqa: E402

ROBOTS = HERE.parent / "examples" / "robots"


def targets(chain, m: int, aligned: bool) -> np.ndarray:
    """``(m, 22)``: each target's 16 entries, then a reference 0.01 rad off its source configuration."""
    limits = chain.limits()
    lo = np.maximum([-np.pi if v is None else v for v in limits["lower"]], -np.pi)
    hi = np.minimum([np.pi if v is None else v for v in limits["upper"]], np.pi)
    q = lo + np.random.default_rng(0).uniform(0.05, 0.95, (m, chain.n)) * (hi - lo)
    if aligned:
        q[:, 4] = 0.0
    T = reference.chain_kinematics(chain.numeric(), q).T.reshape(m, 16)
    return np.ascontiguousarray(np.concatenate([T, q + 0.01], axis=1))


def instructions(exe: Path, data: Path, m: int, which: int) -> int:
    out = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", str(exe), str(data), str(m),
                          str(which)], capture_output=True, text=True, check=True)
    return int(re.search(r"Collected : (\d+)", out.stderr)[1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="puma560,ur5", help="example robots (examples/robots/NAME.toml)")
    parser.add_argument("--targets", type=int, default=300)
    parser.add_argument("--aligned", action="store_true", help="joint 5 at 0 in every source configuration")
    args = parser.parse_args()
    if shutil.which("valgrind") is None:
        sys.exit("valgrind is needed (apt-get install valgrind)")
    cc = shutil.which("gcc") or shutil.which("cc")
    print("| robot | ik_all instructions per call | ik_nearest instructions per call |")
    print("|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in args.robots.split(","):
            chain = load_robot(ROBOTS / f"{name}.toml")
            folder = work / name
            generate(chain, out=folder, langs="c", functions="ik_all,ik_nearest", prefix=name)
            exe = folder / "count"
            subprocess.run([cc, "-O2", "-std=c99", f"-DPREFIX={name}", f"-I{folder}", str(HERE / "ik_instructions.c"),
                            str(folder / f"{name}.c"), "-lm", "-o", str(exe)], check=True)
            data = folder / "targets.bin"
            targets(chain, args.targets, args.aligned).tofile(data)
            per_call = [(instructions(exe, data, args.targets, w) - instructions(exe, data, 0, w)) / args.targets
                        for w in (0, 1)]
            print(f"| {name} | {per_call[0]:.0f} | {per_call[1]:.0f} |")


if __name__ == "__main__":
    main()
