"""No tracebacks: file-system trouble and bad options end in one line and a non-zero exit (issue 12, part 3)."""

import errno
import math
import subprocess
import sys
import time

import pytest

from skelarm_sym.cli import build_parser, main
from skelarm_sym.models.planar.show import SHOW_MAX_LINKS


def one_line_error(capsys, args, status=2):
    """Run the CLI in-process; assert the status and a single ``skelarm-sym: error:`` line; return it."""
    assert main(args) == status
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skelarm-sym: error: "), err
    return err[0]


def test_output_path_too_long_for_the_file_system(tmp_path, capsys):
    long = tmp_path / ("x" * 300)
    line = one_line_error(capsys, ["generate", "--links", "2", "--out", str(long)])
    assert "File name too long" in line
    nested = tmp_path / "ok" / ("y" * 300) / "z"
    assert "File name too long" in one_line_error(capsys, ["generate", "--links", "2", "--out", str(nested)])
    assert list(tmp_path.iterdir()) == []  # nothing left behind (not even tmp_path/ok)


def test_plot_into_a_folder_that_cannot_be_written(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    line = one_line_error(capsys, ["show", "--links", "2", "--plot", "/proc/arm.png"])  # not writable even for root
    assert "cannot write plot '/proc/arm.png'" in line
    line = one_line_error(capsys, ["show", "--links", "2", "--plot", str(tmp_path / ("x" * 300) / "a.png")])
    assert "File name too long" in line
    line = one_line_error(capsys, ["show", "--links", "2", "--plot", str(tmp_path / "missing" / "a.png")])
    assert "does not exist" in line


def test_negative_seed(capsys):
    assert "--seed must be a whole number >= 0, got -1" in one_line_error(capsys, ["check", "--links", "2", "--seed", "-1"])


def test_any_other_os_error_during_generate(monkeypatch, tmp_path, capsys):
    import skelarm_sym.generate as gen

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "arm2.c"))

    monkeypatch.setattr(gen, "generate", full)
    line = one_line_error(capsys, ["generate", "--links", "2", "--out", str(tmp_path)], status=1)
    assert line == f"skelarm-sym: error: No space left on device: {tmp_path / 'arm2.c'}"


@pytest.mark.parametrize("prefix", ["os", "sys", "collections", "json", "random"])
def test_prefix_shadowing_a_standard_module_is_refused_for_python(prefix, tmp_path, capsys):
    line = one_line_error(capsys, ["generate", "--links", "2", "--prefix", prefix, "--out", str(tmp_path / "o")])
    assert f"prefix {prefix!r} is a Python standard module" in line
    assert not (tmp_path / "o").exists()


def test_prefix_of_a_standard_module_is_fine_for_c_only(tmp_path, capsys):
    assert main(["generate", "--links", "2", "--prefix", "collections", "--lang", "c", "--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["collections.c", "collections.h"]


def test_python_api_refuses_shadowing_prefix():
    from skelarm_sym.errors import InputError
    from skelarm_sym.generate import generate

    with pytest.raises(InputError, match="standard module"):
        generate(2, prefix="os", out=None)


def test_show_of_a_long_chain_is_refused_quickly():
    start = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "skelarm_sym", "show", "--links", "300"], capture_output=True, text=True, timeout=60)
    elapsed = time.perf_counter() - start
    assert r.returncode == 2 and elapsed < 20, (r.returncode, elapsed)
    assert r.stderr.strip() == (
        f"skelarm-sym: error: show prints closed forms up to {SHOW_MAX_LINKS} links (they grow as n^2 terms), got 300; "
        "use 'skelarm-sym generate --links 300' for code in step form, or show --plot for a picture"
    )


def test_show_at_the_limit_still_prints(capsys):
    assert main(["show", "--links", str(SHOW_MAX_LINKS), "--what", "p", "--format", "text"]) == 0
    out = capsys.readouterr().out
    assert f"l{SHOW_MAX_LINKS}*cos(q1 + " in out


