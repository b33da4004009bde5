"""The emitted C's own sine and cosine (``templates/c/sincos.c.j2``) against libm, and against another checkout's.

    python benchmarks/scalar_trig.py                                   # this checkout's kernel and libm
    python benchmarks/scalar_trig.py --before /path/to/other/.venv/bin/python --angles 3,4,7

A single call computes the sines and cosines of all its angles in one static helper, ``{prefix}_trigK`` (K: the
angles padded to 4, or to a multiple of 8 beyond 4): with the kernel four angles at a time (double code, but where
GCC targets x86-64 glibc with AVX2; ``--flags`` with ``-mavx2`` and without ``-DSKELARM_NO_SIMD`` times libmvec's
loops there instead). For each count of angles this script generates a planar arm
with that many links (its ``position`` has one angle a link), includes the C source in a driver (the helper
is static) and times, in turn, many short samples of 200 calls each (cycling through 256 sets of random
angles in [-pi, pi]): the helper of this checkout (``after``), of another one (``before``, when given: the
interpreter of its environment) and libm's ``sin`` and ``cos`` angle by angle. Printed: a low quantile of the
samples (``--quantile``, 0.1: other load only adds time), in ns per call of all the angles, for each compiler
found (gcc, clang) with ``-O2 -DSKELARM_NO_SIMD`` (``--flags``).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

DRIVER = r"""
#define SAMPLES %(samples)d
#define REPEATS SAMPLES
#include "timing.h"
#include <stdio.h>
%(includes)s
#define USED %(used)d
static void libm_trig(const double *ang, double *cs, double *sn)
{
    int k;
    for (k = 0; k < USED; ++k) {
        cs[k] = cos(ang[k]);
        sn[k] = sin(ang[k]);
    }
}
int main(int argc, char **argv)
{
    static double ang[256][%(width)d], t[3][SAMPLES];
    double cs[%(width)d], sn[%(width)d], sink = 0.0;
    const double quant = argc > 1 ? atof(argv[1]) : 0.1;
    const int loops = 200;
    int i, k, r;
    srand(12345);
    for (i = 0; i < 256; ++i)
        for (k = 0; k < %(width)d; ++k)
            ang[i][k] = k < USED ? -3.14159 + 6.28318 * (rand() / (double)RAND_MAX) : 0.0;
    for (r = 0; r < SAMPLES; ++r) {
        double t0;
%(timed)s
        t0 = now();
        for (i = 0; i < loops; ++i) { libm_trig(ang[i & 255], cs, sn); sink += cs[0] + sn[USED - 1]; }
        t[2][r] = (now() - t0) / loops;
    }
    k = (int)(quant * (SAMPLES - 1));
    for (i = 0; i < 3; ++i) qsort(t[i], SAMPLES, sizeof(double), cmp);
    printf("%%.1f %%.1f %%.1f %%g\n", t[0][k], t[1][k], t[2][k], sink * 0.0);
    return 0;
}
"""

TIMED = r"""        t0 = now();
        for (i = 0; i < loops; ++i) { %(prefix)s_trig%(size)d(ang[i & 255], cs, sn, USED); sink += cs[0] + sn[USED - 1]; }
        t[%(slot)d][r] = (now() - t0) / loops;"""


def trig_size(source: str, prefix: str, used: int) -> int:
    """The size K of the single call's helper ``{prefix}_trigK`` for ``used`` angles (the smallest K >= used)."""
    sizes = sorted(int(k) for k in re.findall(rf"void {prefix}_trig(\d+)\(", source))
    return next(k for k in sizes if k >= used)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", help="the Python of another checkout's environment (its kernel is timed too)")
    parser.add_argument("--angles", default="3,4,7", help="comma-separated counts of angles")
    parser.add_argument("--flags", default="-O2 -DSKELARM_NO_SIMD")
    parser.add_argument("--samples", type=int, default=300)
    parser.add_argument("--quantile", type=float, default=0.1)
    args = parser.parse_args()
    compilers = [c for c in ("gcc", "clang") if shutil.which(c)]
    if not compilers:
        sys.exit("scalar_trig.py: no C compiler (gcc or clang) on PATH")
    generators = ([("before", args.before)] if args.before else []) + [("after", sys.executable)]
    print(f"quantile {args.quantile} of {args.samples} samples, ns per call of all the angles; flags {args.flags}")
    print()
    print("| compiler | angles | " + " | ".join(label for label, _ in generators) + " | libm sin + cos |")
    print("|---|---|" + "---|" * (len(generators) + 1))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for used in [int(x) for x in args.angles.split(",") if x]:
            folder = work / f"n{used}"
            folder.mkdir()
            includes, timed = [], []
            for slot, (label, python) in enumerate(generators):
                prefix = f"{label}_x"
                subprocess.run([python, "-m", "skelarm_sym", "generate", "--links", str(used), "--lang", "c", "--functions",
                                "position", "--prefix", prefix, "--out", str(folder), "--force"],
                               check=True, capture_output=True, cwd=work)
                size = trig_size((folder / f"{prefix}.c").read_text(), prefix, used)
                includes.append(f'#include "{prefix}.c"')
                timed.append(TIMED % {"prefix": prefix, "size": size, "slot": slot})
            width = max(8, -(-used // 8) * 8)
            (folder / "main.c").write_text(DRIVER % {"includes": "\n".join(includes), "samples": args.samples, "used": used,
                                                     "width": width, "timed": "\n".join(timed)})
            for cc in compilers:
                exe = folder / f"main_{cc}"
                subprocess.run([cc, "-std=c99", *args.flags.split(), f"-I{folder}", f"-I{HERE}", str(folder / "main.c"),
                                "-o", str(exe), "-lm"], check=True)
                out = [float(x) for x in subprocess.run([str(exe), str(args.quantile)], capture_output=True, text=True,
                                                        check=True).stdout.split()[:3]]
                own = out[:len(generators)] if args.before else [out[0]]
                print(f"| {cc} | {used} | " + " | ".join(f"{x:.1f}" for x in own) + f" | {out[2]:.1f} |", flush=True)


if __name__ == "__main__":
    main()
