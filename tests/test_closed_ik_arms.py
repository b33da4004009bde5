"""Real arms: every exact candidate reproduces the target (1e-12 relative, judged by the NumPy reference),
the configuration that made the target is among them, the set is complete against a 200-start numeric IK,
and equals EAIK's when EAIK is installed."""

from __future__ import annotations

import numpy as np
import pytest

from skelarm_sym.closed_ik import classify
from skelarm_sym.closed_ik.derive import operations
from skelarm_sym.models.chain import reference_ik_all as judge

from closed_ik_support import (TOML_ARMS, URDF_ARMS, load_arm, pose_errors, random_configurations, solver, targets_of,
                               wrapped_distance)

ARMS = list(TOML_ARMS) + list(URDF_ARMS)
FAMILIES = {**{k: v[2:] for k, v in TOML_ARMS.items()}, **{k: v[3:] for k, v in URDF_ARMS.items()}}
ALLOWED = {"Add", "Mul", "Pow(int)", "Pow(1/2)", "Pow(-1/2)", "sin", "cos", "atan2", "Abs", "Min", "Max", "Piecewise",
           "StrictLessThan", "LessThan", "StrictGreaterThan", "GreaterThan", "And", "Or"}


@pytest.mark.parametrize("name", ARMS)
def test_family(name):
    chain, lock = load_arm(name)
    family = classify(chain, lock)
    assert (family.name, family.position) == FAMILIES[name]
    assert family.max_solutions == 8


@pytest.mark.parametrize("name", ARMS)
def test_candidates_reproduce_the_target_and_contain_its_configuration(name):
    chain, lock, ik = solver(name)
    num = chain.numeric()
    rng = np.random.default_rng(7)
    q = random_configurations(chain, 200, rng)
    T = targets_of(chain, q)
    Q, flags = ik.candidates(T.reshape(-1, 16), None if lock is None else q[:, lock])
    assert Q.shape == (200, 8, chain.n) and np.all(np.isfinite(Q))
    rev = judge.revolute_mask(num)
    exact = (flags & 1) == 0  # (200, 8)
    pos, rot = pose_errors(num, Q, T)  # the judge's pose_error of every candidate against its own target
    near = np.where(exact, wrapped_distance(Q, q[:, None, :], rev), np.inf).min(axis=1)
    missed = np.flatnonzero(~(near < 1e-6))
    assert len(missed) == 0, (missed[:5], q[missed[:5]])
    worst = np.where(exact, np.maximum(pos, rot), -np.inf).max()
    assert worst <= 1e-12, worst


@pytest.mark.parametrize("name", ["puma560", "ur5", "stanford", "iiwa14_lock3", "panda_lock7"])
def test_complete_against_multistart_numeric_ik(name):
    chain, lock, ik = solver(name)
    num = chain.numeric()
    rev = judge.revolute_mask(num)
    rng = np.random.default_rng(11)
    q = random_configurations(chain, 2, rng)
    T = targets_of(chain, q)
    each = judge.multistart_ik_each(num, T, starts=200, fixed=None if lock is None else {lock: q[:, lock]})
    for i, numeric in enumerate(each):
        assert len(numeric) >= 1
        Q, flags = ik.candidates(T[i].reshape(16), None if lock is None else q[i, lock])
        exact = Q[(flags & 1) == 0]
        assert len(judge.missing(exact, numeric, rev, 1e-5)) == 0


@pytest.mark.slow
@pytest.mark.parametrize("name", ARMS)
def test_complete_against_multistart_numeric_ik_more_targets(name):
    chain, lock, ik = solver(name)
    num = chain.numeric()
    rev = judge.revolute_mask(num)
    rng = np.random.default_rng(12)
    q = random_configurations(chain, 10, rng)
    T = targets_of(chain, q)
    each = judge.multistart_ik_each(num, T, starts=200, fixed=None if lock is None else {lock: q[:, lock]})
    for i, numeric in enumerate(each):
        Q, flags = ik.candidates(T[i].reshape(16), None if lock is None else q[i, lock])
        assert len(judge.missing(Q[(flags & 1) == 0], numeric, rev, 1e-5)) == 0


