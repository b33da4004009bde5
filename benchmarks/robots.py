"""Benchmark table for 3-D robots: operation counts, generation time, and the emitted C
``{prefix}_kinematics`` (T, J, dJ/dt, twist, classical acceleration) against a hand-written
O(n) recursion in C and against Pinocchio 4 computing the same five outputs.

    python benchmarks/robots.py                                   # the example robots
    python benchmarks/robots.py examples/robots/ur5.toml path/to/panda.urdf --tip panda_hand_tcp

Pinocchio's column needs its C++ headers (``pip install '.[oracle]'``: the ``pin`` wheel ships them
with Eigen and Boost under ``cmeel.prefix``); it is compiled once, header-only (a few minutes,
cached in ``benchmarks/build/``), with the same ``-O2 -march=native`` as the others. Pinocchio
runs ``computeJointJacobiansTimeVariation``, ``updateFramePlacement``, ``getFrameJacobian`` and
``getFrameJacobianTimeVariation`` in LOCAL_WORLD_ALIGNED, then ``J v`` and ``J a + dJ v``. Every
program's outputs at the first configuration are compared with the NumPy reference before its
time is reported. Times: median over 15 passes of 2000 random configurations, ns per call. The last two columns time
the emitted ``inverse_velocity`` (lambda = 1e-3) and ``manipulability_gradient`` the same way.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np

from skelarm_sym import reference
from skelarm_sym.build import find_compiler
from skelarm_sym.models.chain.derive import canonical_joints
from skelarm_sym.generate import generate
from skelarm_sym.models.chain.loader import load_robot

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DEFAULT = ["examples/robots/puma560.toml", "examples/robots/ur5.toml", "examples/robots/panda.toml"]
FLAGS = ["-O2", "-march=native"]
CONFIGS, REPEATS = 2000, 15


def chain_file(chain, path: Path) -> None:
    """The chain as the C/C++ benchmark programs read it: z motions after constant 3 x 4 placements."""
    joints, tool = canonical_joints(chain)
    if any(j.multiplier != 1 or j.offset != 0 or j.coordinate != k for k, j in enumerate(joints)):
        raise SystemExit(f"{chain.name}: the comparison programs handle plain chains (no mimic or angle offsets)")
    rows = [str(len(joints))]
    for j in joints:
        M = j.before.numeric()
        rows.append(f"{int(j.kind == 'prismatic')} " + " ".join(repr(float(x)) for x in M[:3].reshape(-1)))
    rows.append(" ".join(repr(float(x)) for x in tool.numeric()[:3].reshape(-1)))
    path.write_text("\n".join(rows) + "\n")


def configs_file(n: int, path: Path, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    data = rng.uniform(-np.pi, np.pi, (CONFIGS, n, 3))
    data[..., 1:] /= np.pi
    lines = [f"{CONFIGS} {REPEATS}"] + [" ".join(repr(float(x)) for x in row.reshape(-1)) for row in data]
    path.write_text("\n".join(lines) + "\n")
    return data


def run(command: list[str], n: int, expected: np.ndarray, extra: bool = False):
    """Run a timing program; check its first outputs against ``expected``; return ns per call
    (and, with ``extra``, the emitted program's inverse_velocity and manipulability_gradient ns per call)."""
    out = subprocess.run(command, capture_output=True, text=True, check=True).stdout.split("\n")
    values = np.array([float(x) for x in out[0].split()])
    error = np.abs(values - expected).max()
    if not error < 1e-9 * max(1.0, np.abs(expected).max()):
        raise SystemExit(f"{command[0]}: outputs differ from the reference by {error:.3g}")
    times = out[1].split()
    return (float(times[0]), float(times[2]), float(times[3])) if extra else float(times[0])


def pinocchio_program(work: Path) -> Path | None:
    """Build (once) the Pinocchio timing program; None when the pin wheel's headers are missing."""
    prefix = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
    if not (prefix / "include" / "pinocchio").is_dir():
        return None
    exe = HERE / "build" / "chain_pinocchio"
    source = HERE / "chain_pinocchio.cpp"
    if exe.exists() and exe.stat().st_mtime > source.stat().st_mtime:
        return exe
    exe.parent.mkdir(exist_ok=True)
    defines = ["-DNDEBUG", "-DBOOST_MPL_LIMIT_LIST_SIZE=30", "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
               "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "-DBOOST_FUSION_INVOKE_MAX_ARITY=12"]
    print("compiling the Pinocchio program (header-only, a few minutes) ...", file=sys.stderr)
    subprocess.run(["g++", *FLAGS, "-std=c++17", *defines, f"-I{prefix / 'include'}", f"-I{prefix / 'include' / 'eigen3'}",
                    str(source), "-o", str(exe)], check=True)
    return exe


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("robots", nargs="*", default=DEFAULT)
    parser.add_argument("--tip", help="URDF tip link (for .urdf robots)")
    parser.add_argument("--no-pinocchio", action="store_true")
    args = parser.parse_args(argv)
    cc = find_compiler()
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    print(f"compiler: {version}; flags: {' '.join(FLAGS)}")
    print()
    print("| robot | joints | gen s | sin | cos | arith | C ns/call | recursive C ns/call | ratio | Pinocchio ns/call | ratio "
          "| inverse_velocity ns | manipulability_gradient ns |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        recursive = work / "chain_recursive"
        subprocess.run([cc, *FLAGS, "-std=c99", str(HERE / "chain_recursive.c"), "-o", str(recursive), "-lm"], check=True)
        pin = None if args.no_pinocchio else pinocchio_program(work)
        for name in args.robots:
            path = Path(name) if Path(name).is_absolute() else ROOT / name
            chain = load_robot(path, tip=args.tip) if path.suffix == ".urdf" else load_robot(path)
            start = time.perf_counter()
            g = generate(chain, langs="c", out=work / chain.name, prefix=f"b_{chain.name}")
            gen_seconds = time.perf_counter() - start
            ops = next(p for p in g.programs if p.name == "kinematics").ops
            chain_file(chain, work / f"{chain.name}.chain")
            data = configs_file(chain.n, work / f"{chain.name}.cfg")
            q, dq, ddq = data[0, :, 0], data[0, :, 1], data[0, :, 2]
            k = reference.chain_kinematics(chain.numeric(), q, dq, ddq)
            expected = np.concatenate([k.T.reshape(-1), k.J.reshape(-1), k.dJ.reshape(-1), k.twist, k.acc])
            exe = work / f"emitted_{chain.name}"
            subprocess.run([cc, *FLAGS, "-std=c99", f"-DPREFIX=b_{chain.name}", f'-DHEADER="b_{chain.name}.h"', f"-DN={chain.n}",
                            f"-I{work / chain.name}", f"-I{HERE}", str(HERE / "chain_emitted.c"),
                            str(work / chain.name / f"b_{chain.name}.c"), "-o", str(exe), "-lm"], check=True)
            ours, inverse_ns, gradient_ns = run([str(exe), str(work / f"{chain.name}.cfg")], chain.n, expected, extra=True)
            loop = run([str(recursive), str(work / f"{chain.name}.chain"), str(work / f"{chain.name}.cfg")], chain.n, expected)
            pin_ns = run([str(pin), str(work / f"{chain.name}.chain"), str(work / f"{chain.name}.cfg")], chain.n, expected) if pin else None
            pin_text = f"{pin_ns:.1f} | {ours / pin_ns:.2f}" if pin_ns else "- | -"
            print(f"| {chain.name} | {chain.n} | {gen_seconds:.2f} | {ops.sin} | {ops.cos} | {ops.arithmetic} | {ours:.1f} | "
                  f"{loop:.1f} | {ours / loop:.2f} | {pin_text} | {inverse_ns:.1f} | {gradient_ns:.1f} |", flush=True)


if __name__ == "__main__":
    main()
