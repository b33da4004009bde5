"""URDF loader: chains from URDF trees, checked against an independent NumPy walk of the raw XML and Pinocchio.

The independent forward kinematics here (``raw_fk``) reads the XML itself and composes every joint on the
path (fixed ones included) with its own rpy and Rodrigues code, so it shares nothing with the loader's
folding of fixed joints, normalisation of axes or mimic resolution. Jacobians are checked against central
differences of ``raw_fk``.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import skelarm_sym
from skelarm_sym.errors import InputError
from skelarm_sym.models.chain.loader import load_robot
from skelarm_sym.models.chain.urdf import load_urdf
from skelarm_sym.models.chain.reference import chain_kinematics


# -- an independent forward kinematics from the raw XML -----------------------------------------------

def _rpy(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp_, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp_], [0, 1, 0], [-sp_, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _vec(element, key, default):
    if element is None or element.get(key) is None:
        return np.array(default, dtype=float)
    return np.array([float(x) for x in element.get(key).split()])


def raw_fk(text: str, base: str, tip: str, values: dict[str, float]) -> np.ndarray:
    """Pose of ``tip`` in ``base`` with joint positions ``values`` by name (mimic joints computed here)."""
    root = ET.fromstring(text)
    joints = {j.get("name"): j for j in root.findall("joint")}
    by_child = {j.find("child").get("link"): j for j in joints.values()}

    def position(j) -> float:
        mimic = j.find("mimic")
        if mimic is None:
            return values[j.get("name")]
        return float(mimic.get("multiplier", 1)) * position(joints[mimic.get("joint")]) + float(mimic.get("offset", 0))

    path, link = [], tip
    while link != base:
        path.append(by_child[link])
        link = by_child[link].find("parent").get("link")
    T = np.eye(4)
    for j in reversed(path):
        o = j.find("origin")
        step = np.eye(4)
        step[:3, :3] = _rpy(*_vec(o, "rpy", (0, 0, 0)))
        step[:3, 3] = _vec(o, "xyz", (0, 0, 0))
        motion = np.eye(4)
        axis = _vec(j.find("axis"), "xyz", (1, 0, 0))
        if j.get("type") in ("revolute", "continuous"):
            motion[:3, :3] = _rot(axis, position(j))
        elif j.get("type") == "prismatic":
            motion[:3, 3] = axis / np.linalg.norm(axis) * position(j)
        T = T @ step @ motion
    return T


def fd_jacobian(text, base, tip, names, q, h=1e-6) -> np.ndarray:
    """Geometric Jacobian (rows v, w; base axes; tip origin) by central differences of ``raw_fk``."""
    J = np.zeros((6, len(names)))
    for i in range(len(names)):
        plus, minus = q.copy(), q.copy()
        plus[i] += h
        minus[i] -= h
        Tp = raw_fk(text, base, tip, dict(zip(names, plus)))
        Tm = raw_fk(text, base, tip, dict(zip(names, minus)))
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ raw_fk(text, base, tip, dict(zip(names, q)))[:3, :3].T
        J[3:, i] = [W[2, 1], W[0, 2], W[1, 0]]
    return J


def pose_by_hand(chain, q) -> np.ndarray:
    """``base @ prod(before @ M(theta) @ after) @ tool`` from Chain.numeric(), composed here."""
    nc = chain.numeric()
    T = nc.base.copy()
    for j in nc.joints:
        th = j.multiplier * q[j.coordinate] + j.offset
        M = np.eye(4)
        if j.kind == "revolute":
            M[:3, :3] = _rot(j.axis, th)
        else:
            M[:3, 3] = j.axis * th
        T = T @ j.before @ M @ j.after
    return T @ nc.tool


def write(tmp_path: Path, text: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# -- the edge cases in one arm ---------------------------------------------------------------------------

EDGE = """<?xml version="1.0"?>
<robot name="edge-arm 1">
  <link name="world"/> <link name="base"/> <link name="l1"/> <link name="l2"/> <link name="l2b"/>
  <link name="l3"/> <link name="l4"/> <link name="l5"/> <link name="flange"/> <link name="tool"/>
  <joint name="mount" type="fixed">
    <parent link="world"/> <child link="base"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.1 0.2 0.3"/>
  </joint>
  <joint name="j1" type="revolute">
    <parent link="base"/> <child link="l1"/>
    <origin xyz="0 0 0.4" rpy="0.3 -0.2 1.5707963267948966"/>
    <axis xyz="0 2 2"/>
    <limit lower="-2.5" upper="2.0" velocity="1.5" effort="10"/>
  </joint>
  <joint name="j2" type="continuous">
    <parent link="l1"/> <child link="l2"/>
    <origin xyz="0.25  0 0.05" rpy="-0.4 0.5 0.6"/>
    <axis xyz="-3 0 0"/>
    <limit lower="-0.5" upper="0.5" velocity="2.5" effort="10"/>
  </joint>
  <joint name="middle" type="fixed">
    <parent link="l2"/> <child link="l2b"/>
    <origin xyz="0 0.05 0" rpy="0.7 0 -0.1"/>
  </joint>
  <joint name="slide" type="prismatic">
    <parent link="l2b"/> <child link="l3"/>
    <origin xyz="0.1 0.2 -0.1" rpy="0.2 0.9 -1.1"/>
    <axis xyz="1 2 -2"/>
    <limit lower="-0.1" upper="0.35" velocity="0.5" effort="100"/>
  </joint>
  <joint name="follow" type="revolute">
    <parent link="l3"/> <child link="l4"/>
    <origin xyz="0 0.1 0.2" rpy="3.141592653589793 0.25 -0.35"/>
    <axis xyz="0.3 -0.4 1.2"/>
    <limit lower="-1" upper="1" velocity="3" effort="10"/>
    <mimic joint="j1" multiplier="-0.5" offset="0.3"/>
  </joint>
  <joint name="j4" type="revolute">
    <parent link="l4"/> <child link="l5"/>
    <origin xyz="0.05 0 0.1" rpy="0.15 -0.25 0.35"/>
    <limit lower="-3" upper="3" velocity="4" effort="10"/>
  </joint>
  <joint name="flange_joint" type="fixed">
    <parent link="l5"/> <child link="flange"/>
    <origin xyz="0 0 0.08" rpy="0 0 -0.7853981633974483"/>
  </joint>
  <joint name="tcp" type="fixed">
    <parent link="flange"/> <child link="tool"/>
    <origin xyz="0.01 0.02 0.1" rpy="-0.2 0.1 0.05"/>
  </joint>
