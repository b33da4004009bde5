"""``generate --from DIR``: the files in a folder written again from the command their header records.

The header's ``regenerate with`` line is printable ASCII, so a path with a non-ASCII character or a backslash
is printed there escaped (``\\u00E4``), which no shell reads back; those headers say so and name
``generate --from .``, which reads the recorded command exactly. The same command serves files moved away
from their robot file (``--robot FILE``) and a set of mixed generations that records one command."""

from __future__ import annotations

import shlex
import shutil
from pathlib import Path

import pytest

from skelarm_sym.cli import main
from skelarm_sym.generate import file_stamp, recorded_command

ROOT = Path(__file__).resolve().parents[1]
SCARA = ROOT / "examples" / "robots" / "scara.toml"
NAMES = ("scara.h", "scara.c", "scara.py")


def _texts(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _line(text: str) -> str:
    """The command as printed on the header's ``regenerate with`` line (what a user copies)."""
    return next(line for line in text.splitlines() if "regenerate with (in this folder):" in line).split(": ", 1)[1]


@pytest.mark.parametrize("folder_name", ["rob\u00f6ts", "back\\slash"])
def test_a_path_the_header_prints_escaped_is_regenerated_from_the_folder(tmp_path, monkeypatch, capsys, folder_name):
    robot = tmp_path / folder_name / "scara.toml"
    robot.parent.mkdir()
    shutil.copy(SCARA, robot)
    out = tmp_path / "out"
    assert main(["generate", "--robot", str(robot), "--out", str(out), "--functions", "pose,jacobian"]) == 0
    first = _texts(out)
    header = first["scara.h"].decode()
    printed = shlex.split(_line(header))  # the printed line names another file: the shell keeps the escape
    assert f"../{folder_name}/scara.toml" not in printed and "skelarm-sym generate --from ." in header
    assert recorded_command(header).split()[3] == shlex.quote(f"../{folder_name}/scara.toml")
    (out / "scara.c").write_text("edited\n")  # an edited (or half-written) file is written again
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    capsys.readouterr()
    assert main(["generate", "--from", str(out)]) == 0
    assert _texts(out) == first
    assert f"wrote {out / 'scara.c'}" in capsys.readouterr().out
    assert main(["check", "--from", str(out), "--cases", "5"]) == 0


def test_an_ascii_path_prints_no_note():
    header = (ROOT / "generated" / "ur5.h").read_text()
    assert "generate --from" not in header
    assert shlex.split(_line(header))[:4] == ["skelarm-sym", "generate", "--robot", "../examples/robots/ur5.toml"]


def test_a_moved_folder_is_regenerated_with_the_robot_file_it_is_given(tmp_path, capsys):
    robot = tmp_path / "robots" / "scara.toml"
    robot.parent.mkdir()
    shutil.copy(SCARA, robot)
    assert main(["generate", "--robot", str(robot), "--out", str(tmp_path / "dh"), "--functions", "pose"]) == 0
    moved = tmp_path / "sub" / "deeper" / "dh"
    shutil.copytree(tmp_path / "dh", moved)
    before = _texts(moved)
    capsys.readouterr()
    assert main(["generate", "--from", str(moved)]) == 2
    assert "name it with --robot FILE" in capsys.readouterr().err
    assert _texts(moved) == before
    assert main(["generate", "--from", str(moved), "--robot", str(robot)]) == 0
    assert recorded_command((moved / "scara.h").read_text()).split()[3] == "../../../robots/scara.toml"
    assert main(["check", "--from", str(moved), "--cases", "5"]) == 0  # the record names the robot file again


@pytest.mark.parametrize("option", [
    ["--lang", "c"], ["--lang", "c,python"], ["--precision", "float"], ["--out", "other"], ["--functions", "pose"],
    ["--cmake"], ["--tip", "x"], ["--links", "3"], ["--model", "diffdrive"],
])
def test_options_the_files_record_are_refused_with_from(tmp_path, monkeypatch, capsys, option):
    out = tmp_path / "out"
    assert main(["generate", "--robot", str(SCARA), "--out", str(out), "--functions", "pose"]) == 0
    before = _texts(out)
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    assert main(["generate", "--from", str(out), *option]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{option[0]} with --from: the files' header records the options" in err
    assert _texts(out) == before and sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_set_of_mixed_generations_of_one_command_is_written_again_together(tmp_path, capsys):
    """A robot file edited, then a generation killed between renames: scara.py is of the new robot, the C of the
    old. check --from refuses the set and names generate --from, which writes all of it from the robot file."""
    robot = tmp_path / "scara.toml"
    shutil.copy(SCARA, robot)
    out = tmp_path / "out"
    assert main(["generate", "--robot", str(robot), "--out", str(out), "--functions", "pose"]) == 0
    old = _texts(out)
    robot.write_text(SCARA.read_text().replace("a = 0.325", "a = 0.335"))
    assert main(["generate", "--robot", str(robot), "--out", str(out), "--functions", "pose"]) == 0
    new = _texts(out)
    assert new["scara.py"] != old["scara.py"]
    for name in ("scara.h", "scara.c"):
        (out / name).write_bytes(old[name])
    stamps = {file_stamp((out / name).read_text()) for name in NAMES}
    assert len(stamps) == 2
    capsys.readouterr()
    assert main(["check", "--from", str(out)]) == 2
    assert "regenerate them together: skelarm-sym generate --from DIR does" in capsys.readouterr().err
    assert main(["generate", "--from", str(out)]) == 0
    assert _texts(out) == new


DASHED = """<robot name="d"><link name="--base"/><link name="--out=elsewhere"/><link name="--tip"/>
<joint name="j" type="revolute"><parent link="--base"/><child link="--out=elsewhere"/><origin xyz="0 0 0.1"/>
<axis xyz="0 0 1"/></joint>
<joint name="k" type="revolute"><parent link="--out=elsewhere"/><child link="--tip"/><origin xyz="0.2 0 0"/>
<axis xyz="0 1 0"/></joint></robot>
"""


def test_names_that_start_with_a_dash_are_recorded_so_that_they_read_back(tmp_path, monkeypatch, capsys):
    """A security review: links named ``--base`` and ``--out=...`` (and a robot file named ``--cmake.urdf``) were
    recorded as ``--base --base``, which ``generate --from`` and ``check --from`` then refused (``--base: expected one
    argument``). An option whose value starts with ``-`` is recorded ``--base=--base``."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "--cmake.urdf").write_text(DASHED)
    assert main(["generate", "--robot=--cmake.urdf", "--base=--base", "--tip=--tip", "--lang", "c", "--prefix", "d", "--out", "gen"]) == 0
    command = recorded_command((tmp_path / "gen" / "d.h").read_text())
    assert "--robot=../--cmake.urdf" not in command  # relative to gen/: starts with '..', no '=' needed
    assert "--base=--base" in command and "--tip=--tip" in command, command
    capsys.readouterr()
    assert main(["generate", "--from", "gen"]) == 0
    assert main(["check", "--from", "gen", "--cases", "2"]) == 0
    (tmp_path / "gen" / "--cmake.urdf").write_text(DASHED)  # the robot file beside the files: recorded --robot=--cmake.urdf
    assert main(["generate", "--robot=gen/--cmake.urdf", "--base=--base", "--tip=--tip", "--lang", "c", "--prefix", "d", "--out", "gen",
                 "--force"]) == 0
    assert "--robot=--cmake.urdf" in recorded_command((tmp_path / "gen" / "d.h").read_text())
    assert main(["generate", "--from", "gen"]) == 0


def test_check_from_a_folder_for_a_missing_library_names_the_languages_it_can_check(tmp_path, monkeypatch, capsys):
    """A new user's ``check --from`` on a folder holding PyTorch files, without PyTorch, stopped at "torch is not
    installed" and checked nothing; the message now names the --lang that checks the rest."""
    import sys

    assert main(["generate", "--links", "2", "--lang", "c,python,torch", "--out", str(tmp_path / "gen")]) == 0
    capsys.readouterr()
    monkeypatch.setitem(sys.modules, "torch", None)  # import torch raises ImportError
    monkeypatch.delenv("PYTEST_CURRENT_TEST")  # else the backend skips the test instead of refusing
    assert main(["check", "--from", str(tmp_path / "gen"), "--cases", "2"]) == 2
    err = capsys.readouterr().err
    assert "torch is not installed" in err and "or check the folder's other languages: --lang c,python" in err, err
    assert main(["check", "--from", str(tmp_path / "gen"), "--cases", "2", "--lang", "c,python"]) == 0


def test_from_replaces_only_files_skelarm_sym_wrote(tmp_path, capsys):
    """A security review: ``generate --from`` wrote with force on, so a header whose regenerate line was edited to
    add ``--cmake`` (or another language) replaced a hand-written CMakeLists.txt (or .py) beside the set. It refuses
    now, as a plain ``generate`` does, and changes nothing."""
    folder = tmp_path / "gen"
    assert main(["generate", "--links", "2", "--lang", "c", "--out", str(folder)]) == 0
    mine = "# my own build\nproject(mine C)\n"
    (folder / "CMakeLists.txt").write_text(mine)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    for name in ("arm2.h", "arm2.c"):
        path = folder / name
        path.write_text(path.read_text().replace("--out .", "--cmake --out .", 1))
    edited = {p.name: p.read_bytes() for p in folder.iterdir()}
    capsys.readouterr()
    assert main(["generate", "--from", str(folder)]) == 2
    assert "CMakeLists.txt exists and was not generated by skelarm-sym" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == edited and edited["CMakeLists.txt"] == before["CMakeLists.txt"]
    (folder / "CMakeLists.txt").unlink()  # and a language none of whose files it wrote: a hand-written arm2.py
    (folder / "arm2.py").write_text("print('mine')\n")
    for name in ("arm2.h", "arm2.c"):
        path = folder / name
        path.write_text(path.read_text().replace("--cmake --out .", "--out .", 1).replace("--lang c ", "--lang c,python ", 1))
    assert main(["generate", "--from", str(folder)]) == 2
    assert "arm2.py exists and was not generated by skelarm-sym" in capsys.readouterr().err
    assert (folder / "arm2.py").read_text() == "print('mine')\n"
    assert main(["generate", "--from", str(folder), "--force"]) == 0  # as the message says: --force replaces it
    assert "generated by skelarm-sym" in (folder / "arm2.py").read_text()
