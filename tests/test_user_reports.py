"""What a new user with a real robot file meets, checked end to end: robot-file text stays data in every
language's output, a refused compile says what ran and what the compiler said, ``check --from`` finds and
judges what ``generate`` wrote from any folder (and says in one line which files are missing or foreign),
a set of files of mixed generations is refused by each reader, and the pose IK's header states how its
success depends on ``lambda`` with numbers a measurement here reproduces.

The fixtures are the robot files under tests/fixtures/robots/ (pi/2 offsets, every joint type, hostile
but printable names)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym.backends import BACKENDS
from skelarm_sym.cli import main
from skelarm_sym.generate import file_stamp, generate
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "robots"
LOADABLE = sorted(p.name for p in FIXTURES.iterdir() if p.suffix in (".urdf", ".toml"))
needs_cc = pytest.mark.skipif(not (shutil.which("cc") or shutil.which("gcc")), reason="no C compiler")


# -- robot-file text is data in every language's files ---------------------------------------------------

# what could end a comment or a string, splice a line or form a trigraph in each kind of file
DANGEROUS = {
    ".h": ("*/", "/*", "??", "\\"), ".c": ("*/", "/*", "??", "\\"), ".cu": ("*/", "/*", "??", "\\"),
    ".cuh": ("*/", "/*", "??", "\\"), ".py": ('"', "\\"), ".txt": (),  # CMake: see below
}


@pytest.mark.parametrize("fixture", LOADABLE)
def test_every_language_writes_robot_file_text_only_escaped(fixture):
    """Every registered backend (C, NumPy, the CPython extension, PyTorch, JAX, CUDA and the CMake file)
    writes printable ASCII only, and no name, description or loader option of the robot file that holds a
    sequence able to end a comment or string there appears in it as written."""
    chain = load_robot(FIXTURES / fixture)
    generated = generate(chain, langs=",".join(BACKENDS), out=None, prefix="fixture", cmake=True, functions="pose")
    expected = {"fixture" + s for backend in BACKENDS.values() for s in backend.FILE_SUFFIXES} | {"CMakeLists.txt"}
    assert set(generated.sources) == expected
    texts = [chain.name, chain.description, *chain.coordinates, *(j.name for j in chain.joints)]
    texts += [value for _, value in chain.load_options]
    for name, text in generated.sources.items():
        bad = sorted({ch for ch in text if not (32 <= ord(ch) < 127 or ch == "\n")})
        assert bad == [], (name, bad)
        for foreign in filter(None, texts):
            assert Path(name).suffix in DANGEROUS, (
                f"{name}: no escaping rule for {Path(name).suffix!r} files: add to DANGEROUS the sequences that end a "
                "comment or a string in that language (docs/architecture.md, 'Adding a backend')")
            if any(s in foreign for s in DANGEROUS[Path(name).suffix]) or any(ord(ch) >= 127 for ch in foreign):
                assert foreign not in text, (name, foreign)
        if Path(name).suffix in (".h", ".c", ".cu", ".cuh"):  # every comment closes where it should
            stripped = re.sub(r"/\*.*?\*/", "", re.sub(r'"(?:[^"\\\n]|\\.)*"', '""', text), flags=re.S)
            assert "*/" not in stripped and "/*" not in stripped, name
        if name.endswith(".py"):
            compile(text, name, "exec")  # a string ended early would be a syntax error or a statement
        if name == "CMakeLists.txt":  # robot-file text only in line comments (no bracket comment)
            for line in text.splitlines():
                if any(foreign in line for foreign in filter(None, texts) if re.search(r"\$\{|#\[|\\|[^ -~]", foreign)):
                    assert line.lstrip().startswith("# ") and not line.lstrip().startswith(("#[[", "#[=")), line


# -- a refused compile ------------------------------------------------------------------------------------

@needs_cc
def test_a_failed_compile_on_the_command_line_shows_the_command_and_the_first_errors(tmp_path, monkeypatch, capsys):
    """``generate --compile`` whose compiler refuses the code prints, under the one-line error naming the
    file and the first error, the command that ran and the compiler's first lines (was: the file only)."""
    compiler = shutil.which("gcc") or shutil.which("cc")
    monkeypatch.setenv("SKELARM_SYM_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", f"{compiler} -DSKELARM_USER_REPORTS=1 -include no_such_header_4715.h")
    assert main(["generate", "--links", "2", "--functions", "position", "--lang", "c", "--out", str(tmp_path / "out"),
                 "--compile"]) == 1
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert lines[0].startswith("skelarm-sym: error: compiling arm2.c failed: ") and "no_such_header_4715.h" in lines[0], err
    command = next((line for line in lines[1:] if line.strip().startswith("command: ")), None)
    assert command is not None, err
    assert "-DSKELARM_USER_REPORTS=1" in command and "-std=c99" in command and "arm2.c" in command, command
    output = lines[lines.index(command) + 1:]
    assert output and any("no_such_header_4715.h" in line for line in output), err
    assert all(line.startswith("  ") for line in lines[1:])  # the detail is indented under the error
    assert "Traceback" not in err