</robot>
"""
EDGE_COORDS = ("j1", "j2", "slide", "j4")


def test_edge_arm_structure(tmp_path):
    path = write(tmp_path, EDGE)
    chain = load_urdf(path)
    assert chain.name == "edge_arm_1"
    assert chain.coordinates == EDGE_COORDS
    assert chain.source == str(path)
    assert chain.description == "URDF, base world, tip tool"
    assert [j.name for j in chain.joints] == ["j1", "j2", "slide", "follow", "j4"]
    assert [j.kind for j in chain.joints] == ["revolute", "revolute", "prismatic", "revolute", "revolute"]
    assert [j.coordinate for j in chain.joints] == [0, 1, 2, 0, 3]
    follow = chain.joints[3]
    assert float(follow.multiplier) == -0.5 and float(follow.offset) == pytest.approx(0.3, abs=0)
    # axes: exact along x (either sign) and for the default; unit otherwise
    assert chain.joints[1].axis == (-1, 0, 0)
    assert chain.joints[4].axis == (1, 0, 0)
    for j, raw in ((chain.joints[0], (0, 2, 2)), (chain.joints[2], (1, 2, -2)), (follow, (0.3, -0.4, 1.2))):
        a = np.array([float(x) for x in j.axis])
        np.testing.assert_allclose(a, np.array(raw) / np.linalg.norm(raw), rtol=0, atol=1e-15)
    # after is identity; the fixed joints are folded: mount is the base, flange and tcp the tool, middle in slide
    assert all(j.after.is_identity for j in chain.joints)
    raw = ET.fromstring(EDGE)

    def origin(name):
        o = raw.find(f"joint[@name='{name}']/origin")
        T = np.eye(4)
        T[:3, :3] = _rpy(*_vec(o, "rpy", (0, 0, 0)))
        T[:3, 3] = _vec(o, "xyz", (0, 0, 0))
        return T

    nc = chain.numeric()
    np.testing.assert_allclose(nc.base, origin("mount"), atol=1e-15)
    np.testing.assert_allclose(nc.tool, origin("flange_joint") @ origin("tcp"), atol=1e-15)
    np.testing.assert_allclose(nc.joints[2].before, origin("middle") @ origin("slide"), atol=1e-15)
    np.testing.assert_allclose(nc.joints[0].before, origin("j1"), atol=1e-15)
    # yaw pi/2 and roll pi snap exactly: j1's rotation has exact entries where cos(pi/2) = 0
    R1 = chain.joints[0].before.rotation
    assert R1[0, 0] == 0 and R1[1, 0].is_Float and R1[2, 0].is_Float
    # roll pi snaps: R[2, 1] = cos(pitch) sin(roll) is exactly 0 (1.2e-16 * cos(0.25) without the snap)
    assert chain.joints[3].before.rotation[2, 1] is sp.S.Zero


def test_edge_arm_limits(tmp_path):
    chain = load_urdf(write(tmp_path, EDGE))
    limits = chain.limits()
    # j1's range [-2.5, 2] narrowed by its mimic "follow" = -0.5 q + 0.3 within [-1, 1]: q in [-1.4, 2.6];
    # follow's speed limit 3 allows |dq| <= 6, above j1's own 1.5
    assert limits["lower"] == pytest.approx((-1.4, None, -0.1, -3.0), abs=1e-15)
    assert limits["upper"] == (2.0, None, 0.35, 3.0)
    assert limits["velocity"] == (1.5, 2.5, 0.5, 4.0)
    j2 = chain.joints[1]
    assert (j2.lower, j2.upper, j2.velocity) == (None, None, 2.5)  # continuous: no position limits


def test_edge_arm_pose_and_jacobian(tmp_path, rng):
    chain = load_urdf(write(tmp_path, EDGE))
    nc = chain.numeric()
    for _ in range(5):
        q = rng.uniform(-2, 2, 4)
        q[2] = rng.uniform(-0.1, 0.35)
        dq, ddq = rng.normal(size=4), rng.normal(size=4)
        expected = raw_fk(EDGE, "world", "tool", dict(zip(EDGE_COORDS, q)))
        k = chain_kinematics(nc, q, dq, ddq)
        np.testing.assert_allclose(k.T, expected, atol=1e-12)
        np.testing.assert_allclose(pose_by_hand(chain, q), expected, atol=1e-12)
        J = fd_jacobian(EDGE, "world", "tool", EDGE_COORDS, q)
        np.testing.assert_allclose(k.J, J, atol=1e-8)
        np.testing.assert_allclose(k.twist, J @ dq, atol=1e-8)
        # dJ against differences of the reference Jacobian along the motion
        h = 1e-6
        dJ = (chain_kinematics(nc, q + h * dq).J - chain_kinematics(nc, q - h * dq).J) / (2 * h)
        np.testing.assert_allclose(k.dJ, dJ, atol=1e-7)


def test_mimic_before_its_leader_and_prismatic_mimic(tmp_path, rng):
    """A follower may come before the joint it follows; a prismatic mimic; mimic of a mimic."""
    text = """<robot name="m">
      <link name="a"/><link name="b"/><link name="c"/><link name="c2"/><link name="d"/><link name="e"/>
      <joint name="f1" type="revolute"><parent link="a"/><child link="b"/>
        <origin xyz="0.1 0 0" rpy="0.2 0 0"/><axis xyz="0 0 1"/>
        <limit lower="-9" upper="9" velocity="9"/>
        <mimic joint="lead"/></joint>
      <joint name="lead" type="revolute"><parent link="b"/><child link="c"/>
        <origin xyz="0 0.3 0" rpy="0 0.4 0"/><axis xyz="0 1 0"/>
        <limit lower="-1" upper="1.5" velocity="2"/></joint>
      <joint name="f2" type="revolute"><parent link="c"/><child link="c2"/>
        <origin xyz="0.05 0 0.1" rpy="0.1 0.2 0.3"/><axis xyz="1 1 0"/>
        <mimic joint="f1" multiplier="-2" offset="0.3"/></joint>
      <joint name="p" type="prismatic"><parent link="c2"/><child link="d"/>
        <origin xyz="0 0 0.2" rpy="0 0 0.5"/><axis xyz="0 0 -1"/>
        <limit lower="0" upper="0.2" velocity="0.1"/>
        <mimic joint="f2" multiplier="0.1" offset="0.02"/></joint>
      <joint name="r" type="revolute"><parent link="d"/><child link="e"/>
        <origin xyz="0.1 0.1 0" rpy="0 0 0"/><axis xyz="1 0 0"/>
        <limit lower="-2" upper="2" velocity="3"/></joint>
    </robot>"""
    chain = load_urdf(write(tmp_path, text))
    assert chain.coordinates == ("lead", "r")
    assert [j.coordinate for j in chain.joints] == [0, 0, 0, 0, 1]
    # p = 0.1 * f2 + 0.02 = 0.1 * (-2 * f1 + 0.3) + 0.02, f1 = lead
    p = chain.joints[3]
    assert p.kind == "prismatic" and float(p.multiplier) == pytest.approx(-0.2) and float(p.offset) == pytest.approx(0.05)
    # the coordinate's limits are its own joint's [-1, 1.5], narrowed to where every follower stays within its
    # own: f1 (= lead, within [-9, 9]) narrows nothing; p = 0.1 (-2 lead + 0.3) + 0.02 within [0, 0.2] keeps lead
    # in [-0.75, 0.25], and p's speed limit 0.1 allows |d lead| <= 0.5
    limits = chain.limits()
    assert limits["lower"] == pytest.approx((-0.75, -2.0), abs=1e-15)
    assert limits["upper"] == pytest.approx((0.25, 2.0), abs=1e-15)
    assert limits["velocity"] == pytest.approx((0.5, 3.0), abs=1e-15)
    nc = chain.numeric()
    for _ in range(4):
        q = rng.uniform(-1, 1, 2)
        expected = raw_fk(text, "a", "e", dict(zip(chain.coordinates, q)))
        np.testing.assert_allclose(chain_kinematics(nc, q).T, expected, atol=1e-12)
        np.testing.assert_allclose(chain_kinematics(nc, q).J, fd_jacobian(text, "a", "e", chain.coordinates, q), atol=1e-8)
    # the header says which coordinate moves each mimic joint, and the URDF angle rule
    from skelarm_sym.generate import generate

    header = generate(chain, langs="c", out=None, functions="pose").sources["robot.h"]
    notes = " ".join(line.lstrip(" */") for line in header.splitlines())
    assert "Mimic joints (moved by another joint's coordinate): f1 = q[0] (lead); f2 = -2*q[0] (lead) + 0.3;" in notes
    assert "p = -0.2*q[0] (lead) + 0.05" in notes, notes
    assert "URDF angles within 1e-12 of a multiple of pi/2" in notes
    assert "lead [-0.75, 0.25] |dq| <= 0.5" in notes
    assert "Each coordinate's range keeps the mimic joints that follow it within their own limits." in notes


# -- a chain inside a tree -------------------------------------------------------------------------------

TREE = """<robot name="twoarms">
  <link name="torso"/> <link name="chest"/>
  <link name="L1"/> <link name="L2"/> <link name="Lhand"/> <link name="Lfinger"/>
  <link name="R1"/> <link name="R2"/> <link name="Rtool"/>
  <joint name="waist" type="revolute"><parent link="torso"/><child link="chest"/>
    <origin xyz="0 0 0.5" rpy="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1"/></joint>
  <joint name="l1" type="revolute"><parent link="chest"/><child link="L1"/>
    <origin xyz="0 0.2 0.1" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" velocity="2"/></joint>
  <joint name="l2" type="revolute"><parent link="L1"/><child link="L2"/>
    <origin xyz="0.3 0 0" rpy="0 0.3 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="2"/></joint>
  <joint name="lwrist" type="fixed"><parent link="L2"/><child link="Lhand"/>
    <origin xyz="0.25 0 0" rpy="0.1 0.2 0.3"/></joint>
  <joint name="lfinger" type="prismatic"><parent link="Lhand"/><child link="Lfinger"/>
    <origin xyz="0.05 0 0"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" velocity="0.2"/></joint>
  <joint name="r1" type="revolute"><parent link="chest"/><child link="R1"/>
    <origin xyz="0 -0.2 0.1" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" velocity="2"/></joint>
  <joint name="r2" type="continuous"><parent link="R1"/><child link="R2"/>
    <origin xyz="0.3 0 0" rpy="0 -0.3 0"/><axis xyz="0 1 0"/></joint>
  <joint name="rtool" type="fixed"><parent link="R2"/><child link="Rtool"/>
    <origin xyz="0.2 0 0.01"/></joint>
