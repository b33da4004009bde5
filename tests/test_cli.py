"""The command line: output, exit codes, one-line errors."""

import subprocess
from pathlib import Path
import sys

import pytest

from skelarm_sym.cli import main


ROBOTS = Path(__file__).resolve().parent.parent / "examples" / "robots"


def run(*args):
    return subprocess.run([sys.executable, "-m", "skelarm_sym", *args], capture_output=True, text=True)


def test_show_two_link_jacobian_is_the_seeds():
    r = run("show", "--links", "2", "--what", "J", "--format", "text")
    assert r.returncode == 0
    assert "-l1*sin(q1) - l2*sin(q1 + q2)" in r.stdout and "l2*cos(q1 + q2)" in r.stdout


def test_show_determinant_simplified(capsys):
    assert main(["show", "--links", "2", "--what", "det", "--format", "text"]) == 0
    assert capsys.readouterr().out.strip().endswith("l1*l2*sin(q2)")
    assert main(["show", "--links", "2", "--what", "J", "--format", "latex"]) == 0
    assert "\\sin" in capsys.readouterr().out


def test_generate_writes_and_check_passes(tmp_path, capsys):
    assert main(["generate", "--links", "3", "--lengths", "1,0.8,0.5", "--out", str(tmp_path), "--prefix", "demo", "--compile"]) == 0
    out = capsys.readouterr().out
    assert "compiled" in out and "kinematics: 3 sin, 3 cos" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.c", "demo.h", "demo.py"]
    assert main(["check", "--links", "4", "--cases", "10", "--precision", "float"]) == 0
    assert "34 passed, 0 failed" in capsys.readouterr().out  # 10 forward, w, 3 solves x 2 dampings; C and Python


@pytest.mark.parametrize(
    "args, message",
    [
        (["generate", "--links", "0"], "at least 1"),
        (["generate", "--links", "-2"], "at least 1"),
        (["generate", "--links", "2.5"], "whole number"),
        (["generate", "--links", "5000"], "at most 1000"),
        (["generate", "--links", "3", "--lengths", "1,2"], "expected 3 link lengths, got 2"),
        (["generate", "--links", "2", "--lengths", "1,-2"], "finite and positive"),
        (["generate", "--links", "2", "--prefix", "x;y"], "C identifier"),
        (["generate", "--links", "2", "--prefix", "stddef", "--lang", "c"], "names a C system header: stddef.h would be read"),
        (["generate", "--links", "2", "--prefix", "STDIO"], "STDIO.h would be read for <stdio.h>"),
        (["generate", "--links", "2", "--lang", "fortran"], "unknown language"),
        (["generate", "--links", "2", "--precision", "half"], "unknown precision"),
        (["show", "--links", "2", "--what", "Q"], "unknown --what"),
        (["check", "--links", "2", "--cases", "0"], "--cases must be between 1 and 100000, got 0"),
        # a probe: 10^11 cases asked NumPy for 4.37 TiB (a traceback), 10^8 had the process killed
        (["check", "--links", "2", "--cases", "100000000000"], "--cases must be between 1 and 100000, got 100000000000"),
        ([], "required"),
        # a new user's probe: messages that pointed the wrong way or listed too little
        (["show", "--robot", str(ROBOTS / "ur5.toml"), "--what", "links"], "--what links lists a URDF file's link tree"),
        (["show", "--robot", str(ROBOTS / "ur5.toml"), "--what", "nosuch"], "all, ik, links"),
        (["generate", "--robot", str(ROBOTS / "ur5.toml"), "--functions", "nosuch"], "ik_solve_position, ik_all, ik_nearest, ik_nearest_weighted"),
        # a probe: an empty list named only the seven functions an empty selection derives
        (["generate", "--robot", str(ROBOTS / "ur5.toml"), "--functions", ""], "no function named; choose from pose, jacobian"),
        (["generate", "--robot", str(ROBOTS / "ur5.toml"), "--functions", " , "], "ik_solve_position, ik_all, ik_nearest, ik_nearest_weighted"),
        (["generate", "--robot", str(ROBOTS / "ur5.toml"), "--tip", "tool0"], "a tip link (tip= / --tip) is chosen in URDF files only"),
        (["generate", "--robot", str(ROBOTS / "panda.toml"), "--functions", "ik_all"], "lock one joint, --ik-lock JOINT"),
        # a security review: CMake refused these target names only when the user ran it
        (["generate", "--links", "2", "--prefix", "all", "--cmake", "--lang", "c"], "CMake reserves the target name 'all'"),
        (["generate", "--links", "2", "--prefix", "ZERO_CHECK", "--cmake", "--lang", "c"], "CMake reserves the target name"),
        (["generate", "--links", "2", "--prefix", "m", "--cmake", "--lang", "c"], "the math library the target links"),
        (["generate", "--links", "2", "--prefix", "cmake_arm", "--cmake", "--lang", "c"], "would be CMake's own"),
        # a second review: Python reads "\u0662" as 2 and "1_0" as 10 (recorded --lengths 10.0,2.0)
        (["generate", "--links", "\u0662"], "must be a whole number, got '\u0662'"),
        (["generate", "--links", "2", "--lengths", "1_0,2"], "link lengths must be comma-separated numbers, got '1_0'"),
        (["generate", "--model", "diffdrive", "--track", "\u0660.\u0665"], "must be a positive number"),
        # a second review: a keyword of the commands the target is passed to, and headers <immintrin.h> includes
        (["generate", "--links", "2", "--prefix", "PROPERTIES", "--cmake", "--lang", "c"], "a keyword of the CMake commands"),
        (["generate", "--links", "2", "--prefix", "mmintrin", "--lang", "c"], "mmintrin.h would be read for <mmintrin.h>"),
        (["generate", "--links", "2", "--prefix", "mm_malloc", "--lang", "c"], "mm_malloc.h would be read"),
        # a security review: a superscript three is a digit to str.isdigit, not to int (a traceback)
        (["generate", "--robot", str(ROBOTS / "panda.toml"), "--ik-lock", "\u00b3"], "no joint named '\u00b3' to lock"),
        (["generate", "--robot", str(ROBOTS / "panda.toml"), "--ik-lock", "\u0663"], "no joint named '\u0663' to lock"),
    ],
)
def test_bad_input_is_one_line_and_status_2(args, message, tmp_path):
    r = run(*args, *(["--out", str(tmp_path / "o")] if args[:1] == ["generate"] else []))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("skelarm-sym: error:") and message in lines[0], r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()


