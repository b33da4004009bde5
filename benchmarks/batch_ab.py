"""Single calls and batches of emitted C functions, two generators side by side in one program.

    python benchmarks/batch_ab.py --before /path/to/other/checkout/.venv/bin/python
    python benchmarks/batch_ab.py --before ... --cases links:2:kinematics,robot:examples/robots/panda.toml:jacobian
    python benchmarks/batch_ab.py --before ... --cases robot:path/to/ur5_robot.urdf@tool0:pose   # a URDF's tip after @

Each case is generated twice, by this checkout (``after``) and by the Python of another checkout
(``before``: the interpreter of a virtual environment where that checkout is installed), with prefixes
``before_*`` and ``after_*``, and both are linked into one C program that times them in turn: every repeat
times a single call of each (cycling through 256 configurations in cache), then each batch on m = 1000
(in cache) and, every tenth sample, on m = ``--large`` configurations. Printed: a low quantile of the
samples (``--quantile``, 0.1 by default: other load on the machine only adds time) in ns per call or per
configuration, and the ratio after / before of each (short samples taken in turn keep the ratios
meaningful on a busy machine). Both are compiled with the same compiler and ``--flags``
(``-O2 -march=native`` by default, as ``benchmarks/bench.py``).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

from skelarm_sym.build import find_compiler
from skelarm_sym.generate import generate
from skelarm_sym.models import PlanarArm
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CASES = ("links:2:kinematics,links:2:jacobian,links:6:kinematics,links:6:jacobian,"
                 "robot:examples/robots/ur5.toml:kinematics,robot:examples/robots/ur5.toml:jacobian,"
                 "robot:examples/robots/panda.toml:kinematics,robot:examples/robots/panda.toml:jacobian,"
                 "robot:examples/robots/panda.toml:pose,robot:examples/robots/panda.toml:inverse_velocity")

DRIVER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "before_x.h"
#include "after_x.h"
#define SAMPLES %(samples)d
#define CONFIGS 256
static double now(void) { struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t); return t.tv_sec * 1e9 + t.tv_nsec; }
static int cmp(const void *x, const void *y) { double a = *(const double *)x, b = *(const double *)y; return (a > b) - (a < b); }
static double quantile(double *v, double q) { qsort(v, SAMPLES, sizeof *v, cmp); return v[(int)(q * (SAMPLES - 1))]; }
static double *filled(long count, double low, double high)
{
    double *x = malloc(sizeof(double) * (count ? count : 1));
    long i;
    for (i = 0; i < count; ++i) x[i] = low + (high - low) * (rand() / (double)RAND_MAX);
    return x;
}
int main(int argc, char **argv)
{
    const long large = argc > 1 ? atol(argv[1]) : 100000, small = 1000;
    const double quant = argc > 2 ? atof(argv[2]) : 0.1;
    const long loops = %(loops)d;
    static double t[6][SAMPLES];
    double sink = 0.0;
    long i, r;
%(buffers)s
    for (r = 0; r < SAMPLES; ++r) {
        double t0 = now();
        for (i = 0; i < loops; ++i) { const long k = i %% CONFIGS; before_x_%(f)s(%(single)s); sink += %(first)s[k * %(first_size)d]; }
        t[0][r] = (now() - t0) / loops;
        t0 = now();
        for (i = 0; i < loops; ++i) { const long k = i %% CONFIGS; after_x_%(f)s(%(single)s); sink += %(first)s[k * %(first_size)d]; }
        t[1][r] = (now() - t0) / loops;
        t0 = now();
        before_x_%(f)s_batch(small, %(batch)s);
        t[2][r] = (now() - t0) / small;
        t0 = now();
        after_x_%(f)s_batch(small, %(batch)s);
        t[3][r] = (now() - t0) / small;
        if (r %% 10 == 0) {
            t0 = now();
            before_x_%(f)s_batch(large, %(batch)s);
            t[4][r / 10] = (now() - t0) / large;
            t0 = now();
            after_x_%(f)s_batch(large, %(batch)s);
            t[5][r / 10] = (now() - t0) / large;
        }
        sink += %(first)s[0];
    }
    for (r = (SAMPLES + 9) / 10; r < SAMPLES; ++r) { t[4][r] = 1e300; t[5][r] = 1e300; }  /* past the large samples (r = 0, 10, ...) */
    printf("%%.2f %%.2f %%.2f %%.2f %%.2f %%.2f %%g\n", quantile(t[0], quant), quantile(t[1], quant), quantile(t[2], quant),
           quantile(t[3], quant), quantile(t[4], quant / 10), quantile(t[5], quant / 10), sink * 0.0);
    return 0;
}
"""


