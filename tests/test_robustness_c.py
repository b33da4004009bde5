"""Numerical robustness of the emitted C (issue 13): trigonometry, floating-point traps, fast-math,
the contracts the header states. Values are judged against NumPy, never against the generator."""

import math
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym.build import STRICT_FLAGS, compile_arm
from skelarm_sym.generate import generate

COMPILERS = [c for c in ("gcc", "clang") if shutil.which(c)]
needs_cc = pytest.mark.skipif(not COMPILERS, reason="no C compiler (gcc or clang) on PATH")


def ulps(got, want, dtype):
    """Distance of ``got`` from ``want`` in units of the last place of ``want`` (at least of 1e-300/tiny)."""
    got = np.asarray(got, dtype=np.float64)
    want = np.asarray(want, dtype=np.float64)
    spacing = np.spacing(np.maximum(np.abs(want), np.finfo(dtype).tiny).astype(dtype)).astype(np.float64)
    return np.abs(got - want) / spacing


@needs_cc
@pytest.mark.parametrize("precision, big", [("double", 1e8), ("float", 1e4)])
@pytest.mark.parametrize("n", [1, 2, pytest.param(3, marks=pytest.mark.slow), pytest.param(6, marks=pytest.mark.slow)])
def test_sines_and_cosines_match_libm_and_batches_bit_for_bit(precision, big, n):
    """With q = (a, 0, ..., 0) and lengths 1 the last Jacobian column is (-sin a, cos a) exactly."""
    dtype = np.float64 if precision == "double" else np.float32
    g = generate(n, out=None, langs="c", precision=precision, lengths=(1.0,) * n, functions="jacobian,kinematics")
    rng = np.random.default_rng(n)
    a = np.concatenate([rng.uniform(-big, big, 61), rng.uniform(-200, 200, 60), [100.0, -100.0, big, -big, 1e3]])
    a = a.astype(dtype).astype(np.float64)  # exactly representable in the precision
    q = np.zeros((len(a), n))
    q[:, 0] = a
    want_sin = np.sin(a).astype(dtype)  # float64 libm, rounded: a correctly rounded float reference
    want_cos = np.cos(a).astype(dtype)
    dq = rng.uniform(-1, 1, q.shape)
    for flags in (("-O2",), ("-O2", "-march=native"), ("-O0",), ("-O2", "-DSKELARM_NO_SIMD")):
        arm = compile_arm(g, flags=flags)
        J = arm.jacobian(q)  # m = 125: vectorised blocks and a short last block
        single = np.array([arm.jacobian(row) for row in q])
        assert np.array_equal(J, single), f"{flags}: a single call differs from its batch"
        assert ulps(-J[:, 0, n - 1], want_sin, dtype).max() <= 4, flags
        assert ulps(J[:, 1, n - 1], want_cos, dtype).max() <= 4, flags
        both = arm.kinematics(q, dq, dq)
        for k, row in enumerate(q[:7]):
            for out_batch, out_single in zip(both, arm.kinematics(row, dq[k], dq[k])):
                assert np.array_equal(out_batch[k], out_single), flags


def _driver(folder: Path, prefix: str, body: str, flags=("-O0",), compiler="gcc", extra_c=()):
    """Compile ``body`` (statements of main, with the header included) with the generated C and run it."""
    (folder / "main.c").write_text(
        "#define _GNU_SOURCE\n#include <fenv.h>\n#include <math.h>\n#include <stdio.h>\n"
        f'#include "{prefix}.h"\nint main(void)\n{{\n{body}\n    return 0;\n}}\n'
    )
    exe = folder / "main"
    cmd = [compiler, "-std=gnu99", *flags, "-o", str(exe), str(folder / "main.c"), str(folder / f"{prefix}.c"), *extra_c, "-lm"]
    result = subprocess.run(cmd, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60)
    return run


def _numbers(text: str) -> dict[str, np.ndarray]:
    out = {}
    for line in text.splitlines():
        name, *values = line.split()
        out[name] = np.array([float(v) for v in values])
    return out


def _print(name: str, array: str, size: int) -> str:
    fmt = " ".join(["%.17g"] * size)
    args = ", ".join(f"(double){array}[{k}]" for k in range(size))
    return f'    printf("{name} {fmt}\\n", {args});\n'


fe_available = pytest.mark.skipif(
    not sys.platform.startswith("linux") or not shutil.which("gcc"), reason="feenableexcept needs glibc and gcc"
)