# -- check --from reads what generate wrote, from anywhere ------------------------------------------------------

def test_check_from_another_folder_regenerates_a_urdf_chain_with_base_tip_and_out(tmp_path, monkeypatch, capsys):
    """A URDF generated with --base, --tip and --out from one folder is checked with ``check --from`` from
    another: the header's regenerate line records every option that shapes the output and the robot file
    relative to the output folder (no machine path), and the check passes."""
    (tmp_path / "robots").mkdir()
    shutil.copy(FIXTURES / "ur_like.urdf", tmp_path / "robots" / "arm.urdf")
    (tmp_path / "work").mkdir()
    (tmp_path / "elsewhere" / "deeper").mkdir(parents=True)
    monkeypatch.chdir(tmp_path / "work")
    assert main(["generate", "--robot", "../robots/arm.urdf", "--base", "base_link", "--tip", "wrist_3_link",
                 "--functions", "pose,kinematics", "--out", "../out/gen"]) == 0
    capsys.readouterr()
    header = (tmp_path / "out" / "gen" / "arm.h").read_text()
    line = next(x for x in header.splitlines() if "regenerate with (in this folder):" in x)
    command = line.split("(in this folder): ", 1)[1]
    assert command == ("skelarm-sym generate --robot ../../robots/arm.urdf --base base_link --tip wrist_3_link "
                       "--lang c,python --prefix arm --precision double --functions pose,kinematics --out .")
    for text in ((tmp_path / "out" / "gen" / name).read_text() for name in ("arm.h", "arm.c", "arm.py")):
        assert str(tmp_path) not in text and str(ROOT) not in text and os.path.expanduser("~") + "/" not in text
    monkeypatch.chdir(tmp_path / "elsewhere" / "deeper")
    assert main(["check", "--from", "../../out/gen", "--cases", "4"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == f"checking arm.h, arm.c, arm.py in ../../out/gen ({command})"
    assert "differ" not in out and re.search(r"^C pose\s+T\s.*ok$", out, re.M)
    assert main(["check", "--from", str(tmp_path / "out" / "gen"), "--cases", "2"]) == 0  # and by absolute path


def _mixed(tmp_path: Path) -> Path:
    """A folder as a kill between renames leaves it: arm2.h and arm2.c of one generation, arm2.py of another."""
    first, second = tmp_path / "first", tmp_path / "second"
    generate(2, out=first, lengths=[1.0, 0.5], functions="position")
    generate(2, out=second, lengths=[0.7, 0.3], functions="position")
    shutil.copy(second / "arm2.py", first / "arm2.py")
    return first


def test_check_from_a_set_of_mixed_generations_names_the_files_in_one_line(tmp_path, capsys):
    folder = _mixed(tmp_path)
    stamps = {name: file_stamp((folder / name).read_text()) for name in ("arm2.h", "arm2.c", "arm2.py")}
    assert stamps["arm2.h"] == stamps["arm2.c"] != stamps["arm2.py"]
    assert main(["check", "--from", str(folder)]) == 2
    captured = capsys.readouterr()
    err = captured.err
    assert err.count("\n") == 1 and err.startswith("skelarm-sym: error: ") and "Traceback" not in err
    assert "different generations" in err and "regenerate them together" in err
    for name, stamp in stamps.items():
        assert f"{name} {stamp}" in err
    assert captured.out == ""  # nothing was checked


@pytest.mark.skipif(not shutil.which("cmake"), reason="cmake is not installed")
@needs_cc
def test_cmake_refuses_a_header_of_another_generation(tmp_path):
    """The CMakeLists.txt of a set stops the configure step, naming the header, when arm2.h is not of its
    generation; with its own header it configures."""
    ours, theirs = tmp_path / "ours", tmp_path / "theirs"
    generate(2, out=ours, langs="c", cmake=True, lengths=[1.0, 0.5], functions="position")
    generate(2, out=theirs, langs="c", cmake=True, lengths=[0.7, 0.3], functions="position")
    build = tmp_path / "build"
    run = subprocess.run(["cmake", "-S", str(ours), "-B", str(build)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    shutil.copy(theirs / "arm2.h", ours / "arm2.h")
    shutil.rmtree(build)
    run = subprocess.run(["cmake", "-S", str(ours), "-B", str(build)], capture_output=True, text=True, timeout=300)
    assert run.returncode != 0
    assert "arm2.h is not from the generation of this CMakeLists.txt" in run.stdout + run.stderr


@pytest.mark.parametrize("keep, shown", [
    (["arm2.h"], "(arm2.h without arm2.c)"),
    (["arm2.cu"], "(arm2.cu without arm2.cuh and arm2_cuda.py)"),
    (["arm2.h", "arm2.cu", "arm2_cuda.py"], "(arm2.h without arm2.c; arm2.cu and arm2_cuda.py without arm2.cuh)"),
])
def test_check_from_a_set_with_missing_files_names_them_in_one_line(tmp_path, capsys, keep, shown):
    folder = tmp_path / "f"
    generate(2, out=folder, langs="c,cuda", functions="position")
    for path in folder.iterdir():
        if path.name not in keep:
            path.unlink()
    assert main(["check", "--from", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"skelarm-sym: error: --from {str(folder)!r}: no whole set of files for prefix 'arm2' {shown}; ")
    assert "check needs its .c or .py beside the header, or every file of another language's set (.cuh, .cu and _cuda.py)" in err


def test_check_from_a_folder_without_generated_files_lists_every_kind_it_reads(tmp_path, capsys):
    folder = tmp_path / "f"
    folder.mkdir()
    (folder / "arm2.py").write_text("print('written by hand')\n")  # foreign: not generated, not read
    assert main(["check", "--from", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    suffixes = list(dict.fromkeys(s for backend in BACKENDS.values() for s in backend.FILE_SUFFIXES))
    listed = re.search(r"no files generated by skelarm-sym \((.*)\) in it", err).group(1)
    assert re.split(r", | or ", listed) == suffixes
    assert {".ext.c", "_torch.py", "_jax.py", ".cu", ".cuh", "_cuda.py"} <= set(suffixes)


# -- the pose IK states its success against lambda -------------------------------------------------------

@needs_cc
def test_the_pose_ik_header_states_success_against_lambda_and_the_measurement_agrees():
    """generated/ur5.h states, beside the damping rule, the measured success for lambda = 0, 1e-3, 1e-2
    and 0.1; UR5's numbers are measured again here (1000 random reachable poses from random starts within
    the limits, tol 1e-10, 100 steps) and a usual damping loses nothing against none."""
    from skelarm_sym.build import compile_arm
    from skelarm_sym.models.chain.dh_file import load_robot_file

    header = (ROOT / "generated" / "ur5.h").read_text()
    doc = header[:header.index("int ur5_ik_solve(")]
    doc = doc[doc.rindex("/* pose IK of the tool frame."):]
    assert "never stops the convergence" in doc
    match = re.search(r"for lambda = 0 / 1e-3 / 1e-2 / 0\.1:\s*\*\s*UR5 ([\d.]+) / ([\d.]+) / ([\d.]+) / ([\d.]+) %", doc)
    assert match, doc
    stated = [float(x) for x in match.groups()]
    chain = load_robot_file(ROOT / "examples" / "robots" / "ur5.toml")
    arm = compile_arm(generate(chain, langs="c", out=None, prefix="ur5_lambda", functions="pose,ik_solve"))
    limits = chain.limits()
    lo = np.array([-np.pi if x is None else x for x in limits["lower"]])
    hi = np.array([np.pi if x is None else x for x in limits["upper"]])
    rng = np.random.default_rng(0)
    pairs = [(arm.pose(rng.uniform(lo, hi)), rng.uniform(lo, hi)) for _ in range(1000)]
    measured = []
    for lam in (0.0, 1e-3, 1e-2, 0.1):
        results = [arm.ik_solve(q0, target, lambda_=lam, tol=1e-10, max_iter=100) for target, q0 in pairs]
        measured.append(100.0 * sum(r.status == "converged" for r in results) / len(pairs))
    assert all(abs(m - s) <= 0.3 for m, s in zip(measured, stated)), (measured, stated)
    assert min(measured) >= 99.0 and measured[2] >= measured[0] - 0.5, measured


# -- what the header says about floating-point environments ------------------------------------------------

def test_the_header_states_the_trap_and_bit_equality_conditions():
    """A C user reads in the header that glibc's vector sin/cos and the scalar path's own kernel raise
    FE_OVERFLOW (FE_INVALID) for huge angles when traps are enabled (the own kernel's thresholds are run in
    tests/test_robustness_c.py), and for which compiler flags single calls equal their batches bit for bit (not
    with FMA contraction, not with GCC's vectoriser where FMA is available, not with -ffast-math)."""
    text = " ".join(generate(3, langs="c", out=None, functions="position").sources["arm3.h"].replace("*", " ").split())
    assert ("With floating-point exceptions enabled as traps (feenableexcept), huge angles raise them: libmvec "
            "FE_OVERFLOW for |angle| above about 1e38, the own kernel FE_OVERFLOW above about 1e39") in text
    assert "every path FE_INVALID for infinite angles" in text
    assert "Single calls equal their batch results bit for bit when both are built without FMA contraction" in text
    assert "-O0 to -O3 for plain x86-64, or a target with FMA built with -ffp-contract=off -fno-tree-slp-vectorize" in text
    assert "-ffast-math reorders sums: the results may then differ in the last bits" in text


# -- the README is a user's guide -----------------------------------------------------------------------------

def test_the_readme_first_screen_is_the_newcomer_path():
    """The first 60 lines of README.md: install, list a URDF's links to choose --tip, generate from a URDF
    with --tip, build with cc, call X_kinematics and X_ik_solve; further down, how long the tests take and
    the quick subset; no issue numbers anywhere in it."""
    readme = (ROOT / "README.md").read_text()
    first = "\n".join(readme.splitlines()[:60])
    assert "pip install" in first
    assert re.search(r"skelarm-sym show --robot \S+\.urdf --what links", first)
    assert re.search(r"skelarm-sym generate --robot \S+\.urdf --tip \S+", first)
    assert re.search(r"^cc .*-lm", first, re.M)
    assert re.search(r"\w+_kinematics\(", first) and re.search(r"\w+_ik_solve\(", first)
    assert re.search(r"about \d+ minutes", readme) and 'pytest -q -m "not slow"' in readme
    assert not re.search(r"(?i)\bissues? ?#?\d|\(#\d+\)", readme)


def test_the_recorded_command_runs_as_printed_with_trigraphs_and_comment_ends_in_names(tmp_path, monkeypatch, capsys):
    """A tip named ``tip?? ??/`` or ``a */ b /* c`` (a new user's probe): the C header recorded ``--tip 'tip?\\?
    ?\\?/'``, its comment escapes, and the command did not run as printed. The words are now quoted so that no
    trigraph or comment end appears (``'tip?''? ?''?/'``: the same word to a shell); run as printed, the command
    regenerates the same files, and ``check --from`` reads it."""
    import shlex

    for tip in ("tip?? ??/", "a */ b /* c"):
        folder = tmp_path / ("x" if "?" in tip else "y")
        folder.mkdir()
        text = (FIXTURES / "ur_like.urdf").read_text().replace('"wrist_3_link"', f'"{tip}"')
        (folder / "arm.urdf").write_text(text)
        monkeypatch.chdir(folder)
        assert main(["generate", "--robot", "arm.urdf", "--tip", tip, "--functions", "pose", "--out", "gen"]) == 0
        capsys.readouterr()
        for name in ("arm.h", "arm.c", "arm.py"):
            line = next(x for x in (folder / "gen" / name).read_text().splitlines() if "regenerate with (in this folder):" in x)
            command = line.split("(in this folder): ", 1)[1].strip()
            assert "??" not in command and "*/" not in command and "\\" not in command
            words = shlex.split(command)
            assert words[words.index("--tip") + 1] == tip
        monkeypatch.chdir(folder / "gen")
        before = {p.name: p.read_text() for p in (folder / "gen").iterdir()}
        assert main(words[1:]) == 0  # as printed: skelarm-sym generate ... --out .
        assert {p.name: p.read_text() for p in (folder / "gen").iterdir()} == before
        assert main(["check", "--from", ".", "--cases", "2"]) == 0
        capsys.readouterr()


def test_the_solvers_comments_name_the_limit_tables_only_where_the_files_have_them():
    """A robot file without position limits (kuka_kr6.toml) gets no Q_MIN/Q_MAX, and its solvers' comments
    said 'Joint limits (Q_MIN/MAX) are kept by clamping' all the same."""
    for name, limited in (("kuka_kr6", False), ("ur5", True)):
        sources = generate(load_robot(ROOT / f"examples/robots/{name}.toml"), out=None, functions="ik_solve,ik_solve_position").sources
        for suffix in (".h", ".py"):
            text = sources[name + suffix]
            has_tables = f"{name.upper()}_Q_MIN" in text if suffix == ".h" else "\nQ_MIN = " in text
            assert has_tables == limited, (name, suffix)
            named = f"{name.upper()}_Q_MIN" if suffix == ".h" else "Q_MIN"  # the header names its macros
            assert text.count(f"Joint limits ({named}/MAX) are kept by clamping") == (2 if limited else 0), (name, suffix)
            assert text.count("The arm has no position limits (no Q_MIN/Q_MAX): nothing is clamped") == (0 if limited else 2)
        assert "stop when the position error (m) is <= tol" in sources[name + ".py"]  # ik_solve_position's tol


def test_the_status_comments_name_a_lock_only_for_an_arm_that_has_one():
    """A C++ integrator's report: ur5.h's UR5_IK_INVALID comment said "target (or lock) not finite, the lock beyond
    IK_LOCK_MAX", for an arm with no lock and a macro the header does not define."""
    ur5 = generate(load_robot(ROOT / "examples/robots/ur5.toml"), out=None, langs="c", functions="ik_all,ik_nearest").sources["ur5.h"]
    invalid = [line for line in ur5.splitlines() if line.startswith("#define UR5_IK_INVALID")]
    assert invalid and "lock" not in invalid[0] and "target not finite" in invalid[0], invalid
    panda = generate(load_robot(ROOT / "examples/robots/panda.toml", ik_lock=7), out=None, langs="c",
                     functions="ik_all").sources["panda.h"]
    assert "the lock beyond PANDA_IK_LOCK_MAX" in panda
