"""Shared helpers of tests/test_closed_ik*.py: robots, cached solvers, random family arms, targets."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from skelarm_sym.models.chain import Chain, Transform, dh_joint
from skelarm_sym.models.chain import load_robot
from skelarm_sym.models.chain.reference import chain_kinematics

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = ROOT / "examples" / "robots"

# name -> (file, lock joint index or None, expected family, expected positioning structure)
TOML_ARMS = {
    "puma560": ("puma560.toml", None, "spherical_wrist", "parallel_23"),
    "ur5": ("ur5.toml", None, "three_parallel", None),
    "stanford": ("stanford.toml", None, "spherical_wrist", "prismatic_3"),
    "kuka_kr6": ("kuka_kr6.toml", None, "spherical_wrist", "parallel_23"),
    "abb_irb140": ("abb_irb140.toml", None, "spherical_wrist", "parallel_23"),
    "iiwa14_lock3": ("iiwa14.toml", 2, "spherical_wrist", "intersect_12"),
    "panda_lock7": ("panda.toml", 6, "spherical_shoulder", "intersect_12"),
    "puma560_modified": ("puma560_modified.toml", None, "spherical_wrist", "parallel_23"),
}

# URDFs of the example-robot-data package: name -> (path under robots/, tip, lock, family, structure)
URDF_ARMS = {
    "ur5_urdf": ("ur_description/urdf/ur5_robot.urdf", "tool0", None, "three_parallel", None),
    "ur10_urdf": ("ur_description/urdf/ur10_robot.urdf", "tool0", None, "three_parallel", None),
    "kinova_j2s6": ("kinova_description/robots/kinova.urdf", "j2s6s200_end_effector", None, "spherical_wrist", "parallel_23"),
    "panda_urdf_lock7": ("panda_description/urdf/panda.urdf", "panda_hand_tcp", 6, "spherical_shoulder", "intersect_12"),
}


def example_robot_data_dir() -> Path | None:
    """The robots/ folder of the ``example-robot-data`` pip package, or ``None``."""
    try:
        import example_robot_data  # noqa: F401  (a cmeel package: it only puts its files on the path)
    except ImportError:
        pass
    import sys

    for base in sys.path:
        candidate = Path(base) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if candidate.is_dir():
            return candidate
    return None


def load_arm(name: str) -> tuple[Chain, int | None]:
    """The chain and lock of an arm of :data:`TOML_ARMS` or :data:`URDF_ARMS` (skips without example-robot-data)."""
    if name in TOML_ARMS:
        file, lock, _, _ = TOML_ARMS[name]
        return load_robot(ROBOTS / file), lock
    path, tip, lock, _, _ = URDF_ARMS[name]
    root = example_robot_data_dir()
    if root is None:
        pytest.skip("example-robot-data is not installed (pip install example-robot-data): its URDFs are the source")
    return load_robot(root / path, tip=tip), lock


@functools.lru_cache(maxsize=None)
def solver(name: str):
    """A cached :class:`ClosedFormIK` for an arm name."""
    from skelarm_sym.closed_ik.evaluate import ClosedFormIK

    chain, lock = load_arm(name)
    return chain, lock, ClosedFormIK(chain, lock)


def random_configurations(chain: Chain, m: int, rng: np.random.Generator, within_limits: bool = False) -> np.ndarray:
    """``m`` configurations: revolute joints uniform in [-pi, pi] (``within_limits``: in their limits where
    finite), prismatic ones within their limits (or [0.2, 1])."""
    q = rng.uniform(-np.pi, np.pi, (m, chain.n))
    limits = chain.limits()
    if within_limits:
        for c in range(chain.n):
            lo, hi = limits["lower"][c], limits["upper"][c]
            if lo is not None and hi is not None:
                q[:, c] = rng.uniform(lo, hi, m)
    for j in chain.joints:
        if j.kind == "prismatic":
            c = j.coordinate
            lo = limits["lower"][c] if limits["lower"][c] is not None else 0.2
            hi = limits["upper"][c] if limits["upper"][c] is not None else 1.0
            q[:, c] = rng.uniform(lo, hi, m)
    return q


def targets_of(chain: Chain, q: np.ndarray) -> np.ndarray:
    """Tool poses (m, 4, 4) by the NumPy reference."""
    return chain_kinematics(chain.numeric(), q).T


def pose_errors(num, Q: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The judge's :func:`~skelarm_sym.models.chain.reference_ik_all.pose_error` of every candidate ``Q`` (m, S, n)
    against its own target ``T`` (m, 4, 4), by one forward pass over all m * S rows: ``(pos, rot)``, each (m, S)."""
    from skelarm_sym.models.chain.reference_ik_all import reach

    m, S, n = Q.shape
    Tq = chain_kinematics(num, Q.reshape(-1, n)).T.reshape(m, S, 4, 4)
    pos = np.linalg.norm(Tq[..., :3, 3] - T[:, None, :3, 3], axis=-1) / reach(num)
    rot = np.max(np.abs(Tq[..., :3, :3] - T[:, None, :3, :3]), axis=(-1, -2))
    return pos, rot