@pytest.mark.parametrize("name", [a for a in ARMS if a != "stanford"])
def test_equals_eaik(name):
    pytest.importorskip("eaik", reason="EAIK is optional (pip install eaik): the oracle of exact solution sets")
    chain, lock, ik = solver(name)
    num = chain.numeric()
    rev = judge.revolute_mask(num)
    rng = np.random.default_rng(13)
    q = random_configurations(chain, 30, rng)
    T = targets_of(chain, q)
    for i in range(len(q)):
        Q, flags = ik.candidates(T[i].reshape(16), None if lock is None else q[i, lock])
        ours = Q[(flags & 1) == 0]
        eaik_q, eaik_ls = judge.eaik_solutions(num, T[i], None if lock is None else {lock: q[i, lock]})
        theirs = eaik_q[~eaik_ls]
        assert len(judge.missing(ours, theirs, rev, 1e-7)) == 0, (i, "EAIK has a solution we lack")
        assert len(judge.missing(theirs, ours, rev, 1e-7)) == 0, (i, "we have a solution EAIK lacks")


@pytest.mark.parametrize("name", ["puma560", "ur5", "stanford", "iiwa14_lock3"])
def test_only_the_allowed_operations(name):
    _, _, ik = solver(name)
    assert operations(ik.ik) <= ALLOWED, operations(ik.ik) - ALLOWED


NEAR_SINGULAR = [("ur5", 4), ("ur5", 2), ("puma560", 4), ("iiwa14_lock3", 3), ("iiwa14_lock3", 1), ("panda_lock7", 3),
                 ("panda_lock7", 5), ("stanford", 4)]


@pytest.mark.parametrize("name,joint", NEAR_SINGULAR)
def test_near_singular_targets_keep_their_digits(name, joint):
    # a joint 1e-5 .. 0 rad from a singular value (wrist aligned, elbow stretched, shoulder continuum): every exact
    # candidate still reproduces the target to 1e-12 (before the cancellation-free SP1/SP4/SP2 forms: up to 7.5e-9)
    chain, lock, ik = solver(name)
    num = chain.numeric()
    for eps in (1e-5, 1e-9, 1e-13, 0.0):
        rng = np.random.default_rng(3)
        q = random_configurations(chain, 10, rng)
        q[:, joint] = eps
        T = targets_of(chain, q)
        Q, flags = ik.candidates(T.reshape(-1, 16), None if lock is None else q[:, lock])
        for i in range(len(q)):
            exact = Q[i][(flags[i] & 1) == 0]
            assert len(exact) >= 1
            pos, rot = judge.pose_error(num, exact, T[i])
            assert max(pos.max(), rot.max()) <= 1e-12, (eps, i)


def test_eaik_oracle_on_parallel_axes_pointing_opposite_ways():
    """EAIK 1.2's HPRobot answers a UR5 whose elbow axis is reversed (DH twist pi before joint 3) with eight rows,
    none reproducing the target (a probe of reversed URDF axes); the oracle turns such axes to point the same way
    and negates their joints' values, and its rows reproduce the targets."""
    pytest.importorskip("eaik", reason="EAIK is optional (pip install eaik): the oracle of exact solution sets")
    import sympy as sp

    from closed_ik_support import ur_like_chain
    from skelarm_sym.models.chain.reference import chain_kinematics

    chain = ur_like_chain("ur5_reversed_elbow", twist2=sp.pi)
    num, rng = chain.numeric(), np.random.default_rng(0)
    for _ in range(5):
        q = rng.uniform(-2.5, 2.5, 6)
        T = chain_kinematics(num, q[None]).T[0]
        Q, ls = judge.eaik_solutions(num, T)
        assert (~ls).sum() >= 1
        assert max(np.abs(chain_kinematics(num, row[None]).T[0] - T).max() for row in Q[~ls]) < 1e-12
