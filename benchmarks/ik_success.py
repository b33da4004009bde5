"""IK success and speed benchmark: UR5, Panda, PUMA 560 (examples/robots/<name>.toml, limits from the file).

    PYTHONPATH=. python benchmarks/ik_success.py [--count 1000] [--python-count 1000] [--no-pinocchio]

Targets: poses of random configurations within the limits; starts: random configurations within the
limits (numpy default_rng(0)); tol 1e-10 m and 1e-10 rad, max_iter 100, lambda 0.

* C: the emitted ``X_ik_solve`` through the compiled wrapper (``arm.ik_solve_pose``): success rate,
  median / max iterations, the failures' final errors, NaN check.
* Python: ``skelarm_sym.ik.solve_pose`` (NumPy loop on the emitted ``ik_terms``), µs per solve.
* Pinocchio: ``benchmarks/ik_pinocchio.cpp``, the same loop (same constants and restarts) written with
  ``forwardKinematics``, ``updateFramePlacement``, ``computeFrameJacobian`` (LOCAL_WORLD_ALIGNED),
  ``log3`` and an Eigen LDLT; it also times the emitted solver in the same process (the emitted C
  built as a shared library with the same ``-O2 -march=native``, loaded with dlopen) on the same
  targets. Compiled once, header-only (a few minutes), cached in benchmarks/build/.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

from robots import FLAGS, chain_file  # noqa: E402

from skelarm_sym import ik  # noqa: E402
from skelarm_sym.build import compile_arm, find_compiler  # noqa: E402
from skelarm_sym.generate import generate  # noqa: E402
from skelarm_sym.models.chain.dh_file import load_robot_file  # noqa: E402

ROBOTS = ("ur5", "panda", "puma560")
TOL, MAX_ITER = 1e-10, 100


def pinocchio_program() -> Path | None:
    """Build (once) benchmarks/build/ik_pinocchio; None without the pin wheel's headers."""
    import sysconfig

    prefix = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
    if not (prefix / "include" / "pinocchio").is_dir():
        return None
    exe = HERE / "build" / "ik_pinocchio"
    source = HERE / "ik_pinocchio.cpp"
    if exe.exists() and exe.stat().st_mtime > source.stat().st_mtime:
        return exe
    exe.parent.mkdir(exist_ok=True)
    defines = ["-DNDEBUG", "-DBOOST_MPL_LIMIT_LIST_SIZE=30", "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
               "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "-DBOOST_FUSION_INVOKE_MAX_ARITY=12"]
    print("compiling the Pinocchio IK program (header-only, a few minutes) ...", file=sys.stderr)
    subprocess.run(["g++", *FLAGS, "-std=c++17", *defines, f"-I{prefix / 'include'}", f"-I{prefix / 'include' / 'eigen3'}",
                    str(source), "-o", str(exe), "-ldl"], check=True)
    return exe


def cases(chain, arm, count: int):
    limits = chain.limits()
    lo = np.array([-np.pi if x is None else x for x in limits["lower"]])
    hi = np.array([np.pi if x is None else x for x in limits["upper"]])
    rng = np.random.default_rng(0)
    return [(arm.pose(rng.uniform(lo, hi)), rng.uniform(lo, hi)) for _ in range(count)]


def targets_file(chain, pairs, path: Path) -> None:
    opts = ik.chain_options(chain)
    n = chain.n
    lo = [-1e300 if x is None else x for x in opts["limits"]["lower"]]
    hi = [1e300 if x is None else x for x in opts["limits"]["upper"]]
    draw_lo = [-np.pi if x is None else x for x in opts["limits"]["lower"]]
    draw_span = [(np.pi if u is None else u) - d for u, d in zip(opts["limits"]["upper"], draw_lo)]
    periodic = [int(p and h - lo_ >= 2 * np.pi) for p, lo_, h in zip(opts["periodic"], lo, hi)]
    tail = " ".join(repr(float(x)) for x in [*lo, *hi, *draw_lo, *draw_span]) + " " + " ".join(map(str, periodic))
    lines = [f"{len(pairs)} {n}"] + [
        " ".join(repr(float(x)) for x in [*T.reshape(-1), *q0]) + " " + tail for T, q0 in pairs
    ]
    path.write_text("\n".join(lines) + "\n")


def summary(results):
    ok = np.array([r.status == "converged" for r in results])
    its = np.array([r.iterations for r in results])
    fails = [(r.position_error, r.rotation_error) for r in results if r.status != "converged"]
    worst = max(fails, key=lambda e: e[0] + e[1]) if fails else (0.0, 0.0)
    finite = all(np.all(np.isfinite(r.q)) and np.isfinite(r.position_error) and np.isfinite(r.rotation_error) for r in results)
    return ok.mean(), int(np.median(its)), int(its.max()), len(fails), worst, finite


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1000)
    parser.add_argument("--python-count", type=int, default=1000)
    parser.add_argument("--no-pinocchio", action="store_true")
    args = parser.parse_args(argv)
    cc = find_compiler()
    pin = None if args.no_pinocchio else pinocchio_program()
    print(f"targets {args.count} per robot (Python: {args.python_count}); tol {TOL:g} m and rad; max_iter {MAX_ITER}; flags {' '.join(FLAGS)}")
    print()
    print("| robot | C success | median it | max it | failures: worst (m, rad) | NaN-free | Python success | Python µs | "
          "C µs (in-process) | Pinocchio loop µs | Pinocchio success | C / Pinocchio |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in ROBOTS:
            chain = load_robot_file(ROOT / "examples" / "robots" / f"{name}.toml")
            prefix = f"ikb_{name}"
            g = generate(chain, langs="c", out=work / name, prefix=prefix)
            arm = compile_arm(g)
            pairs = cases(chain, arm, args.count)
            c_results = [arm.ik_solve_pose(q0, T, tol=TOL, max_iter=MAX_ITER) for T, q0 in pairs]
            rate, median, most, nfail, worst, finite = summary(c_results)
            opts = ik.chain_options(chain)
            start = time.perf_counter()
            py_results = [ik.solve_pose(arm, q0, T, tol=TOL, max_iter=MAX_ITER, **opts) for T, q0 in pairs[: args.python_count]]
            py_us = (time.perf_counter() - start) / max(1, len(py_results)) * 1e6
            py_rate = summary(py_results)[0] if py_results else float("nan")
            pin_text = "- | - | - | -"
            if pin:
                lib = work / f"lib{prefix}.so"
                subprocess.run([cc, *FLAGS, "-std=c99", "-shared", "-fPIC", str(work / name / f"{prefix}.c"), "-o", str(lib), "-lm"], check=True)
                chain_file(chain, work / f"{name}.chain")
                targets_file(chain, pairs, work / f"{name}.targets")
                constants = [repr(x) for x in (ik.C_START, ik.C_MIN, ik.C_MAX, ik.C_UP, ik.C_DOWN, ik.STEP_MAX, ik.STALL, ik.PROGRESS)]
                constants += [str(ik.ATTEMPT), str(ik.WINDOW), str(ik.SEED), repr(ik.STATIONARY), str(ik.CANDIDATES), repr(ik.SHRINK)]
                out = subprocess.run([str(pin), str(work / f"{name}.chain"), str(work / f"{name}.targets"), str(lib), prefix, *constants],
                                     capture_output=True, text=True, check=True).stdout.split("\n")
                rows = {line.split()[0]: line.split()[1:] for line in out if line.strip()}
                p_ok, _, p_us = rows["pinocchio"]
                c_ok, _, c_us = rows["emitted"]
                if int(c_ok) != int(round(rate * len(pairs))):
                    print(f"warning: {name}: in-process C converged {c_ok}, wrapper {rate * len(pairs):.0f}", file=sys.stderr)
                pin_text = f"{float(c_us):.2f} | {float(p_us):.2f} | {int(p_ok) / len(pairs):.1%} | {float(c_us) / float(p_us):.3f}"
            print(f"| {name} | {rate:.1%} | {median} | {most} | {nfail}: ({worst[0]:.2e}, {worst[1]:.2e}) | {finite} | "
                  f"{py_rate:.1%} | {py_us:.0f} | {pin_text} |", flush=True)


if __name__ == "__main__":
    main()