def wrapped_distance(a: np.ndarray, b: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """max |a - b| over the last axis, revolute entries modulo 2 pi."""
    d = a - b
    d = np.where(revolute, (d + np.pi) % (2 * np.pi) - np.pi, d)
    return np.max(np.abs(d), axis=-1)


# -- random arms of each family (standard DH: A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)) -------------

FAMILY_CONSTRAINTS = {
    # (family, structure): {row index: {key: value}}; "kind3" makes joint 3 prismatic
    ("spherical_wrist", "parallel_23"): {1: {"alpha": 0.0}, 3: {"a": 0.0}, 4: {"a": 0.0, "d": 0.0}},
    ("spherical_wrist", "intersect_12"): {0: {"a": 0.0}, 3: {"a": 0.0}, 4: {"a": 0.0, "d": 0.0}},
    ("spherical_wrist", "intersect_23"): {1: {"a": 0.0}, 3: {"a": 0.0}, 4: {"a": 0.0, "d": 0.0}},
    ("spherical_wrist", "prismatic_3"): {0: {"a": 0.0}, 2: {"kind": "prismatic"}, 3: {"a": 0.0}, 4: {"a": 0.0, "d": 0.0}},
    ("spherical_shoulder", "intersect_12"): {0: {"a": 0.0}, 1: {"a": 0.0, "d": 0.0}, 4: {"a": 0.0}},
    ("three_parallel", None): {1: {"alpha": 0.0}, 2: {"alpha": 0.0}, 4: {"a": 0.0}},
    ("three_parallel_reversed", None): {0: {"a": 0.0}, 2: {"alpha": 0.0}, 3: {"alpha": 0.0}},
}


def ur_like_chain(name: str, twist2=sp.S.Zero, a3: float = -0.39225) -> Chain:
    """A standard-DH UR5 (examples/robots/ur5.toml's lengths, no limits) with the twist before joint 3 set to
    ``twist2`` (``sp.pi``: axes 3 and 4 point against axis 2) and the forearm length ``a3`` (m)."""
    rows = [(0.0, sp.pi / 2, 0.089159), (-0.425, twist2, 0.0), (a3, sp.S.Zero, 0.0), (0.0, sp.pi / 2, 0.10915),
            (0.0, -sp.pi / 2, 0.09465), (0.0, sp.S.Zero, 0.0823)]
    return Chain(name, tuple(dh_joint(f"j{i + 1}", "revolute", "standard", sp.Float(a) if a else sp.S.Zero, alpha,
                                      sp.Float(d) if d else sp.S.Zero, sp.S.Zero, i) for i, (a, alpha, d) in enumerate(rows)))


def random_family_chain(family: tuple[str, str | None], rng: np.random.Generator) -> Chain:
    """A random 6-joint standard-DH arm of ``family`` with a random base and tool (lengths in [-0.5, 0.5] m,
    twists at least 0.3 rad away from 0 and pi so only the family's own axes are parallel). The family's parallel
    axes point the same way or opposite ways (a twist of 0 or pi, each with probability 1/2: a URDF's half-turn
    reverses an axis), drawn after everything else so the other parameters of a seed do not depend on them."""
    cons = FAMILY_CONSTRAINTS[family]
    rows = []
    for i in range(6):
        row = {
            "kind": "revolute",
            "a": rng.uniform(-0.5, 0.5),
            "d": rng.uniform(-0.5, 0.5),
            "alpha": rng.choice([-1, 1]) * rng.uniform(0.3, math.pi - 0.3),
            "theta": rng.uniform(-math.pi, math.pi),
        }
        row.update(cons.get(i, {}))
        rows.append(row)
    base = Transform.from_xyz_rpy([sp.Float(x) for x in rng.uniform(-0.3, 0.3, 3)], [sp.Float(x) for x in rng.uniform(-1, 1, 3)])
    tool = Transform.from_xyz_rpy([sp.Float(x) for x in rng.uniform(-0.2, 0.2, 3)], [sp.Float(x) for x in rng.uniform(-1, 1, 3)])
    joints = []
    for i, row in enumerate(rows):
        alpha = sp.Float(row["alpha"]) if row["alpha"] else sp.S.Zero
        if row["alpha"] == math.pi or (cons.get(i, {}).get("alpha") == 0.0 and rng.random() < 0.5):
            alpha = sp.pi
        joints.append(dh_joint(f"j{i + 1}", row["kind"], "standard", sp.Float(row["a"]) if row["a"] else sp.S.Zero,
                               alpha, sp.Float(row["d"]) if row["d"] else sp.S.Zero, sp.Float(row["theta"]), i))
    return Chain("random_" + family[0], tuple(joints), base=base, tool=tool)