def test_a_refusal_for_other_options_comes_before_the_derivation(tmp_path, monkeypatch, capsys):
    """Files generated with other options in the target folder are refused before the derivation where the
    options besides the function list differ (a new user's probe: an all-functions generate into a folder of
    pose-only files derived every function, seconds for a large chain, before it refused); a function list that
    asks for fewer functions than the files record is refused before it too; one with names they do not record is
    refused after the derivation that settles it; the same options regenerate."""
    import dataclasses

    import skelarm_sym.generate as generation

    out = tmp_path / "gen"
    assert main(["generate", "--links", "3", "--functions", "jacobian", "--out", str(out)]) == 0
    derived, kind_of = [], generation.kind_of

    def counting(model):  # the model's kind, its derivations counted
        kind = kind_of(model)
        return dataclasses.replace(kind, derive=lambda *a, **k: derived.append(1) or kind.derive(*a, **k))

    monkeypatch.setattr(generation, "kind_of", counting)
    for argv in (["--functions", "jacobian", "--precision", "float"], []):  # other options: no derivation
        assert main(["generate", "--links", "3", *argv, "--out", str(out)]) == 2
        assert "was generated with other options" in capsys.readouterr().err
    assert derived == []
    assert main(["generate", "--links", "3", "--functions", "position", "--out", str(out)]) == 2  # after deriving
    assert "was generated with other options" in capsys.readouterr().err and derived == [1]
    assert main(["generate", "--links", "3", "--functions", "jacobian", "--out", str(out)]) == 0
    # fewer functions than the files record: refused before deriving (names they record exist); a name they do not
    # record waits for the derivation, which tells an unknown one
    both = tmp_path / "both"
    assert main(["generate", "--links", "3", "--functions", "jacobian,position", "--out", str(both)]) == 0
    derived.clear()
    assert main(["generate", "--links", "3", "--functions", "position", "--out", str(both)]) == 2
    assert "was generated with other options" in capsys.readouterr().err and derived == []
    assert main(["generate", "--links", "3", "--functions", "position,positon", "--out", str(both)]) == 2
    assert "unknown function 'positon'" in capsys.readouterr().err and derived == [1]
    assert main(["generate", "--links", "3", "--functions", "position,jacobian", "--out", str(both)]) == 0


def test_pose_without_plot_is_refused_instead_of_ignored(capsys):
    """``show --links 2 --pose 1,nan`` printed the closed forms and exited 0: the angles (even a NaN) were
    never read."""
    line = one_line_error(capsys, ["show", "--links", "2", "--pose", "1,0.5"])
    assert "--pose sets the joint angles of --plot: add --plot FILE" in line
    assert main(["show", "--links", "2"]) == 0


def test_pose_in_degrees_is_caught_and_can_be_written(tmp_path, capsys):
    """``--pose 90,45`` drew an arm at 90 and 45 rad, silently: degrees typed for radians. A value beyond a turn is
    refused with the spelling that works (``90deg``), and that spelling gives the degrees' radians."""
    line = one_line_error(capsys, ["show", "--links", "2", "--pose", "90,45", "--plot", str(tmp_path / "a.png")])
    assert "joint angle '90' is more than a turn: angles are in radians (for degrees write 90deg)" in line
    assert "not finite" in one_line_error(capsys, ["show", "--links", "2", "--pose", "1,inf", "--plot", "a.png"])
    # as the other numbers of the command line: ASCII, no _ (Python reads "\u0663" as 3)
    assert "got '\u0663'" in one_line_error(capsys, ["show", "--links", "2", "--pose", "1,\u0663", "--plot", "a.png"])
    assert list(tmp_path.iterdir()) == []
    args = build_parser().parse_args(["show", "--links", "2", "--pose", "30deg, -45DEG,0.5", "--plot", "a.png"])
    assert args.pose == pytest.approx((math.pi / 6, -math.pi / 4, 0.5), rel=1e-15)


def test_a_function_the_model_has_not_says_why(tmp_path, capsys):
    """--links 2 --functions inverse_velocity3 said "unknown function", though the function exists from 3 links."""
    assert main(["generate", "--links", "2", "--functions", "inverse_velocity3", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("skelarm-sym: error: function 'inverse_velocity3' needs 3 links or more"), err
    assert not (tmp_path / "o").exists()


def test_an_unknown_option_names_the_one_meant(capsys):
    """``--language c`` said only ``unrecognized arguments``; now the option it is near, or the command that takes
    it, is named (a new user's report). ``--lang py`` is python, as ``numpy`` is."""
    line = one_line_error(capsys, ["generate", "--links", "2", "--language", "c", "--out", "x"])
    assert line.endswith("unrecognized arguments: --language c (--language: did you mean --lang?)")
    line = one_line_error(capsys, ["generate", "--links", "2", "--seed", "3", "--out", "x"])
    assert line.endswith("(--seed is an option of check)")
    assert one_line_error(capsys, ["check", "--links", "2", "--sead", "3"]).endswith("(--sead: did you mean --seed?)")


def test_lang_py_is_python(tmp_path, capsys):
    assert main(["generate", "--links", "2", "--lang", "py", "--out", str(tmp_path)]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["arm2.py"]


@pytest.mark.parametrize("model", [["--links", "2"], ["--model", "diffdrive"]])
def test_expand_is_refused_where_nothing_is_abbreviated(model, capsys):
    """``show --expand`` was accepted silently for a planar arm and the diff drive, whose forms are printed in full."""
    assert "--expand applies to --robot" in one_line_error(capsys, ["show", *model, "--expand"])


def test_a_robot_file_that_is_a_pipe_is_refused_not_waited_on(tmp_path):
    """A security review: ``--robot fifo.toml`` (a named pipe; a tarball can carry one) waited for a writer forever,
    also through ``check --from``'s recorded robot file. A robot file must be a regular file."""
    import os

    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    r = subprocess.run([sys.executable, "-m", "skelarm_sym", "show", "--robot", str(fifo)], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 2 and "not a regular file (a pipe or a device)" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