</robot>"""


@pytest.mark.parametrize(
    "base, tip, coords, chain_base",
    [
        (None, "Rtool", ("waist", "r1", "r2"), "torso"),
        (None, "Lhand", ("waist", "l1", "l2"), "torso"),
        ("chest", "Lfinger", ("l1", "l2", "lfinger"), "chest"),
        ("L1", "Lhand", ("l2",), "L1"),
    ],
)
def test_chain_inside_a_tree(tmp_path, rng, base, tip, coords, chain_base):
    chain = load_urdf(write(tmp_path, TREE), base=base, tip=tip)
    assert chain.coordinates == coords
    assert chain.description == f"URDF, base {chain_base}, tip {tip}"
    nc = chain.numeric()
    for _ in range(3):
        q = rng.uniform(-1, 1, len(coords))
        expected = raw_fk(TREE, chain_base, tip, dict(zip(coords, q)))
        np.testing.assert_allclose(chain_kinematics(nc, q).T, expected, atol=1e-12)
        np.testing.assert_allclose(chain_kinematics(nc, q).J, fd_jacobian(TREE, chain_base, tip, coords, q), atol=1e-8)


def test_tree_without_tip_lists_the_leaves(tmp_path):
    path = write(tmp_path, TREE)
    with pytest.raises(InputError) as info:
        load_urdf(path)
    message = str(info.value)
    assert message.startswith(f"{path}: 2 leaf links below 'torso'")
    assert "'Lfinger'" in message and "'Rtool'" in message and "\n" not in message
    # below a base with one leaf, the tip is found
    assert load_urdf(path, base="R1").coordinates == ("r2",)
    assert load_urdf(path, base="R1").description == "URDF, base R1, tip Rtool"


# -- bad input -------------------------------------------------------------------------------------------

def _arm(*joints: str, links=("a", "b", "c"), root="robot") -> str:
    body = "".join(f'<link name="{n}"/>' for n in links) + "".join(joints)
    return f'<{root} name="bad">{body}</{root}>'


J_AB = '<joint name="ab" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>'
J_BC = '<joint name="bc" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/></joint>'


@pytest.mark.parametrize(
    "text, kwargs, expected",
    [
        ("<robot><link name='a'/>", {}, "not valid XML"),
        (_arm(J_AB, J_BC, root="model"), {}, "root element is <model>, expected <robot>"),
        (_arm(J_AB, J_BC, '<joint name="ca" type="fixed"><parent link="c"/><child link="a"/></joint>'), {}, "cycle"),
        (_arm(J_AB, J_BC.replace('"b"/><child', '"a"/><child').replace('link="c"', 'link="b"')), {}, "link 'b' has two parents"),
        (_arm(J_AB, J_BC), {"tip": "nowhere"}, "no link 'nowhere'"),
        (_arm(J_AB, J_BC), {"base": "nowhere"}, "no link 'nowhere'"),
        (_arm(J_AB, J_BC.replace('link="c"', 'link="x"')), {}, "child link 'x' is not a <link>"),
        (_arm(J_AB, J_BC), {"base": "c", "tip": "a"}, "link 'a' is not below base 'c'"),
        (_arm(J_AB, J_BC), {"base": "b", "tip": "b"}, "tip and base are the same link 'b'"),
        (_arm(J_AB.replace("<axis", '<origin xyz="0 nan 0"/><axis'), J_BC), {}, "joint 'ab' origin xyz must be finite"),
        (_arm(J_AB.replace("<axis", '<origin rpy="0 0 inf"/><axis'), J_BC), {}, "joint 'ab' origin rpy must be finite"),
        # snapped to a quarter turn: one unit in the last place of 1e20 is more than a turn
        (_arm(J_AB.replace("<axis", '<origin rpy="1e20 0 3e17"/><axis'), J_BC), {},
         "joint 'ab' origin rpy 1e+20 rad is beyond +-100000 rad, where a double keeps too few digits below a turn"),
        (_arm(J_AB.replace("<axis", '<origin xyz="0 1"/><axis'), J_BC), {}, "joint 'ab' origin xyz must be 3 numbers"),
        (_arm(J_AB.replace("<axis", '<limit lower="" upper="1" effort="1" velocity="1"/><axis'), J_BC), {},
         "joint 'ab' limit lower must be a number, got ''"),  # was "must have 1 numbers"
        (_arm(J_AB.replace('xyz="0 0 1"', 'xyz="0 0 0"'), J_BC), {}, "joint 'ab' axis has length zero"),
        (_arm(J_AB, J_BC.replace("</joint>", '<mimic joint="bc"/></joint>')), {}, "joint 'bc' mimic refers to itself"),
        (_arm(J_AB, J_BC.replace("</joint>", '<mimic joint="ab" multiplier="1e300"/></joint>')), {},
         "joint 'bc' mimic multiplier 1e+300 is beyond +-1000"),
        (_arm(J_AB, J_BC.replace("</joint>", '<mimic joint="ab" offset="1e300"/></joint>')), {},
         "joint 'bc' mimic offset 1e+300 rad is beyond +-100000 rad"),
        (_arm(J_AB, J_BC.replace("</joint>", '<mimic joint="zz"/></joint>')), {}, "refers to joint 'zz', which is not in the file"),
        (_arm(J_AB, J_BC.replace("</joint>", '<mimic joint="ab"/></joint>')), {"base": "b"}, "refers to joint 'ab', which is not on the chain"),
        (_arm(J_AB, J_BC.replace("<parent link=\"b\"/>", "")), {}, "joint 'bc' has no <parent link=...>"),
        (_arm(J_AB, J_BC.replace("<child link=\"c\"/>", "<child/>")), {}, "joint 'bc' has no <child link=...>"),
        (_arm(J_AB, J_BC.replace("revolute", "floating")), {}, "joint 'bc' is floating: floating and planar joints are not supported"),
        (_arm(J_AB, J_BC.replace("revolute", "planar")), {}, "joint 'bc' is planar"),
        (_arm(J_AB, J_BC.replace("revolute", "hinge")), {}, "joint 'bc': type must be one of"),
        (_arm(J_AB, J_BC.replace("<axis", '<limit lower="1" upper="-1"/><axis')), {}, "lower 1.0 is above upper -1.0"),
        (_arm(J_AB, J_BC.replace("<axis", '<limit velocity="-1"/><axis')), {}, "velocity must not be negative"),
        (_arm(J_AB.replace("<axis", '<limit lower="0" upper="1"/><axis'),
              J_BC.replace("<axis", '<limit lower="2" upper="3"/><mimic joint="ab"/><axis')), {},
         "coordinate 'ab': the limits of the joints that follow it ('bc') leave no value within its range"),
        (_arm(J_AB, J_BC.replace("<axis", '<limit upper="one"/><axis')), {}, "joint 'bc' limit upper must be decimal numbers"),
        (_arm(J_AB.replace("<axis", '<limit lower="-1" upper="1"/><axis'),
              J_BC.replace("<axis", '<limit lower="3" upper="4"/><mimic joint="ab" multiplier="0"/><axis')), {},
         "joint 'bc' follows 'ab' with multiplier 0: it is held at 0, outside its limits [3, 4]"),
        # float() reads these, urdfdom does not: a typo for 0.5 became 5 m, another script's digits a length
        (_arm(J_AB.replace("<axis", '<origin xyz="0_5 0 0"/><axis'), J_BC), {}, "joint 'ab' origin xyz must be decimal numbers"),
        (_arm(J_AB.replace("<axis", '<origin xyz="\u0661 0 0"/><axis'), J_BC), {}, "must be decimal numbers (ASCII digits"),
        (_arm(J_AB.replace("<axis", '<origin xyz="\uff11.5 0 0"/><axis'), J_BC), {}, "must be decimal numbers"),
        (_arm(J_AB, J_BC.replace("<axis", '<limit upper="1e3_0"/><axis')), {}, "joint 'bc' limit upper must be decimal numbers"),
        # xacro read as URDF lost the joints its macros and includes expand to, and said nothing
        (_arm(J_AB, J_BC, '<xacro:wrist parent="c"/>').replace('name="bad"', 'name="bad" xmlns:xacro="http://www.ros.org/wiki/xacro"'),
         {}, "it holds xacro markup (<xacro:wrist>): a xacro file, not a URDF; expand it first (xacro"),
        (_arm(J_AB.replace("<axis", '<origin xyz="0 0 ${h}"/><axis'), J_BC), {}, "it holds a xacro expression ('0 0 ${h}' in <origin xyz>)"),
        (_arm(J_AB, J_BC).replace('<link name="a"/>', '<link name="a"><visual><geometry><mesh filename="$(find pkg)/a.stl"/>'
                                  '</geometry></visual></link>'), {}, "it holds a xacro expression"),
        (_arm(J_AB.replace("revolute", "fixed"), J_BC.replace("revolute", "fixed")), {}, "no revolute, continuous or prismatic joint"),
        (_arm(J_AB), {}, "2 root links ('a', 'c')"),
        (_arm(J_AB, J_AB), {}, "joint 'ab' is defined twice"),
        ("<robot/>", {}, "no <link> elements"),
    ],
)
def test_bad_input(tmp_path, text, kwargs, expected):
    path = write(tmp_path, text)
    with pytest.raises(InputError) as info:
        load_urdf(path, **kwargs)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert expected in message
    assert "\n" not in message


def test_a_broken_mimic_off_the_chain_is_left_out(tmp_path):
    path = write(tmp_path, TREE.replace('<axis xyz="0 1 0"/><limit lower="0"', '<mimic joint="gone"/><axis xyz="0 1 0"/><limit lower="0"'))
    assert load_urdf(path, tip="Rtool").coordinates == ("waist", "r1", "r2")
    with pytest.raises(InputError, match="joint 'lfinger' mimic refers to joint 'gone', which is not in the file"):
        load_urdf(path, tip="Lfinger")


def test_missing_file_and_folder(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_urdf(tmp_path / "none.urdf")
    with pytest.raises(InputError, match="is a folder"):
        load_urdf(tmp_path)


def test_valid_arm_from_the_bad_input_template(tmp_path):
    """The template above is a valid arm, so the errors come from the one change each makes."""
    chain = load_urdf(write(tmp_path, _arm(J_AB, J_BC)))
    assert chain.coordinates == ("ab", "bc") and chain.name == "bad"
    assert chain.limits() == {"lower": (None, None), "upper": (None, None), "velocity": (None, None)}
    # velocity="0" (exporters write it for "not set") is no limit; a prismatic joint keeps its own limits
    text = _arm(J_AB.replace("<axis", '<limit lower="-1" upper="0.5" velocity="0" effort="0"/><axis'),
                J_BC.replace("revolute", "prismatic").replace("<axis", '<limit lower="0" upper="0.3" velocity="0.2"/><axis'))
    chain = load_urdf(write(tmp_path, text))
    assert [j.kind for j in chain.joints] == ["revolute", "prismatic"]
    assert chain.limits() == {"lower": (-1.0, 0.0), "upper": (0.5, 0.3), "velocity": (None, 0.2)}


# -- load_robot: one entry for URDF and TOML --------------------------------------------------------------

TOML = """
name = "two"
[[joints]]
type = "revolute"
a = 0.5
[[joints]]
type = "revolute"
a = 0.25
"""


def test_load_robot_dispatches_on_suffix(tmp_path):
    assert skelarm_sym.load_robot is load_robot
    urdf = load_robot(write(tmp_path, TREE, "arms.URDF"), tip="Rtool")
    assert urdf.coordinates == ("waist", "r1", "r2")
    toml_path = write(tmp_path, TOML, "two.toml")
    dh = load_robot(toml_path)
    assert dh.name == "two"
    T = pose_by_hand(dh, np.array([0.3, -0.4]))
    np.testing.assert_allclose(T[:2, 3], [0.5 * math.cos(0.3) + 0.25 * math.cos(-0.1), 0.5 * math.sin(0.3) + 0.25 * math.sin(-0.1)])
    with pytest.raises(InputError, match=r"two\.toml: a tip link \(tip= / --tip\) is chosen in URDF files only"):
        load_robot(toml_path, tip="x")
    with pytest.raises(InputError, match=r"two\.toml: a base and tip link \(base= / --base, tip= / --tip\) are chosen"):
        load_robot(toml_path, base="a", tip="x")
    with pytest.raises(InputError, match=r"arm\.xml: unknown kind of robot file '\.xml'"):
        load_robot(tmp_path / "arm.xml")


def test_robot_name_becomes_a_c_identifier(tmp_path):
    for raw, name in (("ur5", "ur5"), ("my-robot 2", "my_robot_2"), ("2dof", "robot_2dof"), ("double", "double_robot")):
        assert load_urdf(write(tmp_path, _arm(J_AB, J_BC).replace('"bad"', f'"{raw}"'))).name == name
    assert load_urdf(write(tmp_path, _arm(J_AB, J_BC).replace(' name="bad"', ""), "arm-x.urdf")).name == "arm_x"


# -- real URDFs against Pinocchio --------------------------------------------------------------------------

def _robots_dir() -> Path | None:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    path = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))
    return path if path.is_dir() else None


ROBOTS = _robots_dir()
needs_oracle = pytest.mark.skipif(
    ROBOTS is None or importlib.util.find_spec("pinocchio") is None,
    reason="the oracle extra (pip install 'skelarm-sym[oracle]': pin, example-robot-data) is not installed",
)


@needs_oracle
@pytest.mark.parametrize(
    "file, tip, n",
    [
        ("panda_description/urdf/panda.urdf", "panda_hand", 7),
        ("panda_description/urdf/panda.urdf", "panda_hand_tcp", 7),
        ("panda_description/urdf/panda.urdf", "panda_leftfinger", 8),  # a prismatic joint in a hand turned by -pi/4
        ("ur_description/urdf/ur5_robot.urdf", "tool0", 6),
    ],
)
def test_against_pinocchio(file, tip, n, rng):
    import pinocchio as pin

    path = ROBOTS / file
    chain = load_robot(path, tip=tip)
    assert chain.n == n
    full = pin.buildModelFromUrdf(str(path))
    lock = [full.getJointId(name) for name in full.names[1:] if name not in chain.coordinates]
    model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
    data = model.createData()
    assert model.nq == model.nv == n
    # Pinocchio's joint order is ours (both base to tip), and so are its limits
    assert tuple(model.names[1:]) == chain.coordinates
    limits = chain.limits()
    np.testing.assert_allclose(limits["lower"], model.lowerPositionLimit)
    np.testing.assert_allclose(limits["upper"], model.upperPositionLimit)
    np.testing.assert_allclose(limits["velocity"], model.velocityLimit)
    frame = model.getFrameId(tip)
    nc = chain.numeric()
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    lower, upper = np.maximum(model.lowerPositionLimit, -math.pi), np.minimum(model.upperPositionLimit, math.pi)
    for _ in range(5):
        q = rng.uniform(lower, upper)
        dq, ddq = rng.normal(size=n), rng.normal(size=n)
        pin.forwardKinematics(model, data, q, dq, ddq)
        pin.updateFramePlacements(model, data)
        J = pin.computeFrameJacobian(model, data, q, frame, world)
        pin.computeJointJacobiansTimeVariation(model, data, q, dq)
        dJ = pin.getFrameJacobianTimeVariation(model, data, frame, world)
        twist = pin.getFrameVelocity(model, data, frame, world).vector
        acc = pin.getFrameClassicalAcceleration(model, data, frame, world).vector
        k = chain_kinematics(nc, q, dq, ddq)
        np.testing.assert_allclose(k.T, data.oMf[frame].homogeneous, atol=1e-10)
        np.testing.assert_allclose(pose_by_hand(chain, q), data.oMf[frame].homogeneous, atol=1e-10)
        np.testing.assert_allclose(k.J, J, atol=1e-10)
        np.testing.assert_allclose(k.dJ, dJ, atol=1e-9)
        np.testing.assert_allclose(k.twist, twist, atol=1e-9)
        np.testing.assert_allclose(k.acc, acc, atol=1e-9)


@needs_oracle
def test_panda_structure():
    chain = load_robot(ROBOTS / "panda_description/urdf/panda.urdf", tip="panda_hand_tcp")
    assert chain.name == "panda"
    assert chain.description == "URDF, base panda_link0, tip panda_hand_tcp"
    # rpy of +-pi/2 snap: every joint's before rotation is exact (entries 0, +-1); axes exact z
    for j in chain.joints:
        assert j.axis == (0, 0, 1)
        assert all(e.is_Integer for e in j.before.rotation)
        assert j.after.is_identity
    # the three fixed joints to the tcp are one tool transform: z 0.107 + 0.1034, yaw -pi/4
    tool = chain.numeric().tool
    c = math.cos(-math.pi / 4)
    np.testing.assert_allclose(tool, [[c, c, 0, 0], [-c, c, 0, 0], [0, 0, 1, 0.2104], [0, 0, 0, 1]], atol=1e-15)
    assert chain.base.is_identity
    assert chain.limits()["upper"][3] == -0.0698


UR5_DH = """
name = "ur5dh"
convention = "standard"
[[joints]]
type = "revolute"
d = 0.089159
alpha = "pi/2"
[[joints]]
type = "revolute"
a = -0.425
[[joints]]
type = "revolute"
a = -0.39225
[[joints]]
type = "revolute"
d = 0.10915
alpha = "pi/2"
[[joints]]
type = "revolute"
d = 0.09465
alpha = "-pi/2"
[[joints]]
type = "revolute"
d = 0.0823
"""


@needs_oracle
def test_ur5_from_dh_and_from_urdf_agree(tmp_path, rng):
    """Universal Robots' DH table and ur_description's URDF: base_link is the DH base turned by pi about z,
    tool0 is the DH tool frame; the URDF's 11-digit pi/2 limits the agreement to about 1e-11."""
    dh = load_robot(write(tmp_path, UR5_DH, "ur5.toml"))
    urdf = load_robot(ROBOTS / "ur_description/urdf/ur5_robot.urdf", base="base_link", tip="tool0")
    assert urdf.coordinates == ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
    turn = np.diag([-1.0, -1.0, 1.0, 1.0])
    for _ in range(5):
        q = rng.uniform(-math.pi, math.pi, 6)
        dq, ddq = rng.normal(size=6), rng.normal(size=6)
        a, b = chain_kinematics(dh.numeric(), q, dq, ddq), chain_kinematics(urdf.numeric(), q, dq, ddq)
        np.testing.assert_allclose(turn @ a.T, b.T, atol=1e-10)
        rot = np.kron(np.eye(2), turn[:3, :3])
        np.testing.assert_allclose(rot @ a.J, b.J, atol=1e-10)
        np.testing.assert_allclose(rot @ a.acc, b.acc, atol=1e-9)


