"""Time of one call from Python on one configuration: the ctypes path against the CPython extension.

    python benchmarks/call_overhead.py                   # the default cases
    python benchmarks/call_overhead.py --samples 400     # more samples on a busy machine

For each case the same generation is compiled twice (``compile_arm(..., extension=False)``: the ctypes
library alone, as before the extension existed; ``extension=True``: the library with the CPython
extension), and the two are timed in turn: each sample is a loop of calls on float64 arrays of one
configuration, a tenth of a millisecond or so, and the printed figures are the minimum and the median of
the samples in microseconds per call (other load on the machine only adds time: the minimum is the
undisturbed cost, the median what a busy machine gives). ``direct`` calls the extension's entry without
the Python method around it. The C function itself takes well under 0.2 µs in every case
(``benchmarks/batch_ab.py`` times it), so these figures are the overhead of the call; the solvers' take about
1 µs (``ik_all``, ``ik_nearest``) and a few µs (``ik_solve``, ``benchmarks/ik_all.py``), included here. For a
solver, ``direct`` returns the raw ``(status, outputs...)`` tuple, not the record.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from skelarm_sym.build import compile_arm
from skelarm_sym.generate import generate
from skelarm_sym.models import DiffDrive, PlanarArm
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]
CASES = {
    "diffdrive body_rates": (lambda: DiffDrive(None), "body_rates"),
    "planar n = 1 position": (lambda: PlanarArm(1), "position"),
    "planar n = 3 jacobian": (lambda: PlanarArm(3), "jacobian"),
    "planar n = 3 kinematics": (lambda: PlanarArm(3), "kinematics"),
    "panda jacobian": (lambda: load_robot(ROOT / "examples/robots/panda.toml"), "jacobian"),
    "panda kinematics": (lambda: load_robot(ROOT / "examples/robots/panda.toml"), "kinematics"),
    "puma560 ik_all": (lambda: load_robot(ROOT / "examples/robots/puma560.toml"), "ik_all"),
    "puma560 ik_nearest": (lambda: load_robot(ROOT / "examples/robots/puma560.toml"), "ik_nearest"),
    "puma560 ik_solve": (lambda: load_robot(ROOT / "examples/robots/puma560.toml"), "ik_solve"),
}


def arguments(function, rng, model=None) -> list:
    """Values for every input: a solver's target is the pose of a configuration, its start that configuration
    moved by 0.1 rad; its other inputs their defaults."""
    if function.kind != "straight":
        from skelarm_sym.models.chain.reference import chain_kinematics

        q = rng.uniform(-1.0, 1.0, model.n)
        values = {"target": chain_kinematics(model.numeric(), q[None]).T[0], "q0": q + 0.1, "q_ref": q + 0.1}
        return [values[a.name] if a.name in values else a.default.value for a in function.inputs]
    out = []
    for a in function.inputs:
        low, high = (0.5, 1.5) if a.domain == "positive" else (0.0, 0.2) if a.domain == "nonnegative" else (-1.0, 1.0)
        out.append(float(rng.uniform(low, high)) if a.is_scalar else rng.uniform(low, high, a.size))
    return out


def flat(result) -> np.ndarray:
    """Every output of a call, one after another (a solver's status as its length)."""
    parts = result if isinstance(result, tuple) else (result,)
    return np.concatenate([np.ravel(len(x) if isinstance(x, str) else x).astype(float) for x in parts])


def sample(fn, args, loops: int) -> float:
    start = time.perf_counter()
    for _ in range(loops):
        fn(*args)
    return (time.perf_counter() - start) / loops * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated names from: " + ", ".join(CASES))
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    print("µs per call on one configuration: minimum / median of the samples")
    print()
    print("| case | ctypes | extension | ratio of minima | extension, direct |")
    print("|---|---|---|---|---|")
    for name in args.cases.split(","):
        make, function = CASES[name]
        model = make()
        g = generate(model, langs="c", out=None, functions=function, prefix="bench")
        plain, fast = compile_arm(g, extension=False), compile_arm(g, extension=True)
        f = g.module.function(function)
        values = arguments(f, rng, model)
        calls = {"ctypes": getattr(plain, function), "extension": getattr(fast, function),
                 "direct": getattr(fast.extension, function)}
        np.testing.assert_array_equal(flat(calls["ctypes"](*values)), flat(calls["extension"](*values)))
        loops = {key: max(1, int(100 / sample(fn, values, 20))) for key, fn in calls.items()}
        times: dict[str, list[float]] = {key: [] for key in calls}
        for _ in range(args.samples):
            for key, fn in calls.items():
                times[key].append(sample(fn, values, loops[key]))
        row = {key: (min(v), statistics.median(v)) for key, v in times.items()}
        print(f"| {name} | {row['ctypes'][0]:.2f} / {row['ctypes'][1]:.2f} | {row['extension'][0]:.2f} / "
              f"{row['extension'][1]:.2f} | {row['extension'][0] / row['ctypes'][0]:.3f} | "
              f"{row['direct'][0]:.2f} / {row['direct'][1]:.2f} |", flush=True)


if __name__ == "__main__":
    main()
