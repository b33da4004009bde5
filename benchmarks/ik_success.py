"""IK success rate against the damping ``lambda``: the emitted pose solver on UR5, Panda, PUMA 560
(examples/robots/<name>.toml, limits from the file).

    python benchmarks/ik_success.py                                  # 1000 targets, lambda 0, 1e-3, 1e-2, 0.1
    python benchmarks/ik_success.py --count 200 --python-count 0     # quick
    python benchmarks/ik_success.py --lambdas 0,0.05 --no-pinocchio

Targets: poses of random configurations within the limits; starts: random configurations within the
limits (numpy ``default_rng(0)``: the same pairs for every lambda); tol 1e-10 (m and rad), max_iter 100.

* C: the emitted ``X_ik_solve`` (``skelarm_sym/models/chain/solver.py``) through the compiled wrapper
  (``arm.ik_solve(q0, target, lambda, tol, max_iter)``), one table row per robot and lambda: success
  rate (status ``converged`` and the returned pose within 1e-9 of the target by the NumPy reference
  recursion, which judges, not the emitted pose), median / max iterations, the failures' worst final
  errors, whether every returned q and error is finite, and µs per solve of the C function alone (built
  as a shared library with ``-O2 -march=native``, called through ctypes with its arguments prepared:
  about 1 µs of the figure is the call).
* Python: the emitted NumPy module's ``ik_solve`` (the same IR description), success rate and µs per
  solve on the first ``--python-count`` pairs (lambda 0 only; slow: a NumPy call per operation row).
* Pinocchio (lambda 0 only; needs ``pip install '.[oracle]'``): ``benchmarks/ik_pinocchio.cpp``, the same
  loop (same constants and restarts) written with ``forwardKinematics``, ``updateFramePlacement``,
  ``computeFrameJacobian`` (LOCAL_WORLD_ALIGNED), ``log3`` and an Eigen LDLT; it also times the emitted
  solver in the same process (the emitted C built as a shared library with the same ``-O2
  -march=native``, loaded with dlopen) on the same targets. Compiled once, header-only (a few minutes),
  cached in benchmarks/build/. At lambda 0 its damping ``max(lambda^2, c |e|)`` is the emitted one.
"""

from __future__ import annotations

import argparse
import ctypes
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

from skelarm_sym import reference  # noqa: E402
from skelarm_sym.build import compile_arm, find_compiler, load_python  # noqa: E402
from skelarm_sym.generate import generate  # noqa: E402
from skelarm_sym.models.chain import solver  # noqa: E402
from skelarm_sym.models.chain.dh_file import load_robot_file  # noqa: E402

ROBOTS = ("ur5", "panda", "puma560")
TOL, MAX_ITER, JUDGE = 1e-10, 100, 1e-9


def pinocchio_program() -> Path | None:
    """Build (once) benchmarks/build/ik_pinocchio; None without the pin wheel's headers."""
    import sysconfig

    prefix = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
    if not (prefix / "include" / "pinocchio").is_dir():
        return None
    if not (prefix / "include" / "eigen3" / "Eigen").is_dir():
        print("the Pinocchio loop is skipped: Eigen's headers are missing (pip install cmeel-eigen, in the oracle extra)",
              file=sys.stderr)
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


def bounds(chain):
    limits = chain.limits()
    lo = np.array([-np.pi if x is None else x for x in limits["lower"]], dtype=float)
    hi = np.array([np.pi if x is None else x for x in limits["upper"]], dtype=float)
    return lo, hi


def reference_poses(numeric, q) -> np.ndarray:
    """Tool poses (..., 4, 4) of configurations q (..., n) by the NumPy reference recursion."""
    return reference.chain_kinematics(numeric, np.asarray(q, dtype=float)).T


def rotation_angles(R) -> np.ndarray:
    """Angles of rotation matrices R (..., 3, 3)."""
    axis = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    return np.arctan2(0.5 * np.linalg.norm(axis, axis=-1), (np.trace(R, axis1=-2, axis2=-1) - 1) / 2)