@needs_oracle
def test_edge_arm_against_pinocchio_mimic(tmp_path, rng):
    """Pinocchio's own URDF parser with mimic joints (mimic=True) on the edge arm: a second, outside oracle
    for the mimic, the continuous joint (cos/sin in Pinocchio's q), unaligned axes and the folded fixed joints.

    Pinocchio 4.1's getFrameJacobianTimeVariation is not the time derivative of its own frame Jacobian on a
    model with a mimic joint (off by up to 0.3 in the mimicked joint's column and later ones), so dJ is
    compared with central differences of Pinocchio's Jacobian along the motion instead."""
    import pinocchio as pin

    path = write(tmp_path, EDGE)
    model = pin.buildModelFromUrdf(str(path), mimic=True)
    data = model.createData()
    assert model.nv == 4 and tuple(model.names[1:]) == ("j1", "j2", "slide", "follow", "j4")
    chain = load_urdf(path)
    nc = chain.numeric()
    frame = model.getFrameId("tool")
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for _ in range(5):
        q = rng.uniform(-2, 2, 4)
        dq, ddq = rng.normal(size=4), rng.normal(size=4)
        qp = np.array([q[0], math.cos(q[1]), math.sin(q[1]), q[2], q[3]])
        pin.forwardKinematics(model, data, qp, dq, ddq)
        pin.updateFramePlacements(model, data)
        k = chain_kinematics(nc, q, dq, ddq)
        np.testing.assert_allclose(k.T, data.oMf[frame].homogeneous, atol=1e-12)
        np.testing.assert_allclose(k.twist, pin.getFrameVelocity(model, data, frame, world).vector, atol=1e-11)
        np.testing.assert_allclose(k.acc, pin.getFrameClassicalAcceleration(model, data, frame, world).vector, atol=1e-11)

        def jacobian(x):
            xp = np.array([x[0], math.cos(x[1]), math.sin(x[1]), x[2], x[3]])
            return pin.computeFrameJacobian(model, data, xp, frame, world).copy()

        np.testing.assert_allclose(k.J, jacobian(q), atol=1e-12)
        h = 1e-6
        np.testing.assert_allclose(k.dJ, (jacobian(q + h * dq) - jacobian(q - h * dq)) / (2 * h), atol=1e-8)


