"""The chain reference (skelarm_sym.models.chain.reference) against finite differences, the planar
reference and, when it imports, Pinocchio.

The pose used for finite differences is computed HERE, independently of the reference: a plain
product of 4 x 4 matrices with joint rotations from unit quaternions (the reference uses
Rodrigues' formula and carries R and p separately through a velocity recursion).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skelarm_sym.models.chain import Chain, Joint, Transform, dh_joint
from skelarm_sym.models.chain.dh_file import load_robot_file
from skelarm_sym.reference import chain_kinematics
from skelarm_sym.models.planar.reference import kinematics as planar_kinematics

ROBOTS = Path(__file__).resolve().parent.parent / "examples" / "robots"


# -- an independent pose ----------------------------------------------------------------------------

def quaternion_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of the unit quaternion (cos(a/2), sin(a/2) axis)."""
    w = math.cos(angle / 2.0)
    x, y, z = math.sin(angle / 2.0) * np.asarray(axis, dtype=float)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def pose(numeric, q) -> np.ndarray:
    """base * prod(before * M(theta) * after) * tool as a product of homogeneous matrices."""
    T = np.array(numeric.base, dtype=float)
    for j in numeric.joints:
        theta = j.multiplier * q[j.coordinate] + j.offset
        M = np.eye(4)
        if j.kind == "revolute":
            M[:3, :3] = quaternion_rotation(j.axis, theta)
        else:
            M[:3, 3] = theta * np.asarray(j.axis)
        T = T @ j.before @ M @ j.after
    return T @ numeric.tool


def vee(S: np.ndarray) -> np.ndarray:
    """The vector of the skew-symmetric part of S."""
    A = 0.5 * (S - S.T)
    return np.array([A[2, 1], A[0, 2], A[1, 0]])


def d1(f, h):
    """First derivative at 0, five-point stencil."""
    return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h)


def d2(f, h):
    """Second derivative at 0, five-point stencil."""
    return (-f(2 * h) + 16 * f(h) - 30 * f(0.0) + 16 * f(-h) - f(-2 * h)) / (12 * h * h)


