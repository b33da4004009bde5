"""Closed-form IK on many random arms of every family: the check of tests/test_closed_ik_families.py over a range of seeds.

    python benchmarks/closed_ik_sweep.py --seeds 20000:20150                 # 150 random arms per family
    python benchmarks/closed_ik_sweep.py --seeds 4025:4026 --families spherical_wrist
    python benchmarks/closed_ik_sweep.py --emitted --precision float --seeds 31000:31020   # the emitted C and NumPy

Each seed builds a random 6-joint arm of a family (``random_family_chain``: random standard-DH lengths and skew twists
with the family's zeros, a random base and tool), derives its closed-form IK (SymPy, lambdified) and checks targets of
random configurations: every exact candidate reproduces its target to 1e-11 and the source configuration is among the
candidates. The test suite runs one seed per family (and three random ones in the slow set); a sweep finds what they
miss (seed 4025 of the prismatic-third-joint family found the ``nsimplify`` regression of the skewed-wrist
discriminant). With ``--emitted``, each arm's C and NumPy (``pose``, ``jacobian``, ``ik_all``, ``ik_nearest``,
``ik_nearest_weighted`` in ``--precision``) are generated, compiled and judged as ``skelarm-sym check`` judges them
(5 random configurations, 10 IK targets): about 2 s an arm. Prints one line per family: failing seeds and their first
message; exits 1 when any seed failed. About 0.6 s a seed on two idle cores.
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
    parser.add_argument("--emitted", action="store_true", help="judge the emitted C and NumPy as check does")
    parser.add_argument("--precision", default="double", help="with --emitted: double or float")
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
                if args.emitted:
                    problem = _emitted_problem(family, seed, args.precision)
                    if problem:
                        bad.append((seed, problem))
                else:
                    check_family(family, seed, targets=args.targets)
            except AssertionError as exc:
                bad.append((seed, str(exc).splitlines()[0][:120]))
        failed += len(bad)
        name = family[0] + (f" ({family[1]})" if family[1] else "")
        print(f"{name}: {len(bad)} of {end - first} seeds failed" + (f"; first: seed {bad[0][0]}: {bad[0][1]}" if bad else "")
              + f"  [{time.time() - start:.0f} s]", flush=True)
    return 1 if failed else 0


def _emitted_problem(family, seed: int, precision: str) -> str:
    """The first failing row of ``check``'s comparison and IK rows for the emitted C and NumPy of seed ``seed``'s
    random arm of ``family``, or ``""``."""
    import numpy as np
    from closed_ik_support import random_family_chain

    from skelarm_sym.check import check_solvers, compare, load_implementations
    from skelarm_sym.generate import generate

    chain = random_family_chain(family, np.random.default_rng(seed))
    generated = generate(chain, langs="c,python", out=None, precision=precision,
                         functions="pose,jacobian,ik_all,ik_nearest,ik_nearest_weighted")
    implementations = load_implementations(generated)
    for row in compare(generated, 5, seed, precision, implementations):
        if not row.ok:
            return f"{row.implementation} {row.output}: error {row.abs_error:.3g}"
    for row in check_solvers(generated, implementations, 10, seed, precision):
        if not row.ok:
            return row.row()[:160]
    return ""


if __name__ == "__main__":
    sys.exit(main())
