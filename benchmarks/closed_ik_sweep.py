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

    python benchmarks/closed_ik_sweep.py --urdfs                             # every 6-coordinate chain of example-robot-data

With ``--urdfs`` (needs ``pip install example-robot-data``), the same check on real robot files instead of random
arms: for every leaf link of every URDF of example-robot-data, the chain of the last six coordinates above it, where
it is in a closed-form family (centauro's wheel legs, whose parallel axes point opposite ways, were wrong and the
random arms did not have such axes). Prints one line per chain checked and a summary; about 2 s a chain.
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
    parser.add_argument("--urdfs", action="store_true", help="every 6-coordinate leaf chain of example-robot-data instead")
    args = parser.parse_args(argv)
    first, end = (int(x) for x in args.seeds.split(":"))
    sys.path.insert(0, str(ROOT / "tests"))
    if args.urdfs:
        return _urdf_sweep(args.targets)
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


def _urdf_sweep(targets: int) -> int:
    """:func:`check_chain` on the last six coordinates above every leaf of every example-robot-data URDF that is in a
    closed-form family; 1 when any failed."""
    import numpy as np
    from casadi_compare import robots_folder
    from test_closed_ik_families import check_chain

    from skelarm_sym import load_robot
    from skelarm_sym.closed_ik import ClosedFormError, classify
    from skelarm_sym.errors import InputError
    from skelarm_sym.models.chain.urdf import urdf_links

    robots = robots_folder()
    if not robots.is_dir():
        raise SystemExit(f"example-robot-data's robots are not at {robots}: pip install example-robot-data")
    checked = failed = 0
    seen: set[tuple] = set()
    for path in sorted(robots.glob("*/urdf/*.urdf")):
        try:
            links = urdf_links(path)
        except InputError:  # a file the loader refuses (every refusal is tested in test_example_robot_data.py)
            continue
        parent = {link.name: link.parent for link in links}
        for leaf in sorted(link.name for link in links if link.leaf and link.coordinates >= 6 and not link.stray_mimic):
            base, chain = leaf, None
            while parent[base] is not None:  # the nearest base above which the chain has six coordinates
                base = parent[base]
                try:
                    chain = load_robot(path, base=base, tip=leaf)
                except InputError:  # no moving joint yet, a refused joint
                    chain = None
                    continue
                if chain.n >= 6:
                    break
            if chain is None or chain.n != 6:
                continue
            key = (path.name, base, tuple(j.name for j in chain.joints))
            if key in seen:
                continue
            seen.add(key)
            try:
                family = classify(chain).name
            except ClosedFormError:  # not in a closed-form family: the classifier says why
                continue
            checked += 1
            try:
                check_chain(chain, np.random.default_rng(0), targets, f"{path.name} {base} -> {leaf}")
                verdict = "ok"
            except AssertionError as exc:
                failed += 1
                verdict = "FAIL " + str(exc).splitlines()[0][:100]
            print(f"{path.relative_to(robots)} {base} -> {leaf}: {family}: {verdict}", flush=True)
    print(f"{checked} chains in a closed-form family checked, {failed} failed")
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