# -- axes of any finite size -------------------------------------------------------------------------------

@pytest.mark.parametrize(
    "written, expected",
    [
        ("1e300 0 0", (1, 0, 0)),
        ("0 -1e308 0", (0, -1, 0)),
        ("1e-310 0 0", (1, 0, 0)),  # subnormal
        ("0 0 -5e-324", (0, 0, -1)),  # the smallest subnormal
        ("1e300 1e300 0", (math.sqrt(0.5), math.sqrt(0.5), 0)),
        ("1e-310 -1e-310 1e-310", (1 / math.sqrt(3), -1 / math.sqrt(3), 1 / math.sqrt(3))),
        ("1.7e308 1.7e308 1.7e308", (1 / math.sqrt(3),) * 3),
        ("3e-200 4e-200 0", (0.6, 0.8, 0)),
    ],
)
def test_huge_and_subnormal_axes_are_normalised(tmp_path, written, expected):
    chain = load_urdf(write(tmp_path, _arm(J_AB.replace('xyz="0 0 1"', f'xyz="{written}"'), J_BC)))
    axis = chain.joints[0].axis
    np.testing.assert_allclose([float(x) for x in axis], expected, rtol=0, atol=2e-16)
    if sum(x != 0 for x in expected) == 1:
        assert axis == tuple(sp.Integer(int(x)) for x in expected)  # along x, y or z: exact


