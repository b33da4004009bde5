"""Post-processing (2 pi shifts, limits, duplicates, statuses, nearest) and the special cases end to end:
unreachable targets, singular poses (wrist aligned, wrist over the shoulder, elbow stretched)."""

from __future__ import annotations

import numpy as np
import pytest

from skelarm_sym.closed_ik.postprocess import STATUS, nearest, postprocess, shift
from skelarm_sym.models.chain import reference_ik_all as judge

from closed_ik_support import random_configurations, solver, targets_of

INF = np.inf


def test_shift_to_the_copy_nearest_the_centre():
    rev = np.array([True, True, True, False])
    lo = np.array([-np.pi, 0.0, -INF, 0.0])
    hi = np.array([np.pi, 2 * np.pi, INF, 10.0])
    q = shift(np.array([7.0, -0.5, 100.0, 7.0]), lo, hi, rev)
    assert q == pytest.approx([7.0 - 2 * np.pi, 2 * np.pi - 0.5, 100.0 - 16 * 2 * np.pi, 7.0])
    # a range wider than 2 pi: several copies fit; the one nearest the centre (0) is returned
    assert shift(np.array([5.0]), np.array([-2 * np.pi]), np.array([2 * np.pi]), np.array([True]))[0] == pytest.approx(5.0 - 2 * np.pi)


def test_limits_duplicates_order_and_status():
    rev = np.array([True, True])
    lo, hi = np.array([-1.0, -INF]), np.array([1.0, INF])
    Q = np.array([[0.5, 0.0], [0.5 + 2 * np.pi, 2 * np.pi], [2.0, 0.0], [-0.5, 1.0], [-0.5, 1.0 + 1e-12]])
    flags = np.array([0, 2, 0, 0, 0])
    r = postprocess(Q, flags, lo, hi, rev)
    assert r.status == STATUS["ok"] and r.count == 2
    assert r.solutions == pytest.approx(np.array([[0.5, 0.0], [-0.5, 1.0]]))
    assert list(r.branch[:2]) == [0, 3] and r.flags[0] == 2  # the duplicate's singular bit carried over
    assert np.all(np.isnan(r.q[2:]))
    # every exact candidate outside the limits
    r = postprocess(Q[2:3], flags[2:3], lo, hi, rev)
    assert (r.status, r.count) == (STATUS["out_of_limits"], 0)
    # least squares only
    r = postprocess(Q[:2], np.array([1, 3]), lo, hi, rev)
    assert r.status == STATUS["unreachable"] and r.count == 1 and r.flags[0] == 3
    # exact candidates win over least-squares ones
    r = postprocess(Q[[0, 3]], np.array([1, 0]), lo, hi, rev)
    assert r.status == STATUS["ok"] and r.count == 1 and r.branch[0] == 1


def test_limit_tolerance_clips():
    rev = np.array([False])
    r = postprocess(np.array([[1.0 + 1e-13], [1.0 + 1e-9]]), np.array([0, 0]), np.array([0.0]), np.array([1.0]), rev)
    assert r.count == 1 and r.solutions[0, 0] == 1.0


def test_invalid_targets():
    _, _, ik = solver("puma560")
    bad = np.eye(4)
    bad[0, 0] = 2.0
    assert ik.all(bad).status == STATUS["invalid"]
    nan = np.eye(4)
    nan[1, 3] = np.nan
    r = ik.all(nan)
    assert r.status == STATUS["invalid"] and r.count == 0
    mirror = np.diag([1.0, 1.0, -1.0, 1.0])
    assert ik.all(mirror).status == STATUS["invalid"]


def test_nearest_takes_the_closest_copy():
    rev = np.array([True, False])
    lo, hi = np.array([-4 * np.pi, 0.0]), np.array([4 * np.pi, 1.0])
    r = postprocess(np.array([[0.1, 0.5], [2.0, 0.2]]), np.array([0, 0]), lo, hi, rev)
    q, i = nearest(r, np.array([2 * np.pi + 0.2, 0.5]), lo, hi, rev)
    assert i == 0 and q == pytest.approx([2 * np.pi + 0.1, 0.5])
    assert nearest(postprocess(np.zeros((1, 2)), np.array([1]), lo, np.array([4 * np.pi, -1.0]), rev), np.zeros(2), lo, hi, rev) == (None, -1)


