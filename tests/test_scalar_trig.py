"""The scalar path's own sine and cosine (``templates/c/sincos.c.j2``), judged against the C library's.

The emitted double code computes sines and cosines four angles at a time in plain arithmetic, except where
GCC targets x86-64 glibc with AVX2 (there libmvec). A driver includes the generated source (its
static helpers are then visible) and compares the trigonometry helper with libm's ``sin`` and ``cos``
angle by angle: at most 1 ulp for |x| <= 1e5, libm's own values beyond, NaN for non-finite angles, the
sign of zero kept. The reference is the C library, which shares nothing with the kernel."""

import platform
import shutil
import subprocess

import numpy as np
import pytest

from skelarm_sym.generate import generate

COMPILERS = [c for c in ("gcc", "clang") if shutil.which(c)]
needs_cc = pytest.mark.skipif(not COMPILERS, reason="no C compiler (gcc or clang) on PATH")

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "arm.c"
int main(int argc, char **argv)
{
    static double ang[1 << 12], cs[1 << 12], sn[1 << 12], cs2[1 << 12], sn2[1 << 12];
    FILE *in = fopen(argv[1], "rb"), *out = fopen(argv[2], "wb");
    size_t n, k;
    (void)argc;
    printf("%d\n", ARM_OWN_TRIG);
    while ((n = fread(ang, sizeof(double), 4096, in)) > 0) {
        for (k = n; k < 4096; ++k) {
            ang[k] = 0.0;
        }
        for (k = 0; k < n; k += 4) {
            arm_trig4(ang + k, cs + k, sn + k, n - k < 4 ? (int)(n - k) : 4);
        }
        for (k = 0; k < n; k += 2) { /* the same angles through the tail kernel, two at a time */
            arm_trig4(ang + k, cs2 + k, sn2 + k, 2);
        }
        for (k = 0; k < n; ++k) {
            double libm[2];
            libm[0] = sin(ang[k]);
            libm[1] = cos(ang[k]);
            fwrite(&sn[k], sizeof(double), 1, out);
            fwrite(&cs[k], sizeof(double), 1, out);
            fwrite(libm, sizeof(double), 2, out);
            fwrite(&sn2[k], sizeof(double), 1, out);
            fwrite(&cs2[k], sizeof(double), 1, out);
        }
    }
    fclose(in);
    fclose(out);
    return 0;
}
"""


def _angles() -> np.ndarray:
    """Random angles at several scales, the neighbourhoods of multiples of pi/2 (where the reduction
    cancels), the 1e5 boundary, tiny and subnormal angles, signed zeros and non-finite values."""
    rng = np.random.default_rng(7)
    parts = [rng.uniform(-s, s, 200_000) for s in (0.8, 3.2, 7.0, 60.0, 1e3, 1e5)]
    multiples = np.arange(-63_000, 63_000, 7) * (np.pi / 2)  # up to 1e5
    near = np.concatenate([np.nextafter(multiples, np.inf), multiples, np.nextafter(multiples, -np.inf)])
    edge = [1e5, -1e5, np.nextafter(1e5, np.inf), np.nextafter(-1e5, -np.inf), 1e6, -3e7, 1e300, -1e300,
            0.0, -0.0, 5e-324, -5e-324, 1e-310, 2.2e-308, 1e-20, -1e-8, np.pi / 4, -np.pi / 4,
            np.inf, -np.inf, np.nan]
    return np.concatenate(parts + [near, np.array(edge)])


def _run(tmp_path, compiler: str, flags: tuple[str, ...], angles: np.ndarray) -> tuple[bool, np.ndarray, np.ndarray, np.ndarray]:
    """Whether the own kernel was compiled in, (sin, cos) from the emitted helper built with ``flags``,
    (libm sin, libm cos), and (sin, cos) from the helper asked for two angles at a time (the tail kernel),
    for ``angles``."""
    folder = tmp_path / f"{compiler}{''.join(flags)}".replace("-", "_").replace("=", "_")
    folder.mkdir()
    # a function of at most 4 angles has the helper of a single call, 4 wide (backends/c/backend.py)
    generate(3, out=folder, langs="c", prefix="arm", functions="position")
    (folder / "driver.c").write_text(DRIVER)
    exe = folder / "driver"
    subprocess.run([compiler, "-std=c99", *flags, "-I", str(folder), str(folder / "driver.c"), "-o", str(exe), "-lm"],
                   check=True, capture_output=True, text=True)
    angles.astype(np.float64).tofile(folder / "in.bin")
    run = subprocess.run([str(exe), str(folder / "in.bin"), str(folder / "out.bin")], check=True,
                         capture_output=True, text=True)
    out = np.fromfile(folder / "out.bin", dtype=np.float64).reshape(-1, 6)
    return run.stdout.strip() == "1", out[:, :2], out[:, 2:4], out[:, 4:]


def _ulps(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    spacing = np.spacing(np.maximum(np.abs(want), np.finfo(np.float64).tiny))
    return np.abs(got - want) / spacing


@needs_cc
@pytest.mark.parametrize("compiler", COMPILERS)
def test_own_sine_and_cosine_within_one_ulp_of_libm(tmp_path, compiler):
    angles = _angles()
    used, own, libm, tail = _run(tmp_path, compiler, ("-O2", "-DSKELARM_NO_SIMD"), angles)
    assert used  # x86-64 gcc and clang evaluate in double without fast-math: the kernel is compiled in
    # a single call's tail of one or two angles goes through the two-lane kernel, a batch's through the four-lane
    # one: the same bits, so that single calls and batches agree
    assert np.array_equal(tail, own, equal_nan=True)
    finite = np.isfinite(angles)
    inside = finite & (np.abs(angles) <= 1e5)
    assert _ulps(own[inside], libm[inside]).max() <= 1.0
    beyond = finite & ~inside
    assert np.array_equal(own[beyond], libm[beyond])  # libm's own values past 1e5
    assert np.isnan(own[~finite]).all()
    zeros = angles == 0.0
    assert np.array_equal(np.signbit(own[zeros, 0]), np.signbit(angles[zeros]))  # sin(-0) = -0
    assert (own[zeros, 1] == 1.0).all()
    assert np.array_equal(own[np.abs(angles) < 1e-300, 0], angles[np.abs(angles) < 1e-300])  # sin x = x, exactly
    # every quadrant's sign and swap: the values themselves, not only their distance in ulps
    assert np.abs(own[inside] - libm[inside]).max() <= 2.3e-16


@needs_cc
@pytest.mark.parametrize("flags", [("-O2", "-DSKELARM_NO_SIMD", "-DSKELARM_LIBM_TRIG"),
                                   ("-O2", "-DSKELARM_NO_SIMD", "-ffast-math")])
def test_libm_where_asked_or_where_the_kernel_cannot_run(tmp_path, flags):
    """``-DSKELARM_LIBM_TRIG`` chooses libm; ``-ffast-math`` would fold the kernel's rounding and its
    compensated reduction, so there it is libm too: the values equal libm's bit for bit."""
    angles = _angles()[::7]
    used, own, libm, _ = _run(tmp_path, COMPILERS[0], flags, angles)
    assert not used
    finite = np.isfinite(angles)
    assert np.array_equal(own[finite], libm[finite])


