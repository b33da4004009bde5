"""Benchmark table for skelarm-sym: generation cost, operation counts and run time of emitted code.

Run from the repository root after installing the package:

    python benchmarks/bench.py                      # n = 2, 6, 24, 48, 96 (and generation at 128, 256)
    python benchmarks/bench.py --links 2,6 --gen-links 128

Columns: n; wall seconds and peak MB of the whole ``skelarm-sym generate --links n`` command
(C and Python); kinematics operation counts (sin, cos, add/sub/mul/neg); emitted C
``{prefix}_kinematics`` ns per call; hand-written recursive C (benchmarks/recursive.c, one
sincos per link) ns per call; their ratio; emitted C batch ns per configuration (m = 100 000);
emitted NumPy ns per configuration (m = 100 000); recursive NumPy reference ns per configuration;
where CasADi and SymForce are installed (``pip install '.[bench]'``; SymForce's C++ also needs
Eigen's headers, Debian ``libeigen3-dev``), their generated code for the same outputs
(benchmarks/others.py), checked against the reference, then timed in the same harness:
operation count (CasADi: add, sub, mul, neg, sin, cos instructions; SymForce: its own
"Total ops") and ns per call. SymForce only up to ``--symforce-links`` (default 48): its
generation takes minutes beyond.
A second table times the batch functions against single calls, for batches in cache
(m = 1000) and out of it (m = 100 000; benchmarks/batch.c).
Inputs uniform in [-pi, pi] from fixed seeds; medians of several repeats. Both C codes are
compiled with the same compiler and flags (printed), ``-O2 -march=native`` by default.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from skelarm_sym import reference

sys.path.insert(0, str(Path(__file__).resolve().parent))
import others  # noqa: E402 - beside this script
from skelarm_sym.build import find_compiler, load_python
from skelarm_sym.generate import generate

HERE = Path(__file__).resolve().parent


def generation_cost(n: int, work: Path) -> tuple[float, float]:
    """Wall seconds and peak resident MB of the whole generate command in a fresh process."""
    code = (
        "import sys, time\n"
        "t = time.perf_counter()\n"
        "from skelarm_sym.cli import main\n"
        "rc = main(['generate', '--links', sys.argv[1], '--out', sys.argv[2]])\n"
        "hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')][0]\n"
        "sys.stderr.write(f'{time.perf_counter() - t} {hwm}\\n')\n"
    )
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-c", code, str(n), str(work / f"gen{n}")], capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    _, rss_kb = result.stderr.split()
    return wall, float(rss_kb) / 1024.0


def c_timings(n: int, work: Path, cc: str, flags: list[str], other: tuple[str, list[Path], list[str]] | None = None
              ) -> tuple[float, float, float, float]:
    """(emitted ns/call, recursive ns/call, emitted batch ns/config, other tool's ns/call or nan).

    ``other``: (function name, its source or object files, extra link flags), timed in the same harness.
    """
    out = work / f"c{n}"
    generate(n, langs="c", out=out)
    exe = out / "bench"
    cmd = [*cc.split(), *flags, f"-DN={n}", f"-DPREFIX=arm{n}", f'-DHEADER="arm{n}.h"', "-DLARG=l,", f"-I{out}"]
    files = [str(HERE / "harness.c"), str(out / f"arm{n}.c"), str(HERE / "recursive.c")]
    link = ["-lm"]
    if other is not None:
        name, extra_files, extra_link = other
        cmd.append(f"-DOTHER={name}")
        files += [str(f) for f in extra_files]
        link = extra_link + link
    subprocess.run([*cmd, *files, "-o", str(exe), *link], check=True)
    values = subprocess.run([str(exe), "100000"], capture_output=True, text=True, check=True).stdout.split()
    other_ns = float(values[3]) if other is not None else float("nan")
    return float(values[0]), float(values[1]), float(values[2]), other_ns


def batch_timings(n: int, work: Path, cc: str, flags: list[str], function: str) -> tuple[float, float, float]:
    """(single ns/call, batch ns/config at m = 1000, batch ns/config at m = 100 000) of kinematics or jacobian."""
    out = work / f"c{n}"
    generate(n, langs="c", out=out)
    exe = out / f"batch_{function}"
    define = ["-DJACOBIAN"] if function == "jacobian" else []
    cmd = [*cc.split(), *flags, *define, f"-DN={n}", f"-DPREFIX=arm{n}", f'-DHEADER="arm{n}.h"', f"-I{out}",
           str(HERE / "batch.c"), str(out / f"arm{n}.c"), "-o", str(exe), "-lm"]
    subprocess.run(cmd, check=True)
    values = subprocess.run([str(exe), "100000"], capture_output=True, text=True, check=True).stdout.split()
    return float(values[0]), float(values[1]), float(values[2])


def numpy_timings(n: int, m: int = 100_000, repeats: int = 5) -> tuple[float, float]:
    """(emitted NumPy ns/config, reference ns/config) for a batch of m."""
    g = generate(n, langs="python", out=None)
    module = load_python(g.sources[f"arm{n}.py"], f"arm{n}")
    rng = np.random.default_rng(n)
    q, dq, ddq = rng.uniform(-np.pi, np.pi, (3, m, n))
    l = rng.uniform(0.5, 1.5, n)

    def best(fn):
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t)
        return statistics.median(times) / m * 1e9

    emitted = best(lambda: module.kinematics(q, dq, ddq, l))
    ref = best(lambda: reference.kinematics(q, dq, ddq, l)) if n <= 48 else float("nan")
    return emitted, ref


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--links", default="2,6,24,48,96")
    parser.add_argument("--gen-links", default="128,256", help="extra n for which only generation is measured")
    parser.add_argument("--flags", default="-O2 -march=native")
    parser.add_argument("--batch-links", default="2,6", help="n for the batch table")
    parser.add_argument("--symforce-links", type=int, default=48, help="largest n for SymForce (its generation grows fast)")
    args = parser.parse_args()
    cc = find_compiler()
    flags = args.flags.split()
    version = subprocess.run([*cc.split(), "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores; compiler: {version}; flags: {' '.join(flags)}; numpy {np.__version__}")
    print()
    header = (
        "| n | gen s | gen MB | sin | cos | arith | C ns/call | recursive C ns/call | ratio | C batch ns/cfg "
        "| NumPy ns/cfg | reference ns/cfg | CasADi ops | CasADi ns/call | SymForce ops | SymForce ns/call |"
    )
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        links = [int(x) for x in args.links.split(",") if x]
        gen_only = [int(x) for x in args.gen_links.split(",") if x]
        for n in links + gen_only:
            wall, mb = generation_cost(n, work)
            ops = next(p for p in generate(n, langs="c", out=None).programs if p.name == "kinematics").ops
            if n in links:
                single, rec, batch, _ = c_timings(n, work, cc, flags)
                npy, ref = numpy_timings(n)
                row = [f"{single:.1f}", f"{rec:.1f}", f"{single / rec:.2f}", f"{batch:.1f}", f"{npy:.0f}", f"{ref:.0f}"]
                casadi = others.casadi_kinematics(n, work / f"casadi{n}")
                if casadi:
                    cas = c_timings(n, work, cc, flags, ("casadi_kinematics", [casadi[0]], []))[3]
                    row += [str(sum(casadi[1].values())), f"{cas:.1f}"]
                else:
                    row += ["-", "-"]
                symforce = others.symforce_kinematics(n, work / f"symforce{n}", flags=tuple(flags)) if n <= args.symforce_links else None
                if symforce:
                    sym = c_timings(n, work, cc, flags, ("symforce_kinematics", [symforce[0]], ["-lstdc++"]))[3]
                    row += [str(symforce[1]["ops"]), f"{sym:.1f}"]
                else:
                    row += ["-", "-"]
            else:
                row = ["-"] * 10
            print(f"| {n} | {wall:.2f} | {mb:.0f} | {ops.sin} | {ops.cos} | {ops.arithmetic} | " + " | ".join(row) + " |", flush=True)
        print()
        print("| n | function | single ns/call | batch ns/cfg, m = 1000 | ratio | batch ns/cfg, m = 100 000 | ratio |")
        print("|---|---|---|---|---|---|---|")
        for n in [int(x) for x in args.batch_links.split(",") if x]:
            for function in ("kinematics", "jacobian"):
                single, small, large = batch_timings(n, work, cc, flags, function)
                print(f"| {n} | {function} | {single:.1f} | {small:.1f} | {small / single:.2f} | {large:.1f} | {large / single:.2f} |", flush=True)


if __name__ == "__main__":
    main()
