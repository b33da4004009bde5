"""Pose + Jacobian on 100 000 configurations on the CPU: the emitted PyTorch module (eager and
torch.compile), the emitted JAX module (jax.jit), the emitted NumPy module, and pytorch_kinematics
building its chain from the same URDF when it is installed. Prints a table; not a timed test.

    pip install ".[torch,jax]" pytorch-kinematics example-robot-data
    python benchmarks/torch_jax.py                 # UR5 and Panda from example-robot-data, 100 000 configurations
    python benchmarks/torch_jax.py --configs 20000 --threads 2

Every implementation computes the tool pose T (4 x 4) and the 6 x n Jacobian J (base axes, reference
point the tool origin, rows v then w) in float64; the emitted modules run ``ik_terms`` (T and J at
once), pytorch_kinematics ``forward_kinematics`` and ``jacobian``. Before anything is timed, each result
on 1000 configurations is compared with the emitted NumPy module (pytorch_kinematics to 1e-6: it parses
URDF numbers in float32). Times: the best of ``--repeats`` rounds after one warm-up, the implementations
interleaved round-robin in each round (compile times are reported apart). ``--threads`` sets PyTorch's and XLA's threads (NumPy's ufuncs use one).
"""

from __future__ import annotations

import argparse
import os
from importlib import metadata
import sys
import time
from pathlib import Path

ROBOTS = {
    "UR5": ("ur_description/urdf/ur5_robot.urdf", "base_link", "tool0"),
    "Panda": ("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8"),
}


def urdf_folder() -> Path:
    """example-robot-data's robots folder (the pip package installs it under cmeel.prefix)."""
    for entry in sys.path:
        folder = Path(entry) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if folder.is_dir():
            return folder
    sys.exit("example-robot-data is not installed: pip install example-robot-data")


def best_of(runs: dict, repeats: int) -> dict:
    """The best time of each run over ``repeats`` rounds, the runs interleaved round-robin after one
    warm-up each: other jobs on the machine then slow every implementation alike."""
    for run in runs.values():
        run()
    times = {label: float("inf") for label in runs}
    for _ in range(repeats):
        for label, run in runs.items():
            start = time.perf_counter()
            run()
            times[label] = min(times[label], time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--configs", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    os.environ.setdefault("XLA_FLAGS", f"--xla_cpu_multi_thread_eigen={'true' if args.threads > 1 else 'false'} "
                                       f"intra_op_parallelism_threads={args.threads}")

    import jax
    import numpy as np
    import torch

    try:
        import pytorch_kinematics as pk
    except ImportError:  # the comparison column only
        pk = None
        print("pytorch_kinematics is not installed (pip install pytorch-kinematics): its rows are left out", file=sys.stderr)

    from skelarm_sym.build import load_python
    from skelarm_sym.generate import generate
    from skelarm_sym.models.chain.loader import load_robot

    jax.config.update("jax_enable_x64", True)
    torch.set_num_threads(args.threads)
    folder = urdf_folder()
    rows = []
    for name, (path, base, tip) in ROBOTS.items():
        urdf = folder / path
        g = generate(load_robot(urdf, base=base, tip=tip), langs="python,torch,jax", out=None, prefix="bench",
                     functions="ik_terms")
        npm = load_python(g.sources["bench.py"], "bench")
        tm = load_python(g.sources["bench_torch.py"], "bench_torch")
        jm = load_python(g.sources["bench_jax.py"], "bench_jax")
        n = g.module.function("ik_terms").argument("q").size
        q = np.random.default_rng(0).uniform(-np.pi, np.pi, (args.configs, n))
        qt = torch.as_tensor(q)
        qj = jax.device_put(q)

        chain = pk.build_serial_chain_from_urdf(urdf.read_bytes(), tip, base).to(dtype=torch.float64) if pk else None

        def pk_run(x=qt):
            T = chain.forward_kinematics(x, end_only=True).get_matrix()
            return T, chain.jacobian(x)

        start = time.perf_counter()
        compiled = torch.compile(tm.ik_terms_unchecked)
        compiled(qt[:1000])
        torch_compile_s = time.perf_counter() - start
        jitted = jax.jit(jm.ik_terms_unchecked)
        start = time.perf_counter()
        jax.block_until_ready(jitted(qj))
        jax_compile_s = time.perf_counter() - start

        implementations = {
            "NumPy module": lambda: npm.ik_terms(q),
            "PyTorch module (eager)": lambda: tm.ik_terms_unchecked(qt),
            "PyTorch module (torch.compile)": lambda: compiled(qt),
            "JAX module (jax.jit)": lambda: jax.block_until_ready(jitted(qj)),
        }
        if pk:
            implementations["pytorch_kinematics"] = pk_run
        # the numbers first
        T0, J0 = npm.ik_terms(q[:1000])
        for label, run in implementations.items():
            if label == "NumPy module":
                continue
            if label == "pytorch_kinematics":
                T, J = pk_run(qt[:1000])
            elif label.startswith("JAX"):
                T, J = jitted(qj[:1000])
            elif "compile" in label:
                T, J = compiled(qt[:1000])
            else:
                T, J = tm.ik_terms_unchecked(qt[:1000])
            errors = (float(np.abs(np.asarray(T) - T0).max()), float(np.abs(np.asarray(J) - J0).max()))
            allowed = 1e-6 if label == "pytorch_kinematics" else 1e-12
            if max(errors) > allowed:
                sys.exit(f"{name} {label}: T off by {errors[0]:.2e}, J by {errors[1]:.2e} (allowed {allowed:g})")
            rows.append((name, label, "check", errors))
        times = best_of(implementations, args.repeats)
        yardstick = times.get("pytorch_kinematics", float("nan"))
        for label, seconds in times.items():
            rows.append((name, label, "time", seconds, yardstick / seconds, times["NumPy module"] / seconds))
        rows.append((name, "compile", "once", torch_compile_s, jax_compile_s))

    print(f"pose + J (float64) on {args.configs} configurations, CPU, {args.threads} thread(s); "
          f"torch {torch.__version__}, jax {jax.__version__}, "
          f"pytorch_kinematics {metadata.version('pytorch-kinematics') if pk else 'not installed'}")
    print()
    print("| robot | implementation | ms | configurations/s | vs pytorch_kinematics | vs NumPy module | max error T, J vs NumPy |")
    print("|---|---|---:|---:|---:|---:|---|")
    checks = {(r[0], r[1]): r[3] for r in rows if r[2] == "check"}
    for r in rows:
        if r[2] == "time":
            err = checks.get((r[0], r[1]))
            err_text = "(reference)" if err is None else f"{err[0]:.1e}, {err[1]:.1e}"
            versus = "-" if r[4] != r[4] else f"{r[4]:.1f}x"  # NaN without pytorch_kinematics
            print(f"| {r[0]} | {r[1]} | {r[3] * 1e3:.1f} | {args.configs / r[3]:.3g} | {versus} | {r[5]:.2f}x | {err_text} |")
    print()
    for r in rows:
        if r[2] == "once":
            print(f"{r[0]}: torch.compile took {r[3]:.1f} s, jax.jit {r[4]:.1f} s (once per shape)")


if __name__ == "__main__":
    main()
