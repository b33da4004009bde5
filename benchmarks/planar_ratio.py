"""Planar ``kinematics`` against the hand-written recursion, two generators side by side in one program.

    python benchmarks/planar_ratio.py --before /path/to/other/checkout/.venv/bin/python --links 24,48

``benchmarks/bench.py`` reports the emitted single call over ``benchmarks/recursive.c`` (one sincos per
link) as medians of a few repeats, which a busy machine moves by tens of percent. Here the emitted code of
this checkout (``after``), that of another (``before``: the interpreter of its environment) and the
recursion are linked into one program and timed in turn, many short samples each (200 calls, cycling
through 256 configurations in cache); printed: a low quantile of each (``--quantile``, 0.1: other load
only adds time) in ns per call, and each emitted code's ratio to the recursion. ``-O2 -march=native``
like bench.py.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

from skelarm_sym.build import find_compiler

HERE = Path(__file__).resolve().parent

DRIVER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "before_x.h"
#include "after_x.h"
#define SAMPLES %(samples)d
void recursive_kinematics(const double *q, const double *dq, const double *ddq, const double *l, double *p, double *J,
                          double *H, double *v, double *a);
static double now(void) { struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t); return t.tv_sec * 1e9 + t.tv_nsec; }
static int cmp(const void *x, const void *y) { double a = *(const double *)x, b = *(const double *)y; return (a > b) - (a < b); }
int main(int argc, char **argv)
{
    static double q[256][N], dq[256][N], ddq[256][N], l[N], p[2], J[2 * N], H[2 * N], v[2], a[2];
    static double t[3][SAMPLES];
    const double quant = argc > 1 ? atof(argv[1]) : 0.1;
    double sink = 0.0;
    int i, k, r;
    const int loops = 200;
    srand(12345);
    for (i = 0; i < 256; ++i)
        for (k = 0; k < N; ++k) {
            q[i][k] = -3.14159 + 6.28318 * (rand() / (double)RAND_MAX);
            dq[i][k] = -3.14159 + 6.28318 * (rand() / (double)RAND_MAX);
            ddq[i][k] = -3.14159 + 6.28318 * (rand() / (double)RAND_MAX);
        }
    for (k = 0; k < N; ++k) l[k] = 0.5 + rand() / (double)RAND_MAX;
    for (r = 0; r < SAMPLES; ++r) {
        double t0 = now();
        for (i = 0; i < loops; ++i) { before_x_kinematics(q[i & 255], dq[i & 255], ddq[i & 255], l, p, J, H, v, a); sink += a[0]; }
        t[0][r] = (now() - t0) / loops;
        t0 = now();
        for (i = 0; i < loops; ++i) { after_x_kinematics(q[i & 255], dq[i & 255], ddq[i & 255], l, p, J, H, v, a); sink += a[0]; }
        t[1][r] = (now() - t0) / loops;
        t0 = now();
        for (i = 0; i < loops; ++i) { recursive_kinematics(q[i & 255], dq[i & 255], ddq[i & 255], l, p, J, H, v, a); sink += a[0]; }
        t[2][r] = (now() - t0) / loops;
    }
    for (k = 0; k < 3; ++k) qsort(t[k], SAMPLES, sizeof(double), cmp);
    k = (int)(quant * (SAMPLES - 1));
    printf("%%.1f %%.1f %%.1f %%g\n", t[0][k], t[1][k], t[2][k], sink * 0.0);
    return 0;
}
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="the Python of the other checkout's environment")
    parser.add_argument("--links", default="6,24,48")
    parser.add_argument("--flags", default="-O2 -march=native")
    parser.add_argument("--samples", type=int, default=300)
    parser.add_argument("--quantile", type=float, default=0.1)
    args = parser.parse_args()
    cc = find_compiler()
    print(f"quantile {args.quantile} of {args.samples} samples, ns per call; flags {args.flags}")
    print()
    print("| n | recursion | before | ratio | after | ratio |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for n in [int(x) for x in args.links.split(",") if x]:
            folder = work / f"n{n}"
            folder.mkdir()
            for label, python in (("before", args.before), ("after", sys.executable)):
                subprocess.run([python, "-m", "skelarm_sym", "generate", "--links", str(n), "--lang", "c", "--functions",
                                "kinematics", "--prefix", f"{label}_x", "--out", str(folder), "--force"],
                               check=True, capture_output=True, cwd=work)
            (folder / "main.c").write_text(DRIVER % {"samples": args.samples})
            exe = folder / "main"
            subprocess.run([*cc.split(), "-std=c99", *args.flags.split(), f"-DN={n}", f"-I{folder}", str(folder / "main.c"),
                            str(folder / "before_x.c"), str(folder / "after_x.c"), str(HERE / "recursive.c"), "-o", str(exe),
                            "-lm"], check=True)
            out = subprocess.run([str(exe), str(args.quantile)], capture_output=True, text=True, check=True).stdout.split()
            before, after, recursion = (float(x) for x in out[:3])
            print(f"| {n} | {recursion:.1f} | {before:.1f} | {before / recursion:.2f} | {after:.1f} | {after / recursion:.2f} |",
                  flush=True)


if __name__ == "__main__":
    main()
