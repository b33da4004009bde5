"""How closely the closed-form ``ik_nearest`` reproduces its target, per robot, precision and implementation.

Targets: the poses (computed in double by the NumPy reference, then rounded to the working precision) of
configurations drawn within the limits (5 % to 95 % of each range, revolute ranges clipped to [-pi, pi];
seed 0); ``--aligned`` puts joint 5 at 0 for every target (an aligned wrist: a continuum, where a row within
``WRIST_ALIGNED_TOL`` of alignment is taken as aligned). ``ik_nearest`` starts from the source configuration.
Errors by the judge (``reference_ik_all.pose_error``): the position error over the reach, and the largest
entry of ``R - R_target``; the table prints the largest and the 99th percentile over the targets.

    python benchmarks/ik_pose_accuracy.py --robots puma560,kuka_kr6 --precision float --aligned
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from skelarm_sym import reference  # noqa: E402
from skelarm_sym.check import load_implementations  # noqa: E402
from skelarm_sym.generate import generate  # noqa: E402
from skelarm_sym.models.chain.loader import load_robot  # noqa: E402
from skelarm_sym.models.chain.reference_ik_all import pose_error  # noqa: E402


def targets(chain, m: int, aligned: bool) -> np.ndarray:
    """Source configurations (m, n) within the limits; joint 5 at 0 when ``aligned``."""
    limits = chain.limits()
    lower = np.array([-np.pi if v is None else max(v, -np.pi) for v in limits["lower"]])
    upper = np.array([np.pi if v is None else min(v, np.pi) for v in limits["upper"]])
    q = lower + (0.05 + 0.9 * np.random.default_rng(0).uniform(size=(m, chain.n))) * (upper - lower)
    if aligned:
        q[:, 4] = 0.0
    return q


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="puma560,kuka_kr6,ur5", help="names under examples/robots (TOML)")
    parser.add_argument("--precision", default="float", choices=("double", "float"))
    parser.add_argument("--targets", type=int, default=500)
    parser.add_argument("--aligned", action="store_true")
    args = parser.parse_args()
    dtype = np.float32 if args.precision == "float" else np.float64
    print(f"ik_nearest from the source, {args.targets} targets, {args.precision}, "
          f"{'aligned wrist (q5 = 0)' if args.aligned else 'random configurations'}")
    print("| robot | implementation | max position / reach | 99 % | max rotation entry | 99 % |")
    print("|---|---|---|---|---|---|")
    for name in args.robots.split(","):
        chain = load_robot(HERE.parent / "examples" / "robots" / f"{name}.toml")
        generated = generate(chain, langs="c,python", precision=args.precision, out=None, functions="ik_nearest")
        numeric = chain.numeric(None)
        q = targets(chain, args.targets, args.aligned)
        T = reference.chain_kinematics(numeric, q).T.astype(dtype).astype(float)
        for label, implementation in load_implementations(generated):
            answer = implementation.ik_nearest(q.astype(dtype), T.reshape(len(q), 16).astype(dtype))
            rows = np.asarray(answer[0] if isinstance(answer, tuple) else answer.q, dtype=float)
            found = np.all(np.isfinite(rows), axis=-1)
            position, rotation = pose_error(numeric, rows[found], T[found])
            missing = "" if found.all() else f" ({(~found).sum()} without a row)"
            print(f"| {name} | {label}{missing} | {position.max():.2e} | {np.quantile(position, 0.99):.2e} | "
                  f"{rotation.max():.2e} | {np.quantile(rotation, 0.99):.2e} |")


if __name__ == "__main__":
    main()