def fd_jacobian(numeric, q, h=1e-5) -> np.ndarray:
    """Columns [dp/dq_i; vee(dR/dq_i R^T)] by finite differences of the independent pose."""
    n = numeric.n
    R = pose(numeric, q)[:3, :3]
    J = np.zeros((6, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        dT = d1(lambda t: pose(numeric, q + t * e), h)
        J[:3, i] = dT[:3, 3]
        J[3:, i] = vee(dT[:3, :3] @ R.T)
    return J


def fd_motion(numeric, q, dq, ddq, h1=1e-5, h2=1e-3):
    """Twist and classical acceleration along q(t) = q + dq t + ddq t^2 / 2 by finite differences."""
    path = lambda t: pose(numeric, q + dq * t + 0.5 * ddq * t * t)  # noqa: E731
    T0 = path(0.0)
    dT = d1(path, h1)
    ddT = d2(path, h2)
    R = T0[:3, :3]
    twist = np.concatenate([dT[:3, 3], vee(dT[:3, :3] @ R.T)])
    # R'' R^T = S(dw) + S(w)^2 and S(w)^2 is symmetric: the skew part is the angular acceleration.
    acc = np.concatenate([ddT[:3, 3], vee(ddT[:3, :3] @ R.T)])
    return twist, acc


def close(actual, expected, tol=1e-6):
    actual, expected = np.asarray(actual), np.asarray(expected)
    scale = 1.0 + np.max(np.abs(expected))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=tol * scale)


def check_against_fd(chain: Chain, q, dq, ddq, params=None):
    numeric = chain.numeric(params)
    r = chain_kinematics(numeric, q, dq, ddq)
    close(r.T, pose(numeric, q), 1e-12)
    J = fd_jacobian(numeric, q)
    close(r.J, J)
    R = r.T[:3, :3]
    close(r.J_tool, np.vstack([R.T @ J[:3], R.T @ J[3:]]))
    dJ = d1(lambda t: chain_kinematics(numeric, q + t * dq).J, 1e-5)
    close(r.dJ, dJ)
    twist, acc = fd_motion(numeric, q, dq, ddq)
    close(r.twist, twist)
    close(r.acc, acc, 2e-6)
    # the identities the derivation relies on
    close(r.J @ dq, r.twist, 1e-12)
    close(r.J @ ddq + r.dJ @ dq, r.acc, 1e-12)
    return r


# -- random chains -----------------------------------------------------------------------------------

finite = st.floats(-1.5, 1.5, allow_nan=False, allow_infinity=False)
angles = st.floats(-math.pi, math.pi, allow_nan=False, allow_infinity=False)


def frames():
    return st.tuples(st.tuples(finite, finite, finite), st.tuples(angles, angles, angles)).map(
        lambda xr: Transform.from_xyz_rpy(xr[0], xr[1]))


@st.composite
def dh_chains(draw, max_joints=8):
    n = draw(st.integers(1, max_joints))
    convention = draw(st.sampled_from(["standard", "modified"]))
    joints = []
    for i in range(n):
        kind = draw(st.sampled_from(["revolute", "prismatic"]))
        a, d = draw(finite), draw(finite)
        alpha, theta = draw(angles), draw(angles)
        joints.append(dh_joint(f"q{i + 1}", kind, convention, a, alpha, d, theta, i))
    base = draw(frames())
    tool = draw(frames())
    return Chain("random", tuple(joints), base, tool)


@st.composite
def general_chains(draw, max_joints=6):
    """Non-z axes, rpy in every constant transform, random offsets."""
    n = draw(st.integers(1, max_joints))
    joints = []
    for i in range(n):
        kind = draw(st.sampled_from(["revolute", "prismatic"]))
        axis = draw(st.tuples(finite, finite, finite).filter(lambda v: sum(x * x for x in v) > 0.05))
        joints.append(Joint(f"j{i}", kind, draw(frames()), axis, draw(frames()), i, offset=sp.Float(draw(finite))))
    return Chain("general", tuple(joints), draw(frames()), draw(frames()))


def motion(n, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-2, 2, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-1.5, 1.5, n)


SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(dh_chains(), st.integers(0, 2**32 - 1))
def test_random_dh_chains_match_finite_differences(chain, seed):
    check_against_fd(chain, *motion(chain.n, seed))


@SETTINGS
@given(general_chains(), st.integers(0, 2**32 - 1))
def test_general_axes_and_rpy_match_finite_differences(chain, seed):
    check_against_fd(chain, *motion(chain.n, seed))


# -- prismatic joints -------------------------------------------------------------------------------

def test_prismatic_only_chain_columns_are_axes():
    """Cartesian gantry with a tilted base: J = [z_k; 0], dJ = 0 (the chain never rotates)."""
    base = Transform.from_xyz_rpy([0.1, -0.2, 0.3], [0.3, -0.4, 0.5])
    joints = (
        Joint("x", "prismatic", Transform.identity(), (1, 0, 0), Transform.identity(), 0),
        Joint("y", "prismatic", Transform.identity(), (0, 1, 0), Transform.identity(), 1),
        Joint("z", "prismatic", Transform.identity(), (0, 0, 1), Transform.translate(0, 0, 0.5), 2),
    )
    chain = Chain("gantry", joints, base)
    q, dq, ddq = np.array([0.3, -0.7, 1.1]), np.array([0.5, 0.2, -0.4]), np.array([1.0, -2.0, 0.5])
    r = check_against_fd(chain, q, dq, ddq)
    R0 = chain.numeric().base[:3, :3]
    np.testing.assert_allclose(r.J[:3], R0, atol=1e-15)
    np.testing.assert_array_equal(r.J[3:], 0.0)
    np.testing.assert_allclose(r.dJ, 0.0, atol=1e-15)
    np.testing.assert_allclose(r.twist[:3], R0 @ dq, atol=1e-15)
    np.testing.assert_allclose(r.acc[:3], R0 @ ddq, atol=1e-15)
    np.testing.assert_allclose(r.T[:3, 3], R0 @ (q + [0, 0, 0.5]) + [0.1, -0.2, 0.3], atol=1e-15)


def test_prismatic_after_revolute_has_rotating_axis():
    """Polar arm: revolute about z, then prismatic along the rotating x axis.

    p = (q2 cos q1, q2 sin q1, 0): J = [[-q2 s, c], [q2 c, s], [0, 0], 0, 0, [1, 0]], the prismatic
    column's derivative is [w x z; 0] = dq1 [-s, c, 0; 0], and the acceleration has the Coriolis
    term 2 w x z dq2.
    """
    joints = (
        Joint("turn", "revolute", Transform.identity(), (0, 0, 1), Transform.identity(), 0),
        Joint("reach", "prismatic", Transform.identity(), (1, 0, 0), Transform.identity(), 1),
    )
    chain = Chain("polar", joints)
    q1, q2, dq1, dq2, ddq1, ddq2 = 0.7, 1.3, 0.9, -0.4, 0.3, 0.8
    r = check_against_fd(chain, np.array([q1, q2]), np.array([dq1, dq2]), np.array([ddq1, ddq2]))
    c, s = math.cos(q1), math.sin(q1)
    np.testing.assert_allclose(r.J, [[-q2 * s, c], [q2 * c, s], [0, 0], [0, 0], [0, 0], [1, 0]], atol=1e-15)
    np.testing.assert_allclose(r.dJ[:, 1], [-s * dq1, c * dq1, 0, 0, 0, 0], atol=1e-15)
    ax = (ddq2 - q2 * dq1**2) * c - (q2 * ddq1 + 2 * dq1 * dq2) * s
    ay = (ddq2 - q2 * dq1**2) * s + (q2 * ddq1 + 2 * dq1 * dq2) * c
    np.testing.assert_allclose(r.acc, [ax, ay, 0, 0, 0, ddq1], atol=1e-14)


# -- mimic joints ----------------------------------------------------------------------------------------

def test_mimic_joint_adds_scaled_column():
    """Two joints on coordinate 0 (the second at -0.5 q0 + 0.3): J is the sum of the scaled columns."""
    tilt = Transform.from_xyz_rpy([0.2, 0.0, 0.1], [0.4, 0.2, -0.3])
    joints = (
        Joint("a", "revolute", Transform.identity(), (0, 0, 1), Transform.translate(0.5, 0, 0), 0),
        Joint("b", "revolute", tilt, (0, 1, 0), Transform.translate(0.4, 0.1, 0), 1),
        Joint("a_mimic", "revolute", tilt, (1, 0, 1), Transform.translate(0.3, 0, 0.2), 0,
              offset=sp.Float(0.3), multiplier=sp.Float(-0.5)),
        Joint("slide_mimic", "prismatic", Transform.identity(), (0, 0, 1), Transform.identity(), 1,
              offset=sp.Float(0.1), multiplier=sp.Integer(2)),
    )
    chain = Chain("mimic", joints, coordinates=("a", "b"))
    q, dq, ddq = np.array([0.4, -0.9]), np.array([1.2, 0.7]), np.array([-0.5, 0.9])
    r = check_against_fd(chain, q, dq, ddq)
    # the same arm with four independent coordinates, then the chain rule by hand
    free = Chain("free", tuple(Joint(j.name, j.kind, j.before, j.axis, j.after, k) for k, j in enumerate(joints)))
    theta = np.array([q[0], q[1], -0.5 * q[0] + 0.3, 2 * q[1] + 0.1])
    dtheta = np.array([dq[0], dq[1], -0.5 * dq[0], 2 * dq[1]])
    f = chain_kinematics(free.numeric(), theta, dtheta)
    S = np.array([[1, 0], [0, 1], [-0.5, 0], [0, 2]])
    np.testing.assert_allclose(r.J, f.J @ S, atol=1e-14)
    np.testing.assert_allclose(r.dJ, f.dJ @ S, atol=1e-14)
    np.testing.assert_allclose(r.T, f.T, atol=1e-15)


# -- planar special case ----------------------------------------------------------------------------

@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_planar_dh_table_gives_planar_reference(n):
    rng = np.random.default_rng(n)
    lengths = rng.uniform(0.2, 1.5, n)
    chain = Chain("planar", tuple(dh_joint(f"q{i}", "revolute", "standard", float(l), 0, 0, 0, i)
                                  for i, l in enumerate(lengths)))
    q, dq, ddq = rng.uniform(-3, 3, (4, n)), rng.uniform(-2, 2, (4, n)), rng.uniform(-2, 2, (4, n))
    r = chain_kinematics(chain.numeric(), q, dq, ddq)
    p = planar_kinematics(q, dq, ddq, lengths)
    np.testing.assert_allclose(r.J[..., [0, 1], :], p.J, atol=1e-13)
    np.testing.assert_allclose(r.J[..., 5, :], 1.0, atol=0)
    np.testing.assert_array_equal(r.J[..., 2:5, :], 0.0)
    np.testing.assert_allclose(r.dJ[..., [0, 1], :], p.H, atol=1e-13)
    np.testing.assert_allclose(r.dJ[..., 2:, :], 0.0, atol=1e-15)
    np.testing.assert_allclose(r.T[..., :2, 3], p.p, atol=1e-13)
    np.testing.assert_allclose(r.twist[..., :2], p.v, atol=1e-13)
    np.testing.assert_allclose(r.acc[..., :2], p.a, atol=1e-13)
    np.testing.assert_allclose(r.acc[..., 5], ddq.sum(-1), atol=1e-13)


# -- batching ----------------------------------------------------------------------------------------------

def test_batch_equals_single():
    chain = load_robot_file(ROBOTS / "ur5.toml").numeric()
    rng = np.random.default_rng(7)
    q, dq, ddq = rng.uniform(-3, 3, (2, 3, 6)), rng.uniform(-2, 2, (2, 3, 6)), rng.uniform(-2, 2, (2, 3, 6))
    batch = chain_kinematics(chain, q, dq, ddq)
    for idx in np.ndindex(2, 3):
        one = chain_kinematics(chain, q[idx], dq[idx], ddq[idx])
        for name in ("T", "J", "J_tool", "dJ", "twist", "acc"):
            np.testing.assert_array_equal(getattr(batch, name)[idx], getattr(one, name), err_msg=name)
    # dq broadcasts against a batch of q
    shared = chain_kinematics(chain, q, dq[0, 0], ddq[0, 0])
    assert shared.dJ.shape == (2, 3, 6, 6)
    np.testing.assert_array_equal(shared.acc[1, 2], chain_kinematics(chain, q[1, 2], dq[0, 0], ddq[0, 0]).acc)


@pytest.mark.parametrize("name", ["stanford.toml", "ur5.toml"])  # a prismatic joint; revolute only
def test_a_pose_without_rates_is_the_pose_with_zero_rates(name):
    # without dq and ddq the recursion skips the rates' terms: the same numbers as with zero rates given
    chain = load_robot_file(ROBOTS / name).numeric()
    q = np.random.default_rng(3).uniform(-3, 3, (5, chain.n))
    lean, full = chain_kinematics(chain, q), chain_kinematics(chain, q, np.zeros_like(q), np.zeros_like(q))
    for field in ("T", "J", "J_tool", "dJ", "twist", "acc", "origins", "axes"):
        np.testing.assert_array_equal(getattr(lean, field), getattr(full, field), err_msg=field)
    assert not np.any(lean.dJ) and not np.any(lean.twist) and not np.any(lean.acc)


def test_wrong_shape_is_refused():
    chain = load_robot_file(ROBOTS / "ur5.toml").numeric()
    with pytest.raises(ValueError, match=r"\(\.\.\., 6\)"):
        chain_kinematics(chain, np.zeros(5))


# -- example robots ----------------------------------------------------------------------------------

EXAMPLES = sorted(p.name for p in ROBOTS.glob("*.toml"))


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_robots_match_finite_differences(name):
    chain = load_robot_file(ROBOTS / name)
    for seed in range(3):
        check_against_fd(chain, *motion(chain.n, seed))


def test_ur5_zero_pose_is_published_one():
    """UR5 at q = 0 (standard DH, UR's parameters): tool at (a2 + a3, -(d4 + d6), d1 - d5)."""
    r = chain_kinematics(load_robot_file(ROBOTS / "ur5.toml").numeric(), np.zeros(6))
    np.testing.assert_allclose(r.T[:3, 3], [-0.425 - 0.39225, -(0.10915 + 0.0823), 0.089159 - 0.09465], atol=1e-15)
    np.testing.assert_allclose(r.T[:3, :3], [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-15)


def test_panda_zero_pose_flange():
    """Panda at q = 0: flange at (0.088, 0, 0.333 + 0.316 + 0.384 - 0.107), pointing down."""
    r = chain_kinematics(load_robot_file(ROBOTS / "panda.toml").numeric(), np.zeros(7))
    np.testing.assert_allclose(r.T[:3, 3], [0.088, 0.0, 0.333 + 0.316 + 0.384 - 0.107], atol=1e-15)
    np.testing.assert_allclose(r.T[:3, :3], [[1, 0, 0], [0, -1, 0], [0, 0, -1]], atol=1e-15)


def test_ur5_files_differ_by_a_half_turn_of_the_base():
    """examples/robots/ur5.urdf (ur_description's frames) and ur5.toml (UR's DH table) describe the same arm with
    bases a half turn apart: T_urdf(q) = Rz(pi) T_toml(q), the tool frames equal. A new user compared the README's
    quickstart (URDF) with docs/robots.md's demo (TOML) and found x and y negated; the docs now say so."""
    from skelarm_sym.models.chain.loader import load_robot

    urdf = load_robot(ROBOTS / "ur5.urdf", tip="tool0").numeric()
    toml = load_robot_file(ROBOTS / "ur5.toml").numeric()
    q = np.random.default_rng(5).uniform(-3, 3, (20, 6))
    Rz = np.diag([-1.0, -1.0, 1.0, 1.0])
    np.testing.assert_allclose(chain_kinematics(urdf, q).T, Rz @ chain_kinematics(toml, q).T, atol=1e-15)
    assert np.abs(chain_kinematics(urdf, q).T - chain_kinematics(toml, q).T).max() > 0.5


def test_puma560_conventions_describe_the_same_arm():
    """Corke's standard table and Craig's modified one (joint 2 offset pi): T_std(q) = Rz(pi) T_mod(q).

    Same q, same arm: the Jacobians agree after the same base rotation, and the per-joint axes and
    origins coincide up to it (the joint-2 and joint-3 axes point the same way, not opposite).
    """
    std = load_robot_file(ROBOTS / "puma560.toml").numeric()
    mod = load_robot_file(ROBOTS / "puma560_modified.toml").numeric()
    Rz = np.diag([-1.0, -1.0, 1.0, 1.0])
    rng = np.random.default_rng(560)
    q, dq, ddq = rng.uniform(-3, 3, (20, 6)), rng.uniform(-2, 2, (20, 6)), rng.uniform(-2, 2, (20, 6))
    s, m = chain_kinematics(std, q, dq, ddq), chain_kinematics(mod, q, dq, ddq)
    np.testing.assert_allclose(s.T, Rz @ m.T, atol=1e-15)
    R6 = np.kron(np.eye(2), Rz[:3, :3])
    np.testing.assert_allclose(s.J, R6 @ m.J, atol=1e-15)
    np.testing.assert_allclose(s.dJ, R6 @ m.dJ, atol=1e-14)
    np.testing.assert_allclose(s.J_tool, m.J_tool, atol=1e-15)
    np.testing.assert_allclose(s.acc, m.acc @ R6.T, atol=1e-14)
    np.testing.assert_allclose(s.axes, m.axes @ Rz[:3, :3].T, atol=1e-15)
    # q = 0 (Corke's "qz", an L shape): tool at (a2 + a3, -d3, d4)
    zero = chain_kinematics(std, np.zeros(6)).T
    np.testing.assert_allclose(zero[:3, 3], [0.4318 + 0.0203, -0.15005, 0.4318], atol=1e-15)
    # Craig's table exactly as printed (joint-2 theta = 0) reverses joint 1 instead
    craig = Chain("craig", tuple(dh_joint(f"q{i}", "revolute", "modified", a, al, d, 0, i) for i, (a, al, d) in enumerate(
        [(0, 0, 0), (0, -sp.pi / 2, 0), (0.4318, 0, 0.15005), (0.0203, -sp.pi / 2, 0.4318),
         (0, sp.pi / 2, 0), (0, -sp.pi / 2, 0)]))).numeric()
    flipped = q * [-1, 1, 1, 1, 1, 1]
    np.testing.assert_allclose(s.T, np.diag([1.0, -1.0, -1.0, 1.0]) @ chain_kinematics(craig, flipped).T, atol=1e-15)


# -- Pinocchio --------------------------------------------------------------------------------------------

def _pinocchio_model(pin, numeric):
    """A Pinocchio model of a chain without mimic joints; q_pin = theta (offset added by the caller)."""
    model = pin.Model()
    parent = 0
    previous = np.array(numeric.base, dtype=float)
    for j in numeric.joints:
        placement = previous @ j.before
        se3 = pin.SE3(placement[:3, :3].copy(), placement[:3, 3].copy())
        axis = np.asarray(j.axis, dtype=float)
        joint = pin.JointModelRevoluteUnaligned(axis) if j.kind == "revolute" else pin.JointModelPrismaticUnaligned(axis)
        parent = model.addJoint(parent, joint, se3, j.name)
        model.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
        previous = np.array(j.after, dtype=float)
    tool = previous @ numeric.tool
    frame = model.addFrame(pin.Frame("tool", parent, 0, pin.SE3(tool[:3, :3].copy(), tool[:3, 3].copy()),
                                     pin.FrameType.OP_FRAME))
    return model, frame


PIN_CHAINS = [f"pin{k}" for k in range(6)] + ["puma560.toml", "ur5.toml", "panda.toml", "stanford.toml", "scara.toml"]


@pytest.mark.parametrize("case", PIN_CHAINS)
def test_against_pinocchio(case):
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (the pin wheel) is not installed")
    if case.endswith(".toml"):
        chain = load_robot_file(ROBOTS / case)
    else:
        chain = _random_general_chain(int(case[3:]))
    numeric = chain.numeric()
    model, frame = _pinocchio_model(pin, numeric)
    data = model.createData()
    LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    offsets = np.array([j.offset for j in numeric.joints])
    for seed in range(3):
        q, dq, ddq = motion(numeric.n, 100 + seed)
        r = chain_kinematics(numeric, q, dq, ddq)
        theta = q + offsets
        pin.forwardKinematics(model, data, theta, dq, ddq)
        pin.updateFramePlacements(model, data)
        acc = pin.getFrameClassicalAcceleration(model, data, frame, LWA)
        twist = pin.getFrameVelocity(model, data, frame, LWA)
        pin.computeJointJacobians(model, data, theta)
        J = pin.getFrameJacobian(model, data, frame, LWA)
        pin.computeJointJacobiansTimeVariation(model, data, theta, dq)
        dJ = pin.getFrameJacobianTimeVariation(model, data, frame, LWA)
        np.testing.assert_allclose(r.T, data.oMf[frame].homogeneous, atol=1e-12)
        np.testing.assert_allclose(r.J, J, atol=1e-12)
        np.testing.assert_allclose(r.dJ, dJ, atol=1e-11)
        np.testing.assert_allclose(r.twist, np.concatenate([twist.linear, twist.angular]), atol=1e-12)
        np.testing.assert_allclose(r.acc, np.concatenate([acc.linear, acc.angular]), atol=1e-11)


def _random_general_chain(seed: int) -> Chain:
    """Random chain without mimic joints: random axes (every other one a DH z), rpy everywhere."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 8))

    def frame():
        return Transform.from_xyz_rpy(rng.uniform(-1, 1, 3).tolist(), rng.uniform(-3, 3, 3).tolist())

    joints = []
    for i in range(n):
        kind = "prismatic" if rng.random() < 0.35 else "revolute"
        axis = (0, 0, 1) if i % 2 else tuple(rng.uniform(-1, 1, 3).tolist())
        joints.append(Joint(f"j{i}", kind, frame(), axis, frame(), i, offset=sp.Float(float(rng.uniform(-1, 1)))))
    return Chain(f"random{seed}", tuple(joints), frame(), frame())


def test_reference_imports_numpy_only():
    """The judge shares no code with what it judges: its imports are NumPy and the standard library."""
    import ast

    import skelarm_sym.models.chain.reference as module

    tree = ast.parse(Path(module.__file__).read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add("." * node.level + (node.module or ""))
    assert imported == {"__future__", "dataclasses", "numpy"}, imported


def test_an_arm_far_from_the_world_origin_is_judged_as_at_the_origin(tmp_path):
    """A URDF whose arm hangs from a map frame 4.5e6 m away: the reference took every p_e - o_k between numbers
    that large and lost their digits, and check FAILed the emitted code (18 rows; it is bit for bit the code of the
    arm at the origin). The recursion now carries positions from the first joint's origin: every output but T's
    translation equals the same arm's at the origin to rounding, and T's is that translation moved."""
    from skelarm_sym.models.chain.urdf import load_urdf
    from skelarm_sym.models.chain.reference import chain_kinematics

    links = "".join(f'<link name="l{k}"/>' for k in range(7)) + '<link name="world"/>'
    joints = "".join(f'<joint name="j{k}" type="revolute"><parent link="l{k}"/><child link="l{k + 1}"/>'
                     f'<origin xyz="0.05 0.02 0.3" rpy="{0.3 * k} 0.5 0"/><axis xyz="0 0 1"/></joint>' for k in range(6))
    far, near = tmp_path / "far.urdf", tmp_path / "near.urdf"
    for path, offset in ((far, "500000 4500000 120"), (near, "0 0 0")):
        path.write_text(f'<robot name="r">{links}<joint name="w" type="fixed"><parent link="world"/><child link="l0"/>'
                        f'<origin xyz="{offset}"/></joint>{joints}</robot>')
    rng = np.random.default_rng(2)
    q, dq, ddq = (rng.uniform(-2, 2, (20, 6)) for _ in range(3))
    a = chain_kinematics(load_urdf(far).numeric(), q, dq, ddq)
    b = chain_kinematics(load_urdf(near).numeric(), q, dq, ddq)
    for name in ("J", "J_tool", "dJ", "twist", "acc"):  # (it was 1e-10 off: the digits of 4.5e6 m)
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-13, err_msg=name)
    np.testing.assert_array_equal(a.T[:, :3, :3], b.T[:, :3, :3])
    np.testing.assert_allclose(a.T[:, :3, 3] - [500000, 4500000, 120], b.T[:, :3, 3], rtol=0, atol=1e-9)
