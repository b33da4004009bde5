"""Closed-form IK with all solutions: the emitted C per robot, judged and timed. A table, not a test.

    python benchmarks/ik_all.py [--targets 1000] [--numeric 20] [--robots puma560,ur5]

Per robot (UR5 and UR10 URDFs and the Kinova j2s6 from example-robot-data when installed, PUMA 560, KUKA KR 6,
ABB IRB 140, Stanford arm, iiwa 14 with joint 3 locked, Panda with joint 7 locked):

* targets: the poses of ``--targets`` random configurations within the joint limits (5 % to 95 % of each range;
  a locked joint at its configuration's value), so each has at least one solution within the limits;
* ``solutions``: rows ``X_ik_all`` returns per target (within the limits, distinct), mean (min-max);
* ``worst error``: the largest position error / reach or rotation-matrix entry error of any returned row, by the
  NumPy reference's forward kinematics; ``source``: targets whose source configuration is among the rows;
* ``numeric-only``: solutions within the limits that the judge's 200-start numeric IK (reference_ik_all.multistart_ik)
  finds and the rows lack, over the first ``--numeric`` targets; ``EAIK differs``: targets whose rows differ from
  EAIK's exact solutions that fit the limits (either direction, 1e-7), when eaik is installed;
* ``ik_all ns``, ``ik_solve ns``: C, one harness (benchmarks/ik_all_harness.c) compiled with ``cc -O2`` with the
  generated file holding both; median over 15 sweeps of all targets, per call, this thread's CPU time (a shared
  machine's other processes do not inflate it; the wall-clock median is printed below the table), the least of
  5 runs of the harness; ik_solve from a
  random start within the limits, tol 1e-10, at most 100 steps (not for locked arms: it moves every joint);
* ``EAIK ns``: EAIK's ``IK`` called in-process from Python on the same targets, median per call (its Python
  binding included); ``EAIK batch ns``: its ``IK_batched`` on all targets at once with one worker thread, per
  target (least of 5 runs): the binding's cost spread over the batch, the closest figure to its C++ time here;
* ``generate s``: ``skelarm-sym generate --robot FILE [--ik-lock J] --functions ik_all`` as a fresh process, wall
  clock and CPU (the process and its children; SymPy's import included).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))  # closed_ik_support: the tests' arms

from closed_ik_support import ROBOTS, example_robot_data_dir, load_arm
from skelarm_sym.build import compile_arm, find_compiler
from skelarm_sym.closed_ik import classify
from skelarm_sym.generate import generate
from skelarm_sym.models.chain import reference_ik_all as judge
from skelarm_sym.models.chain.lock import with_ik_lock

HERE = Path(__file__).resolve().parent
RUNS = 5
"""The harness runs this many times; each column is the least of its medians (the machine is shared: a run that
other processes slowed is not the code's time)."""
ROBOT_LIST = ["ur5_urdf", "ur10_urdf", "puma560", "kuka_kr6", "abb_irb140", "kinova_j2s6", "stanford", "iiwa14_lock3",
              "panda_lock7", "ur5"]
URDF_FILES = {"ur5_urdf": "ur_description/urdf/ur5_robot.urdf", "ur10_urdf": "ur_description/urdf/ur10_robot.urdf",
              "kinova_j2s6": "kinova_description/robots/kinova.urdf"}
TIPS = {"ur5_urdf": "tool0", "ur10_urdf": "tool0", "kinova_j2s6": "j2s6s200_end_effector"}
TOML_FILES = {"puma560": "puma560.toml", "kuka_kr6": "kuka_kr6.toml", "abb_irb140": "abb_irb140.toml",
              "stanford": "stanford.toml", "iiwa14_lock3": "iiwa14.toml", "panda_lock7": "panda.toml", "ur5": "ur5.toml"}


def inner_configurations(chain, rev, lower, upper, m, rng):
    span = np.where(rev, np.pi, 0.5)
    lo = np.where(np.isfinite(lower), lower, -span)
    hi = np.where(np.isfinite(upper), upper, span)
    return lo + (0.05 + 0.9 * rng.uniform(size=(m, chain.n))) * (hi - lo)


def fits(q, lower, upper, rev) -> bool:
    for x, lo, hi, r in zip(q, lower, upper, rev):
        if r and np.isfinite(lo):
            x = x + 2 * np.pi * np.ceil((lo - x) / (2 * np.pi))
        elif r and np.isfinite(hi):
            x = x + 2 * np.pi * np.floor((hi - x) / (2 * np.pi))
        if not lo <= x <= hi:
            return False
    return True


def command_of(name: str) -> list[str] | None:
    if name in TOML_FILES:
        words = ["--robot", str(ROBOTS / TOML_FILES[name])]
    else:
        root = example_robot_data_dir()
        if root is None:
            return None
        words = ["--robot", str(root / URDF_FILES[name]), "--tip", TIPS[name]]
    if name.endswith("_lock3"):
        words += ["--ik-lock", "3"]
    if name.endswith("_lock7"):
        words += ["--ik-lock", "7"]
    return words


def generation_time(words: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds of ``skelarm-sym generate ... --functions ik_all`` in a fresh process."""
    out = tempfile.mkdtemp(prefix="ik_all_gen_")
    try:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t = time.perf_counter()
        subprocess.run([sys.executable, "-m", "skelarm_sym", "generate", *words, "--functions", "ik_all", "--out", out],
                       check=True, capture_output=True)
        wall = time.perf_counter() - t
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    finally:
        shutil.rmtree(out, ignore_errors=True)


def time_c(generated, chain, targets, locks, starts, locked: bool) -> list[float]:
    """``ik_all`` and ``ik_solve`` ns per call (CPU and wall medians) from the harness, and the mean solution count."""
    prefix = generated.module.prefix
    work = Path(tempfile.mkdtemp(prefix="ik_all_bench_"))
    try:
        for name, text in generated.sources.items():
            if name.endswith((".c", ".h")):
                (work / name).write_text(text)
        data = work / "data.bin"
        with open(data, "wb") as handle:
            np.ascontiguousarray(targets.reshape(-1, 16), dtype=np.float64).tofile(handle)
            np.ascontiguousarray(locks, dtype=np.float64).tofile(handle)
            np.ascontiguousarray(starts, dtype=np.float64).tofile(handle)
        exe = work / "harness"
        cc = find_compiler()
        flags = [f"-DPREFIX={prefix}", f"-DN={chain.n}"] + (["-DLOCKED"] if locked else [])
        subprocess.run([cc, "-O2", "-std=c99", *flags, f"-I{work}", str(HERE / "ik_all_harness.c"), str(work / f"{prefix}.c"),
                        "-lm", "-o", str(exe)], check=True, capture_output=True)
        runs = [[float(x) for x in subprocess.run([str(exe), str(data), str(len(targets))], check=True, capture_output=True,
                                                   text=True).stdout.split()] for _ in range(RUNS)]
        return [min(column) for column in zip(*runs)]
    finally:
        shutil.rmtree(work, ignore_errors=True)


def eaik_robot(numeric, lock_joint, lock_value):
    try:
        from eaik.IK_HP import HPRobot
    except ImportError:
        return None
    H, P, R0 = judge.hp_data(numeric)
    fixed = [] if lock_joint is None else [(lock_joint, lock_value)]
    return HPRobot(H, P, fixed_axes=fixed), R0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", type=int, default=1000)
    ap.add_argument("--numeric", type=int, default=20)
    ap.add_argument("--robots", default=",".join(ROBOT_LIST))
    args = ap.parse_args()
    rows, walls = [], []
    print(f"# {args.targets} targets per robot; load average at start: {os.getloadavg()[0]:.2f} "
          f"({os.cpu_count()} CPUs)", flush=True)
    print("| robot | family | solutions/target | worst error | source | numeric-only | EAIK differs | ik_all ns | ik_solve ns | EAIK ns | EAIK batch ns | generate s (wall / CPU) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.robots.split(","):
        words = command_of(name)
        if words is None:
            print(f"| {name} | (example-robot-data not installed) |", flush=True)
            continue
        chain, lock = load_arm(name)
        if lock is not None:
            chain = with_ik_lock(chain, lock + 1)
        family = classify(chain, lock)
        fam = family.name + (f" ({family.position})" if family.position else "")
        gen_wall, gen_cpu = generation_time(words)
        generated = generate(chain, out=None, functions="ik_all" if lock is not None else "ik_all,ik_solve",
                             langs="c,python")
        arm = compile_arm(generated)
        numeric = chain.numeric()
        rev = judge.revolute_mask(numeric)
        limits = chain.limits()
        lower = np.array([-np.inf if v is None else v for v in limits["lower"]])
        upper = np.array([np.inf if v is None else v for v in limits["upper"]])
        rng = np.random.default_rng(2026)
        q = inner_configurations(chain, rev, lower, upper, args.targets, rng)
        starts = inner_configurations(chain, rev, lower, upper, args.targets, rng)
        T = judge.chain_kinematics(numeric, q).T
        coord = None if lock is None else chain.joints[lock].coordinate
        locks = np.zeros(args.targets) if coord is None else q[:, coord]
        counts, worst, source, eaik_diff, numeric_only = [], 0.0, 0, 0, 0
        eaik = eaik_robot(numeric, lock, 0.0) if not any(j.kind == "prismatic" for j in chain.joints) else None
        eaik_ns, eaik_poses = [], []
        for i in range(args.targets):
            extra = () if coord is None else (float(locks[i]),)
            r = arm.ik_all(T[i], *extra)
            sols = r.q[: r.count]
            counts.append(r.count)
            if r.count:
                pos, rot = judge.pose_error(numeric, sols, T[i])
                worst = max(worst, float(pos.max()), float(rot.max()))
            source += int(len(judge.missing(sols, q[i:i + 1], rev, 1e-7)) == 0)
            if eaik is not None:
                fixed_eaik = None if lock is None else {lock: float(locks[i])}
                theirs = judge.eaik_solutions(numeric, T[i], fixed_eaik)
                exact = np.array([s for s, ls in zip(*theirs) if not ls and fits(s, lower, upper, rev)]).reshape(-1, len(rev))
                if len(judge.missing(sols, exact, rev, 1e-7)) or len(judge.missing(exact, sols, rev, 1e-7)):
                    eaik_diff += 1
                robot = eaik[0] if lock is None else eaik_robot(numeric, lock, float(locks[i]))[0]
                pose = np.eye(4)
                pose[:3, :3] = T[i][:3, :3] @ eaik[1].T
                pose[:3, 3] = T[i][:3, 3]
                t = time.perf_counter_ns()
                robot.IK(pose)
                eaik_ns.append(time.perf_counter_ns() - t)
                eaik_poses.append(pose)
            if i < args.numeric:
                fixed = None if coord is None else {coord: float(locks[i])}
                found = judge.multistart_ik(numeric, T[i], starts=200, seed=i, fixed=fixed)
                inside = np.array([s for s in found if fits(s, lower, upper, rev)]).reshape(-1, len(rev))
                numeric_only += len(judge.missing(sols, inside, rev, 1e-6))
        all_cpu, all_wall, solve_cpu, solve_wall, _ = time_c(generated, chain, T, locks, starts, coord is not None)
        walls.append(f"{name}: ik_all {all_wall:.0f} ns, ik_solve {solve_wall:.0f} ns (wall)")
        counts = np.array(counts)
        solve = f"{solve_cpu:.0f}" if solve_cpu >= 0 else "n/a (locked)"
        eaik_text = f"{np.median(eaik_ns):.0f}" if eaik_ns else "n/a"
        batch_text = "n/a"
        if eaik_poses and lock is None:  # a locked joint's value differs per target: one robot per target
            batch = np.array(eaik_poses)
            best = float("inf")
            for _ in range(5):
                t = time.perf_counter_ns()
                eaik[0].IK_batched(batch, 1)
                best = min(best, (time.perf_counter_ns() - t) / len(batch))
            batch_text = f"{best:.0f}"
        row = (f"| {name} | {fam} | {counts.mean():.2f} ({counts.min()}-{counts.max()}) | {worst:.1e} | "
               f"{source}/{args.targets} | {numeric_only} in {min(args.numeric, args.targets)} | "
               f"{(str(eaik_diff) + ' / ' + str(args.targets)) if eaik is not None else 'n/a'} | {all_cpu:.0f} | {solve} | "
               f"{eaik_text} | {batch_text} | {gen_wall:.2f} / {gen_cpu:.2f} |")
        rows.append(row)
        print(row, flush=True)
    print()
    print(f"# wall-clock medians (load average now {os.getloadavg()[0]:.2f}): " + "; ".join(walls))


if __name__ == "__main__":
    main()
