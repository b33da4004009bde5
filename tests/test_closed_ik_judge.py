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


def test_many_targets_at_once_give_each_target_its_own_solutions():
    # one batch of 3 x 200 starts: each entry is what the target's own run gives (seed, locked value and all), so
    # no start reads another target's pose, seed or lock
    chain, lock, _ = solver("iiwa14_lock3")
    num = chain.numeric()
    q = np.array([[0.3, 0.4, -0.5, 0.6, 0.7, -0.8, 0.2], [-1.0, 0.9, 0.4, -1.2, 0.1, 0.5, -0.3],
                  [0.6, -0.2, -0.9, 1.4, -0.6, 1.1, 0.8]])
    T = targets_of(chain, q)
    each = judge.multistart_ik_each(num, T, starts=200, seeds=[5, 6, 7], fixed={lock: q[:, lock]})
    assert len(each) == 3
    for i in range(3):
        alone = judge.multistart_ik(num, T[i], starts=200, seed=5 + i, fixed={lock: q[i, lock]})
        assert len(alone) >= 1 and np.array_equal(each[i], alone), i
        assert np.allclose(each[i][:, lock], q[i, lock], atol=0)  # the lock held at its own target's value
    others = judge.multistart_ik(num, T[1], starts=200, seed=5, fixed={lock: q[1, lock]})
    assert not np.array_equal(each[0], others)


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
