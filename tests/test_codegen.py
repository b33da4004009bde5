"""Emitted C and Python: strict compilation, values against the reference, layout, determinism."""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym import InputError, reference
from skelarm_sym.build import DEFAULT_FLAGS, STRICT_FLAGS, compile_arm, load_python
from skelarm_sym.check import compare
from skelarm_sym.generate import generate
from skelarm_sym.ir.lower import lower as build_programs
from skelarm_sym import derive

ROOT = Path(__file__).resolve().parents[1]
COMPILERS = [c for c in ("gcc", "clang") if shutil.which(c)]
BY_COMPILER = [pytest.param(c, marks=pytest.mark.slow if c == "clang" else ()) for c in COMPILERS]
"""The compilers as parameters: clang's compiles are in the slow set (gcc compiles the same text in the quick one)."""


@pytest.mark.parametrize("n", [*range(1, 13), 64])
@pytest.mark.parametrize("precision", ["double", "float"])
def test_emitted_code_matches_reference(n, precision):
    results = compare(generate(n, precision=precision, out=None), cases=30, seed=n, precision=precision)
    # per language: 10 forward outputs, w, and each solve undamped and damped
    assert len(results) == 2 * (10 + 1 + 2 * (3 if n >= 3 else 2))
    bad = [r for r in results if not r.ok]
    assert not bad, bad