def _probe(code: str) -> str:
    """What ``code`` prints, run by this interpreter in a fresh process (which must succeed)."""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_command_freezes_the_collector_at_exit():
    """A command registers gc.freeze to run at exit (Python's shutdown collections then skip the objects of
    the run); while the program runs its collector is on. atexit runs handlers last-in first-out, so the
    probe registered before main() runs after the freeze and finds more objects frozen than while running."""
    probe = (
        "import atexit, gc\n"
        "counts = []\n"
        "atexit.register(lambda: print('frozen at exit', gc.get_freeze_count() > counts[0]))\n"
        "from skelarm_sym.cli import main\n"
        "for _ in range(2):\n"
        "    main(['show', '--links', '2', '--what', 'J', '--format', 'text'])\n"
        "counts.append(gc.get_freeze_count())\n"
        "print('running', gc.isenabled())\n"
    )
    assert _probe(probe).splitlines()[-2:] == ["running True", "frozen at exit True"]


@pytest.mark.parametrize("enabled", [True, False])
@pytest.mark.parametrize("sympy_first", [False, True])
def test_sympy_is_imported_without_collections(enabled, sympy_first):
    """The package imports SymPy with the collector paused (its import would otherwise trigger about ten
    generation-1 collections over its own long-lived objects) and leaves the collector on or off as it
    found it; importing the package never freezes anything (the host program's objects stay collectable)."""
    probe = (
        "import gc\n"
        f"{'import sympy' if sympy_first else ''}\n"
        f"{'' if enabled else 'gc.disable()'}\n"
        "before = [s['collections'] for s in gc.get_stats()]\n"
        "import skelarm_sym\n"
        "import sys; assert 'sympy' in sys.modules\n"
        "print([s['collections'] - b for s, b in zip(gc.get_stats(), before)][1:], gc.isenabled(), gc.get_freeze_count() > 0)\n"
    )
    out = _probe(probe)
    older, state = out.split("]")
    assert sum(int(x) for x in older.strip("[ ").split(",")) <= 2, out
    assert state.split() == [str(enabled), "False"]