def test_only_the_zero_axis_has_length_zero(tmp_path):
    for written in ("0 0 0", "0.0 -0.0 0e-5"):
        with pytest.raises(InputError, match="joint 'ab' axis has length zero"):
            load_urdf(write(tmp_path, _arm(J_AB.replace('xyz="0 0 1"', f'xyz="{written}"'), J_BC)))


# -- large files: linear, and limited ------------------------------------------------------------------

def _big_urdf(off_chain: int) -> str:
    """A 3-joint arm with ``off_chain`` more links off its path: half hang from the base by fixed joints
    (a wide tree), half form one long branch of fixed joints (a deep tree)."""
    arm = ('<link name="base"/><link name="l1"/><link name="l2"/><link name="tool"/>'
           '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/></joint>'
           '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/><axis xyz="0 1 0"/></joint>'
           '<joint name="j3" type="fixed"><parent link="l2"/><child link="tool"/><origin xyz="0.3 0 0"/></joint>')
    wide, deep = off_chain // 2, off_chain - off_chain // 2
    parts = [arm]
    parts += [f'<link name="w{i}"/><joint name="jw{i}" type="fixed"><parent link="base"/><child link="w{i}"/></joint>' for i in range(wide)]
    parts += [f'<link name="d{i}"/><joint name="jd{i}" type="fixed"><parent link="{"base" if i == 0 else f"d{i - 1}"}"/>'
              f'<child link="d{i}"/></joint>' for i in range(deep)]
    return f'<robot name="big">{"".join(parts)}</robot>'


