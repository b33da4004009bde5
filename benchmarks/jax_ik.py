"""The emitted JAX module's closed-form IK solvers: the first call (tracing and XLA's compile, what a user waits
for once per input shape) and the time per target after it. Prints a table; not a timed test.

    pip install ".[jax]"
    python benchmarks/jax_ik.py                                  # UR5 (examples/robots/ur5.toml), 10 000 targets
    python benchmarks/jax_ik.py --robot examples/robots/puma560.toml --targets 2000

Targets are the poses of random configurations (joint values uniform in [-2, 2] rad, float64); ``ik_nearest``
starts from those configurations plus noise (sigma 0.1 rad). Each solver is first called once (the first-call
column), then ``--repeats`` times (the best one is reported per target). Before anything is timed, the rows of
``ik_all`` and the ``q`` of ``ik_nearest`` are compared with the emitted NumPy module's on the first 200 targets
(statuses and counts exactly, values to 1e-9). XLA runs with its default settings unless ``XLA_FLAGS`` is set;
every solver runs in a fresh process, so that no compile is shared.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run_one(robot: Path, solver: str, targets: int, repeats: int, folder: str) -> dict:
    """In this process: load the modules written to ``folder``, check ``solver`` against NumPy, time it."""
    import jax
    import numpy as np

    from skelarm_sym.build import load_python
    from skelarm_sym.models.chain.loader import load_robot

    jax.config.update("jax_enable_x64", True)
    jm, nm = (load_python(Path(folder, f"{name}.py").read_text(), name) for name in ("arm_jax", "arm"))
    rng = np.random.default_rng(0)
    q = rng.uniform(-2.0, 2.0, (targets, load_robot(robot).n))
    T = nm.pose(q)
    q0 = q + rng.normal(0.0, 0.1, q.shape)
    call = (lambda: jm.ik_all_unchecked(T)) if solver == "ik_all" else (lambda: jm.ik_nearest_unchecked(q0, T))
    start = time.perf_counter()
    result = call()
    jax.block_until_ready(result)
    first = time.perf_counter() - start
    k = min(200, targets)
    ref = nm.ik_all(T[:k]) if solver == "ik_all" else nm.ik_nearest(q0[:k], T[:k])
    names = [jm.STATUS_NAMES[int(code)] for code in np.asarray(result.status)[:k]]  # JAX: codes; NumPy: names
    assert names == list(ref.status), f"{solver}: statuses differ from the NumPy module's"
    if solver == "ik_all":
        np.testing.assert_array_equal(np.asarray(result.count)[:k], ref.count)
    np.testing.assert_allclose(np.asarray(result.q)[:k], ref.q, rtol=0, atol=1e-9)
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(call())
        best = min(best, time.perf_counter() - start)
    return {"robot": robot.stem, "solver": solver, "first_s": first, "us_per_target": best / targets * 1e6}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default=str(ROOT / "examples" / "robots" / "ur5.toml"))
    parser.add_argument("--targets", type=int, default=10_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--one", help=argparse.SUPPRESS)  # internal: "SOLVER FOLDER", run in a child process
    args = parser.parse_args(argv)
    if args.one:
        solver, folder = args.one.split(" ", 1)
        print(json.dumps(run_one(Path(args.robot), solver, args.targets, args.repeats, folder)))
        return
    from skelarm_sym.generate import generate
    from skelarm_sym.models.chain.loader import load_robot

    with tempfile.TemporaryDirectory() as folder:
        generate(load_robot(Path(args.robot)), langs="jax,python", out=folder, prefix="arm",
                 functions="pose,ik_all,ik_nearest")
        print(f"| robot | solver | first call (trace + compile), s | µs per target ({args.targets} targets) |")
        print("|---|---|---|---|")
        for solver in ("ik_all", "ik_nearest"):
            done = subprocess.run([sys.executable, __file__, "--robot", args.robot, "--targets", str(args.targets),
                                   "--repeats", str(args.repeats), "--one", f"{solver} {folder}"],
                                  capture_output=True, text=True)
            if done.returncode != 0:
                sys.exit(f"{solver}: {done.stderr.strip().splitlines()[-1] if done.stderr.strip() else 'failed'}")
            row = json.loads(done.stdout.strip().splitlines()[-1])
            print(f"| {row['robot']} | {solver} | {row['first_s']:.1f} | {row['us_per_target']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
