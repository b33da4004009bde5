"""IK success benchmark: UR5, Panda, PUMA 560; targets from random configurations within limits, random starts.

Usage: PYTHONPATH=. python benchmarks/ik_success.py [targets] (default 1000). Uses examples/robots/<name>.toml
when present (limits from the file), else the DH tables of tests/test_chain.py with [-pi, pi].
Solver: skelarm_sym.ik.solve_pose (NumPy LM loop) on the compiled C pose/jacobian.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from skelarm_sym.build import compile_arm  # noqa: E402
from skelarm_sym.generate import generate  # noqa: E402
from skelarm_sym.ik import solve_pose  # noqa: E402


def robots():
    from test_chain import PANDA, PUMA, UR5

    out = []
    for name, fallback in (("ur5", UR5), ("panda", PANDA), ("puma560", PUMA)):
        path = ROOT / "examples" / "robots" / f"{name}.toml"
        if path.exists():
            from skelarm_sym.models.robot_file import load_robot_file

            out.append(load_robot_file(path))
        else:
            out.append(fallback)
    return out


def main(count: int = 1000) -> None:
    print(f"{'robot':10s} {'success':>8s} {'median it':>10s} {'ms/solve':>9s}  worst failure errors (m, rad)")
    for chain in robots():
        arm = compile_arm(generate(chain, langs="c", out=None))
        limits = chain.limits()
        lo = np.array([-np.pi if x is None else x for x in limits["lower"]])
        hi = np.array([np.pi if x is None else x for x in limits["upper"]])
        rng = np.random.default_rng(0)
        results, start = [], time.perf_counter()
        for _ in range(count):
            target = arm.pose(rng.uniform(lo, hi))
            results.append(solve_pose(arm, rng.uniform(lo, hi), target, limits=(limits["lower"], limits["upper"])))
        elapsed = (time.perf_counter() - start) / count
        ok = [r.status == "converged" for r in results]
        fails = [(r.position_error, r.rotation_error) for r in results if r.status != "converged"]
        worst = max(fails, key=lambda e: e[0] + e[1]) if fails else (0.0, 0.0)
        assert all(np.all(np.isfinite(r.q)) for r in results)
        print(f"{chain.name:10s} {np.mean(ok):8.1%} {np.median([r.iterations for r in results]):10.0f} "
              f"{elapsed * 1e3:9.2f}  {len(fails)} failed, worst ({worst[0]:.2e}, {worst[1]:.2e})")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