@pytest.mark.parametrize("compiler", BY_COMPILER)
@pytest.mark.parametrize("n, lengths, precision", [(1, None, "double"), (4, None, "float"), (5, (1.0, 0.8, 0.5, 2.0, 1.0), "double"), (3, (1.0, 0.5, 0.25), "float")])
def test_compiles_with_strict_flags(tmp_path, compiler, n, lengths, precision):
    g = generate(n, lengths=lengths, precision=precision, langs="c", out=tmp_path)
    for flags in (["-O2"], ["-O0"], ["-O2", "-march=native"], ["-O2", "-DSKELARM_NO_SIMD"]):
        cmd = [compiler, *STRICT_FLAGS, *flags, "-c", str(tmp_path / f"arm{n}.c"), "-o", str(tmp_path / "x.o")]
        result = subprocess.run(cmd, capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        assert result.stderr == ""
    # the header alone is valid C++ too (extern "C")
    if shutil.which("g++"):
        (tmp_path / "use.cpp").write_text(f'#include "arm{n}.h"\nint main() {{ return 0; }}\n')
        r = subprocess.run(["g++", "-Wall", "-Werror", "-c", str(tmp_path / "use.cpp"), "-o", str(tmp_path / "u.o")], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
    src = g.sources[f"arm{n}.c"]
    assert [line for line in src.splitlines() if line.startswith("#include")] == ["#include <math.h>", f'#include "arm{n}.h"']
    assert "malloc" not in src and "static double" not in src


def test_float_code_has_no_double(tmp_path):
    src = generate(3, lengths=(1.0, 0.8, 0.5), precision="float", langs="c", out=None).sources["arm3.c"]
    code = "\n".join(line for line in src.splitlines() if not line.lstrip().startswith(("*", "/*")))
    assert "double" not in code
    assert "sinf(" in code and "cosf(" in code
    import re

    literals = re.findall(r"(?<![\w.])(\d+\.\d*(?:e[-+]?\d+)?)(f?)", code)
    assert literals and all(suffix == "f" for _, suffix in literals)


def test_numeric_lengths_drop_the_l_argument(rng):
    lengths = (1.0, 0.8, 0.5)
    g = generate(3, lengths=lengths, out=None)
    assert "const double l[3]" not in g.sources["arm3.h"]
    arm = compile_arm(g)
    py = load_python(g.sources["arm3.py"], "arm3")
    q = rng.uniform(-np.pi, np.pi, 3)
    expected = reference.kinematics(q, lengths=lengths).J
    np.testing.assert_allclose(arm.jacobian(q), expected, atol=1e-14)
    np.testing.assert_allclose(py.jacobian(q), expected, atol=1e-14)


@pytest.mark.parametrize("n", [6, 64])  # the vectorised block path and the per-configuration path
def test_batches_equal_single_calls_and_shapes(rng, n):
    g = generate(n, out=None, functions="kinematics,jacobian,inverse_velocity")
    arm = compile_arm(g, flags=DEFAULT_FLAGS)  # -O2: the optimised block path must equal single calls bit for bit
    py = load_python(g.sources[f"arm{n}.py"], f"arm{n}")
    m = 203  # not a multiple of the block size
    q, dq, ddq = rng.uniform(-np.pi, np.pi, (3, m, n))
    l = rng.uniform(0.5, 1.5, n)
    batch = arm.kinematics(q, dq, ddq, l)
    for j in (0, 57, m - 1):
        single = arm.kinematics(q[j], dq[j], ddq[j], l)
        for b, s in zip(batch, single):
            np.testing.assert_array_equal(b[j], s)
    assert [x.shape for x in batch] == [(m, 2), (m, 2, n), (m, 2, n), (m, 2), (m, 2)]
    v = rng.uniform(-1, 1, (m, 2))
    dq_batch = arm.inverse_velocity(q, v, l, 0.01)
    np.testing.assert_array_equal(dq_batch[m - 1], arm.inverse_velocity(q[m - 1], v[m - 1], l, 0.01))
    q4 = q[:200].reshape(4, 50, n)
    assert py.jacobian(q4, l).shape == (4, 50, 2, n)
    np.testing.assert_allclose(py.jacobian(q4, l).reshape(200, 2, n), batch[1][:200], atol=1e-13)
    assert arm.jacobian(q4, l).shape == (4, 50, 2, n)


def test_wrong_shapes_are_clear_errors():
    g = generate(3, out=None, functions="jacobian,velocity")
    arm = compile_arm(g)
    py = load_python(g.sources["arm3.py"], "arm3")
    with pytest.raises(InputError, match=r"q must have shape \(\.\.\., 3\)"):
        arm.jacobian(np.zeros(4), np.ones(3))
    with pytest.raises(InputError, match=r"l must have shape \(\.\.\., 3\)"):  # (2, 3): lengths per configuration
        arm.jacobian(np.zeros(3), np.ones(4))
    with pytest.raises(ValueError, match=r"q must have shape \(\.\.\., 3\)"):
        py.jacobian(np.zeros((5, 2)), np.ones(3))
    with pytest.raises(ValueError, match="do not broadcast"):
        py.velocity(np.zeros((5, 3)), np.zeros((4, 3)), np.ones(3))
    for impl in (arm, py):  # a number for q: the shape given, () (the NumPy module said (1,), its contiguous copy's)
        with pytest.raises(ValueError, match=re.escape("q must have shape (..., 3), got ()")):
            impl.jacobian(1.0, np.ones(3))


def test_compile_cache_is_reused():
    g = generate(2, langs="c", out=None, functions="position")  # calls nothing: any one function makes a library
    first = compile_arm(g).path
    mtime = first.stat().st_mtime_ns
    assert compile_arm(g).path == first and first.stat().st_mtime_ns == mtime


@pytest.mark.parametrize("prefix", ["9arm", "a-b", "x;int y", "int", "static", "class", "", "a" * 49, "arm\n"])
def test_unsafe_prefix_rejected(prefix, tmp_path):
    with pytest.raises(InputError):
        generate(2, prefix=prefix, out=tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_leaves_nothing(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(InputError, match="not a folder"):
        generate(2, out=blocker)
    with pytest.raises(InputError, match="cannot create output folder"):
        generate(2, out=blocker / "sub")
    assert blocker.read_text() == "not a folder"


def test_failed_write_removes_temporary_files(tmp_path, monkeypatch):
    import skelarm_sym.generate as gen

    real_replace = os.replace
    calls = []

    def failing_replace(src, dst):
        calls.append(dst)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(gen.os, "replace", failing_replace)
    with pytest.raises(InputError, match="No space left"):
        generate(2, out=tmp_path)
    monkeypatch.setattr(gen.os, "replace", real_replace)
    assert calls and list(tmp_path.iterdir()) == []


def _regenerate_committed(out):
    import runpy

    runpy.run_path(str(ROOT / "scripts" / "regenerate.py"))["regenerate"](out)


def test_generated_folder_is_up_to_date(tmp_path):
    _regenerate_committed(tmp_path)
    committed = ROOT / "generated"
    fresh = sorted(p.name for p in tmp_path.iterdir())
    assert fresh == sorted(p.name for p in committed.iterdir() if p.suffix in (".c", ".h", ".py"))
    for name in fresh:
        assert (tmp_path / name).read_bytes() == (committed / name).read_bytes(), f"generated/{name} is stale: run scripts/regenerate.py"


def test_output_is_independent_of_hash_seed(tmp_path):
    code = (
        "import sys; from skelarm_sym.generate import generate; from skelarm_sym.models.diffdrive import DiffDrive; "
        "generate(5, out=sys.argv[1]); generate(3, lengths=(1.0, 0.5, 0.25), precision='float', out=sys.argv[1], prefix='f3'); "
        "generate(DiffDrive(), out=sys.argv[1]); from skelarm_sym.models.chain.loader import load_robot; "
        f"generate(load_robot({str(ROOT / 'examples/robots/ur5.toml')!r}), out=sys.argv[1], functions='kinematics,jacobian_dot')"
    )  # UR5: parallel axes, whose shared factors ir/factors.py takes out in an order that must not follow a hash
    for seed in ("1", "987"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        subprocess.run([sys.executable, "-c", code, str(tmp_path / seed)], check=True, env=env)
    for name in ("arm5.c", "arm5.h", "arm5.py", "f3.c", "f3.h", "f3.py", "diffdrive.c", "diffdrive.py", "ur5.c", "ur5.py"):
        assert (tmp_path / "1" / name).read_bytes() == (tmp_path / "987" / name).read_bytes()


@pytest.mark.parametrize("n", range(1, 65))
def test_operation_counts(n):
    programs = {p.name: p for p in build_programs(derive(n), names=("kinematics", "jacobian"))}
    ops = programs["kinematics"].ops
    assert ops.sin == n and ops.cos == n
    # per link 18; 4 negations in all (one arm alone: 3 of its 15 go, the signs of a single link being free)
    assert ops.arithmetic == (18 * n - 4 if n > 1 else 13) <= 24 * n + 10
    assert ops.div == 0 and ops.sqrt == 0
    assert programs["jacobian"].ops.arithmetic == 5 * n - 2


def test_written_files_follow_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        g = generate(2, out=tmp_path)
    finally:
        os.umask(old)
    for path in g.paths:
        assert path.stat().st_mode & 0o777 == 0o644  # not mkstemp's 0600


def test_numpy_chunks_give_the_same_values(rng):
    """Batches larger than CHUNK run in slices; partial broadcasts are expanded first."""
    g = generate(4, out=None, langs="python", functions="kinematics")
    py = load_python(g.sources["arm4.py"], "arm4")
    q = rng.uniform(-np.pi, np.pi, (3, 1, 7, 4))  # broadcasts with dq's (5, 1, 4)
    dq = rng.uniform(-1, 1, (5, 1, 4))
    ddq = rng.uniform(-1, 1, 4)
    l = rng.uniform(0.5, 1.5, 4)
    whole = py.kinematics(q, dq, ddq, l)
    py.CHUNK = 4  # 105 configurations: 27 slices, the last one short
    sliced = py.kinematics(q, dq, ddq, l)
    for a, b in zip(whole, sliced):
        assert a.shape[:3] == (3, 5, 7)
        np.testing.assert_array_equal(a, b)
    k = reference.kinematics(np.broadcast_to(q, (3, 5, 7, 4)), np.broadcast_to(dq, (3, 5, 7, 4)), np.broadcast_to(ddq, (3, 5, 7, 4)), l)
    np.testing.assert_allclose(sliced[4], k.a, atol=1e-12)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 7])
def test_trig_helpers_with_and_without_vector_math(n, rng):
    """Each trig strategy (scalar, paired or quad vector sines, vector loops) and its plain fallback."""
    g = generate(n, out=None, langs="c", functions="kinematics")
    q, dq, ddq = rng.uniform(-np.pi, np.pi, (3, 40, n))
    l = rng.uniform(0.5, 1.5, n)
    want = reference.kinematics(q, dq, ddq, l)
    for flags in (("-O2",), ("-O2", "-march=native"), ("-O2", "-DSKELARM_NO_SIMD")):
        arm = compile_arm(g, flags=flags)
        p, J, H, v, a = arm.kinematics(q, dq, ddq, l)
        single = arm.kinematics(q[3], dq[3], ddq[3], l)
        for got, expected in ((p, want.p), (J, want.J), (H, want.H), (single[4], want.a[3])):
            np.testing.assert_allclose(got, expected, atol=1e-13)


@pytest.mark.parametrize("precision", ["double", "float"])
def test_check_catches_a_wrong_statement(precision):
    """A check that cannot fail is worthless: flip one sign in the emitted C and in the Python."""
    import dataclasses
    import re

    g = generate(4, precision=precision, out=None)
    sources = dict(g.sources)
    anchors = {"arm4.c": ("---- arm4_coriolis:", "---- arm4_velocity:"), "arm4.py": ("def _coriolis_core(", "def coriolis(")}
    for name, (begin, end) in anchors.items():
        text = sources[name]
        start, stop = text.index(begin), text.index(end)
        region = text[start:stop]
        # the first temporary defined as a sum: make it a difference (in every copy: single and batch)
        statement = re.search(r"t\d+ = \S+ \+ \S+", region).group(0)
        region = region.replace(statement, statement.replace(" + ", " - "))
        sources[name] = text[:start] + region + text[stop:]
    broken = dataclasses.replace(g, sources=sources)
    results = compare(broken, cases=20, seed=1, precision=precision)
    failed = {(r.implementation.split()[0], r.output) for r in results if not r.ok}
    assert ("C", "H") in failed and ("Python", "H") in failed
    assert all(r.ok for r in results if r.output in ("p", "J"))  # the rest still agrees


LIGHT_FUNCTIONS = "manipulability,manipulability_gradient,inverse_velocity,jacobian_rpy"


@pytest.mark.parametrize("flags", [("-O2",), ("-O2", "-DSKELARM_FULL_OPTIMIZE")])
def test_long_closed_forms_compiled_light_or_full_match_the_reference(flags):
    """The long closed forms without a vectorised batch (divisions, square roots) carry ``{P}_LIGHT``: GCC
    compiles them at -O1 when the file is optimised (half the compile time, no loss of speed:
    benchmarks/compile_time.py, benchmarks/batch_ab.py), or at the command line's level with
    -DSKELARM_FULL_OPTIMIZE. Both builds agree with the reference, single calls and batches."""
    from skelarm_sym.models.chain.loader import load_robot

    g = generate(load_robot(ROOT / "examples" / "robots" / "panda.toml"), langs="c", out=None, functions=LIGHT_FUNCTIONS)
    src = g.sources["panda.c"]
    for name in LIGHT_FUNCTIONS.split(","):
        assert f"static PANDA_LIGHT void panda_{name}_finish(" in src, name
    arm = compile_arm(g, flags=flags)
    results = compare(g, cases=20, seed=5, implementations=[("C", arm)])
    assert {r.output for r in results} >= {"w", "grad", "dq", "JA"}
    bad = [r for r in results if not r.ok]
    assert not bad, bad


def test_the_compiled_library_takes_lengths_per_configuration_as_the_numpy_module_does():
    """A new user's probe: l of shape (5, 3) beside q (5, 3) broadcast in the NumPy module, while the compiled
    wrapper said "l must have shape (3,)"; the README promises both the same functions and signatures."""
    from skelarm_sym.build import compile_arm, load_python

    g = generate(3, out=None, langs="c,python", prefix="perl", functions="jacobian,inverse_velocity")
    arm, mod = compile_arm(g), load_python(g.sources["perl.py"], "perl")
    rng = np.random.default_rng(5)
    q, l, v = rng.uniform(-1, 1, (5, 3)), rng.uniform(0.5, 1.5, (5, 3)), rng.uniform(-1, 1, (5, 2))
    for args in ((q, l), (q[0], l), (q, l[0])):
        np.testing.assert_allclose(arm.jacobian(*args), mod.jacobian(*args), rtol=0, atol=1e-14)
    np.testing.assert_allclose(arm.inverse_velocity(q, v, l, 0.1), mod.inverse_velocity(q, v, l, 0.1), rtol=0, atol=1e-13)
    with pytest.raises(ValueError, match=re.escape("batch shapes do not broadcast: q (5, 3), l (4, 3)")):
        arm.jacobian(q, np.ones((4, 3)))


@pytest.mark.parametrize("compiler", COMPILERS)
def test_double_code_is_quiet_under_double_promotion_warnings(tmp_path, compiler):
    """C99's NAN is a float: the solvers' ``q[k] = NAN`` promoted it to double implicitly (24 clang
    ``-Wdouble-promotion`` warnings in ur5.c, a flag embedded builds use to catch slow double arithmetic).
    Double code prints it ``(double)NAN``."""
    generated = Path(__file__).resolve().parents[1] / "generated"
    assert "(double)NAN" in (generated / "ur5.c").read_text()
    for name in ("ur5", "panda"):
        cmd = [compiler, *STRICT_FLAGS, "-Wdouble-promotion", "-O0", f"-I{generated}", "-c", str(generated / f"{name}.c"),
               "-o", str(tmp_path / "x.o")]
        result = subprocess.run(cmd, capture_output=True, text=True)
        assert result.returncode == 0 and result.stderr == "", result.stderr


def _stack_by_gcc(c_file: Path, tmp_path: Path) -> dict[str, int]:
    """The deepest stack of every function of ``c_file`` at gcc -O0 on this machine: its frame plus the deepest
    path of frames below it, from gcc's call graph (``-fcallgraph-info=su``); the C library's functions count 0."""
    obj = tmp_path / (c_file.stem + ".o")
    subprocess.run(["gcc", *STRICT_FLAGS, "-O0", "-fcallgraph-info=su", f"-I{c_file.parent}", "-c", str(c_file), "-o", str(obj)],
                   check=True, capture_output=True)
    graph = obj.with_suffix(".ci").read_text()
    frames = {title.rsplit(":", 1)[-1]: int(size.group(1)) if (size := re.search(r"\\n(\d+) bytes", label)) else 0
              for title, label in re.findall(r'node: \{ title: "([^"]+)" label: "([^"]+)"', graph)}
    calls: dict[str, set[str]] = {}
    for caller, callee in re.findall(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"', graph):
        calls.setdefault(caller.rsplit(":", 1)[-1], set()).add(callee.rsplit(":", 1)[-1])
    deepest: dict[str, int] = {}

    def depth(name: str) -> int:
        if name not in deepest:
            deepest[name] = frames.get(name, 0) + max((depth(g) for g in calls.get(name, ())), default=0)
        return deepest[name]

    return {name: depth(name) for name in frames}


def _stated_stacks(header: str) -> dict[str, int]:
    """Each declared function's ``Stack: at most N bytes`` (or KB) from the comment above it."""
    stated = {}
    for comment, name in re.findall(r"/\*((?:(?!\*/).)*)\*/\s*\n[\w ]+? (\w+)\(", header, re.S):
        figure = re.search(r"Stack: at most (\d+) (bytes|KB)\.", comment)
        if figure:
            stated[name] = int(figure.group(1)) * (1024 if figure.group(2) == "KB" else 1)
    return stated


@pytest.mark.skipif(not shutil.which("gcc"), reason="gcc is not installed")
def test_every_function_states_a_stack_that_bounds_an_unoptimised_build(tmp_path):
    """The header's figure for each public function (single call and batch, solvers included) is at least what
    gcc -O0 uses along the deepest call path. The figures had left out the trigonometry a function calls and
    the frames' fixed parts (ur5_pose: 488 stated, 984 used), and the solvers' single calls stated none."""
    from skelarm_sym.models.chain.loader import load_robot

    generated = Path(__file__).resolve().parents[1] / "generated"
    kr6 = tmp_path / "kr6"
    generate(load_robot(ROOT / "examples" / "robots" / "kuka_kr6.toml"), langs="c", out=kr6, precision="float")
    checked = 0
    for c_file in (generated / "ur5.c", generated / "arm3f.c", generated / "diffdrive.c", kr6 / "kuka_kr6.c"):
        header = c_file.with_suffix(".h").read_text()
        declared = re.findall(r"^\w[\w ]*? (\w+)\([^;]*\);$", header, re.M)
        stated = _stated_stacks(header)
        assert sorted(stated) == sorted(declared), c_file.name  # a figure for every function
        used = _stack_by_gcc(c_file, tmp_path)
        over = {name: (used[name], figure) for name, figure in stated.items() if used[name] > figure}
        assert not over, (c_file.name, over)
        checked += len(stated)
    assert checked > 60


@pytest.mark.skipif(not shutil.which("gcc"), reason="gcc is not installed")
def test_double_code_refuses_to_build_with_single_precision_literals(tmp_path):
    """gcc's -fsingle-precision-constant (common in Cortex-M builds) made every literal of double code a float:
    poses and Jacobians drifted by 2.6e-7 with no warning. The double .c now stops the build, naming why; float
    code builds under it."""
    generated = Path(__file__).resolve().parents[1] / "generated"
    for name, builds in (("ur5", False), ("arm3f", True)):
        cmd = ["gcc", *STRICT_FLAGS, "-fsingle-precision-constant", f"-I{generated}", "-c", str(generated / f"{name}.c"),
               "-o", str(tmp_path / "x.o")]
        result = subprocess.run(cmd, capture_output=True, text=True)
        assert (result.returncode == 0) == builds, result.stderr
        if not builds:
            assert "ur5_needs_double_literals_not_fsingle_precision_constant" in result.stderr