def test_loading_is_linear_in_the_number_of_links(tmp_path):
    """20 000 off-chain links took 5.4 s of CPU (the duplicate check scanned a list, and so did the cycle
    check along a deep branch); now the time grows in proportion to the file."""
    import gc
    import time

    paths = {n: write(tmp_path, _big_urdf(n), f"big{n}.urdf") for n in (5_000, 20_000)}
    seconds = {}
    # The collector's passes over the session's objects are not the loader's time: the objects the session holds
    # (a worker's SymPy derivations: a full collection took a second each) are frozen, out of the collector's
    # sight (they stay so: the session freezes what it holds, see conftest.py), and the collector is off while a
    # load is timed.
    gc.freeze()
    for n, path in paths.items():
        runs = []
        # the fastest of five (CPU time, so other processes do not count); the larger file stops early once
        # the bounds below hold: more runs could only lower its minimum, never fail them
        for _ in range(5):
            gc.collect()  # the previous load's garbage, not the session's
            gc.disable()
            try:
                start = time.process_time()
                chain = load_urdf(path, tip="tool")
                runs.append(time.process_time() - start)
            finally:
                gc.enable()
            if n == 20_000 and min(runs) < min(8 * seconds[5_000], 3.0):
                break
        assert chain.coordinates == ("j1", "j2")
        seconds[n] = min(runs)
    assert seconds[20_000] < 8 * seconds[5_000], seconds  # 4 when linear, 16 when quadratic
    assert seconds[20_000] < 3.0, seconds
    # without a tip the 10 002 leaves (tool, the wide half, the end of the deep branch) are counted, quickly
    with pytest.raises(InputError, match=r"10002 leaf links below 'base' \('tool', 'w0', .*\(10002 in all\)\): choose one as tip"):
        load_urdf(paths[20_000])


def test_element_and_size_limits(tmp_path, monkeypatch):
    from skelarm_sym.models.chain import urdf

    assert urdf.MAX_URDF_BYTES == 16 * 1024 * 1024 and urdf.MAX_URDF_ELEMENTS == 100_000
    assert "16 MiB" in urdf.__doc__ and "100 000" in urdf.__doc__  # stated where users read them
    path = write(tmp_path, _big_urdf(400))
    monkeypatch.setattr(urdf, "MAX_URDF_ELEMENTS", 300)
    with pytest.raises(InputError) as info:
        load_urdf(path, tip="tool")
    assert str(info.value) == f"{path}: 404 <link> elements: at most 300 are read"
    monkeypatch.setattr(urdf, "MAX_URDF_ELEMENTS", 404)
    assert load_urdf(path, tip="tool").n == 2  # 404 links and 403 joints: within
    big = write(tmp_path, _arm(J_AB, J_BC) + "<!--" + "x" * urdf.MAX_URDF_BYTES + "-->", "big.urdf")
    with pytest.raises(InputError) as info:
        load_urdf(big)
    assert str(info.value) == f"{big}: larger than 16 MiB: a URDF file is read only up to that size"


def test_a_cycle_is_named_in_one_pass(tmp_path):
    # a -> b -> c -> a, with d below b: every link has one parent and none is a root
    cycle = ('<joint name="ca" type="fixed"><parent link="c"/><child link="a"/></joint>'
             '<joint name="bd" type="fixed"><parent link="b"/><child link="d"/></joint>')
    path = write(tmp_path, _arm(J_AB, J_BC, cycle, links=("d", "a", "b", "c")))
    with pytest.raises(InputError) as info:
        load_urdf(path, base="a", tip="c")
    assert str(info.value) == f"{path}: the joints form a cycle through links 'b', 'a', 'c'"


# -- the default prefix ------------------------------------------------------------------------------------

@pytest.mark.parametrize(
    "file, robot, prefix, name",
    [
        ("xarm7.urdf", "UF_ROBOT", "xarm7", "UF_ROBOT"),  # was UF_ROBOT
        ("UR5e.urdf", "ur5e_robot", "UR5e", "ur5e_robot"),
        ("panda arm (copy).urdf", "panda", "panda_arm_copy", "panda"),
        ("2-link.urdf", "planar", "robot_2_link", "planar"),
        ("code.urdf", "x", "code_robot", "x"),
        ("test.urdf", "x", "test_robot", "x"),  # not in sys.stdlib_module_names, yet Python's own test package
        ("m.urdf", "x", "m_robot", "x"),  # the math library a --cmake target links
        ("torch.urdf", "x", "torch_robot", "x"),
        ("ロボット.urdf", "UF_ROBOT", "UF_ROBOT", "UF_ROBOT"),  # no ASCII letter in the stem: the robot's name
        ("ロボット.urdf", "ロボット", "robot", "robot"),
    ],
)
def test_default_prefix_is_the_file_name(tmp_path, file, robot, prefix, name):
    chain = load_robot(write(tmp_path, _arm(J_AB, J_BC).replace('"bad"', f'"{robot}"'), file))
    assert chain.default_prefix == prefix
    assert chain.name == name  # the robot's own name, made a C identifier, still describes it


def test_toml_default_prefix_stays_its_name_key(tmp_path):
    assert load_robot(write(tmp_path, TOML, "other-file.toml")).default_prefix == "two"
    assert load_robot(write(tmp_path, TOML.replace('name = "two"', ""), "other-file.toml")).default_prefix == "other_file"


def test_prefix_rule_is_stated_for_the_cli():
    from skelarm_sym.models.chain import loader

    assert "xarm7.urdf: xarm7" in loader.PREFIX_RULE and "name key" in loader.PREFIX_RULE
    assert "\n" not in loader.PREFIX_RULE
    # every rule the cases above exercise (runs collapse, code.urdf, a stem without letters)
    for part in ("becomes one _ (none at either end)", "_robot after a name some output cannot take: a C or Python reserved word", "torch: torch_robot", "robot's name, else robot",
                 "TOML file its name key (a C identifier)"):
        assert part in loader.PREFIX_RULE, part
    assert "the file name's stem made an identifier, else the ``<robot name>``" in loader.__doc__


# -- listing the links to choose a tip -----------------------------------------------------------------------

def test_urdf_tree_lists_links_joints_and_leaves(tmp_path):
    from skelarm_sym.models.chain.loader import UrdfLink, urdf_links, urdf_tree

    path = write(tmp_path, TREE.replace("</robot>", '<link name="spare"/></robot>'))
    assert urdf_tree(path) == [
        "torso",
        "  chest  <- waist (revolute)",
        "    L1  <- l1 (revolute)",
        "      L2  <- l2 (revolute)",
        "        Lhand  <- lwrist (fixed)",
        "          Lfinger  <- lfinger (prismatic)  [leaf: 4 coordinates from torso]",
        "    R1  <- r1 (revolute)",
        "      R2  <- r2 (continuous)",
        "        Rtool  <- rtool (fixed)  [leaf: 3 coordinates from torso]",
        "spare  [no joints]",
    ]
    links = urdf_links(path)
    assert links[5] == UrdfLink("Lfinger", 5, "Lhand", "lfinger", "prismatic", 4, True)
    assert links[0] == UrdfLink("torso", 0, None, None, None, 0, False)
    # every leaf the tree marks is a tip that loads, with the coordinates it announced
    for link in links:
        if link.leaf and link.depth:
            assert load_urdf(path, base="torso", tip=link.name).n == link.coordinates


