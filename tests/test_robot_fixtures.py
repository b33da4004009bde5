"""The robot files under tests/fixtures/robots: the ones at the top load exactly (hostile but printable
names kept verbatim, as data), the ones under refused/ are refused with one line that names the file,
the element or key, and the code point. The emitted code of every loadable fixture is tested elsewhere
(generated, compiled strictly, imported)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from skelarm_sym.errors import InputError
from skelarm_sym.models.chain.loader import load_robot
from skelarm_sym.models.chain.reference import chain_kinematics
from test_urdf import fd_jacobian, raw_fk

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "robots"
LOADABLE = sorted(p.name for p in FIXTURES.iterdir() if p.suffix in (".urdf", ".toml"))
REFUSED = sorted(p.name for p in (FIXTURES / "refused").iterdir())


def test_every_fixture_is_checked_here():
    assert LOADABLE == ["gantry_gripper.urdf", "hostile_names.toml", "hostile_names.urdf", "ur_like.toml", "ur_like.urdf"]
    assert sorted(REFUSED_CASES) == REFUSED


def _pose_matches_the_raw_xml(chain, path: Path, base: str, tip: str, rng) -> None:
    text = path.read_text(encoding="utf-8")
    nc = chain.numeric()
    for _ in range(3):
        q = rng.uniform(-1, 1, chain.n)
        expected = raw_fk(text, base, tip, dict(zip(chain.coordinates, q)))
        np.testing.assert_allclose(chain_kinematics(nc, q).T, expected, atol=1e-9)  # 1.570796327 is pi/2 + 1e-10
        np.testing.assert_allclose(chain_kinematics(nc, q).J, fd_jacobian(text, base, tip, chain.coordinates, q), atol=1e-7)


def test_ur_like_urdf_snaps_its_written_quarter_turns(rng):
    chain = load_robot(FIXTURES / "ur_like.urdf")
    assert chain.default_prefix == "ur_like" and chain.name == "ur_like"
    assert chain.coordinates == tuple(f"{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3"))
    assert [j.kind for j in chain.joints] == ["revolute"] * 6
    assert chain.description == "URDF, base world, tip tool0"
    # rpy="0.0 1.570796327 0.0" is Ry(pi/2) exactly; the tool's "-1.570796327 0 0" is Rx(-pi/2)
    ry = sp.ImmutableMatrix([[0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    assert chain.joints[1].before.rotation == ry and chain.joints[3].before.rotation == ry
    assert chain.tool.rotation == sp.ImmutableMatrix([[1, 0, 0], [0, 0, 1], [0, -1, 0]])
    assert chain.tool.translation == sp.ImmutableMatrix([0, sp.Float(0.0823), 0])
    # the continuous wrist has no position limits; the others keep theirs
    limits = chain.limits()
    assert limits["lower"] == (-6.28318530718,) * 2 + (-3.14159265359,) + (-6.28318530718,) * 2 + (None,)
    assert limits["velocity"] == (3.15,) * 3 + (3.2,) * 3
    _pose_matches_the_raw_xml(chain, FIXTURES / "ur_like.urdf", "world", "tool0", rng)


def test_ur_like_toml_is_the_same_arm_with_limits_written_as_expressions(rng):
    chain = load_robot(FIXTURES / "ur_like.toml")
    assert chain.default_prefix == "ur_like" and chain.description == "UR5-like arm, standard DH"
    limits = chain.limits()
    assert limits["lower"] == (-2 * math.pi, -2 * math.pi, -math.pi, -2 * math.pi, -2 * math.pi, -2 * math.pi)
    assert limits["upper"] == (2 * math.pi, 2 * math.pi, math.pi, 2 * math.pi, 2 * math.pi, 2 * math.pi)
    assert limits["velocity"] == (math.pi,) * 3 + (2 * math.pi,) * 3
    # the URDF's base_link is the DH base turned by pi about z; its tool0 is the DH tool frame. The
    # written 1.570796327 is pi/2 exactly after loading, so they agree to rounding
    urdf = load_robot(FIXTURES / "ur_like.urdf").numeric()
    turn = np.diag([-1.0, -1.0, 1.0, 1.0])
    for _ in range(5):
        q = rng.uniform(-math.pi, math.pi, 6)
        a, b = chain_kinematics(chain.numeric(), q), chain_kinematics(urdf, q)
        np.testing.assert_allclose(turn @ a.T, b.T, atol=1e-14)
        np.testing.assert_allclose(np.kron(np.eye(2), turn[:3, :3]) @ a.J, b.J, atol=1e-14)


def test_gantry_gripper_reads_every_joint_type(rng):
    chain = load_robot(FIXTURES / "gantry_gripper.urdf")
    assert chain.coordinates == ("x", "y", "turret", "elbow")
    assert [(j.name, j.kind, j.coordinate) for j in chain.joints] == [
        ("x", "prismatic", 0), ("y", "prismatic", 1), ("turret", "revolute", 2), ("elbow", "revolute", 3),
        ("parallel", "revolute", 3), ("finger_slide", "prismatic", 1),
    ]
    parallel, finger = chain.joints[4], chain.joints[5]
    assert parallel.multiplier == -1 and parallel.offset == 0
    assert float(finger.multiplier) == 0.5 and float(finger.offset) == 0.01
    assert chain.base.translation == sp.ImmutableMatrix([0, 0, sp.Float(1.2)])
    # turret "3.141592654 0 0" is Rx(pi); elbow "1.570796327 0 0" is Rx(pi/2): exact entries
    assert chain.joints[2].before.rotation == sp.ImmutableMatrix([[1, 0, 0], [0, -1, 0], [0, 0, -1]])
    # y's own range [-0.5, 0.5] narrowed by finger_slide = 0.5 y + 0.01 within [0, 0.04]: y in [-0.02, 0.06];
    # parallel = -elbow within [-1.5, 1.5] narrows nothing
    limits = chain.limits()
    assert limits["lower"] == pytest.approx((0.0, -0.02, None, -1.5), abs=1e-15)
    assert limits["upper"][1] == pytest.approx(0.06, abs=1e-15) and limits["upper"][3] == 1.5
    _pose_matches_the_raw_xml(chain, FIXTURES / "gantry_gripper.urdf", "floor", "tcp", rng)


# -- hostile but printable: data, kept as written ----------------------------------------------------

URDF_BASE = "${CMAKE_COMMAND} world"
URDF_TIP = "x */ __attribute__((constructor)) void f(void){} /*"
URDF_JOINTS = (
    "j1 \"\"\"; __import__('os').system('touch pwned'); \"\"\"",
    "j2 \\ backslash \\\\ ??/ trigraph ??= ??' %s %n {0}",
    "j3 'single' \"double\" */ /* // # ]]",
    "Gelenk_ä_ü_関節",
)


def test_hostile_urdf_names_are_kept_verbatim(rng):
    path = FIXTURES / "hostile_names.urdf"
    chain = load_robot(path)
    assert tuple(j.name for j in chain.joints) == URDF_JOINTS
    assert chain.coordinates == URDF_JOINTS[:3]
    assert chain.joints[3].coordinate == 0 and float(chain.joints[3].multiplier) == 0.5
    assert chain.description == f"URDF, base {URDF_BASE}, tip {URDF_TIP}"
    assert chain.name == "evil_robot_CMAKE_COMMAND"  # the robot's name, made a C identifier
    assert chain.default_prefix == "hostile_names"  # the file's stem
    assert [j.kind for j in chain.joints] == ["revolute", "revolute", "prismatic", "revolute"]
    # the same path chosen by its hostile names
    again = load_robot(path, base=URDF_BASE, tip=URDF_TIP)
    assert again.coordinates == chain.coordinates and again.description == chain.description
    _pose_matches_the_raw_xml(chain, path, URDF_BASE, URDF_TIP, rng)


def test_hostile_toml_text_is_kept_verbatim():
    chain = load_robot(FIXTURES / "hostile_names.toml")
    assert chain.description == (
        '"""; __import__("os").system("touch pwned"); """ */ /* #[[ ${CMAKE_COMMAND} ]] \\ ??/ $(id) ä 関節'
    )
    assert chain.coordinates == (
        "q1 */ __attribute__((constructor)) void f(void){} /*",
        '"""; import os; os.system("touch pwned") #',
        "#[[ ${CMAKE_COMMAND} ]] \\back\\slash ??/ ??=",
        "Gelenk_ä θ₂ 'quoted'",
    )
    assert chain.name == "hostile" and chain.default_prefix == "hostile"
    assert [j.kind for j in chain.joints] == ["revolute", "revolute", "prismatic", "revolute"]
    assert chain.limits()["lower"] == (-170 * math.pi / 180, None, 0.0, None)


