"""Errors from a robot file name the file and the culprit, and a robot's name that is a reserved word
still gives usable files (the default prefix is made an identifier, as a URDF's file name is)."""

from __future__ import annotations

from pathlib import Path

import pytest

from skelarm_sym.cli import main
from skelarm_sym.generate import generate
from skelarm_sym.models.chain.loader import load_robot

ONE_JOINT = 'name = "{name}"\nconvention = "standard"\n[[joints]]\nname = "j1"\ntype = "revolute"\na = {a}\n'
SECOND = '[[joints]]\nname = "{name}"\ntype = "revolute"\na = 0.5\n'


@pytest.mark.parametrize("name, prefix", [("long", "long_robot"), ("code", "code_robot"), ("numpy", "numpy_robot"),
                                          ("arm", "arm"), ("params", "params")])
def test_a_reserved_robot_name_gets_a_usable_default_prefix(tmp_path, name, prefix):
    robot = tmp_path / "r.toml"
    robot.write_text(ONE_JOINT.format(name=name, a=1.0))
    chain = load_robot(robot)
    assert chain.name == name and chain.default_prefix == prefix
    result = generate(chain, out=tmp_path / "out", functions="pose")
    assert sorted(p.name for p in result.paths) == sorted(prefix + s for s in (".h", ".c", ".py"))


def test_an_explicit_reserved_prefix_is_still_refused(tmp_path, capsys):
    robot = tmp_path / "r.toml"
    robot.write_text(ONE_JOINT.format(name="arm", a=1.0))
    assert main(["generate", "--robot", str(robot), "--prefix", "long", "--out", str(tmp_path / "out")]) == 2
    assert "prefix 'long' is a reserved word" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_repeated_joint_name_is_named_with_both_rows(tmp_path, capsys):
    robot = tmp_path / "dup.toml"
    robot.write_text(ONE_JOINT.format(name="arm", a=1.0) + SECOND.format(name="elbow") + SECOND.format(name="j1"))
    assert main(["generate", "--robot", str(robot), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"skelarm-sym: error: {robot}: joint names must be distinct: 'j1' names joints[0] and joints[2]"


def test_an_unrepresentable_reach_names_the_file(tmp_path, capsys):
    robot = tmp_path / "big.toml"
    robot.write_text(ONE_JOINT.format(name="arm", a=1e100))
    assert main(["generate", "--robot", str(robot), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"skelarm-sym: error: {robot}: the robot's reach") and "1e+100" in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("limit", ["lower = -1e39", "upper = 3.5e38", "velocity = 1e39"])
def test_a_limit_beyond_float_is_refused_in_float_and_kept_in_double(tmp_path, capsys, limit):
    """Float files wrote `#define Z_Q_MIN {-inff, ...}` and `const float lo[] = { -inff }` (not C) and exited 0."""
    robot = tmp_path / "z.toml"
    robot.write_text(ONE_JOINT.format(name="z", a=1.0) + limit + "\n")
    assert main(["generate", "--robot", str(robot), "--precision", "float", "--out", str(tmp_path / "f")]) == 2
    err = capsys.readouterr().err.strip()
    kind = limit.split()[0]
    assert err.startswith(f"skelarm-sym: error: {robot}: joint 'j1' {kind} limit = ") and "not representable in float" in err, err
    assert not (tmp_path / "f").exists()
    assert main(["generate", "--robot", str(robot), "--out", str(tmp_path / "d"), "--functions", "pose"]) == 0
    header = (tmp_path / "d" / "z.h").read_text()
    value = float(limit.split("=")[1])
    assert f"{value:g}" in header, limit  # the limit itself, in double


@pytest.mark.parametrize("limits, precision, bound", [("lower = 1e15\nupper = 2e15", "double", "4.504e+05"),
                                                       ("lower = -2e15\nupper = -1e15", "double", "4.504e+05"),
                                                       ("lower = 100\nupper = 110", "float", "83.89")])
def test_limits_that_hold_no_resolvable_angle_are_refused(tmp_path, capsys, limits, precision, bound):
    """A revolute range far from zero (an exponent too many) was generated; its solver drew restarts at 1e15 rad,
    where one unit in the last place is 0.125 rad, and `check` failed every IK target."""
    robot = tmp_path / "far.toml"
    robot.write_text(ONE_JOINT.format(name="far", a=1.0) + limits + "\n")
    assert main(["generate", "--robot", str(robot), "--precision", precision, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"skelarm-sym: error: {robot}: joint 'j1' limits [") and f"within {bound} rad of zero" in err, err
    assert precision in err and "\n" not in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("limits", ["lower = -1e16\nupper = 1e16", "lower = 100\nupper = 110", "lower = -1e5\nupper = -1e5"])
def test_wide_or_double_resolvable_limits_are_kept(tmp_path, limits):
    """URDFs write +-1e16 for a joint without limits (example-robot-data's iris rotors); [100, 110] rad resolves in double."""
    robot = tmp_path / "wide.toml"
    robot.write_text(ONE_JOINT.format(name="wide", a=1.0) + limits + "\n")
    assert main(["generate", "--robot", str(robot), "--out", str(tmp_path / "o"), "--functions", "pose"]) == 0


@pytest.mark.parametrize("limit", ["lower = -1e-40", "velocity = 1e-46"])
def test_a_limit_below_floats_smallest_normal_is_zero_in_float(tmp_path, limit):
    """A limit of -1e-40 was refused in float with "use a value between 1.18e-38 and 3.4e+38" (a range that leaves
    out 0 and every negative number); float holds it as 0, as it holds a tiny constant."""
    robot = tmp_path / "t.toml"
    robot.write_text(ONE_JOINT.format(name="t", a=1.0) + limit + "\nupper = 1.0\n")
    assert main(["generate", "--robot", str(robot), "--precision", "float", "--out", str(tmp_path / "f"), "--functions", "pose"]) == 0
    header = (tmp_path / "f" / "t.h").read_text()
    assert "e-40" not in header and "e-46" not in header


def test_compile_without_c_is_refused(tmp_path, capsys):
    """`generate --lang python --compile` exited 0 and compiled nothing, without a word (--cmake refused alike)."""
    scara = str(Path(__file__).resolve().parents[1] / "examples" / "robots" / "scara.toml")
    assert main(["generate", "--robot", scara, "--lang", "python", "--compile", "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip() == "skelarm-sym: error: --compile builds the C: generate with lang 'c'"
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("langs", [None, 5, ["c", 3]])
def test_langs_of_another_type_is_a_value_error(langs):
    """generate(chain, langs=None) raised TypeError: 'NoneType' object is not iterable."""
    chain = load_robot(Path(__file__).resolve().parents[1] / "examples" / "robots" / "scara.toml")
    with pytest.raises(ValueError, match="langs must be a comma-separated string or a sequence of language names"):
        generate(chain, out=None, langs=langs, functions="pose")


def test_a_folder_given_as_the_robot_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="a folder, not a robot file"):
        load_robot(tmp_path)
