"""The iterative pose IK (``ik_solve``) on targets whose spherical wrist is nearly aligned: how many converge.

    python benchmarks/ik_near_singular.py                          # Stanford, IRB 140, PUMA 560, UR5; q5 = 0, 1e-6, 1e-8
    python benchmarks/ik_near_singular.py --robots ur5 --count 200 --wrist 0,1e-4,1e-6

Targets: poses of random configurations within the limits (5 % inside each bound, revolute joints within
[-pi, pi]) with joint 5 set to each ``--wrist`` value; starts: other such configurations (numpy
``default_rng(7)``, the same for every value); lambda 0, tol 1e-10, 100 steps, the emitted C through the compiled
wrapper. At ``q5 = 0`` the wrist is aligned; near it J's smallest singular value is about ``q5`` and the pose
barely depends on how joints 4 and 6 share the rotation. Prints one row per robot: converged of ``--count``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from skelarm_sym import reference  # noqa: E402
from skelarm_sym.build import compile_arm  # noqa: E402
from skelarm_sym.generate import generate  # noqa: E402
from skelarm_sym.models.chain.dh_file import load_robot_file  # noqa: E402


def converged(name: str, wrist: list[float], count: int) -> list[int]:
    chain = load_robot_file(ROOT / "examples" / "robots" / f"{name}.toml")
    arm = compile_arm(generate(chain, langs="c", out=None, prefix=f"near_{name}", functions="ik_solve"))
    lim = chain.limits()
    lo = np.maximum([-np.pi if v is None else v for v in lim["lower"]], -np.pi)
    hi = np.minimum([np.pi if v is None else v for v in lim["upper"]], np.pi)
    inner_lo, inner_hi = lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo)
    out = []
    for q5 in wrist:
        rng = np.random.default_rng(7)
        ok = 0
        for _ in range(count):
            q = rng.uniform(inner_lo, inner_hi)
            q[4] = q5
            target = reference.chain_kinematics(chain.numeric(), q).T
            q0 = rng.uniform(inner_lo, inner_hi)
            ok += arm.ik_solve(q0, target, 0.0, 1e-10, 100).status == "converged"
        out.append(ok)
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="stanford,abb_irb140,puma560,ur5")
    parser.add_argument("--wrist", default="0,1e-6,1e-8", help="comma-separated values of q5 (rad)")
    parser.add_argument("--count", type=int, default=80, help="targets per robot and value")
    args = parser.parse_args(argv)
    wrist = [float(x) for x in args.wrist.split(",")]
    print(f"converged of {args.count} targets (lambda 0, tol 1e-10, 100 steps)")
    print()
    print("| robot | " + " | ".join(f"q5 = {w:g}" for w in wrist) + " |")
    print("|---|" + "---|" * len(wrist))
    for name in args.robots.split(","):
        print(f"| {name} | " + " | ".join(str(k) for k in converged(name, wrist, args.count)) + " |", flush=True)


if __name__ == "__main__":
    main()