def cases(chain, count: int):
    lo, hi = bounds(chain)
    rng = np.random.default_rng(0)
    draws = [(rng.uniform(lo, hi), rng.uniform(lo, hi)) for _ in range(count)]
    poses = reference_poses(chain.numeric(), np.array([t for t, _ in draws]))
    return [(T, q0) for T, (_, q0) in zip(poses, draws)]


def targets_file(chain, pairs, path: Path) -> None:
    """The targets as ik_pinocchio.cpp reads them (limits and restart ranges of solver.limits_of)."""
    lim = solver.limits_of(chain, "double")
    periodic = [int(k in lim["wrapped"]) for k in range(chain.n)]
    tail = " ".join(repr(float(x)) for x in [*lim["lower"], *lim["upper"], *lim["draw_low"], *lim["draw_span"]])
    tail += " " + " ".join(map(str, periodic))
    lines = [f"{len(pairs)} {chain.n}"] + [
        " ".join(repr(float(x)) for x in [*T.reshape(-1), *q0]) + " " + tail for T, q0 in pairs
    ]
    path.write_text("\n".join(lines) + "\n")


def judged(numeric, results, pairs) -> np.ndarray:
    """Per result: converged by the solver's report and by the reference's forward kinematics."""
    T = reference_poses(numeric, np.array([r.q for r in results], dtype=float))
    targets = np.array([t for t, _ in pairs])
    position = np.linalg.norm(T[:, :3, 3] - targets[:, :3, 3], axis=-1)
    rotation = rotation_angles(targets[:, :3, :3] @ np.swapaxes(T[:, :3, :3], -1, -2))
    converged = np.array([r.status == "converged" for r in results])
    return converged & (position <= JUDGE) & (rotation <= JUDGE)


def summary(numeric, results, pairs):
    ok = judged(numeric, results, pairs)
    its = np.array([r.iterations for r in results])
    fails = [(r.position_error, r.rotation_error, r.status) for r, good in zip(results, ok) if not good]
    worst = max(fails, key=lambda e: e[0] + e[1]) if fails else (0.0, 0.0, "-")
    finite = all(np.all(np.isfinite(r.q)) and np.isfinite(r.position_error) and np.isfinite(r.rotation_error) for r in results)
    return ok.mean(), int(np.median(its)), int(its.max()), len(fails), worst, finite


def shared_library(work: Path, name: str, prefix: str, cc: str) -> Path:
    lib = work / f"lib{prefix}.so"
    if not lib.exists():
        subprocess.run([cc, *FLAGS, "-std=c99", "-shared", "-fPIC", str(work / name / f"{prefix}.c"), "-o", str(lib), "-lm"],
                       check=True)
    return lib


def c_microseconds(lib: Path, prefix: str, pairs, lam: float, repeats: int = 3) -> float:
    """The C ``X_ik_solve`` alone on every pair, µs per solve (least of ``repeats`` sweeps)."""
    P = ctypes.POINTER(ctypes.c_double)
    f = getattr(ctypes.CDLL(str(lib)), f"{prefix}_ik_solve")
    f.restype = ctypes.c_int
    n = len(pairs[0][1])
    q, err, its = np.zeros(n), np.zeros(2), ctypes.c_int()
    prepared = [(np.ascontiguousarray(q0, dtype=float), np.ascontiguousarray(T, dtype=float).reshape(-1)) for T, q0 in pairs]
    calls = [(a.ctypes.data_as(P), b.ctypes.data_as(P), ctypes.c_double(lam), ctypes.c_double(TOL), ctypes.c_int(MAX_ITER),
              q.ctypes.data_as(P), err.ctypes.data_as(P), ctypes.byref(its)) for a, b in prepared]
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        for args in calls:
            f(*args)
        best = min(best, (time.perf_counter() - start) / len(calls) * 1e6)
    return best