@pytest.mark.parametrize("name", ["puma560", "abb_irb140", "stanford", "iiwa14_lock3"])
def test_all_within_limits_reproduce_and_nearest_finds_the_source(name):
    chain, lock, ik = solver(name)
    num = chain.numeric()
    rng = np.random.default_rng(21)
    lo, hi = ik.lower, ik.upper
    q = random_configurations(chain, 40, rng, within_limits=True)
    T = targets_of(chain, q)
    for i in range(len(q)):
        r = ik.all(T[i], None if lock is None else q[i, lock])
        assert r.status == STATUS["ok"] and 1 <= r.count <= 8
        sols = r.solutions
        assert np.all(sols >= lo) and np.all(sols <= hi)
        pos, rot = judge.pose_error(num, sols, T[i])
        assert max(pos.max(), rot.max()) <= 1e-12
        qn, row = ik.nearest(q[i], T[i], None if lock is None else q[i, lock])
        assert np.max(np.abs(qn - q[i])) < 1e-6
        # the set is every exact candidate that some 2 pi copy puts within limits, each once
        Q, flags = ik.candidates(T[i].reshape(16), None if lock is None else q[i, lock])
        fits = []
        for cand in Q[(flags & 1) == 0]:
            ok = all(any(lo[j] <= cand[j] + 2 * np.pi * k * ik.revolute[j] <= hi[j] for k in range(-3, 4))
                     for j in range(chain.n))
            if ok and not any(judge.same(cand, f, ik.revolute, 1e-9) for f in fits):
                fits.append(cand)
        assert len(fits) == r.count


def test_out_of_the_stroke_is_out_of_limits():
    # the Stanford arm reaches (3, 1, 2) with its boom out 3.5 m: exact solutions, none within the 1.27 m stroke
    _, _, ik = solver("stanford")
    T = np.eye(4)
    T[:3, 3] = [3.0, 1.0, 2.0]
    r = ik.all(T)
    assert (r.status, r.count) == (STATUS["out_of_limits"], 0)


@pytest.mark.parametrize("name", ["puma560", "ur5", "kuka_kr6", "panda_lock7"])
def test_unreachable_target_gives_flagged_least_squares_rows(name):
    chain, lock, ik = solver(name)
    T = np.eye(4)
    T[:3, 3] = [3.0, 1.0, 2.0]  # far outside the arm's reach
    r = ik.all(T, None if lock is None else 0.3)
    assert r.status == STATUS["unreachable"] and r.count >= 1
    assert np.all(np.isfinite(r.solutions)) and np.all(r.flags[: r.count] & 1)
    # least squares: the arm reaches toward the target (closer than a typical random configuration)
    num = chain.numeric()
    pos = judge.pose_error(num, r.solutions, T)[0]
    rng = np.random.default_rng(0)
    others = judge.pose_error(num, random_configurations(chain, 200, rng), T)[0]
    assert pos.min() <= np.percentile(others, 50)


SINGULAR = {
    # name: (joint to set, value, what)
    "puma560": (4, 0.0, "wrist aligned: q5 = 0"),
    "ur5": (4, 0.0, "wrist aligned with the parallel axes: q5 = 0"),
    "kuka_kr6": (4, 0.0, "wrist aligned"),
    "iiwa14_lock3": (3, 0.0, "elbow stretched: q4 = 0"),
}


@pytest.mark.parametrize("name", list(SINGULAR))
def test_singular_poses_are_finite_flagged_and_exact(name):
    chain, lock, ik = solver(name)
    joint, value, _ = SINGULAR[name]
    num = chain.numeric()
    rng = np.random.default_rng(5)
    q = random_configurations(chain, 10, rng, within_limits=True)
    q[:, joint] = value
    T = targets_of(chain, q)
    for i in range(len(q)):
        Q, flags = ik.candidates(T[i].reshape(16), None if lock is None else q[i, lock])
        assert np.all(np.isfinite(Q))
        exact = (flags & 1) == 0
        assert np.any(flags[exact] & 2), flags
        pos, rot = judge.pose_error(num, Q[exact], T[i])
        assert max(pos.max(), rot.max()) <= 1e-12
        r = ik.all(T[i], None if lock is None else q[i, lock])
        assert r.status == STATUS["ok"] and np.all(np.isfinite(r.solutions))


def test_wrist_over_the_shoulder_is_a_continuum():
    # iiwa straight up (q2 = q4 = 0): the wrist centre lies on axis 1, so q1 is free (SP2's SP1 meets the axis),
    # and the elbow is stretched (SP3's double root)
    chain, lock, ik = solver("iiwa14_lock3")
    num = chain.numeric()
    q = np.array([0.4, 0.0, 0.3, 0.0, 0.5, 0.7, -0.2])
    T = targets_of(chain, q[None])[0]
    Q, flags = ik.candidates(T.reshape(16), q[2])
    exact = (flags & 1) == 0
    assert np.all(np.isfinite(Q)) and np.all(flags[exact] & 2)
    pos, rot = judge.pose_error(num, Q[exact], T)
    assert max(pos.max(), rot.max()) <= 1e-12
