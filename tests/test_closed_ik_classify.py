"""Classification: the families, exact geometry, and one-line reasons with the failing measure."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
import sympy as sp

from skelarm_sym.closed_ik import ClosedFormError, classify, derive_ik_all, explain
from skelarm_sym.closed_ik.classify import chain_geometry
from skelarm_sym.models.chain import load_robot_file
from skelarm_sym.models.chain import load_robot

from closed_ik_support import ROBOTS


def write(tmp_path, text, name="arm.toml"):
    path = tmp_path / name
    path.write_text(text)
    return load_robot_file(path)


UR5_BODY = (ROBOTS / "ur5.toml").read_text()


def test_family_is_frozen_and_exact():
    family = classify(load_robot(ROBOTS / "puma560.toml"))
    with pytest.raises(dataclasses.FrozenInstanceError):
        family.name = "x"
    centre = dict(family.special_points)["wrist centre"]
    # PUMA 560 at q = 0: wrist centre at (a2 + a3, d3, d4)... in Corke's frames: x = a2 + a3, y = d3, z = -d4 style;
    # exact means: built from the table's numbers only, no rounding noise in the zero entries
    assert all(isinstance(x, (sp.Float, sp.Integer, sp.Rational)) or x == 0 for x in centre)
    assert sorted(abs(float(x)) for x in centre) == pytest.approx(sorted([0.4318 + 0.0203, 0.15005, 0.4318]))
    axes = family.axes
    assert all(x in (-1, 0, 1) for h in axes for x in h)  # pi/2 twists: exact unit axes
    assert "SP4 q1" in family.describe()


def test_geometry_matches_the_reference_at_zero():
    from skelarm_sym.models.chain.reference import chain_kinematics

    for file in ("puma560.toml", "ur5.toml", "stanford.toml", "panda.toml"):
        chain = load_robot(ROBOTS / file)
        geom = chain_geometry(chain)
        kin = chain_kinematics(chain.numeric(), np.zeros(chain.n))
        _, H, P = geom.numeric()
        assert np.allclose(H, kin.axes, atol=1e-15)
        # points may differ along the axis; the lines must coincide
        d = P - kin.origins
        assert np.allclose(d - np.sum(d * H, axis=1)[:, None] * H, 0, atol=1e-15)
        M = np.array([[float(x) for x in r] for r in geom.home_rotation])
        assert np.allclose(M, kin.T[:3, :3], atol=1e-15)
        assert np.allclose([float(x) for x in geom.home_position], kin.T[:3, 3], atol=1e-15)


def test_offset_wrist_is_explained_with_its_distance(tmp_path):
    # UR5 with a 5 cm offset between axes 5 and 6 (a5 = 0.05): no family, and the message says by how much
    text = UR5_BODY.replace('d = 0.09465\nalpha = "-pi/2"', 'd = 0.09465\na = 0.05\nalpha = "-pi/2"')
    chain = write(tmp_path, text)
    with pytest.raises(ClosedFormError) as err:
        classify(chain)
    msg = str(err.value)
    assert "\n" not in msg
    assert "axes 5, 6 do not meet: closest distance 0.05 m" in msg
    assert "axes 4, 5, 6 do not meet" in msg
    assert explain(chain) == msg


def test_puma_with_offset_wrist_names_the_wrist(tmp_path):
    text = (ROBOTS / "puma560.toml").read_text().replace('name = "wrist_2"\ntype = "revolute"', 'name = "wrist_2"\ntype = "revolute"\nd = 0.0823')
    msg = explain(write(tmp_path, text))
    assert re.search(r"spherical wrist: axes 4, 5, 6 do not meet: closest distance 0\.0\d+ m", msg), msg


@pytest.mark.parametrize("file,message", [
    ("scara.toml", "closed-form families here need 6 moving joints, this chain has 4"),
    ("panda.toml", "a 7-joint arm: lock one joint, --ik-lock JOINT; load_robot(path, ik_lock=JOINT) from Python"),
])
def test_joint_counts(file, message):
    assert message in explain(load_robot(ROBOTS / file))


def test_locks():
    panda = load_robot(ROBOTS / "panda.toml")
    assert classify(panda, 6).lock == 6
    with pytest.raises(ClosedFormError, match="no joint named"):
        derive_ik_all(panda, "nope")
    assert derive_ik_all(panda, "panda_joint7").lock == 6
    # Panda with joint 1 locked: joints 2-7 have neither wrist nor shoulder nor three parallel axes
    assert "no closed-form family" in explain(panda, 0)
    with pytest.raises(ClosedFormError, match="reduces a 7-joint chain"):
        classify(load_robot(ROBOTS / "puma560.toml"), 2)


def test_parameters_are_refused(tmp_path):
    text = UR5_BODY.replace("a = -0.425", 'a = "a2"')
    with pytest.raises(ClosedFormError, match="named parameters"):
        classify(write(tmp_path, text))


def test_explain_reads_the_lock_load_robot_recorded():
    """A docs review: ``explain(load_robot("iiwa14.toml", ik_lock=3))`` said the chain needs 6 moving joints; the lock
    given to load_robot (counted from 1) is the one explain uses when it is given none."""
    from pathlib import Path

    from skelarm_sym.closed_ik.classify import explain
    from skelarm_sym.models.chain import load_robot

    robots = Path(__file__).parent.parent / "examples" / "robots"
    assert explain(load_robot(robots / "iiwa14.toml", ik_lock=3)).startswith("spherical_wrist (intersect_12), joint 3 locked")
    assert "this chain has 7 (a 7-joint arm: lock one joint" in explain(load_robot(robots / "iiwa14.toml"))


def test_two_spherical_triples_are_refused():
    """The iiwa with its elbow (joint 4) locked: axes 1, 2, 3 meet at the shoulder and 5, 6, 7 at the wrist, a fixed
    distance apart, so the tool's position has two degrees of freedom: a reachable target has a continuum of
    solutions. It was classified (``intersect_23``) and its rows came back least squares on 193 of 200 reachable
    targets, the source missing on all (a probe on pybullet's iiwa). Refused with the reason; other locks solve."""
    iiwa = load_robot(ROBOTS / "iiwa14.toml")
    with pytest.raises(ClosedFormError, match=r"axes 1, 2, 3 meet at one point and so do axes 5, 6, 7"):
        classify(iiwa, 3)
    assert classify(iiwa, 2).name == "spherical_wrist"


OFFSET_SEVEN = """<robot name="offset7">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/><link name="l5"/><link name="l6"/>
  <link name="l7"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.1 0 0.1"/><axis xyz="0 0 1"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/><origin xyz="0.1 0 -0.1"/><axis xyz="1 0 0"/></joint>
  <joint name="j5" type="revolute"><parent link="l4"/><child link="l5"/><origin xyz="0.3 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="j6" type="revolute"><parent link="l5"/><child link="l6"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/></joint>
  <joint name="j7" type="revolute"><parent link="l6"/><child link="l7"/><origin xyz="0.1 0 0"/><axis xyz="1 0 0"/></joint>
  <joint name="jt" type="fixed"><parent link="l7"/><child link="tool"/><origin xyz="0.05 0.02 0.01" rpy="0.1 0.2 0.3"/></joint>
</robot>
"""


def test_positioning_axes_that_meet_at_one_lock_value_only_are_not_refused(tmp_path):
    """A 7-joint arm with joint 3 locked whose axes 1, 2 and 4 meet at one point only where the lock is 0 or pi (a
    reviewer's arm): the refusal of two spherical triples fired at the lock sample 0 and refused the arm at every
    lock value; only triples that meet at every lock value are refused. Its IK is exact at other lock values."""
    from skelarm_sym.closed_ik.evaluate import ClosedFormIK
    from skelarm_sym.models.chain.reference import chain_kinematics

    (tmp_path / "offset7.urdf").write_text(OFFSET_SEVEN)
    chain = load_robot(tmp_path / "offset7.urdf", ik_lock=3)
    assert (classify(chain, 2).name, classify(chain, 2).position) == ("spherical_wrist", "intersect_12")
    ik, num, rng = ClosedFormIK(chain, lock=2), chain.numeric(), np.random.default_rng(0)
    for lock in (0.7, -1.9):
        q = rng.uniform(-2.5, 2.5, (20, 7))
        q[:, 2] = lock
        T = chain_kinematics(num, q).T
        Q, flags = ik.candidates(T.reshape(-1, 16), lock=lock)
        for k in range(len(q)):
            exact = (flags[k] & 1) == 0
            errors = [np.abs(chain_kinematics(num, row[None]).T[0] - T[k]).max() for row in Q[k][exact]]
            assert exact.any() and max(errors) < 1e-12
