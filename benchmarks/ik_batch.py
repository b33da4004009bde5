"""Closed-form IK over a batch of targets from Python: time per target of each way to call it. A table, not a test.

    python benchmarks/ik_batch.py [--targets 1000,10000] [--robots puma560,ur5,iiwa14_lock3]

Per robot and batch size m (targets: poses of random configurations within the joint limits; a locked joint held
at 0.3 rad):

* ``NumPy single``: the emitted module's ``ik_all(T[j])`` in a Python loop (the scalar code), over the first 200
  targets, per target;
* ``NumPy batch``: ``ik_all(T)`` with ``T`` of shape (m, 4, 4): the masked program over every target at once;
* ``C batch``: the compiled wrapper's ``ik_all(T)``: ``X_ik_all_batch`` through ctypes (input checks, output
  arrays and the record included), built with ``cc -O2``;
* ``PyTorch batch``: the ``_torch.py`` module's ``ik_all_unchecked`` on CPU float64 tensors (when torch is
  installed).

Every batch's rows are compared with the C batch's first (statuses and counts exactly, rows to 1e-9). Each figure
is the least of 3 runs (the machine is shared).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))  # closed_ik_support: the tests' arms

from closed_ik_support import load_arm, random_configurations, targets_of
from skelarm_sym.build import compile_arm, load_python
from skelarm_sym.generate import generate
from skelarm_sym.models.chain.lock import with_ik_lock

LOCK = 0.3


def least_time(call, runs: int = 3) -> float:
    best = float("inf")
    for _ in range(runs):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return best


def torch_module(generated, prefix: str):
    try:
        import torch  # noqa: F401
    except ImportError:
        return None
    from skelarm_sym.generate import render_all

    source = render_all(generated.module, ("torch",), False)[f"{prefix}_torch.py"]
    return load_python(source, prefix + "_torch")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", default="1000,10000", help="comma-separated batch sizes")
    parser.add_argument("--robots", default="puma560,ur5,iiwa14_lock3")
    args = parser.parse_args(argv)
    sizes = [int(x) for x in args.targets.split(",")]
    print("| robot | m | NumPy single µs | NumPy batch µs | C batch µs | PyTorch batch µs | NumPy batch / single |")
    print("|---|---|---|---|---|---|---|")
    for name in args.robots.split(","):
        chain, lock = load_arm(name)
        if lock is not None:
            chain = with_ik_lock(chain, lock + 1)
        generated = generate(chain, out=None, functions="ik_all", langs="c,python")
        prefix = generated.module.prefix
        arm = compile_arm(generated, flags=["-O2"])
        py = load_python(generated.sources[f"{prefix}.py"], prefix)
        pt = torch_module(generated, prefix)
        extra = () if lock is None else (LOCK,)
        rng = np.random.default_rng(1)
        for m in sizes:
            q = random_configurations(chain, m, rng, within_limits=True)
            if lock is not None:
                q[:, chain.joints[lock].coordinate] = LOCK
            T = targets_of(chain, q)
            c = arm.ik_all(T, *extra)
            b = py.ik_all(T, *extra)
            if not (np.array_equal(c.status, b.status) and np.array_equal(c.count, b.count)
                    and np.allclose(c.q, b.q, atol=1e-9, equal_nan=True)):
                print(f"CHECK FAILED: {name} m={m}: the NumPy batch differs from the C batch", file=sys.stderr)
                return 1
            few = min(m, 200)
            single = least_time(lambda: [py.ik_all(T[j], *extra) for j in range(few)], 1) / few
            batch = least_time(lambda: py.ik_all(T, *extra)) / m
            c_batch = least_time(lambda: arm.ik_all(T, *extra)) / m
            torch_text = "-"
            if pt is not None:
                import torch

                Tt = torch.as_tensor(T, dtype=torch.float64)
                r = pt.ik_all_unchecked(Tt, *extra)
                if not np.allclose(r.q.numpy(), c.q, atol=1e-9, equal_nan=True):
                    print(f"CHECK FAILED: {name} m={m}: PyTorch differs from the C batch", file=sys.stderr)
                    return 1
                torch_text = f"{least_time(lambda: pt.ik_all_unchecked(Tt, *extra)) / m * 1e6:.2f}"
            print(f"| {name} | {m} | {single * 1e6:.0f} | {batch * 1e6:.2f} | {c_batch * 1e6:.2f} | {torch_text} | "
                  f"{batch / single:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
