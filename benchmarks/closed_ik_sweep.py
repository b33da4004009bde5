"""Closed-form IK on many random arms of every family: the check of tests/test_closed_ik_families.py over a range of seeds.

    python benchmarks/closed_ik_sweep.py --seeds 20000:20150                 # 150 random arms per family
    python benchmarks/closed_ik_sweep.py --seeds 4025:4026 --families spherical_wrist

Each seed builds a random 6-joint arm of a family (``random_family_chain``: random standard-DH lengths and skew twists
with the family's zeros, a random base and tool), derives its closed-form IK (SymPy, lambdified) and checks targets of
random configurations: every exact candidate reproduces its target to 1e-11 and the source configuration is among the
candidates. The test suite runs one seed per family (and three random ones in the slow set); a sweep finds what they
miss (seed 4025 of the prismatic-third-joint family found the ``nsimplify`` regression of the skewed-wrist
discriminant). Prints one line per family: failing seeds and their first message; exits 1 when any seed failed.
About 0.6 s a seed on two idle cores.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0:20", help="first:end (end excluded), default 0:20")
    parser.add_argument("--targets", type=int, default=60, help="targets per arm (default 60)")
    parser.add_argument("--families", default="", help="comma-separated family names (default: all)")
    args = parser.parse_args(argv)
    first, end = (int(x) for x in args.seeds.split(":"))
    sys.path.insert(0, str(ROOT / "tests"))
    from test_closed_ik_families import FAMILIES, check_family

    wanted = {f for f in args.families.split(",") if f}
    failed = 0
    start = time.time()
    for family in FAMILIES:
        if wanted and family[0] not in wanted:
            continue
        bad = []
        for seed in range(first, end):
            try:
                check_family(family, seed, targets=args.targets)
            except AssertionError as exc:
                bad.append((seed, str(exc).splitlines()[0][:120]))
        failed += len(bad)
        name = family[0] + (f" ({family[1]})" if family[1] else "")
        print(f"{name}: {len(bad)} of {end - first} seeds failed" + (f"; first: seed {bad[0][0]}: {bad[0][1]}" if bad else "")
              + f"  [{time.time() - start:.0f} s]", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