def pinocchio_row(pin, chain, pairs, work: Path, name: str, prefix: str, cc: str) -> dict[str, list[str]]:
    lib = shared_library(work, name, prefix, cc)
    chain_file(chain, work / f"{name}.chain")
    targets_file(chain, pairs, work / f"{name}.targets")
    s = solver
    constants = [repr(x) for x in (s.C_START, s.C_MIN, s.C_MAX, s.C_UP, s.C_DOWN, s.STEP_MAX, s.SETTINGS["double"]["stall"],
                                   s.PROGRESS)]
    constants += [str(s.ATTEMPT), str(s.WINDOW), str(s.SEED), repr(s.STATIONARY), str(s.CANDIDATES), repr(s.SHRINK)]
    constants += [repr(s.GEO_H), repr(s.GEO_ALPHA), repr(s.GEO_GATE), repr(s.GEO_ERROR)]
    out = subprocess.run([str(pin), str(work / f"{name}.chain"), str(work / f"{name}.targets"), str(lib), prefix, *constants],
                         capture_output=True, text=True, check=True).stdout.split("\n")
    return {line.split()[0]: line.split()[1:] for line in out if line.strip()}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1000, help="targets per robot")
    parser.add_argument("--lambdas", default="0,1e-3,1e-2,0.1", help="comma-separated damping values")
    parser.add_argument("--python-count", type=int, default=100, help="targets for the emitted NumPy solver (lambda 0)")
    parser.add_argument("--robots", default=",".join(ROBOTS))
    parser.add_argument("--no-pinocchio", action="store_true")
    args = parser.parse_args(argv)
    lambdas = [float(x) for x in args.lambdas.split(",")]
    cc = find_compiler()
    pin = None if args.no_pinocchio else pinocchio_program()
    print(f"targets {args.count} per robot; tol {TOL:g} m and rad; max_iter {MAX_ITER}; "
          f"success: converged and within {JUDGE:g} by the reference; flags {' '.join(FLAGS)}")
    print()
    print("| robot | lambda | success | median it | max it | failures: worst (m, rad, status) | finite | C µs / solve |")
    print("|---|---|---|---|---|---|---|---|")
    extra = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in args.robots.split(","):
            chain = load_robot_file(ROOT / "examples" / "robots" / f"{name}.toml")
            prefix = f"ikb_{name}"
            g = generate(chain, langs="c,python", out=work / name, prefix=prefix, functions=["ik_solve"])
            arm = compile_arm(g)
            numeric = chain.numeric()
            pairs = cases(chain, args.count)
            for lam in lambdas:
                results = [arm.ik_solve(q0, T, lam, TOL, MAX_ITER) for T, q0 in pairs]
                us = c_microseconds(shared_library(work, name, prefix, cc), prefix, pairs, lam)
                rate, median, most, nfail, worst, finite = summary(numeric, results, pairs)
                worst_text = f"({worst[0]:.1e}, {worst[1]:.1e}, {worst[2]})" if nfail else "-"
                print(f"| {name} | {lam:g} | {rate:.1%} | {median} | {most} | {nfail}: {worst_text} | {finite} | {us:.1f} |",
                      flush=True)
            text = [name]
            if args.python_count:
                module = load_python(g.sources[f"{prefix}.py"], prefix)
                some = pairs[: args.python_count]
                start = time.perf_counter()
                py = [module.ik_solve(q0, T, 0.0, TOL, MAX_ITER) for T, q0 in some]
                py_us = (time.perf_counter() - start) / len(some) * 1e6
                text += [f"{summary(numeric, py, some)[0]:.1%} of {len(some)}", f"{py_us:.0f}"]
            else:
                text += ["-", "-"]
            if pin:
                rows = pinocchio_row(pin, chain, pairs, work, name, prefix, cc)
                (p_ok, _, p_us), (c_ok, _, c_us) = rows["pinocchio"], rows["emitted"]
                text += [f"{float(c_us):.2f}", f"{float(p_us):.2f}", f"{int(p_ok) / len(pairs):.1%}",
                         f"{float(c_us) / float(p_us):.3f}"]
            else:
                text += ["-"] * 4
            extra.append(text)
    print()
    print("lambda 0: the emitted NumPy solver, and the same loop written with Pinocchio (C++ in one process)")
    print()
    print("| robot | NumPy success | NumPy µs / solve | C µs (in-process) | Pinocchio loop µs | Pinocchio success | C / Pinocchio |")
    print("|---|---|---|---|---|---|---|")
    for text in extra:
        print("| " + " | ".join(text) + " |")


if __name__ == "__main__":
    main()