# -- refused: one line naming the file, the element or key and the code point ------------------------

REFUSED_CASES = {
    "newline_in_link.urdf": "link name 'x\\n*/ __attribute__((constructor)) void f(void){} /*' holds the control character U+000A;",
    "bidi_in_joint.urdf": "joint name 'j1\\u202eevil' holds the control character U+202E (RIGHT-TO-LEFT OVERRIDE);",
    "tab_in_robot_name.urdf": "robot name 'tab\\trobot' holds the control character U+0009;",
    "zero_width_in_off_chain_link.urdf": "link name 'hand\\u200b' holds the control character U+200B (ZERO WIDTH SPACE);",
    "newline_in_description.toml": "description 'UR5\\n\"\"\"\\nimport os; os.system(\\'touch pwned\\')\\n\"\"\"' holds the control character U+000A;",
    "bidi_in_joint_name.toml": "joints[0].name 'shoulder\\u202eevil' holds the control character U+202E (RIGHT-TO-LEFT OVERRIDE);",
    "nul_in_joint_name.toml": "joints[1].name 'elbow\\x00' holds the control character U+0000;",
}


@pytest.mark.parametrize("name", sorted(REFUSED_CASES))
def test_refused_fixtures_fail_with_one_line(name):
    path = FIXTURES / "refused" / name
    with pytest.raises(InputError) as info:
        load_robot(path)
    message = str(info.value)
    kind = "descriptions" if "description" in name else "names"
    assert message == f"{path}: {REFUSED_CASES[name]} robot-file {kind} must be printable text"
    assert message.isprintable()


@pytest.mark.parametrize("option", ["base", "tip"])
@pytest.mark.parametrize("bad", ["tool0\n", "tool0\u202e", "\u2066tool0"])
def test_base_and_tip_link_names_are_checked_too(option, bad):
    path = FIXTURES / "ur_like.urdf"
    with pytest.raises(InputError) as info:
        load_robot(path, **{option: bad})
    message = str(info.value)
    assert message.startswith(f"{path}: {option} link {bad!r} holds the control character U+")
    assert message.isprintable()