def test_generate_runs_with_the_collector_paused(monkeypatch, tmp_path):
    """``generate`` derives and prints with the cyclic collector off (its nodes form no cycles worth a
    collection) and turns it back on afterwards, also when the generation fails."""
    import gc

    import skelarm_sym.generate as generate_module

    seen = []
    real = generate_module.generate

    def spy(*args, **kwargs):
        seen.append(gc.isenabled())
        return real(*args, **kwargs)

    monkeypatch.setattr(generate_module, "generate", spy)
    assert gc.isenabled()
    frozen = gc.get_freeze_count()
    assert main(["generate", "--links", "2", "--out", str(tmp_path / "ok")]) == 0
    assert main(["generate", "--links", "2", "--prefix", "x;y", "--out", str(tmp_path / "bad")]) == 2
    assert seen == [False, False] and gc.isenabled()
    assert gc.get_freeze_count() <= frozen  # called with arguments (a program of its own): nothing frozen


def test_generate_as_the_program_freezes_what_it_built(tmp_path):
    """Run as the command itself (``main()`` reading ``sys.argv``), a successful generation freezes what it
    built before turning the collector back on: the process ends next, and a collection would only walk the
    run's nodes once more."""
    probe = (
        "import gc, sys\n"
        "from skelarm_sym.cli import main\n"
        "before = gc.get_freeze_count()\n"
        f"sys.argv = ['skelarm-sym', 'generate', '--links', '3', '--out', {str(tmp_path / 'ok')!r}]\n"
        "assert main() == 0\n"
        "print(gc.get_freeze_count() > before, gc.isenabled())\n"
    )
    assert _probe(probe).splitlines()[-1] == "True True"


def test_an_empty_out_and_a_file_for_from_are_named_in_one_line(tmp_path, monkeypatch):
    """``--out ""`` wrote into the current folder (Path("") is "."); ``--from FILE`` said "no such folder"."""
    monkeypatch.chdir(tmp_path)
    r = run("generate", "--links", "2", "--out", "")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "output folder is empty text" in r.stderr
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "arm2.h").write_text("/* not a folder */\n")
    for command in ("check", "generate"):
        r = run(command, "--from", str(tmp_path / "arm2.h"))
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and "arm2.h': a file, not a folder" in r.stderr


def test_prefixes_that_differ_in_case_only_are_not_written_side_by_side(tmp_path):
    """--prefix arm, then Arm, in one folder: both headers took the guard ARM_H and the macros ARM_*, so a program
    including both silently lost the second (implicit declaration of Arm_pose), and on a case-insensitive file
    system the files overwrote each other. The second set is refused, in one line, whatever its languages; the
    first stays as it was; a file named alike by hand is not skelarm-sym's and does not count."""
    out = tmp_path / "o"
    assert run("generate", "--links", "2", "--prefix", "arm", "--out", str(out)).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    for lang in ("c", "python"):
        r = run("generate", "--links", "2", "--prefix", "Arm", "--lang", lang, "--out", str(out))
        assert r.returncode == 2 and r.stderr.count("\n") == 1
        assert "is of prefix 'arm', which differs from 'Arm' in case only" in r.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    other = tmp_path / "p"
    other.mkdir()
    (other / "arm.h").write_text("/* the user's own */\n")
    assert run("generate", "--links", "2", "--prefix", "Arm", "--out", str(other)).returncode == 0


def test_an_ik_lock_number_that_is_another_joints_name_is_ambiguous(tmp_path):
    """A security review: in a Panda file whose joint 2 is named "3", ``--ik-lock 3`` locked joint 2, without a word."""
    robot = tmp_path / "panda3.toml"
    robot.write_text((ROBOTS / "panda.toml").read_text().replace('name = "panda_joint2"', 'name = "3"', 1))
    r = run("generate", "--robot", str(robot), "--ik-lock", "3", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and not (tmp_path / "o").exists()
    assert ("--ik-lock 3 is ambiguous: joint number 3 is 'panda_joint3', and joint 2 is named '3'; lock the first by "
            "its name (panda_joint3) or the second by its number (2)") in r.stderr, r.stderr