GCC_X86_64_GLIBC = (shutil.which("gcc") is not None and platform.machine() == "x86_64"
                    and platform.libc_ver()[0] == "glibc")


@pytest.mark.skipif(not GCC_X86_64_GLIBC, reason="GCC's vector math is the x86-64 glibc build's")
@pytest.mark.parametrize("flags, own", [(("-O2",), 1), (("-O2", "-mavx2"), 0), (("-O2", "-mavx2", "-DSKELARM_NO_SIMD"), 1),
                                        (("-O3", "-march=x86-64-v3"), 0)])
def test_gcc_takes_the_kernel_on_plain_x86_64_and_libmvec_with_avx2(tmp_path, flags, own):
    """Where GCC targets plain x86-64 (SSE2) the vector build's single calls and batches take the kernel
    (libmvec's two-wide routines cost more: benchmarks/batch_ab.py); with AVX2 libmvec's wider ones, which
    are faster there. Read from the preprocessor (an AVX2 binary need not run on this machine)."""
    generate(3, out=tmp_path, langs="c", prefix="arm", functions="position")
    macros = subprocess.run(["gcc", "-std=c99", *flags, "-dM", "-E", str(tmp_path / "arm.c")], check=True,
                            capture_output=True, text=True).stdout
    assert f"#define ARM_OWN_TRIG {own}" in macros.splitlines()
    assert "#define ARM_VECTOR_MATH 1" in macros.splitlines() or "-DSKELARM_NO_SIMD" in flags