TRAP_MAIN = r"""
#define _GNU_SOURCE
#include <fenv.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "arm.h"
int main(int argc, char **argv)
{
    double q[1], l[1] = {1.0}, p[2];
    (void)argc;
    q[0] = strtod(argv[1], NULL);
    feenableexcept(!strcmp(argv[2], "overflow") ? FE_OVERFLOW : !strcmp(argv[2], "invalid") ? FE_INVALID
                   : FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW);
    arm_position(q, l, p);
    printf("%.17g %.17g\n", p[0], p[1]);
    return 0;
}
"""


@fe_available
@pytest.mark.parametrize("flags", [("-O2",), ("-O2", "-DSKELARM_NO_SIMD")])
def test_the_own_kernel_traps_only_where_the_header_says(tmp_path, flags):
    """Traps on (feenableexcept): the own sine/cosine kernel (GCC's plain x86-64 build and -DSKELARM_NO_SIMD)
    raises nothing for angles up to about 1e39, nor for a NaN angle (NaN out: its fallback compares quietly);
    FE_OVERFLOW beyond, and libm's FE_INVALID for an infinite angle, as the header states."""
    generate(1, out=tmp_path, langs="c", prefix="arm", functions="position")
    header = " ".join((tmp_path / "arm.h").read_text().replace("*", " ").split())
    assert "the own kernel FE_OVERFLOW above about 1e39 and FE_INVALID above about 1e119" in header
    (tmp_path / "main.c").write_text(TRAP_MAIN)
    exe = tmp_path / "main"
    subprocess.run(["gcc", "-std=c99", *flags, "-I", str(tmp_path), str(tmp_path / "main.c"), str(tmp_path / "arm.c"),
                    "-o", str(exe), "-lm"], check=True, capture_output=True, text=True)

    def run(angle: str, traps: str) -> subprocess.CompletedProcess:
        return subprocess.run([str(exe), angle, traps], capture_output=True, text=True, timeout=60)

    for angle in ("0.7", "-3e4", "1e5", "100001", "1e20", "1e36", "-1e36"):
        done = run(angle, "all")
        assert done.returncode == 0, (angle, done.returncode)
        np.testing.assert_allclose([float(x) for x in done.stdout.split()],
                                   [math.cos(float(angle)), math.sin(float(angle))], rtol=0, atol=1e-15)
    done = run("nan", "all")
    assert done.returncode == 0 and all(math.isnan(float(x)) for x in done.stdout.split()), done
    assert run("1e42", "overflow").returncode == -signal.SIGFPE
    assert run("inf", "invalid").returncode == -signal.SIGFPE


@fe_available
@pytest.mark.parametrize("precision", ["double", "float"])
@pytest.mark.parametrize("opt", ["-O0", "-O2"])
def test_no_division_by_zero_at_singular_poses_and_zero_lengths(tmp_path, precision, opt):
    """Traps on: the stretched pose, the folded pose and an arm of length 0 must not raise
    FE_DIVBYZERO or FE_INVALID, and give NumPy's pinv results (0 rates and w = 0 for length 0)."""
    n = 3
    generate(n, out=tmp_path, langs="c", precision=precision, prefix="arm",
             functions="inverse_velocity,inverse_velocity3,manipulability,ik_step")  # the functions the driver calls
    T = "double" if precision == "double" else "float"
    poses = {"stretched": (0.0, 0.0, 0.0), "folded": (0.3, np.pi, 0.0), "regular": (0.3, 0.9, -0.5)}
    lengths = {"unit": (1.0, 1.0, 1.0), "zero": (0.0, 0.0, 0.0), "tail0": (1.0, 0.0, 0.0)}
    v, twist = (0.3, -0.2), (0.1, 0.2, 0.3)
    body = f"    {T} dq[3], w[1], qn[3];\n    feenableexcept(FE_DIVBYZERO | FE_INVALID);\n"
    for pname, q in poses.items():
        for lname, l in lengths.items():
            tag = f"{pname}_{lname}"
            body += "    {\n"
            body += f"        const {T} q[3] = {{{', '.join(repr(float(x)) for x in q)}}}, l[3] = {{{', '.join(map(repr, l))}}};\n"
            body += f"        const {T} v[2] = {{{v[0]}, {v[1]}}}, tw[3] = {{{twist[0]}, {twist[1]}, {twist[2]}}}, target[2] = {{0.0, 0.0}};\n"
            body += "        arm_inverse_velocity(q, v, l, 0, dq);\n" + _print(f"iv_{tag}", "dq", 3)
            body += "        arm_inverse_velocity3(q, tw, l, 0, dq);\n" + _print(f"iv3_{tag}", "dq", 3)
            body += "        arm_manipulability(q, l, w);\n" + _print(f"w_{tag}", "w", 1)
            body += "        arm_ik_step(q, target, l, 0, qn);\n" + _print(f"step_{tag}", "qn", 3)
            body += "    }\n"
    run = _driver(tmp_path, "arm", body, flags=(opt,))
    assert run.returncode == 0, f"trapped (signal {-run.returncode}): {run.stderr}"
    got = _numbers(run.stdout)
    tol = 1e-9 if precision == "double" else 1e-3
    for pname, q in poses.items():
        for lname, l in lengths.items():
            tag = f"{pname}_{lname}"
            theta = np.cumsum(q)
            J = np.array([[-np.sum((l * np.sin(theta))[i:]) for i in range(n)], [np.sum((l * np.cos(theta))[i:]) for i in range(n)]])
            J3 = np.vstack([J, np.ones(n)])
            np.testing.assert_allclose(got[f"iv_{tag}"], np.linalg.pinv(J, rcond=1e-6) @ v, atol=tol, err_msg=tag)
            np.testing.assert_allclose(got[f"iv3_{tag}"], np.linalg.pinv(J3, rcond=1e-6) @ twist, atol=tol, err_msg=tag)
            w = np.prod(np.linalg.svd(J, compute_uv=False))  # sqrt(det(J J^T)) without squaring
            np.testing.assert_allclose(got[f"w_{tag}"], [w], atol=tol, err_msg=tag)
            assert np.all(np.isfinite(got[f"step_{tag}"])), tag
    assert np.array_equal(got["iv_regular_zero"], np.zeros(3)) and got["w_stretched_zero"][0] == 0.0


