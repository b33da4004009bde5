"""TOML robot files (skelarm_sym.models.chain.dh_file): bad input, named parameters, exact angles,
and the example robots."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from skelarm_sym.errors import InputError
from skelarm_sym.models.chain.dh_file import load_robot_file
from skelarm_sym.reference import chain_kinematics

ROBOTS = Path(__file__).resolve().parent.parent / "examples" / "robots"
REV = '[[joints]]\ntype = "revolute"\n'


def write(tmp_path: Path, text: str | bytes, name: str = "robot.toml") -> Path:
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


# -- bad input: one line, naming the file and the problem ----------------------------------------------

BAD = {
    "not_toml": ("name = = 3\n", r"not valid TOML"),
    "huge_theta": (REV + "theta = 1e20\n", r"joints\[0\]\.theta 1e\+20 rad is beyond \+-100000 rad"),
    "huge_alpha_expression": (REV + 'alpha = "1e6*pi"\n', r"joints\[0\]\.alpha 3\.14159e\+06 rad is beyond"),
    # degrees typed where the file reads radians (a new user's report: alpha = 90 was taken as 90 rad)
    "degrees_alpha": (REV + "alpha = 90\n", r"joints\[0\]\.alpha = '90' is 90 rad, more than a turn: angles are in radians "
                                           r"\(for 90 degrees write \"90\*pi/180\"\)"),
    "degrees_theta_expression": (REV + 'theta = "-180"\n', r"joints\[0\]\.theta = '-180' is -180 rad, more than a turn"),
    "degrees_rpy": (REV + "[base]\nrpy = [0, 0, 45]\n", r"base\.rpy\[2\] = '45' is 45 rad, more than a turn"),
    "not_utf8": (b"\xff\xfe\x00name", r"not valid TOML"),
    "unknown_top_key": (REV + "[extra]\nx = 1\n", r"unknown key 'extra'"),
    "unknown_joint_key": (REV + "length = 1.0\n", r"joints\[0\]: unknown key 'length'"),
    "unknown_frame_key": (REV + "[tool]\nquat = [1, 0, 0, 0]\n", r"tool: unknown key 'quat'"),
    "unknown_type": ('[[joints]]\ntype = "spherical"\n', r"joints\[0\]\.type must be revolute or prismatic, got 'spherical'"),
    "type_not_string": ("[[joints]]\ntype = 1\n", r"joints\[0\]\.type must be revolute or prismatic"),
    "unknown_convention": ('convention = "craig"\n' + REV, r"convention must be standard or modified, got 'craig'"),
    "joint_without_type": ("[[joints]]\na = 0.5\n", r"joints\[0\]: missing type"),
    "second_joint_without_type": (REV + "[[joints]]\nd = 0.5\n", r"joints\[1\]: missing type"),
    "nan_literal": (REV + "a = nan\n", r"joints\[0\]\.a must be finite"),
    "inf_literal": (REV + "alpha = -inf\n", r"joints\[0\]\.alpha must be finite"),
    "nan_string": (REV + 'd = "nan"\n', r"joints\[0\]\.d: 'nan' is not finite"),
    "inf_string": (REV + 'theta = "inf"\n', r"joints\[0\]\.theta: 'inf' is not finite"),
    "overflowing_expression": (REV + 'a = "1e308*10"\n', r"joints\[0\]\.a: '1e308\*10' is not finite"),
    "nan_limit": (REV + "lower = nan\n", r"joints\[0\]\.lower must be a finite number"),
    "inf_in_tool": (REV + "[tool]\nxyz = [0.0, inf, 0.0]\n", r"tool\.xyz\[1\] must be finite"),
    "nan_in_base_rpy": (REV + "[base]\nrpy = [0.0, 0.0, nan]\n", r"base\.rpy\[2\] must be finite"),
    "bad_expression": (REV + 'alpha = "pi/+"\n', r"joints\[0\]\.alpha: cannot parse 'pi/\+'"),
    "power_is_not_allowed": (REV + 'a = "2**3"\n', r"joints\[0\]\.a: cannot parse '2\*\*3'"),
    "division_by_zero": (REV + 'a = "1/0"\n', r"joints\[0\]\.a: division by zero"),
    "no_joints": ('name = "arm"\n', r"no joints"),
    "empty_joints": ("joints = []\n", r"no joints"),
    "joint_not_table": ("joints = [1, 2]\n", r"joints\[0\] must be a table"),
    "parameter_starts_with_digit": (REV + 'a = "2a"\n', r"joints\[0\]\.a: cannot parse '2a'"),
    "parameter_with_dash": (REV + 'a = "arm-length"\n', r"joints\[0\]\.a: cannot parse 'arm-length'"),
    "parameter_not_ascii": (REV + 'a = "länge"\n', r"joints\[0\]\.a: cannot parse"),
    "parameter_c_keyword": (REV + 'a = "double"\n', r"parameter name 'double' is a reserved word"),
    "parameter_clashes_with_argument": (REV + 'a = "q"\n', r"parameter name 'q' is a reserved word"),
    # a derivation's own symbols (a security review): "_ch_c1" made wrong code with exit 0, "_ch_W2z" hung generate
    "parameter_is_a_step_name": (REV + 'a = "_ch_c1"\n', r"parameter name '_ch_c1' starts with _, as the derivation's own"),
    "parameter_is_an_ik_target_entry": (REV + 'a = "target3"\n', r"parameter name 'target3' is a reserved word"),
    "parameter_is_the_lock": (REV + 'a = "lock_c"\n', r"parameter name 'lock_c' is a reserved word"),
    "boolean_value": (REV + "a = true\n", r"joints\[0\]\.a must be a number or a string expression, got bool"),
    "short_rpy": (REV + "[base]\nrpy = [0.0, 0.0]\n", r"base\.rpy must be a list of three numbers"),
    "robot_name_not_identifier": ('name = "3d-arm"\n' + REV, r"name must be a C identifier"),
    "robot_name_quoted_once": ("name = \"'x */ y\"\n" + REV, r"name must be a C identifier .*, got \"'x \*/ y\"$"),
    "duplicate_joint_names": ('[[joints]]\ntype = "revolute"\nname = "j"\n' * 2, r"joint names must be distinct"),
    "lower_above_upper": (REV + "lower = 1.0\nupper = -1.0\n", r"lower limit 1\.0 is above upper limit -1\.0"),
    "negative_velocity": (REV + "velocity = -2.0\n", r"joints\[0\]\.velocity must be positive"),
    # long or deep values (issue 16): one line naming the key, whatever the size
    "expression_too_long": (REV + 'theta = "' + "+".join(["1"] * 200) + '"\n',
                            r"joints\[0\]\.theta: the expression '(1\+){20}'\.\.\. \(399 characters\) is longer than 256 characters"),
    "expression_too_deep": (REV + 'theta = "' + "-" * 100 + '1"\n',
                            r"joints\[0\]\.theta: the expression '-+'\.\.\. \(101 characters\) nests operators and parentheses more than 64 levels deep"),
    "parameter_name_too_long": (REV + 'a = "' + "p" * 49 + '"\n', r"joints\[0\]\.a: parameter name 'p{40}'\.\.\. \(49 characters\) is longer than 48 characters"),
    "integer_beyond_double": (REV + "a = " + "9" * 400 + "\n", r"joints\[0\]\.a must be finite, got an integer of 400 digits"),
    "integer_of_5000_digits": (REV + "a = " + "9" * 5000 + "\n", r"not valid TOML: Exceeds the limit \(4300 digits\)"),
    "deep_array": ("x = " + "[" * 600 + "]" * 600 + "\n" + REV, r"line 1: key 'x' nests arrays or inline tables more than 32 deep"),
    "deep_array_in_joint": (REV + "a = 1\n" + REV + "d = " + "[" * 600 + "]" * 600 + "\n",
                            r"line 6: key 'joints\[1\]\.d' nests arrays or inline tables more than 32 deep"),
    "deep_inline_table": (REV + "[tool]\nxyz = " + "{a = " * 600 + "1" + "}" * 600 + "\n",
                          r"line 4: key 'tool\.xyz' nests arrays or inline tables more than 32 deep"),
    # joint limits: numbers or expressions of numbers and pi, not parameters
    "limit_names_a_parameter": (REV + 'lower = "qmin"\n', r"joints\[0\]\.lower must be a number or an expression of numbers and pi \(\"-155\*pi/180\"\), not the name 'qmin'"),
    "limit_expression_bad": (REV + 'upper = "pi/"\n', r"joints\[0\]\.upper: cannot parse 'pi/'"),
    "limit_expression_not_finite": (REV + 'velocity = "1e308*10"\n', r"joints\[0\]\.velocity: '1e308\*10' is not finite"),
    "limit_expression_too_long": (REV + 'lower = "' + "-1" * 200 + '"\n', r"joints\[0\]\.lower: the expression .* is longer than 256 characters"),
    "limit_expressions_reversed": (REV + 'lower = "pi/2"\nupper = "-pi/2"\n', r"lower limit 1\.5707963267948966 is above upper limit -1\.5707963267948966"),
    "limit_expression_velocity_zero": (REV + 'velocity = "pi-pi"\n', r"joints\[0\]\.velocity must be positive"),
    # text: printable only
    "name_with_newline": ('name = "arm\\nx"\n' + REV, r"name 'arm\\nx' holds the control character U\+000A; robot-file names must be printable text"),
    "description_with_bidi": ('description = "a\\u202Eb"\n' + REV, r"description 'a\\u202eb' holds the control character U\+202E \(RIGHT-TO-LEFT OVERRIDE\); robot-file descriptions"),
    "description_with_line_separator": ('description = "a\\u2028b"\n' + REV, r"description 'a\\u2028b' holds the control character U\+2028 \(LINE SEPARATOR\)"),
    "joint_name_with_tab": (REV + 'name = "pan\\tx"\n', r"joints\[0\]\.name 'pan\\tx' holds the control character U\+0009"),
    "joint_name_with_zero_width_joiner": (REV + 'name = "pan\\u200Dx"\n', r"joints\[0\]\.name 'pan\\u200dx' holds the control character U\+200D"),
    "unknown_key_with_newline": ('"a\\nb" = 1\n' + REV, r"unknown key 'a\\nb'"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_is_one_line_naming_file_and_problem(tmp_path, case):
    text, pattern = BAD[case]
    path = write(tmp_path, text, f"{case}.toml")
    with pytest.raises(InputError) as info:
        load_robot_file(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: "), message
    assert len(message) < 300
    assert re.search(pattern, message), message


@pytest.mark.parametrize("case", ["deep_array", "deep_inline_table"])
def test_deep_values_are_refused_whatever_the_recursion_limit(tmp_path, case):
    """tomllib reads 600 levels where the stack allows it (PyTorch's compiler raises the limit on import): the
    file is refused all the same, with the same message."""
    import sys

    text, pattern = BAD[case]
    path = write(tmp_path, text, f"{case}.toml")
    old = sys.getrecursionlimit()
    sys.setrecursionlimit(20000)
    try:
        with pytest.raises(InputError, match=pattern):
            load_robot_file(path)
    finally:
        sys.setrecursionlimit(old)


HUGE = {  # issue 16's cases, each 100 000 deep or long: exit 1 without a file name, or a traceback, before
    "nested_arrays": ("x = " + "[" * 100_000 + "]" * 100_000 + "\n" + REV, "line 1: key 'x' nests arrays or inline tables more than 32 deep"),
    "nested_arrays_in_a_joint": (REV + "a = " + "[" * 100_000 + "]" * 100_000 + "\n",
                                 "line 3: key 'joints[0].a' nests arrays or inline tables more than 32 deep"),
    "sum_of_ones": (REV + 'theta = "' + "+".join(["1"] * 100_000) + '"\n',
                    "joints[0].theta: the expression '" + "1+" * 20 + "'... (199999 characters) is longer than 256 characters"),
    "unary_minus": (REV + 'theta = "' + "-" * 100_000 + '1"\n',
                    "joints[0].theta: the expression '" + "-" * 40 + "'... (100001 characters) is longer than 256 characters"),
    "unary_minus_limit": (REV + 'lower = "' + "-" * 100_000 + '1"\n',
                          "joints[0].lower: the expression '" + "-" * 40 + "'... (100001 characters) is longer than 256 characters"),
    "long_description": ('description = "' + "x" * 100_000 + '\\n"\n' + REV,
                         "description '" + "x" * 80 + "'... (100001 characters) holds the control character U+000A at character 100001;"),
}


@pytest.mark.parametrize("case", sorted(HUGE))
def test_deep_or_long_values_are_one_line_naming_file_and_key(tmp_path, case):
    text, expected = HUGE[case]
    path = write(tmp_path, text, f"{case}.toml")
    with pytest.raises(InputError) as info:
        load_robot_file(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {expected}"), message
    assert "\n" not in message and len(message) < 400


def test_files_over_the_size_limit_are_refused_unread(tmp_path):
    from skelarm_sym.models.chain import dh_file

    assert dh_file.MAX_TOML_BYTES == 1024 * 1024
    text = REV + "# " + "x" * dh_file.MAX_TOML_BYTES + "\n"
    path = write(tmp_path, text, "big.toml")
    with pytest.raises(InputError) as info:
        load_robot_file(path)
    assert str(info.value) == f"{path}: larger than 1 MiB: a robot file is read only up to that size"
    path.write_text(REV + "# " + "x" * (dh_file.MAX_TOML_BYTES - 100) + "\n")  # just below: read
    assert load_robot_file(path).n == 1


def test_limits_accept_expressions_like_angles(tmp_path):
    text = (REV + 'lower = "-155*pi/180"\nupper = "pi"\nvelocity = "pi/2"\n'
            + '[[joints]]\ntype = "prismatic"\nlower = "-0.5/2"\nupper = "1/4"\nvelocity = 0.5\n'
            + REV + "lower = -1\nupper = 2.5\n")
    chain = load_robot_file(write(tmp_path, text))
    assert chain.limits() == {
        "lower": (-155 * math.pi / 180, -0.25, -1.0),
        "upper": (math.pi, 0.25, 2.5),
        "velocity": (math.pi / 2, 0.5, None),
    }
    assert all(type(v) is float for values in chain.limits().values() for v in values if v is not None)


def test_missing_file_and_folder(tmp_path):
    with pytest.raises(InputError, match=r"no such file"):
        load_robot_file(tmp_path / "absent.toml")
    with pytest.raises(InputError, match=r"is a folder"):
        load_robot_file(tmp_path)


# -- named parameters --------------------------------------------------------------------------------------

TWO_LINK = """
name = "two"
[[joints]]
type = "revolute"
a = "a1"
[[joints]]
type = "revolute"
a = "a2"
d = "d2"
[tool]
xyz = ["a1", 0.0, 0.0]
"""


def test_named_parameters_in_order_of_first_appearance(tmp_path):
    chain = load_robot_file(write(tmp_path, TWO_LINK))
    assert [str(p) for p in chain.parameters] == ["a1", "a2", "d2"]
    assert all(p.is_real for p in chain.parameters)
    with pytest.raises(InputError, match=r"give their values"):
        chain.numeric()
    with pytest.raises(InputError, match=r"no value for parameter\(s\) d2"):
        chain.numeric({"a1": 1.0, "a2": 2.0})
    with pytest.raises(InputError, match=r"expected 3 parameter values, got 2"):
        chain.numeric([1.0, 2.0])
    with pytest.raises(InputError, match=r"parameter a2 must be finite"):
        chain.numeric([1.0, math.nan, 0.0])
    by_name = chain.numeric({"a1": 0.7, "a2": 0.4, "d2": 0.1})
    by_order = chain.numeric([0.7, 0.4, 0.1])
    q = np.array([0.3, -1.1])
    for numeric in (by_name, by_order):
        T = chain_kinematics(numeric, q).T
        expected = [0.7 * math.cos(0.3) + 0.4 * math.cos(-0.8) + 0.7 * math.cos(-0.8),
                    0.7 * math.sin(0.3) + 0.4 * math.sin(-0.8) + 0.7 * math.sin(-0.8), 0.1]
        np.testing.assert_allclose(T[:3, 3], expected, atol=1e-15)


def test_named_angle_parameter_stays_symbolic(tmp_path):
    chain = load_robot_file(write(tmp_path, 'convention = "modified"\n' + REV + 'alpha = "twist"\n'))
    (twist,) = chain.parameters
    assert chain.joints[0].before.rotation[1, 1] == sp.cos(twist)
    R = chain.numeric({"twist": 0.25}).joints[0].before[:3, :3]
    np.testing.assert_allclose(R, [[1, 0, 0], [0, math.cos(0.25), -math.sin(0.25)], [0, math.sin(0.25), math.cos(0.25)]],
                               atol=1e-16)


# -- exact angles --------------------------------------------------------------------------------------

@pytest.mark.parametrize("written, exact", [
    ("1.5707963267948966", sp.pi / 2),
    ('"1.5707963267948966"', sp.pi / 2),
    ("-1.5707963267948966", -sp.pi / 2),
    ("3.141592653589793", sp.pi),
    ("1.5707963267949", sp.pi / 2),  # 3.4e-15 away
    ('"pi/2"', sp.pi / 2),
    ('"-pi/2"', -sp.pi / 2),
    ('"3*pi/2"', 3 * sp.pi / 2),
    ("0.0", 0),
])
def test_angles_snap_to_multiples_of_half_pi(tmp_path, written, exact):
    chain = load_robot_file(write(tmp_path, REV + f"alpha = {written}\n"))
    after = chain.joints[0].after  # standard revolute: Tz(d) Tx(a) Rx(alpha)
    c, s = sp.cos(exact), sp.sin(exact)
    assert after.rotation == sp.ImmutableMatrix([[1, 0, 0], [0, c, -s], [0, s, c]])
    assert all(e.is_Integer for e in after.rotation), after.rotation


def test_angles_further_than_tolerance_do_not_snap(tmp_path):
    near = math.pi / 2 + 2e-12
    chain = load_robot_file(write(tmp_path, REV + f"alpha = {near!r}\n"))
    R = chain.joints[0].after.rotation
    assert R[1, 1] != 0 and R[1, 1].is_Float
    assert float(R[1, 1]) == pytest.approx(-2e-12, abs=1e-15)
    assert float(R[2, 1]) == 1.0


def test_theta_offset_snaps_and_rpy_snaps(tmp_path):
    text = REV + "theta = 1.5707963267948966\n[tool]\nrpy = [3.141592653589793, 0.0, -1.5707963267948966]\n"
    chain = load_robot_file(write(tmp_path, text))
    assert chain.joints[0].offset == sp.pi / 2
    assert chain.tool.rotation == sp.ImmutableMatrix([[0, -1, 0], [-1, 0, 0], [0, 0, -1]])


def test_prismatic_keeps_theta_constant_and_offsets_d(tmp_path):
    text = '[[joints]]\ntype = "prismatic"\ntheta = "pi/2"\nd = 0.25\na = 0.5\n'
    chain = load_robot_file(write(tmp_path, text))
    joint = chain.joints[0]
    assert joint.kind == "prismatic" and float(joint.offset) == 0.25
    r = chain_kinematics(chain.numeric(), np.array([0.5]), np.array([2.0]))
    # Rz(pi/2) Tz(q + 0.25) Tx(0.5): tool at (0, 0.5, 0.75), moving at 2 along z
    np.testing.assert_allclose(r.T[:3, 3], [0.0, 0.5, 0.75], atol=1e-16)
    np.testing.assert_allclose(r.twist, [0, 0, 2.0, 0, 0, 0], atol=1e-16)


def test_defaults_and_limits(tmp_path):
    text = REV + 'name = "pan"\nlower = -1.0\nupper = 2.0\nvelocity = 3.0\n[[joints]]\ntype = "prismatic"\n'
    chain = load_robot_file(write(tmp_path, text, "my-arm.toml"))
    assert chain.name == "my_arm"
    assert chain.coordinates == ("pan", "q2")
    assert chain.limits() == {"lower": (-1.0, None), "upper": (2.0, None), "velocity": (3.0, None)}
    assert chain.description == "standard DH"
    assert chain.joints[1].after.is_identity and chain.base.is_identity


# -- the example robots ------------------------------------------------------------------------------

EXAMPLES = {
    "puma560.toml": (6, "standard", "RRRRRR"),
    "puma560_modified.toml": (6, "modified", "RRRRRR"),
    "ur5.toml": (6, "standard", "RRRRRR"),
    "panda.toml": (7, "modified", "RRRRRRR"),
    "stanford.toml": (6, "standard", "RRPRRR"),
    "scara.toml": (4, "standard", "RRPR"),
    "kuka_kr6.toml": (6, "standard", "RRRRRR"),
    "abb_irb140.toml": (6, "standard", "RRRRRR"),
    "iiwa14.toml": (7, "standard", "RRRRRRR"),
}


def test_every_example_is_listed():
    assert sorted(p.name for p in ROBOTS.glob("*.toml")) == sorted(EXAMPLES)


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_example_robots_load(name):
    n, convention, kinds = EXAMPLES[name]
    text = (ROBOTS / name).read_text()
    assert text.startswith("#") and "Source" in text  # cites its table
    chain = load_robot_file(ROBOTS / name)
    assert chain.n == n and len(chain.joints) == n
    assert chain.parameters == ()
    assert convention in chain.description or convention in text.split("convention = ")[1][:12]
    assert "".join(j.kind[0].upper() for j in chain.joints) == kinds
    assert not any(re.fullmatch(r"q\d+", j.name) for j in chain.joints)  # every joint is named
    # DH twists are exact multiples of pi/2: every rotation entry is an exact integer
    for j in chain.joints:
        for transform in (j.before, j.after):
            assert all(e.is_Integer or e.free_symbols for e in transform.rotation), (j.name, transform.rotation)
    for lower, upper in zip(chain.limits()["lower"], chain.limits()["upper"]):
        assert lower is None or upper is None or lower < upper


def test_ur5_and_panda_limits():
    ur5 = load_robot_file(ROBOTS / "ur5.toml").limits()
    assert ur5["upper"] == (2 * math.pi,) * 6 and ur5["velocity"] == (math.pi,) * 6
    panda = load_robot_file(ROBOTS / "panda.toml").limits()
    assert panda["lower"] == (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973)
    assert panda["upper"] == (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973)
    assert panda["velocity"] == (2.175,) * 4 + (2.61,) * 3


def test_panda_flange_and_ur5_parameters_are_exact():
    panda = load_robot_file(ROBOTS / "panda.toml")
    assert panda.tool.translation == sp.ImmutableMatrix([0, 0, sp.Float(0.107)])
    ur5 = load_robot_file(ROBOTS / "ur5.toml")
    d1 = ur5.joints[0].after.translation[2]
    assert float(d1) == 0.089159


def test_a_byte_order_mark_is_read_past(tmp_path):
    """Windows editors save UTF-8 with a byte order mark: tomllib saw it as 'Invalid statement (line 1, column
    1)' (a URDF with one was read). Read past it; a mark elsewhere is still not TOML."""
    assert load_robot_file(write(tmp_path, b"\xef\xbb\xbf" + REV.encode())).n == 1
    with pytest.raises(InputError, match="not valid TOML"):
        load_robot_file(write(tmp_path, REV.encode() + b"\xef\xbb\xbf" + REV.encode()))
