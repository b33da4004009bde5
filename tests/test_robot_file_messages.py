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


@pytest.mark.parametrize("name, prefix", [("torch", "torch_robot"), ("jax", "jax_robot"), ("cupy", "cupy_robot"),
                                          ("test", "test_robot"), ("install", "install_robot"), ("m", "m_robot"),
                                          ("PUBLIC", "PUBLIC_robot"), ("CMAKE_arm", "robot_CMAKE_arm_robot")])
def test_a_robot_named_as_a_module_or_a_cmake_target_gets_a_prefix_every_output_takes(tmp_path, name, prefix):
    """A probe: a TOML robot named ``torch`` (``jax``, ``cupy``) was refused with "prefix 'torch' is a module the emitted
    Python imports" for a --prefix it never gave, and ``test``/``m`` with --cmake ("CMake reserves the target name"),
    where a reserved word gets ``_robot``; ``test.py`` (not in sys.stdlib_module_names) could shadow Python's ``test``
    package. Every such name now gets a default prefix that every language and --cmake take."""
    robot = tmp_path / "r.toml"
    robot.write_text(ONE_JOINT.format(name=name, a=1.0))
    chain = load_robot(robot)
    assert chain.name == name and chain.default_prefix == prefix
    result = generate(chain, out=tmp_path / "out", functions="pose", langs="c,python,torch,jax", cmake=True)
    assert {prefix + ".h", prefix + ".py", prefix + "_torch.py", "CMakeLists.txt"} <= {p.name for p in result.paths}


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
    assert capsys.readouterr().err.strip() == ("skelarm-sym: error: --compile builds the C: generate with lang 'c' (or "
                                               "'cpython', which writes it too)")
    assert not (tmp_path / "o").exists()


def test_compile_and_cmake_take_the_c_that_cpython_writes(tmp_path, capsys):
    """A probe: `--lang cpython` writes the C its extension includes, yet `--lang cpython --compile` was refused with
    "generate with lang 'c'". It compiles now, and --cmake takes that C too."""
    scara = str(Path(__file__).resolve().parents[1] / "examples" / "robots" / "scara.toml")
    out = tmp_path / "o"
    assert main(["generate", "--robot", scara, "--lang", "cpython", "--compile", "--cmake", "--functions", "pose",
                 "--out", str(out)]) == 0
    assert "compiled " in capsys.readouterr().out
    assert {p.name for p in out.iterdir()} == {"scara.h", "scara.c", "scara.ext.c", "CMakeLists.txt"}


@pytest.mark.parametrize("langs", [None, 5, ["c", 3]])
def test_langs_of_another_type_is_a_value_error(langs):
    """generate(chain, langs=None) raised TypeError: 'NoneType' object is not iterable."""
    chain = load_robot(Path(__file__).resolve().parents[1] / "examples" / "robots" / "scara.toml")
    with pytest.raises(ValueError, match="langs must be a comma-separated string or a sequence of language names"):
        generate(chain, out=None, langs=langs, functions="pose")


def test_a_folder_given_as_the_robot_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="a folder, not a robot file"):
        load_robot(tmp_path)


@pytest.mark.parametrize("text", ["1_0", "0x1", "0o7", "0b1", "\uff50\uff49/8", "1e1_0", "pi\u00a0/2"])
def test_an_expression_takes_decimal_numbers_only(tmp_path, capsys, text):
    """A probe: TOML expression strings took Python's spellings, ``a = "1_0"`` as 10, ``theta = "0x1"`` as 1 and a
    full-width ``pi`` (Python folds it) as pi, where a URDF refuses ``0_5`` and the command line non-ASCII digits.
    Now one line naming the value, exit 2, no files."""
    robot = tmp_path / "r.toml"
    robot.write_text(ONE_JOINT.format(name="arm", a=f'"{text}"'), encoding="utf-8")
    assert main(["generate", "--robot", str(robot), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "joints[0].a: cannot parse" in err, err
    assert not (tmp_path / "out").exists()
    for fine, value in (("1e1", 10.0), ("0.5 + pi/2", 2.0707963267948966), (" 2 * (1 + 1) ", 4.0)):
        robot.write_text(ONE_JOINT.format(name="arm", a=f'"{fine}"'))
        assert float(load_robot(robot).joints[0].after.translation[0]) == pytest.approx(value, rel=1e-15)
