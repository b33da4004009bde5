"""Closed-form IK, the NumPy specification: accuracy and completeness per arm, evaluated through lambdify.

    python benchmarks/closed_ik_phase1.py [--targets 1000] [--numeric 20]

Per arm: family; derivation time and steps; over ``--targets`` random configurations (revolute joints
uniform in [-pi, pi], the prismatic stroke within limits): distinct exact solutions per target (no limits;
mean, min, max), solutions within the joint limits (mean), the worst pose error of any exact candidate
(position / reach and max |R - R_t|, by the NumPy reference), the share of targets whose source
configuration is among the candidates, EAIK's sets (both directions, 1e-7 rad) when installed; over
``--numeric`` targets: solutions the 200-start numeric IK of ``skelarm_sym.models.chain.reference_ik_all`` finds that
the closed form lacks (1e-5). No timing: lambdify is not the emitted code.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))  # closed_ik_support: the tests' arms

from closed_ik_support import TOML_ARMS, URDF_ARMS, load_arm, random_configurations, targets_of, wrapped_distance
from skelarm_sym.closed_ik import derive_ik_all
from skelarm_sym.closed_ik.evaluate import ClosedFormIK
from skelarm_sym.closed_ik.postprocess import postprocess
from skelarm_sym.models.chain import reference_ik_all as judge


def distinct(rows, rev, tol=1e-9):
    out = []
    for r in rows:
        if not any(judge.same(r, o, rev, tol) for o in out):
            out.append(r)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--targets", type=int, default=1000)
    ap.add_argument("--numeric", type=int, default=20)
    args = ap.parse_args()
    print("| arm | family | derive s | steps | solutions/target mean (min-max) | within limits | worst error | source found | numeric-only | EAIK differs |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in list(TOML_ARMS) + list(URDF_ARMS):
        try:
            chain, lock = load_arm(name)
        except BaseException as exc:  # pytest.skip outside pytest
            print(f"| {name} | skipped: {exc} |")
            continue
        t = time.perf_counter()
        ik_sym = derive_ik_all(chain, lock)
        derive_s = time.perf_counter() - t
        ik = ClosedFormIK(chain, lock, ik=ik_sym)
        num = chain.numeric()
        rev = judge.revolute_mask(num)
        rng = np.random.default_rng(2026)
        q = random_configurations(chain, args.targets, rng)
        T = targets_of(chain, q)
        Q, flags = ik.candidates(T.reshape(-1, 16), None if lock is None else q[:, lock])
        counts, limited, worst, found, eaik_diff = [], [], 0.0, 0, 0
        eaik_on = name != "stanford"
        for i in range(args.targets):
            exact = Q[i][(flags[i] & 1) == 0]
            counts.append(len(distinct(exact, rev)))
            r = postprocess(Q[i], flags[i], ik.lower, ik.upper, ik.revolute, target=T[i].reshape(16), continuum=ik.ik.continuum)
            limited.append(r.count)
            pos, rot = judge.pose_error(num, exact, T[i])
            worst = max(worst, pos.max(initial=0), rot.max(initial=0))
            found += bool(np.min(wrapped_distance(exact, q[i], rev)) < 1e-6)
            if eaik_on:
                e = judge.eaik_solutions(num, T[i], None if lock is None else {lock: q[i, lock]})
                if e is None:
                    eaik_on = False
                else:
                    theirs = e[0][~e[1]]
                    eaik_diff += bool(len(judge.missing(exact, theirs, rev, 1e-7)) or len(judge.missing(theirs, exact, rev, 1e-7)))
        numeric_only = 0
        for i in range(args.numeric):
            ms = judge.multistart_ik(num, T[i], starts=200, fixed=None if lock is None else {lock: q[i, lock]})
            exact = Q[i][(flags[i] & 1) == 0]
            numeric_only += len(judge.missing(exact, ms, rev, 1e-5))
        c = np.array(counts)
        eaik = f"{eaik_diff} / {args.targets}" if eaik_on else "n/a"
        print(f"| {name} | {ik_sym.family.name} ({ik_sym.family.position or '-'}) | {derive_s:.2f} | {len(ik_sym.steps)} | "
              f"{c.mean():.2f} ({c.min()}-{c.max()}) | {np.mean(limited):.2f} | {worst:.1e} | {found}/{args.targets} | "
              f"{numeric_only} in {args.numeric} | {eaik} |", flush=True)


if __name__ == "__main__":
    main()
