"""`skelarm-sym check` over many robots, seeds and precisions: which pass, and the failing rows of those that do not.

    python benchmarks/check_sweep.py                                  # examples/robots/*.toml and ur5.urdf, seeds 0-5, double and float
    python benchmarks/check_sweep.py --example-robot-data --seeds 0   # every example-robot-data chain (as urdf_ops.py takes it)
    python benchmarks/check_sweep.py --seeds 4 --precisions double examples/robots/kuka_kr6.toml

Each run is the command `skelarm-sym check --robot FILE [--tip TIP] --precision P --seed S` in a subprocess
(this checkout's code); a run passes when it exits 0. Prints one line per failing run (with its FAIL rows) and
a summary; exits 1 when any run failed. Two cores: about 4 s a run (120 runs of the examples: 8 minutes).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def robots(args) -> list[tuple[Path, str | None]]:
    if args.robots:
        return [(Path(r.split(":")[0]), r.split(":")[1] if ":" in r else None) for r in args.robots]
    if args.example_robot_data:
        sys.path.insert(0, str(HERE))
        from casadi_compare import example_robots

        return example_robots()
    return [(p, None) for p in sorted((ROOT / "examples" / "robots").glob("*.toml"))] + [(ROOT / "examples" / "robots" / "ur5.urdf", "tool0")]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("robots", nargs="*", help="robot files (a URDF as PATH:TIP); default: the examples")
    parser.add_argument("--example-robot-data", action="store_true", help="every example-robot-data chain instead")
    parser.add_argument("--seeds", default="0,1,2,3,4,5")
    parser.add_argument("--precisions", default="double,float")
    args = parser.parse_args(argv)
    runs = failed = 0
    for path, tip in robots(args):
        for precision in args.precisions.split(","):
            for seed in args.seeds.split(","):
                command = [sys.executable, "-m", "skelarm_sym", "check", "--robot", str(path), "--precision", precision,
                           "--seed", seed] + (["--tip", tip] if tip else [])
                result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
                runs += 1
                if result.returncode != 0:
                    failed += 1
                    last = (result.stdout.strip().splitlines() or [""])[-1]
                    print(f"FAIL {path.name}{':' + tip if tip else ''} {precision} seed {seed}: {last} {result.stderr.strip()[-300:]}")
                    for line in result.stdout.splitlines():
                        if line.rstrip().endswith("FAIL"):
                            print(f"    {line[:200]}")
                    sys.stdout.flush()
    print(f"{runs - failed} of {runs} runs passed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