def test_urdf_tree_from_a_base_and_tips_with_a_stray_mimic(tmp_path):
    """``show --what links --base L`` lists the tree from L, its coordinates counted from there; a leaf whose path
    holds a mimic joint that follows a joint off it is marked as refused (a new user's probe: the tree counted
    from the root whatever the base, and offered Panda's right finger, which generate refuses)."""
    from skelarm_sym.models.chain.loader import urdf_tree

    path = write(tmp_path, TREE.replace("</robot>", """<link name="thumb"/>
      <joint name="thumb" type="revolute"><parent link="L1"/><child link="thumb"/><axis xyz="0 0 1"/>
        <mimic joint="l2"/></joint></robot>"""))
    lines = urdf_tree(path, "chest")
    assert lines[0] == "chest"
    assert "        Lfinger  <- lfinger (prismatic)  [leaf: 3 coordinates from chest]" in lines
    thumb = next(x for x in lines if x.strip().startswith("thumb"))
    assert thumb.endswith("[leaf: 1 coordinate from chest; refused as a tip: mimic joint 'thumb' follows 'l2', off this chain]")
    with pytest.raises(InputError, match="mimic refers to joint 'l2', which is not on the chain"):
        load_urdf(path, base="chest", tip="thumb")
    for line in lines:  # every leaf not marked refused loads from the base with the coordinates it announced
        if "[leaf:" in line and "refused" not in line:
            tip, count = line.split("<-")[0].strip(), int(line.split("[leaf: ")[1].split()[0])
            assert load_urdf(path, base="chest", tip=tip).n == count
    with pytest.raises(InputError, match="no link 'nowhere' \\(base\\)"):
        urdf_tree(path, "nowhere")


def test_urdf_tree_counts_mimic_joints_out_and_stays_flat_when_deep(tmp_path):
    from skelarm_sym.models.chain.loader import urdf_tree

    path = write(tmp_path, EDGE)
    assert urdf_tree(path)[-1] == "  " * 9 + "tool  <- tcp (fixed)  [leaf: 4 coordinates from world]"
    lines = urdf_tree(write(tmp_path, _big_urdf(60), "deep.urdf"))
    assert len(lines) == 64
    assert lines[-1] == "  " * 24 + "[depth 30] d29  <- jd29 (fixed)  [leaf: 0 coordinates from base]"
    with pytest.raises(InputError, match="not valid XML"):
        urdf_tree(write(tmp_path, "<robot>", "broken.urdf"))


def test_unknown_links_suggest_close_matches(tmp_path):
    path = write(tmp_path, TREE)
    with pytest.raises(InputError) as info:
        load_urdf(path, tip="Rtol")
    assert str(info.value) == (
        f"{path}: no link 'Rtol' (tip); did you mean 'Rtool'? (links: 'torso', 'chest', 'L1', 'L2', 'Lhand', "
        "'Lfinger', 'R1', 'R2', 'Rtool')"
    )
    with pytest.raises(InputError, match=r"no link 'lhand' \(base\); did you mean 'Lhand'\? \(links: "):
        load_urdf(path, base="lhand")
    with pytest.raises(InputError, match=r"no link 'L' \(tip\); did you mean 'L2' or 'L1'\? \(links: "):
        load_urdf(path, tip="L")
    with pytest.raises(InputError) as info:
        load_urdf(path, tip="gripper")
    assert "did you mean" not in str(info.value) and "(links: 'torso'," in str(info.value)


def test_load_robot_takes_the_ik_lock_and_refuses_what_is_not_a_path():
    """The 7-joint arms' hint said "lock=JOINT from Python", an argument no function took (the CLI's --ik-lock had no
    Python spelling but an internal helper); load_robot(5) raised a TypeError. load_robot takes ik_lock=, and a
    path that is not one is a ValueError naming it."""
    from skelarm_sym.generate import generate

    panda = Path(__file__).resolve().parents[1] / "examples" / "robots" / "panda.toml"
    with pytest.raises(InputError, match=r"load_robot\(path, ik_lock=JOINT\) from Python"):
        generate(load_robot(panda), functions="ik_all", out=None)
    locked = load_robot(panda, ik_lock=7)
    assert "panda_ik_all" in generate(locked, functions="ik_all", out=None, langs="c").sources["panda.h"]
    assert "panda_ik_all" in generate(load_robot(panda, ik_lock="panda_joint7"), functions="ik_all", out=None,
                                      langs="c").sources["panda.h"]
    for wrong in (5, None, ["panda.toml"]):
        with pytest.raises(InputError, match="load_robot takes the path of a robot file"):
            load_robot(wrong)


def test_a_slides_mimic_offset_counts_toward_the_reach(tmp_path):
    """A security review: a prismatic ``<mimic offset="1e200">`` was accepted (exit 0) and ``check`` then failed
    with infinities, while ``xyz="1e200 0 0"`` is refused: a slide's constant offset is a translation too."""
    from skelarm_sym.errors import InputError
    from skelarm_sym.generate import generate
    from skelarm_sym.models.chain import load_robot

    path = tmp_path / "m.urdf"
    path.write_text('<robot name="m"><link name="a"/><link name="b"/><link name="c"/>'
                    '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.1"/>'
                    '<axis xyz="0 0 1"/></joint><joint name="j2" type="prismatic"><parent link="b"/><child link="c"/>'
                    '<origin xyz="0.2 0 0"/><axis xyz="1 0 0"/><mimic joint="j1" multiplier="1" offset="1e200"/></joint>'
                    '</robot>')
    with pytest.raises(InputError, match=r"reach \(sum of its constant translations and slide offsets\) = 1e\+200"):
        generate(load_robot(path), out=None, functions="pose")


def test_a_long_joint_name_stays_whole_in_the_header_notes(tmp_path):
    """A probe: the header's "Joint limits" note was wrapped by textwrap's default, which cuts a word longer than the
    line, so a joint name of 130 characters was split across two comment lines (the lists of joints keep names whole).
    Every note now keeps a name on one line."""
    from skelarm_sym.generate import generate

    name = "shoulder_" + "x" * 121
    limited = J_AB.replace('name="ab"', f'name="{name}"').replace(
        "<axis", '<limit lower="-1" upper="1" effort="1" velocity="1"/><axis')
    generated = generate(load_robot(write(tmp_path, _arm(limited, J_BC))), out=None, langs="c", functions="pose")
    header = next(text for file, text in generated.sources.items() if file.endswith(".h"))
    lines = header.splitlines()
    start = next(i for i, line in enumerate(lines) if "Joint limits" in line)
    assert any(line.endswith(" " + name) or f" {name} " in line for line in lines[start:start + 3])