@pytest.mark.parametrize("precision", ["double", "float"])
def test_ik_from_the_stretched_pose_reaches_targets_behind_and_in_front(precision):
    """q = 0 is singular and, for targets on the x axis, a stationary point of the error: the damped
    step is zero. Reachable targets must still converge (C and NumPy alike); unreachable ones stall."""
    from skelarm_sym.build import load_python

    g = generate(2, out=None, precision=precision, functions="ik_solve")
    impls = {"C": compile_arm(g), "NumPy": load_python(g.sources["arm2.py"], "arm2")}
    l = np.ones(2)
    for target in [(0.0, 0.0), (-1.0, 0.0), (0.5, 0.0), (-2.0, 0.0), (1.999, 0.0), (-0.3, 0.0)]:
        for name, impl in impls.items():
            result = impl.ik_solve(np.zeros(2), np.array(target), l, 0.0)
            assert result.status == "converged", (name, target, result)
            theta = np.cumsum(result.q)
            reach = np.array([np.sum(l * np.cos(theta)), np.sum(l * np.sin(theta))])
            assert np.linalg.norm(reach - target) <= (1e-9 if precision == "double" else 1e-4) * l.sum(), (name, target)  # default tol x reach
    for target, closest in [((3.0, 0.0), 1.0), ((-3.0, 0.0), 1.0)]:  # unreachable: the closest reach, then stalled
        for name, impl in impls.items():
            result = impl.ik_solve(np.zeros(2), np.array(target), l, 0.0)
            assert result.status == "stalled" and abs(result.error - closest) < 1e-4, (name, target, result)


