"""A folder of emitted files holds one whole set per prefix, or the set it held before: a write that fails
part way (a file that refuses to be replaced, a folder in the way of a name, a compile that fails) leaves
every file as it was and names the file that failed; a set replaced with fewer languages takes the older
set's other files with it (else ``check --from`` meets files of two generations); only files skelarm-sym
wrote for that prefix are ever removed."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from skelarm_sym import files
from skelarm_sym.check import load_generated
from skelarm_sym.cli import main
from skelarm_sym.errors import InputError
from skelarm_sym.generate import file_stamp, generate, recorded_command

needs_cc = pytest.mark.skipif(not (shutil.which("cc") or shutil.which("gcc")), reason="no C compiler")


def _contents(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def test_a_folder_in_the_way_of_one_name_changes_nothing_and_is_named(tmp_path):
    generate(2, out=tmp_path, functions="position")
    before = _contents(tmp_path)
    os.unlink(tmp_path / "arm2.py")
    (tmp_path / "arm2.py").mkdir()
    before.pop("arm2.py")
    with pytest.raises(InputError, match=r"arm2\.py'?: a folder of that name is in the way; no file was changed"):
        generate(2, out=tmp_path, functions="jacobian", force=True)
    assert _contents(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm2.c", "arm2.h", "arm2.py"]


@pytest.mark.parametrize("failing", [1, 2, 3])
def test_a_rename_that_fails_part_way_puts_the_earlier_files_back(tmp_path, monkeypatch, failing):
    """The n-th rename into place fails (as for a file marked immutable): the ones before it had already
    replaced their files; each gets its old text back, and no temporary or kept-aside copy is left."""
    generate(2, out=tmp_path, functions="position")
    before = _contents(tmp_path)
    real_replace = os.replace
    renames = []

    def replace(src, dst):
        if str(src).endswith(".tmp"):
            renames.append(Path(dst).name)
            if len(renames) == failing:
                raise PermissionError(1, "Operation not permitted")
        return real_replace(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    with pytest.raises(InputError, match=rf"cannot write '.*{renames[failing - 1] if renames else ''}.*Operation not permitted; no file was changed"):
        generate(2, out=tmp_path, functions="jacobian", force=True)
    monkeypatch.setattr(files.os, "replace", real_replace)
    assert len(renames) == failing
    assert _contents(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(before)


def test_a_failed_first_write_into_an_empty_folder_leaves_it_empty(tmp_path, monkeypatch):
    real_replace = os.replace
    calls = []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        return real_replace(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    with pytest.raises(InputError, match="arm2.c'?: No space left"):
        generate(2, out=tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_fewer_languages_with_force_remove_the_older_sets_other_files(tmp_path):
    generate(2, out=tmp_path, langs="c,python", functions="position")
    (tmp_path / "arm2_jax.py").write_text("# the user's own file, no recorded command\n")
    generate(2, out=tmp_path / "other", langs="python", prefix="arm2_torch", functions="position")
    os.replace(tmp_path / "other" / "arm2_torch.py", tmp_path / "arm2_torch.py")  # another prefix's file, named like
    os.rmdir(tmp_path / "other")                                                    # arm2's torch file
    kept = {name: (tmp_path / name).read_bytes() for name in ("arm2_jax.py", "arm2_torch.py")}
    old = _contents(tmp_path)
    with pytest.raises(InputError, match=r"arm2\.h was generated with other options .*--force"):
        generate(2, out=tmp_path, langs="c", functions="position")
    assert _contents(tmp_path) == old
    result = generate(2, out=tmp_path, langs="c", functions="position", force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm2.c", "arm2.h", "arm2_jax.py", "arm2_torch.py"]
    assert {name: (tmp_path / name).read_bytes() for name in kept} == kept
    assert file_stamp((tmp_path / "arm2.h").read_text()) == result.stamp
    loaded = load_generated(tmp_path, "arm2")
    assert sorted(loaded.generated.sources) == ["arm2.c", "arm2.h"] and loaded.edited == ()


def test_a_set_in_another_language_alone_is_refused_without_force(tmp_path):
    """No file of the new set exists yet, but the older set's would stay beside it."""
    generate(2, out=tmp_path, langs="python", functions="position")
    old = _contents(tmp_path)
    with pytest.raises(InputError, match=r"arm2\.py is from an earlier set of 'arm2' generated with other options .*--force"):
        generate(2, out=tmp_path, langs="c", functions="position")
    assert _contents(tmp_path) == old
    generate(2, out=tmp_path, langs="c", functions="position", force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm2.c", "arm2.h"]


def test_a_removal_that_fails_puts_every_file_back(tmp_path, monkeypatch):
    generate(2, out=tmp_path, langs="c,python", functions="position")
    before = _contents(tmp_path)
    real_unlink = os.unlink

    def unlink(path, *args, **kwargs):
        if Path(path).name == "arm2.py":
            raise PermissionError(1, "Operation not permitted")
        return real_unlink(path, *args, **kwargs)

    monkeypatch.setattr(files.os, "unlink", unlink)
    with pytest.raises(InputError, match=r"arm2\.py'?: Operation not permitted; no file was changed"):
        generate(2, out=tmp_path, langs="c", functions="jacobian", force=True)
    monkeypatch.setattr(files.os, "unlink", real_unlink)
    assert _contents(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(before)


def test_the_cmake_file_is_part_of_the_recorded_set(tmp_path):
    """``--cmake`` is recorded in every file's command (the stamp covers CMakeLists.txt): the header's command
    writes the CMake file again, ``check --from`` regenerates the set as it was, and a set replaced without
    ``--cmake`` does not leave a CMakeLists.txt that names the older generation's stamp."""
    result = generate(3, out=tmp_path, cmake=True, functions="position")
    for name in ("arm3.h", "arm3.c", "arm3.py", "CMakeLists.txt"):
        command = recorded_command((tmp_path / name).read_text())
        assert command is not None and command.split().count("--cmake") == 1, (name, command)
    assert file_stamp((tmp_path / "CMakeLists.txt").read_text()) == result.stamp
    assert load_generated(tmp_path).edited == ()
    with pytest.raises(InputError, match="other options"):
        generate(3, out=tmp_path, functions="position")
    generate(3, out=tmp_path, functions="position", force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm3.c", "arm3.h", "arm3.py"]


@needs_cc
def test_a_failed_compile_writes_no_file(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    assert main(["generate", "--links", "2", "--out", str(out), "--compile"]) != 0
    assert "no-such-compiler" in capsys.readouterr().err
    assert not out.exists()
    generate(2, out=out, functions="position")
    before = _contents(out)
    assert main(["generate", "--links", "2", "--out", str(out), "--compile", "--force"]) != 0
    assert _contents(out) == before
    monkeypatch.delenv("CC")
    assert main(["generate", "--links", "2", "--out", str(out), "--compile", "--force"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert [line for line in printed if line.startswith("wrote")] == [f"wrote {out / n}" for n in ("arm2.h", "arm2.c", "arm2.py")]
    assert printed[-1].startswith("compiled ") and printed[-1].endswith("libarm2.so")


def test_a_failed_write_into_new_folders_removes_them(tmp_path, monkeypatch):
    """A full disk while writing into --out new/deep: the error said no file was changed, but new/deep stayed."""
    def replace(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(files.os, "replace", replace)
    with pytest.raises(InputError, match="No space left"):
        generate(2, out=tmp_path / "new" / "deep")
    assert list(tmp_path.iterdir()) == []


def test_another_prefixs_cmake_file_is_named_as_such(tmp_path):
    """The message said 'CMakeLists.txt was generated with other options': it is another prefix's file."""
    generate(2, out=tmp_path, langs="c", cmake=True, functions="position")
    with pytest.raises(InputError, match=r"CMakeLists\.txt belongs to prefix 'arm2' .*: a folder holds one CMakeLists\.txt"):
        generate(3, out=tmp_path, langs="c", cmake=True, functions="position")
    with pytest.raises(InputError, match=r"arm2\.h was generated with other options"):  # its own prefix: as before
        generate(2, out=tmp_path, langs="c", cmake=True, functions="jacobian")


def test_the_same_robot_through_a_symbolic_link_is_the_same_option(tmp_path, capsys):
    """A folder reached through a link made the same robot file count as "other options" (the recorded paths
    differ as text); a copy of the file elsewhere is still another option."""
    real = tmp_path / "real"
    real.mkdir()
    shutil.copy(Path(__file__).resolve().parents[1] / "examples" / "robots" / "scara.toml", real / "scara.toml")
    (tmp_path / "link").symlink_to(real, target_is_directory=True)
    shutil.copy(real / "scara.toml", tmp_path / "copy.toml")
    out = str(tmp_path / "out")
    assert main(["generate", "--robot", str(real / "scara.toml"), "--out", out, "--functions", "pose"]) == 0
    assert main(["generate", "--robot", str(tmp_path / "link" / "scara.toml"), "--out", out, "--functions", "pose"]) == 0
    capsys.readouterr()
    assert main(["generate", "--robot", str(tmp_path / "copy.toml"), "--out", out, "--functions", "pose"]) == 2
    assert "was generated with other options" in capsys.readouterr().err
    assert main(["check", "--from", out]) == 0


def test_an_output_folder_through_a_link_records_the_path_the_system_resolves(tmp_path, capsys):
    """--out through a link to a deeper folder recorded the robot as ../../a/x.toml, counted from where the link
    sits; the system resolves it from the link's target, so check --from said 'no such file'. And
    link/../q.toml loaded one file and recorded another (the lexical ..)."""
    robots = Path(__file__).resolve().parents[1] / "examples" / "robots"
    (tmp_path / "a").mkdir()
    (tmp_path / "x" / "y" / "z").mkdir(parents=True)
    shutil.copy(robots / "scara.toml", tmp_path / "a" / "x.toml")
    (tmp_path / "deep").symlink_to(tmp_path / "x" / "y" / "z", target_is_directory=True)
    out = tmp_path / "deep" / "g"
    assert main(["generate", "--robot", str(tmp_path / "a" / "x.toml"), "--out", str(out), "--functions", "pose"]) == 0
    assert main(["check", "--from", str(out)]) == 0
    recorded = recorded_command((out / "scara.h").read_text())
    robot = recorded.split("--robot ")[1].split()[0]
    assert (tmp_path / "x" / "y" / "z" / "g" / robot).resolve() == (tmp_path / "a" / "x.toml").resolve()
    shutil.copy(robots / "ur5.toml", tmp_path / "x" / "y" / "q.toml")  # what deep/../q.toml names
    shutil.copy(robots / "puma560.toml", tmp_path / "q.toml")  # what it names lexically
    capsys.readouterr()
    assert main(["generate", "--robot", str(tmp_path / "deep" / ".." / "q.toml"), "--out", str(tmp_path / "g7"),
                 "--functions", "pose"]) == 0
    assert main(["check", "--from", str(tmp_path / "g7")]) == 0, capsys.readouterr()
