"""The judge itself: independent of the solver, and able to fail."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from skelarm_sym.models.chain import reference_ik_all as judge

from closed_ik_support import solver, targets_of


def test_judge_imports_numpy_and_the_reference_only():
    tree = ast.parse(Path(judge.__file__).read_text())
    modules = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            modules.add(("." * node.level) + (node.module or ""))
    assert modules <= {"__future__", "numpy", ".reference", "eaik.IK_HP"}, modules


def test_judge_sees_a_missing_and_a_wrong_solution():
    chain, _, ik = solver("puma560")
    num = chain.numeric()
    rev = judge.revolute_mask(num)
    q = np.array([0.3, 0.4, -0.5, 0.6, 0.7, -0.8])
    T = targets_of(chain, q[None])[0]
    numeric = judge.multistart_ik(num, T, starts=200)
    assert len(numeric) == 8  # PUMA 560: eight solutions for a generic reachable pose
    Q, flags = ik.candidates(T.reshape(16))
    assert len(judge.missing(Q, numeric, rev, 1e-6)) == 0
    assert len(judge.missing(Q[1:], numeric, rev, 1e-6)) == 1
    wrong = Q[0].copy()
    wrong[3] += 1e-9
    pos, rot = judge.pose_error(num, np.stack([Q[0], wrong]), T)
    assert max(pos[0], rot[0]) <= 1e-12 < max(pos[1], rot[1])
    # 2 pi apart is the same configuration for revolute joints
    assert judge.same(Q[0], Q[0] + 2 * np.pi, rev, 1e-9)


def test_hp_data_reproduces_the_pose():
    chain, _, _ = solver("ur5")
    num = chain.numeric()
    H, P, R0 = judge.hp_data(num)
    q = np.array([0.1, -0.7, 1.2, 0.3, -0.4, 2.0])
    # product of exponentials from H, P (Rodrigues) against the reference pose
    R, p = np.eye(3), P[0].copy()
    for k in range(6):
        K = np.array([[0, -H[k, 2], H[k, 1]], [H[k, 2], 0, -H[k, 0]], [-H[k, 1], H[k, 0], 0]])
        R = R @ (np.eye(3) + np.sin(q[k]) * K + (1 - np.cos(q[k])) * K @ K)
        p = p + R @ P[k + 1]
    T = targets_of(chain, q[None])[0]
    assert np.allclose(R @ R0, T[:3, :3], atol=1e-14) and np.allclose(p, T[:3, 3], atol=1e-14)