def model_of(kind: str, what: str):
    """A planar arm of ``what`` links, or the robot file ``what`` (a URDF's tip after ``@``: ``panda.urdf@panda_hand``)."""
    if kind == "links":
        return PlanarArm(int(what))
    path, _, tip = what.partition("@")
    return load_robot(ROOT / path, tip=tip or None)


def driver(kind: str, what: str, function: str, repeats: int) -> str:
    g = generate(model_of(kind, what), langs="c", out=None, functions=function, prefix="after_x")
    f = g.module.function(function)
    lines, single, batch = [], [], []
    for a in f.inputs:
        if a.is_scalar:
            lines.append(f"    const double {a.name} = 0.01;")
            single.append(a.name)
            batch.append(a.name)
        elif not a.batched:
            low, high = (0.5, 1.5) if a.domain == "positive" else (-0.5, 0.5)
            lines.append(f"    double *{a.name} = filled({a.size}, {low}, {high});")
            single.append(a.name)
            batch.append(a.name)
        else:
            lines.append(f"    double *{a.name} = filled({a.size} * (large > CONFIGS ? large : CONFIGS), -3.14159, 3.14159);")
            single.append(f"{a.name} + k * {a.size}")
            batch.append(a.name)
    for o in f.outputs:
        lines.append(f"    double *{o.name} = filled({o.size} * (large > CONFIGS ? large : CONFIGS), 0.0, 1.0);")
        single.append(f"{o.name} + k * {o.size}")
        batch.append(o.name)
    first = f.outputs[0]
    return DRIVER % {"samples": repeats, "loops": max(200, 20000 // max(1, f.ops.arithmetic // 10 + 1)),
                     "buffers": "\n".join(lines), "f": function, "single": ", ".join(single), "batch": ", ".join(batch),
                     "first": first.name, "first_size": first.size}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="the Python of the other checkout's environment")
    parser.add_argument("--cases", default=DEFAULT_CASES, help="kind:what:function,... (kind links or robot)")
    parser.add_argument("--flags", default="-O2 -march=native")
    parser.add_argument("--large", type=int, default=100000)
    parser.add_argument("--samples", type=int, default=400, help="samples of each timing (the large batch: a tenth)")
    parser.add_argument("--quantile", type=float, default=0.1,
                        help="the quantile of the samples printed (0.1: a busy machine only adds time, so a low "
                             "quantile estimates the time undisturbed; 0.5: the median)")
    args = parser.parse_args()
    cc = find_compiler()
    flags = args.flags.split()
    print(f"compiler {cc}, flags {' '.join(flags)}; ns per call (single) or per configuration (batch); "
          f"quantile {args.quantile} of {args.samples} samples ({args.samples // 10} for the large batch), "
          "before and after timed in turn in one program")
    print()
    print("| case | function | single before | single after | ratio | batch m=1000 before | after | ratio "
          f"| batch m={args.large} before | after | ratio |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for case in args.cases.split(","):
            kind, what, function = case.split(":")
            path, _, tip = what.partition("@")
            folder = work / f"{kind}_{Path(path).stem}_{function}"
            folder.mkdir()
            source = ["--links", what] if kind == "links" else ["--robot", str(ROOT / path)] + (["--tip", tip] if tip else [])
            for label, python in (("before", args.before), ("after", sys.executable)):
                subprocess.run([python, "-m", "skelarm_sym", "generate", *source, "--lang", "c", "--functions", function,
                                "--prefix", f"{label}_x", "--out", str(folder), "--force"], check=True, capture_output=True,
                               cwd=work)  # not this checkout's folder: -m would import its package first
            (folder / "main.c").write_text(driver(kind, what, function, args.samples))
            exe = folder / "main"
            subprocess.run([*cc.split(), "-std=c99", *flags, f"-I{folder}", str(folder / "main.c"), str(folder / "before_x.c"),
                            str(folder / "after_x.c"), "-o", str(exe), "-lm"], check=True)
            out = subprocess.run([str(exe), str(args.large), str(args.quantile)], capture_output=True, text=True, check=True).stdout.split()
            v = [float(x) for x in out[:6]]
            name = f"planar n = {what}" if kind == "links" else Path(path).stem + (f" ({tip})" if tip else "")
            print(f"| {name} | {function} | {v[0]:.1f} | {v[1]:.1f} | {v[1] / v[0]:.2f} | {v[2]:.1f} | {v[3]:.1f} | "
                  f"{v[3] / v[2]:.2f} | {v[4]:.1f} | {v[5]:.1f} | {v[5] / v[4]:.2f} |", flush=True)


if __name__ == "__main__":
    main()