@needs_cc
@pytest.mark.parametrize("compiler", COMPILERS)
def test_ik_solve_accepts_null_outputs_and_keeps_nan_checks_under_fast_math(tmp_path, compiler):
    generate(2, out=tmp_path, langs="c", prefix="arm", functions="ik_solve")  # the one function the driver calls
    body = """
    double q[2], err = -1.0;
    const double zero[2] = {0.0, 0.0}, l[2] = {1.0, 1.0}, target[2] = {-1.0, 0.0};
    volatile double nan_ = 0.0;
    double bad[2], bad_l[2] = {1.0, 1.0};
    int it = -1, st;
    nan_ = nan_ / nan_;
    bad[0] = nan_; bad[1] = 0.0;
    st = arm_ik_solve(zero, target, l, 0.0, 1e-9, 100, q, NULL, NULL);
    printf("null %d %.17g %.17g\\n", st, q[0], q[1]);
    st = arm_ik_solve(zero, target, l, 0.0, 1e-9, 100, q, &err, NULL);
    printf("null_it %d %.17g\\n", st, err);
    st = arm_ik_solve(zero, target, l, 0.0, 1e-9, 100, q, NULL, &it);
    printf("null_err %d %d\\n", st, it);
    printf("nan_q0 %d\\n", arm_ik_solve(bad, target, l, 0.0, 1e-9, 100, q, NULL, NULL));
    printf("nan_target %d\\n", arm_ik_solve(zero, bad, l, 0.0, 1e-9, 100, q, NULL, NULL));
    bad_l[1] = nan_;
    printf("nan_l %d\\n", arm_ik_solve(zero, target, bad_l, 0.0, 1e-9, 100, q, NULL, NULL));
    printf("nan_lambda %d\\n", arm_ik_solve(zero, target, l, nan_, 1e-9, 100, q, NULL, NULL));
    printf("nan_tol %d\\n", arm_ik_solve(zero, target, l, 0.0, nan_, 100, q, NULL, NULL));
    q[0] = 0.0; q[1] = 0.0;
    printf("inplace %d\\n", arm_ik_solve(q, target, l, 0.0, 1e-9, 100, q, NULL, NULL));
    """
    # -ffinite-math-only alone (no __FAST_MATH__) folded isfinite while the bit tests waited for __FAST_MATH__: a NaN
    # q0 came back "converged"; clang's -fno-honor-nans sets no macro at all
    finite_only = [("-O2", "-ffinite-math-only")] + ([("-O2", "-fno-honor-nans", "-fno-honor-infinities")]
                                                     if compiler == "clang" else [])
    for flags in (("-O2",), ("-O2", "-ffast-math"), ("-O0",), *finite_only):
        run = _driver(tmp_path, "arm", body, flags=flags, compiler=compiler)
        assert run.returncode == 0, (flags, run.returncode, run.stderr)
        got = {line.split()[0]: line.split()[1:] for line in run.stdout.splitlines()}
        assert got["null"][0] == "0" and got["null_it"][0] == "0" and got["null_err"][0] == "0", (flags, got)
        theta = np.cumsum([float(x) for x in got["null"][1:]])
        assert abs(np.cos(theta).sum() + 1.0) < 1e-8 and abs(np.sin(theta).sum()) < 1e-8
        assert float(got["null_it"][1]) <= 1e-9 and int(got["null_err"][1]) > 0
        for key in ("nan_q0", "nan_target", "nan_l", "nan_lambda", "nan_tol"):
            assert got[key] == ["3"], (flags, key, got[key])  # ARM_IK_INVALID
        assert got["inplace"] == ["0"]


@needs_cc
@pytest.mark.parametrize("compiler", [pytest.param(c, marks=pytest.mark.slow if c == "clang" else ()) for c in COMPILERS])
def test_strict_and_fast_math_compiles_and_a_mismatched_header_is_an_error(tmp_path, compiler):
    from skelarm_sym.models.diffdrive import DiffDrive

    cases = [
        generate(3, out=tmp_path, langs="c", precision="float", lengths=(1.0, 0.8, 0.5), prefix="a3f"),
        generate(7, out=tmp_path, langs="c", prefix="a7"),
        generate(DiffDrive(), out=tmp_path, langs="c"),
    ]
    for g in cases:
        c_file = next(name for name in g.sources if name.endswith(".c"))
        header = g.sources[c_file[:-2] + ".h"]
        assert "-lm" in header and "_ZGVbN2v_sin" in header and "must not alias" in header
        for flags in (("-O2",), ("-O0",), ("-O2", "-ffast-math"), ("-O2", "-DSKELARM_NO_SIMD")):
            cmd = [compiler, *STRICT_FLAGS, *flags, "-c", str(tmp_path / c_file), "-o", str(tmp_path / "x.o")]
            result = subprocess.run(cmd, capture_output=True, text=True)
            assert result.returncode == 0 and result.stderr == "", (cmd, result.stderr)
    # an arm3.h of other options beside an arm3.c: compiling must fail loudly, not link wrong code
    generate(3, out=tmp_path / "a", langs="c", prefix="arm3")
    generate(3, out=tmp_path / "b", langs="c", prefix="arm3", precision="float")
    (tmp_path / "a" / "arm3.h").write_text((tmp_path / "b" / "arm3.h").read_text())
    result = subprocess.run([compiler, "-std=c99", "-c", str(tmp_path / "a" / "arm3.c"), "-o", str(tmp_path / "x.o")], capture_output=True, text=True)
    assert result.returncode != 0 and "regenerate both together" in result.stderr


def test_header_states_the_stack_each_function_needs():
    import re

    header = generate(24, out=None, langs="c").sources["arm24.h"]
    stacks = re.findall(r"void arm24_(\w+)\(", header)
    sizes = re.findall(r"Stack: at most (\d+) (bytes|KB)", header)
    assert len(sizes) >= len(stacks)  # every function (and batch) says it
    kin = re.search(r"p, J, H, v and a at once\. Stack: at most (\d+) (bytes|KB)", header)
    kb = int(kin.group(1)) / (1024 if kin.group(2) == "bytes" else 1)
    # 3 arrays of 24 angles (padded to 24) plus about 18 n temporaries of 8 bytes: a few KB
    assert 1.0 < kb < 8.0, kin.group(0)
