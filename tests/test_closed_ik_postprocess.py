"""Post-processing (2 pi shifts, limits, duplicates, statuses, nearest) and the special cases end to end:
unreachable targets, singular poses (wrist aligned, wrist over the shoulder, elbow stretched)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skelarm_sym.closed_ik.postprocess import STATUS, continuum_member, continuum_sign, nearest, postprocess, shift
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


# -- a spherical wrist's continuum ------------------------------------------------------------------------------------

def brute_force_member(x, y, ref, sigma, lower, upper, weights):
    """The nearest member by sampling: every 2 pi copy of the line through (x, y) in a window around ``ref``, each
    sampled every 1e-3 rad in joint a (and at its limits), joint b solved from the line, both tested against the
    limits widened by LIMIT_TOL (independent of the closed form's lines and clamps); ``(distance, point)`` or
    ``(inf, None)``."""
    best, best_d = None, np.inf
    tol = 1e-12   # LIMIT_TOL: a member this close outside a limit counts as on it (and is clipped onto it)
    lo_a = max(lower[0] - tol, ref[0] - 6 * np.pi)
    hi_a = min(upper[0] + tol, ref[0] + 6 * np.pi)
    if lo_a > hi_a:
        return best_d, best
    xs = np.append(np.arange(lo_a, hi_a, 1e-3), hi_a)
    for k in range(-9, 10):
        ys = sigma * ((x + sigma * y) - xs) + 2 * np.pi * k   # x' + sigma y' = x + sigma y + 2 pi k sigma
        ok = (ys >= lower[1] - tol) & (ys <= upper[1] + tol)
        if not ok.any():
            continue
        d = weights[0] * (xs[ok] - ref[0]) ** 2 + weights[1] * (ys[ok] - ref[1]) ** 2
        i = int(np.argmin(d))
        if d[i] < best_d:
            best_d, best = float(d[i]), (float(xs[ok][i]), float(ys[ok][i]))
    return best_d, best


def limits(kind: str, start: float, width: float) -> tuple[float, float]:
    """A joint's (lower, upper): both limits, only one, or none."""
    return {"both": (start, start + width), "lower": (start, np.inf), "upper": (-np.inf, start),
            "none": (-np.inf, np.inf)}[kind]


KIND = st.sampled_from(["both", "both", "lower", "upper", "none"])


@settings(max_examples=150, deadline=None, derandomize=True)
@given(x=st.floats(-7, 7), y=st.floats(-7, 7), ra=st.floats(-7, 7), rb=st.floats(-7, 7), sigma=st.sampled_from([1, -1]),
       ka=KIND, sa=st.floats(-7, 7), wa=st.floats(0.0, 9.0), kb=KIND, sb=st.floats(-7, 7), wb=st.floats(0.05, 9.0),
       weights=st.sampled_from([(1.0, 1.0), (1.0, 3.0), (0.2, 1.0)]))
def test_continuum_member_is_the_nearest_within_the_limits(x, y, ra, rb, sigma, ka, sa, wa, kb, sb, wb, weights):
    """Against sampling: the member returned lies on the continuum (modulo 2 pi), within the limits, and is no
    further from the reference than any sampled member (up to the sampling's step); None only when sampling finds
    no member either. Limits of every kind: two, one (lower or upper) or none per joint (joint b's range at least
    0.05 rad wide, so that sampling joint a meets it)."""
    (lo_a, hi_a), (lo_b, hi_b) = limits(ka, sa, wa), limits(kb, sb, wb)
    lower, upper = (lo_a, lo_b), (hi_a, hi_b)
    got = continuum_member(x, y, (ra, rb), sigma, lower, upper, weights)
    want_d, want = brute_force_member(x, y, (ra, rb), sigma, lower, upper, weights)
    if got is None:
        assert want is None
        return
    gx, gy = got
    assert lower[0] <= gx <= upper[0] and lower[1] <= gy <= upper[1]
    turn = ((gx + sigma * gy) - (x + sigma * y)) / (2 * np.pi)
    assert abs(turn - round(turn)) < 1e-12
    d = weights[0] * (gx - ra) ** 2 + weights[1] * (gy - rb) ** 2
    assert want is not None and d <= want_d + 1e-10
    assert want_d - d <= 5e-3 * (1 + np.sqrt(want_d))   # sampling step 1e-3 rad


def test_continuum_sign_by_the_wrist_angle():
    assert continuum_sign(1e-12, 2, 1) == 1 and continuum_sign(-1e-12, 3, -1) == -1
    assert continuum_sign(np.pi - 1e-12, 2, 1) == -1 and continuum_sign(-np.pi, 2, 1) == -1
    assert continuum_sign(2 * np.pi + 1e-12, 2, 1) == 1
    assert continuum_sign(1e-12, 0, 1) == 0          # not flagged singular
    assert continuum_sign(1e-9, 2, 1) == 0           # further than WRIST_ALIGNED_TOL from a multiple of pi
    assert continuum_sign(np.pi - 1e-12, 2, 1, s_odd=0) == 0 and continuum_sign(1e-12, 2, -1, s_odd=0) == -1  # skewed


CONTINUUM_ARMS = ["puma560", "stanford", "iiwa14_lock3", "panda_lock7", "kuka_kr6", "abb_irb140", "puma560_modified"]


@pytest.mark.parametrize("name", CONTINUUM_ARMS)
def test_wrist_continuum_moves_keep_the_pose(name):
    """The derivation's ``(a, w, b, s, s_odd)`` against the forward kinematics: with joint w at 0 (and at pi), every
    ``(q_a + t, q_b - sigma t)`` gives the same pose, sigma = s (-s at pi); turning the other way does not."""
    chain, lock, ik = solver(name)
    a, w, b, s, s_odd, w0 = ik.ik.continuum
    assert w0 == 0.0  # the example arms align at multiples of pi
    assert s_odd == -s  # every example wrist is at right angles: aligned at odd multiples of pi too
    rng = np.random.default_rng(4)
    q = random_configurations(chain, 5, rng)
    for value, sigma in ((0.0, s), (np.pi, s_odd)):
        q[:, w] = value
        moved = q.copy()
        t = rng.uniform(-2, 2, len(q))
        moved[:, a] += t
        moved[:, b] -= sigma * t
        wrong = q.copy()
        wrong[:, a] += t
        wrong[:, b] += sigma * t
        T, Tm, Tw = targets_of(chain, q), targets_of(chain, moved), targets_of(chain, wrong)
        assert np.max(np.abs(Tm - T)) < 1e-12
        assert np.all(np.max(np.abs(Tw - T), axis=(1, 2)) > 1e-3)


def test_aligned_wrist_rows_fit_the_limits_and_nearest_finds_the_source():
    """Configurations within the limits with the wrist exactly aligned (the Stanford arm's and the iiwa's q5 = 0; the
    Panda's shoulder q2 = 0): the source's branch is among ik_all's rows for every target (the row moved along the
    continuum where its representative missed the limits: 21 of 400 Stanford and 11 of 400 iiwa targets lost it
    before), and ik_nearest from the source returns it (the representative before, at any distance)."""
    for name, w, targets in (("stanford", 4, 400), ("iiwa14_lock3", 5, 400), ("panda_lock7", 1, 200)):
        chain, lock, ik = solver(name)
        a, _, b = ik.ik.continuum[:3]
        num = chain.numeric()
        rng = np.random.default_rng(1)
        q = random_configurations(chain, targets, rng, within_limits=True)
        q[:, w] = 0.0
        T = targets_of(chain, q)
        other = [k for k in range(chain.n) if k not in (a, b)]
        for i in range(len(q)):
            lk = None if lock is None else q[i, lock]
            r = ik.all(T[i], lk)
            assert r.status == STATUS["ok"]
            sols = r.solutions
            assert np.all(sols >= ik.lower) and np.all(sols <= ik.upper)
            pos, rot = judge.pose_error(num, sols, T[i])
            assert max(pos.max(), rot.max()) <= 1e-11
            d = np.abs((sols[:, other] - q[i, other] + np.pi) % (2 * np.pi) - np.pi)
            assert np.min(np.max(d, axis=1)) < 1e-7, (name, i)
            qn, _ = ik.nearest(q[i], T[i], lk)
            assert np.max(np.abs(qn - q[i])) < 1e-6, (name, i, qn, q[i])
