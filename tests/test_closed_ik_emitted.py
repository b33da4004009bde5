"""The emitted closed-form IK (``ik_candidates``, ``ik_all``, ``ik_nearest``) in C and NumPy, judged by the
reference (``models/chain/reference_ik_all.py``: forward recursion, multi-start numeric IK, EAIK) and by the NumPy
post-processing spec (``closed_ik/postprocess.py``): the real arms, random arms of every family, singular poses,
limits and 2 pi shifts, unreachable and invalid targets, float precision, strict compilation under gcc and clang,
the command line (``--ik-lock``, ``--functions``, ``show --what ik``, ``check --from``)."""

from __future__ import annotations

import ctypes
import functools
import importlib.util
import math
import shutil

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skelarm_sym.build import compile_arm, compile_shared, load_python
from skelarm_sym.cli import main
from skelarm_sym.closed_ik.evaluate import lambdify_candidates
from skelarm_sym.closed_ik.postprocess import (STATUS, WRIST_ALIGNED_TOL, WRIST_ALIGNED_TOL_FLOAT, is_valid_target, nearest,
                                               postprocess)
from skelarm_sym.closed_ik.subproblems import Steps, atan2_steps
from skelarm_sym.generate import generate
from skelarm_sym.models.chain import reference_ik_all as judge
from skelarm_sym.models.chain.lock import with_ik_lock

from closed_ik_support import (FAMILY_CONSTRAINTS, ROBOTS, URDF_ARMS, load_arm, random_configurations,
                               random_family_chain, targets_of, wrapped_distance)

LABELS = {v: k for k, v in STATUS.items()}
FUNCTIONS = "ik_all,ik_nearest,ik_nearest_weighted"
POSE_TOL = {"double": 1e-12, "float": 3e-5}
FOUND_TOL = {"double": 1e-7, "float": 3e-3}


class Built:
    """One arm's emitted IK: the chain (lock recorded), the lock coordinate, C and NumPy, and the spec's answer."""

    def __init__(self, chain, lock: int | None, precision: str = "double", functions: str = FUNCTIONS) -> None:
        if lock is not None:
            chain = with_ik_lock(chain, lock + 1)
        self.chain = chain
        self.lock = None if lock is None else chain.joints[lock].coordinate
        self.precision = precision
        self.generated = generate(chain, out=None, functions=functions, precision=precision)
        self.c = compile_arm(self.generated)
        prefix = self.generated.module.prefix
        self.py = load_python(self.generated.sources[f"{prefix}.py"], prefix)
        self.raw = lambdify_candidates(self.generated.derivation)
        self.numeric = chain.numeric()
        self.revolute = judge.revolute_mask(self.numeric)
        limits = chain.limits()
        self.lower = np.array([-np.inf if v is None else v for v in limits["lower"]])
        self.upper = np.array([np.inf if v is None else v for v in limits["upper"]])
        self.continuum = self.generated.derivation.function("ik_candidates").continuum

    def extra(self, q) -> tuple:
        return () if self.lock is None else (float(q[self.lock]),)

    def spec(self, target, q) -> object:
        """The NumPy post-processing of SymPy's candidates (the spec) for one target."""
        Q, flags = self.raw(np.asarray(target).reshape(1, 16), *self.extra(q))
        return postprocess(Q[0], flags[0].astype(int), self.lower, self.upper, self.revolute, target=np.asarray(target).reshape(16),
                           continuum=self.continuum,
                           aligned_tol=WRIST_ALIGNED_TOL if self.precision == "double" else WRIST_ALIGNED_TOL_FLOAT)


@functools.lru_cache(maxsize=None)
def built(name: str, precision: str = "double") -> Built:
    chain, lock = load_arm(name)
    return Built(chain, lock, precision)


def inner_configurations(b: Built, m: int, rng) -> np.ndarray:
    """Configurations strictly inside the limits (5 % to 95 % of each range; [-pi, pi] or [-0.5, 0.5] m where unbounded)."""
    span = np.where(b.revolute, np.pi, 0.5)
    lo = np.where(np.isfinite(b.lower), b.lower, -span)
    hi = np.where(np.isfinite(b.upper), b.upper, span)
    return lo + (0.05 + 0.9 * rng.uniform(size=(m, b.chain.n))) * (hi - lo)


def check_rows(b: Built, result, target, source=None, tol=None) -> np.ndarray:
    """The returned rows of ``result``: finite, NaN past count, within limits, reproducing ``target``, distinct."""
    tol = POSE_TOL[b.precision] if tol is None else tol
    q = np.asarray(result.q, dtype=float)
    assert q.shape == (8, b.chain.n)
    rows = q[: result.count]
    assert np.all(np.isfinite(rows)) and np.all(np.isnan(q[result.count:]))
    assert np.all(rows >= b.lower) and np.all(rows <= b.upper)
    if result.count:
        pos, rot = judge.pose_error(b.numeric, rows, target)
        assert max(pos.max(), rot.max()) <= tol, (pos, rot)
    for i in range(result.count):
        for j in range(i):
            assert not judge.same(rows[i], rows[j], b.revolute, 1e-9 if b.precision == "double" else 1e-4)
    if source is not None:
        assert np.min(wrapped_distance(rows, source, b.revolute)) <= FOUND_TOL[b.precision]
    return rows


# -- the real arms -------------------------------------------------------------------------------------------------

FAST = ["puma560", "ur5"]
SLOW = ["stanford", "kuka_kr6", "abb_irb140", "iiwa14_lock3", "panda_lock7", "puma560_modified"]
ARMS = FAST + [pytest.param(n, marks=pytest.mark.slow) for n in SLOW] + [
    pytest.param(n, marks=pytest.mark.slow) for n in URDF_ARMS]


@pytest.mark.parametrize("name", ARMS)
def test_arm_every_solution_in_c_and_numpy(name):
    """30 targets made from configurations within the limits: status ok; every row reproduces the target to 1e-12,
    lies within the limits, none twice; the source configuration is among the rows and ik_nearest from it returns
    it; C and NumPy return the same rows, flags and count as the NumPy spec on SymPy's candidates."""
    b = built(name)
    rng = np.random.default_rng(18)
    q = inner_configurations(b, 30, rng)
    T = targets_of(b.chain, q)
    for i in range(len(q)):
        spec = b.spec(T[i], q[i])
        assert spec.status == STATUS["ok"]
        for impl in (b.c, b.py):
            r = impl.ik_all(T[i], *b.extra(q[i]))
            assert r.status == "ok" and r.count == spec.count
            rows = check_rows(b, r, T[i], q[i])
            np.testing.assert_allclose(rows, spec.solutions, atol=1e-9)
            assert list(np.asarray(r.flags)[: r.count]) == list(spec.flags[: spec.count])
            assert list(np.asarray(r.flags)[r.count:]) == [-1] * (8 - r.count)
            near = impl.ik_nearest(q[i], T[i], *b.extra(q[i]))
            assert near.status == "ok"
            np.testing.assert_allclose(near.q, q[i], atol=FOUND_TOL["double"])
        # nearest from a far reference: the spec's nearest over the same rows
        q_ref = q[i] + rng.uniform(-2.5, 2.5, b.chain.n) * b.revolute
        if b.lock is not None:
            q_ref[b.lock] = q[i][b.lock]
        want, _ = nearest(spec, q_ref, b.lower, b.upper, b.revolute, continuum=b.continuum)
        for impl in (b.c, b.py):
            got = impl.ik_nearest(q_ref, T[i], *b.extra(q[i]))
            assert np.sum((got.q - q_ref) ** 2) <= np.sum((want - q_ref) ** 2) * (1 + 1e-12) + 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("name", ["puma560", "ur5", "kuka_kr6", "abb_irb140", "iiwa14_lock3", "panda_lock7"])
def test_complete_against_numeric_ik_and_eaik(name):
    """The rows are every solution within the limits: the judge's 200-start numeric IK finds none that is missing,
    and EAIK's exact solutions that fit the limits are exactly the rows (when eaik is installed)."""
    b = built(name)
    rng = np.random.default_rng(7)
    q = inner_configurations(b, 5, rng)
    T = targets_of(b.chain, q)
    fixed_joint = None if b.lock is None else next(k for k, j in enumerate(b.chain.joints) if j.coordinate == b.lock)
    each = judge.multistart_ik_each(b.numeric, T, starts=200, seeds=range(len(q)),
                                    fixed=None if b.lock is None else {b.lock: q[:, b.lock]})
    for i, numeric in enumerate(each):
        r = b.c.ik_all(T[i], *b.extra(q[i]))
        rows = r.q[: r.count]
        fixed = None if b.lock is None else {b.lock: float(q[i][b.lock])}
        inside = [s for s in numeric if fits(s, b)]
        assert len(judge.missing(rows, np.array(inside).reshape(-1, b.chain.n), b.revolute, 1e-6)) == 0
        eaik = judge.eaik_solutions(b.numeric, T[i], None if fixed is None else {fixed_joint: fixed[b.lock]})
        if eaik is not None:
            Q, ls = eaik
            exact = [s for s in Q[~ls] if fits(s, b)]
            exact = np.array(exact).reshape(-1, b.chain.n)
            assert len(judge.missing(rows, exact, b.revolute, 1e-7)) == 0
            assert len(judge.missing(exact, rows, b.revolute, 1e-7)) == 0


def fits(q, b: Built) -> bool:
    """Some 2 pi copy of ``q`` lies within the limits."""
    for x, lo, hi, rev in zip(q, b.lower, b.upper, b.revolute):
        if rev and np.isfinite(lo):
            x = x + 2 * np.pi * np.ceil((lo - x) / (2 * np.pi))
        elif rev and np.isfinite(hi):
            x = x + 2 * np.pi * np.floor((hi - x) / (2 * np.pi))
        if not lo <= x <= hi:
            return False
    return True


# -- random arms of every family ------------------------------------------------------------------------------------

FAMILIES = list(FAMILY_CONSTRAINTS)


def check_random_family(family, seed, targets=20):
    rng = np.random.default_rng(seed)
    chain = random_family_chain(family, rng)
    g = generate(chain, out=None, functions="ik_all", langs="c")
    c = compile_arm(g)
    num = chain.numeric()
    rev = judge.revolute_mask(num)
    q = random_configurations(chain, targets, rng)
    T = targets_of(chain, q)
    for i in range(targets):
        r = c.ik_all(T[i])
        assert r.status == "ok"
        rows = r.q[: r.count]
        pos, rot = judge.pose_error(num, rows, T[i])
        assert max(pos.max(), rot.max()) <= 1e-11, (seed, i)
        assert np.min(wrapped_distance(rows, q[i], rev)) < 1e-6, (seed, i)


@pytest.mark.parametrize("family", FAMILIES[:1] + [pytest.param(f, marks=pytest.mark.slow) for f in FAMILIES[1:]],
                         ids=[f"{a}-{b}" for a, b in FAMILIES])
@settings(max_examples=1, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(seed=st.integers(0, 2**32 - 1))
def test_random_arm_of_each_family_emitted(family, seed):
    """A random DH arm of each family (the shared generator of tests/closed_ik_support.py), emitted in C: every row
    reproduces its target and the source configuration is among them."""
    check_random_family(family, seed)


# -- special cases ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name, joint, values", [
    ("puma560", 4, (0.0, 1e-9, 1e-5)),       # wrist aligned: q4 and q6 share one rotation
    ("puma560", 2, (-math.pi / 2 + 0.0470, )),  # near the elbow stretched (its exact value depends on a3, d4)
    ("ur5", 4, (0.0, 1e-12, 1e-7)),          # UR wrist aligned: q6 and q2 + q3 + q4 share one rotation
    ("ur5", 2, (0.0,)),                      # UR elbow stretched
])
def test_singular_poses_are_finite_flagged_and_exact(name, joint, values):
    """At and near singular values: status ok, every row finite and reproducing the target; at the exact value some
    row carries the singular bit (IK_FLAG_SINGULAR); C and NumPy agree."""
    b = built(name)
    rng = np.random.default_rng(3)
    for value in values:
        q = inner_configurations(b, 5, rng)
        q[:, joint] = value
        T = targets_of(b.chain, q)
        for i in range(len(q)):
            r = b.c.ik_all(T[i])
            p = b.py.ik_all(T[i])
            assert r.status == p.status == "ok" and r.count == p.count >= 1
            check_rows(b, r, T[i], tol=1e-11)
            check_rows(b, p, T[i], tol=1e-11)
            if value == 0.0 and name == "puma560" and joint == 4:
                assert np.any(np.asarray(r.flags)[: r.count] & 2)


def test_wrist_aligned_exactly_is_flagged():
    """PUMA with q5 = 0 exactly (the target built exactly aligned): a continuum, one representative, flagged."""
    b = built("puma560")
    q = np.array([0.3, 0.5, -1.0, 0.4, 0.0, -0.2])
    T = targets_of(b.chain, q[None])[0]
    r = b.c.ik_all(T)
    assert r.status == "ok"
    rows = check_rows(b, r, T)
    flags = np.asarray(r.flags)[: r.count]
    aligned = np.abs(rows[:, 4]) < 1e-6
    assert aligned.any() and np.all(flags[aligned] & 2)


@pytest.mark.parametrize("name, q, pair", [
    ("puma560", [1.7034576792211449, 3.0219331109601084, -1.4985763218216936, -0.5231731521948495, -1.16e-16,
                 -1.082937625587884], (3, 5)),
    ("iiwa14_lock3", [-1.9074823757314854, 0.45884333718735215, 0.3, 0.0541989919576511, -0.24138025631065618, 0.0,
                      2.574040951750458], (4, 6)),
])
def test_a_wrist_aligned_to_rounding_keeps_the_source_branch(name, q, pair):
    """Targets from the emitted NumPy pose at configurations with the wrist aligned: rounding leaves the candidate
    ``q5`` at 1.1e-14 to 1.2e-14, past an aligned tolerance of 1e-14, so q4's SP1 took an angle of rounding noise and
    the row fell outside the limits: the source's branch (its joints outside the aligned pair, which share one
    rotation) was missing in C and NumPy (a new user's probe). With ``ALIGNED_TOL = 1e-13`` (an orientation error of
    at most that) it is among the rows."""
    b = built(name)
    prefix = b.generated.module.prefix
    poses = load_python(generate(b.chain, out=None, langs="python", functions="pose").sources[f"{prefix}.py"], prefix)
    q = np.array(q)
    T = poses.pose(q)
    other = [k for k in range(b.chain.n) if k not in pair]  # the aligned pair shares one rotation: a representative
    for r in (b.c.ik_all(T, *b.extra(q)), b.py.ik_all(T, *b.extra(q))):
        assert r.status == "ok"
        rows = check_rows(b, r, T)
        assert np.min(wrapped_distance(rows[:, other], q[other], b.revolute[other])) <= 1e-7, (rows, q)


@pytest.mark.parametrize("name", ["puma560", "ur5", pytest.param("stanford", marks=pytest.mark.slow),
                                  pytest.param("iiwa14_lock3", marks=pytest.mark.slow),
                                  pytest.param("panda_lock7", marks=pytest.mark.slow)])
def test_a_nearly_aligned_wrist_keeps_both_flips(name):
    """Targets from configurations inside the limits with the wrist 3e-11 to 1e-9 from aligned (q5 = +-eps: no
    continuum by the tolerances, two distinct exact flips). The candidates copied the first root's row into the flip
    branch wherever q4's SP1 (UR: q6's) was flagged a continuum, up to about 1e-9, though only within ALIGNED_TOL
    (UR: SPLIT_TOL) is that row the continuum's representative: the flip, another exact solution, was lost. At 1e-10
    the source's whole row was missing on 29 of 60 PUMA, 32 of 60 Panda and 29 of 60 UR5 targets (and ik_nearest
    from the source returned a row pi away in joints 4 and 6), and UR5 targets whose only reachable 2R arm was the
    flip's came back unreachable, with least-squares rows 0.14 of the reach off. Now, in C and NumPy: status ok,
    every row exact, the source's whole row among them and ik_nearest from the source returning it, to 1e-7 rad
    plus what the near-continuum costs: the joints that nearly share one rotation are conditioned as 1 / eps (up to
    7e-13 / eps seen, on the Panda's shoulder; 3e-14 / eps on the others), far below the flip's pi."""
    b = built(name)
    w = b.continuum[1] if b.continuum else 4
    rng = np.random.default_rng(13)
    q = inner_configurations(b, 60, rng)
    eps = np.repeat([3e-11, 1e-10, 1e-9], 20)
    q[:, w] = eps * rng.choice([-1.0, 1.0], 60)
    T = targets_of(b.chain, q)
    for i in range(len(q)):
        tol = 1e-7 + 2e-12 / eps[i]
        for impl in (b.c, b.py):
            r = impl.ik_all(T[i], *b.extra(q[i]))
            assert r.status == "ok", (i, r.status)
            rows = check_rows(b, r, T[i])
            assert np.min(wrapped_distance(rows, q[i], b.revolute)) <= tol, i
            near = np.asarray(impl.ik_nearest(q[i], T[i], *b.extra(q[i])).q)
            assert wrapped_distance(near, q[i], b.revolute) <= tol, i


def test_a_ur_aligned_wrist_nearest_is_the_member_at_the_references_phi():
    """UR5 with the wrist aligned (q5 = 0 or pi): joint 6 and phi = q2 + q3 + q4 share one rotation, a continuum whose
    members move the 2R arm too; ik_all returns one representative per root of q1, and ik_nearest(q, pose(q))
    returned it, 1-3 rad from q (every such target). ik_nearest now also weighs the members at q_ref's own phi
    (ik_continuum_members, derived with the candidates): from a configuration it returns that configuration; from a
    reference 1e-3 rad off, the spec's answer with the same members (ClosedFormIK, SymPy's steps in NumPy), never
    farther than the representative; weighted too. C and NumPy; every returned row reproduces the target."""
    from skelarm_sym.closed_ik.evaluate import ClosedFormIK

    b = built("ur5")
    spec = ClosedFormIK(b.chain)
    rng = np.random.default_rng(17)
    q = inner_configurations(b, 40, rng)
    q[:, 4] = np.where(np.arange(40) < 20, 0.0, np.pi)
    T = targets_of(b.chain, q)
    refs = q + rng.normal(scale=1e-3, size=q.shape)
    W = 10.0 ** rng.uniform(-1, 1, size=q.shape)
    far = 0.0
    for i in range(len(q)):
        plain, _ = nearest(spec.all(T[i]), refs[i], b.lower, b.upper, b.revolute)  # the representative's rows only
        want, _ = spec.nearest(refs[i], T[i])
        want_w, _ = spec.nearest(refs[i], T[i], weights=W[i])
        far = max(far, float(wrapped_distance(plain[None], q[i], b.revolute)[0]))  # the representative's answer
        assert wrapped_distance(want[None], q[i], b.revolute)[0] <= 0.05  # a member near the source, from 1e-3 off
        for impl in (b.c, b.py):
            np.testing.assert_allclose(impl.ik_nearest(q[i], T[i]).q, q[i], atol=1e-7)
            for ref, weights, expected in ((refs[i], None, want), (refs[i], W[i], want_w)):
                got = np.asarray(impl.ik_nearest(ref, T[i]).q if weights is None else
                                 impl.ik_nearest_weighted(ref, weights, T[i]).q)
                pos, rot = judge.pose_error(b.numeric, got[None], T[i])
                assert max(pos.max(), rot.max()) <= 1e-12
                np.testing.assert_allclose(got, expected, atol=1e-9)
    assert far >= 0.5  # the representative alone was far from the source: the members carry the answer


def wrist_centre_on_axis_1(b: Built, q: np.ndarray, pair: tuple[int, int]) -> np.ndarray | None:
    """``q`` with joints ``pair`` (shoulder, elbow) moved by Newton's method (central differences) until the wrist centre
    (where the last three axes meet, by the NumPy reference's axes) lies on axis 1; None where it does not converge to
    1e-13 m or leaves the limits."""
    from skelarm_sym.models.chain.reference import chain_kinematics

    def residual(x):
        y = q.copy()
        y[list(pair)] = x
        k = chain_kinematics(b.numeric, y)
        (p4, h4), (p5, h5) = (k.origins[-3], k.axes[-3]), (k.origins[-2], k.axes[-2])
        n = np.cross(h4, h5)
        w = p4 + (np.cross(p5 - p4, h5) @ n) / (n @ n) * h4
        h1 = k.axes[0]
        e1 = np.cross(h1, [1.0, 0.0, 0.0] if abs(h1[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        return np.array([(w - k.origins[0]) @ e1, (w - k.origins[0]) @ np.cross(h1, e1)])

    x = q[list(pair)].astype(float)
    for _ in range(40):
        r = residual(x)
        if np.max(np.abs(r)) <= 1e-13:
            break
        J = np.column_stack([(residual(x + d) - residual(x - d)) / 2e-7 for d in np.eye(2) * 1e-7])
        x = x - np.linalg.lstsq(J, r, rcond=None)[0]
    out = q.copy()
    out[list(pair)] = x
    if np.max(np.abs(residual(x))) > 1e-13 or np.any(out < b.lower) or np.any(out > b.upper):
        return None
    return out


@pytest.mark.parametrize("name, pair", [("iiwa14_lock3", (1, 3)), pytest.param("kuka_kr6", (1, 2), marks=pytest.mark.slow),
                                        pytest.param("abb_irb140", (1, 2), marks=pytest.mark.slow)])
def test_a_wrist_centre_on_axis_1_nearest_keeps_joint_1(name, pair):
    """The wrist centre on axis 1 (the iiwa stretched straight up, or bent back over its base; KR 6 and IRB 140 reaching
    over theirs): joint 1 turns the wrist centre about itself, a continuum of q1 with the wrist taking the rest, and
    ik_all holds one representative (q1 from rounding, or 0). ik_nearest(q, pose(q)) returned it: q1 = pi/2 and q5 a
    turn of 1.07 rad from q = (0.5, 0, 0, 0, 0.3, 0.4, 0.2) on the iiwa, a probe found. It now also weighs the rows at
    q_ref's own q1 (ik_continuum_members, each branch with its own wrist): from a configuration it returns that
    configuration (also with the wrist aligned, where joints 5 and 7 move along their own continuum toward q_ref);
    from a reference 1e-3 rad off, the spec's answer (ClosedFormIK with the same members, SymPy's steps in NumPy),
    never farther than the representative's; weighted too. C and NumPy; every answer reproduces the target."""
    from skelarm_sym.closed_ik.evaluate import ClosedFormIK

    b = built(name)
    spec = ClosedFormIK(b.chain, None if b.lock is None else b.lock)
    rng = np.random.default_rng(23)
    found = []
    for q in inner_configurations(b, 60, rng):
        if len(found) < 6:  # stretched straight along axis 1 (the iiwa's zero, turned about joint 1)
            q[list(pair)] = 0.0
        on_axis = wrist_centre_on_axis_1(b, q, pair)
        if on_axis is not None:
            found.append(on_axis)
    q = np.array(found[:24])
    assert len(q) >= 12
    q[::4, -2] = 0.0  # the wrist aligned too
    T = targets_of(b.chain, q)
    refs = q + rng.normal(scale=1e-3, size=q.shape)
    W = 10.0 ** rng.uniform(-1, 1, size=q.shape)
    far = 0.0
    for i in range(len(q)):
        extra = b.extra(q[i])
        assert np.any(spec.candidates(T[i], *extra)[1] & 2)  # a singular representative
        plain, _ = nearest(spec.all(T[i], *extra), refs[i], b.lower, b.upper, b.revolute, continuum=b.continuum)
        want, _ = spec.nearest(refs[i], T[i], *extra)
        want_w, _ = spec.nearest(refs[i], T[i], *extra, weights=W[i])
        np.testing.assert_allclose(spec.nearest(q[i], T[i], *extra)[0], q[i], atol=1e-7)
        far = max(far, float(wrapped_distance(plain[None], q[i], b.revolute)[0]))  # the representative's answer
        if abs(np.sin(q[i, -2])) > 0.1:  # a member near the source, from 1e-3 off (with the wrist near aligned, q1 moved
            # by 1e-3 turns joints 4 and 6 by 1e-3 over the wrist's sine: the member takes that near-continuum's end)
            assert wrapped_distance(want[None], q[i], b.revolute)[0] <= 0.05
        for impl in (b.c, b.py):
            got = impl.ik_nearest(q[i], T[i], *extra)
            assert got.status == "ok"
            np.testing.assert_allclose(got.q, q[i], atol=1e-7)
            for ref, weights, expected in ((refs[i], None, want), (refs[i], W[i], want_w)):
                got = np.asarray(impl.ik_nearest(ref, T[i], *extra).q if weights is None else
                                 impl.ik_nearest_weighted(ref, weights, T[i], *extra).q)
                pos, rot = judge.pose_error(b.numeric, got[None], T[i])
                assert max(pos.max(), rot.max()) <= 1e-12
                np.testing.assert_allclose(got, expected, atol=1e-9)
    assert far >= 0.5  # the representative alone was far from the source: the members carry the answer


def test_an_axis_member_with_the_wrist_aligned_moves_into_the_limits_and_only_reachable_axes_get_members():
    """A probe of the members: (1) the iiwa at q = (0.5, 0, lock 0.3, 0, 1.6, 0, 1.55), its wrist centre on axis 1 and
    its wrist aligned: the member puts q5 = 0 and q7 = 3.15 (beyond +-3.054), and was dropped for that before it moved
    along the wrist's continuum, so ik_nearest(q, pose(q)) returned q1 = 0; the pair is now judged after the move
    (C, NumPy and the spec). (2) The Panda with joint 7 locked got members that were never exact: its shoulder centre
    stays 0.057 m off joint 6's axis; which arms get them is now a search for the least distance. (3) Float members
    are not moved along the wrist's continuum (their wrist angle carries float's rounding; the move made pose errors
    of 1e-4): KR 6 on the axis, the wrist aligned, from nearby references, within float's tolerance."""
    from skelarm_sym.closed_ik.derive import derive_ik_all
    from skelarm_sym.closed_ik.evaluate import ClosedFormIK

    b = built("iiwa14_lock3")
    q = np.array([0.5, 0.0, 0.3, 0.0, 1.6, 0.0, 1.55])
    T = targets_of(b.chain, q[None])[0]
    spec = ClosedFormIK(b.chain, b.lock)
    np.testing.assert_allclose(spec.nearest(q, T, 0.3)[0], q, atol=1e-9)
    for impl in (b.c, b.py):
        got = impl.ik_nearest(q, T, 0.3)
        assert got.status == "ok"
        np.testing.assert_allclose(got.q, q, atol=1e-9)
    panda, lock = load_arm("panda_lock7")
    assert derive_ik_all(panda, lock).members is None
    kr6 = Built(*load_arm("kuka_kr6"), precision="float")
    rng = np.random.default_rng(31)
    checked = 0
    for source in inner_configurations(kr6, 40, rng):
        on_axis = wrist_centre_on_axis_1(kr6, source, (1, 2))
        if on_axis is None:
            continue
        on_axis[4] = 0.0
        target = targets_of(kr6.chain, on_axis[None])[0]
        ref = on_axis + rng.normal(scale=1e-3, size=on_axis.shape)
        for impl in (kr6.c, kr6.py):
            got = np.asarray(impl.ik_nearest(ref, target).q, dtype=float)
            pos, rot = judge.pose_error(kr6.numeric, got[None], target)
            assert max(pos.max(), rot.max()) <= POSE_TOL["float"], (on_axis, got)
        checked += 1
    assert checked >= 10


def test_a_ur_aligned_wrist_with_narrow_limits_takes_a_member_where_the_representative_is_dropped():
    """UR5 with joint 6 limited to [-1.5, 1.5]: at the aligned wrist ik_all's one representative per root of q1 often
    lies outside the limits and is dropped (ik_all: out_of_limits, or only other branches), and ik_nearest(q,
    pose(q)) computed no member, since no returned row was flagged singular: 871 of 2000 such configurations came
    back another solution up to 1.6 rad away or NaN (a new user's probe). The members are now weighed wherever a raw
    candidate is an exact representative: ik_nearest returns q, status ok, in C and NumPy, as the spec does."""
    import dataclasses

    from skelarm_sym.closed_ik.evaluate import ClosedFormIK

    chain, _ = load_arm("ur5")
    joints = [dataclasses.replace(j, lower=-1.5, upper=1.5) if k == 5 else j for k, j in enumerate(chain.joints)]
    b = Built(dataclasses.replace(chain, joints=tuple(joints)), None)
    spec = ClosedFormIK(b.chain)
    rng = np.random.default_rng(19)
    q = inner_configurations(b, 40, rng)
    q[:, 4] = np.where(np.arange(40) % 2, 0.0, np.pi)
    T = targets_of(b.chain, q)
    dropped = 0
    for i in range(len(q)):
        rows = b.c.ik_all(T[i])
        dropped += rows.status == "out_of_limits" or np.min(wrapped_distance(np.asarray(rows.q)[: rows.count], q[i],
                                                                              b.revolute), initial=np.inf) > 1e-3
        want, _ = spec.nearest(q[i], T[i])
        np.testing.assert_allclose(want, q[i], atol=1e-7)
        for impl in (b.c, b.py):
            r = impl.ik_nearest(q[i], T[i])
            assert r.status == "ok"
            np.testing.assert_allclose(r.q, q[i], atol=1e-7)
    assert dropped >= 10


def test_a_float_ur_aligned_wrist_takes_the_split_and_its_members():
    """Float UR5 with the wrist aligned: float's rounding leaves the wrist's sine at about 1e-7 to 1e-6, and with the
    double split tolerance (1e-12) the representative split was never taken, so q6 and phi came from rounding noise
    and no member was exact: ik_nearest(q, pose(q)) returned q (to 1e-3 rad) on 1 of 500 such targets at eea20c4 and
    63 of 500 with the members alone. IK_SPLIT_TOL is 1e-5 in float (a module constant; 1e-12 in double): 442 of 500.
    And 23 of 500 came back unreachable: the representative put joint 4's point on the 2R arm's stretched edge (the
    middle of its range over phi clamped onto the arm's), a double root that float's rounding left least squares; it
    now takes the middle of the two ranges' overlap: every target ok, 500 of 500 back. C and NumPy in float."""
    chain, _ = load_arm("ur5")
    b = Built(chain, None, precision="float")
    assert "#define UR5_IK_SPLIT_TOL 1e-05f" in b.generated.sources["ur5.h"]
    rng = np.random.default_rng(23)
    q = inner_configurations(b, 40, rng)
    q[:, 4] = np.where(np.arange(40) % 2, 0.0, np.pi)
    T = targets_of(b.chain, q)
    for impl in (b.c, b.py):
        back = 0
        for i in range(len(q)):
            assert impl.ik_all(T[i]).status == "ok"
            r = impl.ik_nearest(q[i], T[i])
            back += r.status == "ok" and wrapped_distance(np.asarray(r.q, float), q[i], b.revolute) <= 1e-3
        assert back >= 38, back


def test_a_float_elbow_near_stretched_keeps_its_solutions():
    """Float UR5 with the elbow 1e-9 to 1e-3 rad from stretched: the subproblems' double tolerances (least squares
    below -1e-10 of a discriminant's scale) were float's rounding (about 1e-8), so 61 of 400 such targets came back
    unreachable and the source's row was missing on 159 (a new user's probe). IK_LS_TOL and IK_SING_TOL are module
    constants per precision (1e-6 and 1e-5 in float): every target but a few at the very edge is ok with the source
    among the rows (4 and 4 of 400 in the measurement). C and NumPy in float, poses judged by the reference."""
    chain, _ = load_arm("ur5")
    b = Built(chain, None, precision="float")
    assert "#define UR5_IK_LS_TOL 1e-06f" in b.generated.sources["ur5.h"]
    rng = np.random.default_rng(29)
    q = inner_configurations(b, 40, rng)
    q[:, 2] = 10.0 ** rng.uniform(-9, -3, 40) * rng.choice([-1.0, 1.0], 40)
    T = targets_of(b.chain, q)
    for impl in (b.c, b.py):
        good = 0
        for i in range(len(q)):
            r = impl.ik_all(T[i])
            if r.status != "ok":
                continue
            rows = check_rows(b, r, T[i])
            good += np.min(wrapped_distance(rows, q[i], b.revolute)) <= 1e-2
        assert good >= 37, good


def test_a_double_root_gives_one_row():
    """At an elbow double root (det J = 0 in q2) the two roots part by about the square root of rounding: C and
    NumPy returned two pairs of rows 3e-8 rad apart, all flagged singular, where JAX's rounding gave one row each (a
    new user's probe). Rows both flagged singular within IK_DUP_TOL_SINGULAR (1e-6) are one: two rows, the same in
    every language, each reproducing the target."""
    b = built("puma560")
    poses = load_python(generate(b.chain, out=None, langs="python", functions="pose").sources["puma560.py"], "puma560")
    q = np.array([-0.5111820541496077, -0.48304311766483954, -3.69722551824775, 2.9630334670541765, 0.5318685351098063,
                  -2.465113031220812])
    T = poses.pose(q)
    results = [b.c.ik_all(T), b.py.ik_all(T)]
    for r in results:
        assert r.status == "ok" and r.count == 2 and np.all(np.asarray(r.flags)[:2] & 2)
        rows = check_rows(b, r, T, tol=1e-10)
        assert np.min(wrapped_distance(rows[1:], rows[0], b.revolute)) > 1e-6
    np.testing.assert_array_equal(np.asarray(results[0].q)[:2], np.asarray(results[1].q)[:2])


def test_limits_and_two_pi_shifts():
    """Joint 1 of the PUMA limited to [pi/2, 5pi/2] (centre 3pi/2): every row's q1 is in that range, the copy of
    the spec's; a joint limited to a range that the target's solutions miss gives out_of_limits, count 0."""
    chain, _ = load_arm("puma560")
    joints = list(chain.joints)
    import dataclasses

    joints[0] = dataclasses.replace(joints[0], lower=math.pi / 2, upper=5 * math.pi / 2)
    shifted = dataclasses.replace(chain, joints=tuple(joints))
    b = Built(shifted, None)
    rng = np.random.default_rng(5)
    q = inner_configurations(built("puma560"), 10, rng)
    T = targets_of(chain, q)
    seen_shift = False
    for i in range(len(q)):
        r = b.c.ik_all(T[i])
        rows = check_rows(b, r, T[i])
        spec = b.spec(T[i], q[i])
        np.testing.assert_allclose(rows, spec.solutions, atol=1e-9)
        assert np.all(rows[:, 0] >= math.pi / 2) and np.all(rows[:, 0] <= 5 * math.pi / 2)
        seen_shift |= bool(np.any(rows[:, 0] > math.pi))
    assert seen_shift
    joints[4] = dataclasses.replace(joints[4], lower=1.0, upper=1.2)  # q5 in [1.0, 1.2] rad only
    narrow = Built(dataclasses.replace(chain, joints=tuple(joints)), None)
    q5 = np.array([0.2, 0.3, -0.5, 0.1, -0.4, 0.3])  # q5 = -0.4: no solution has |q5| in [1.0, 1.2]
    T5 = targets_of(chain, q5[None])[0]
    r = narrow.c.ik_all(T5)
    assert (r.status, r.count) == ("out_of_limits", 0) and np.all(np.isnan(r.q))
    n = narrow.c.ik_nearest(q5, T5)
    assert n.status == "out_of_limits" and np.all(np.isnan(n.q))


def test_ur5_rows_lie_within_pi_of_the_centre():
    """UR5 joints are limited to [-2 pi, 2 pi]: several copies fit; the one nearest the centre (0) is returned."""
    b = built("ur5")
    q = inner_configurations(b, 10, np.random.default_rng(9))
    T = targets_of(b.chain, q)
    for i in range(len(q)):
        r = b.c.ik_all(T[i])
        assert np.all(np.abs(r.q[: r.count]) <= math.pi + 1e-12)


@pytest.mark.parametrize("name", ["puma560", "ur5"])
def test_unreachable_targets(name):
    """A target beyond the reach: status unreachable, every row a least-squares candidate (flag bit 1) within the
    limits, finite, the same in C, NumPy and the spec."""
    b = built(name)
    q = inner_configurations(b, 5, np.random.default_rng(11))
    T = targets_of(b.chain, q)
    T[:, :3, 3] *= 10.0
    for i in range(len(q)):
        spec = b.spec(T[i], q[i])
        assert spec.status == STATUS["unreachable"]
        for impl in (b.c, b.py):
            r = impl.ik_all(T[i])
            assert r.status == "unreachable" and r.count == spec.count
            rows = np.asarray(r.q)[: r.count]
            assert np.all(np.isfinite(rows)) and np.all(np.asarray(r.flags)[: r.count] & 1)
            np.testing.assert_allclose(rows, spec.solutions, atol=1e-9)


def raw_call(b: Built, name: str, *args):
    """Call the C function directly (no wrapper checks): status and outputs."""
    f = getattr(b.c._lib, f"{b.generated.module.prefix}_{name}")
    return f(*args)


@pytest.mark.parametrize("name", ["puma560", "iiwa14_lock3"])
def test_invalid_input(name):
    """A non-finite target (or lock), a rotation part that is not orthonormal, or a mirror: the C returns
    IK_INVALID with count 0 and NaN rows; the Python wrappers (ctypes and NumPy) raise a ValueError."""
    b = built(name)
    q = inner_configurations(b, 1, np.random.default_rng(1))[0]
    good = targets_of(b.chain, q[None])[0]
    nan, scaled, mirror = good.copy(), good.copy(), good.copy()
    nan[1, 3] = np.nan
    scaled[:3, :3] *= 1.001
    mirror[:3, 0] *= -1.0
    dp = ctypes.POINTER(ctypes.c_double)
    lock = b.extra(q)
    for bad in (nan, scaled, mirror):
        out = np.zeros(8 * b.chain.n)
        count = ctypes.c_int(5)
        flags = np.zeros(8, dtype=np.intc)
        status = raw_call(b, "ik_all", np.ascontiguousarray(bad.reshape(16)).ctypes.data_as(dp), *[ctypes.c_double(x) for x in lock],
                          out.ctypes.data_as(dp), ctypes.byref(count), flags.ctypes.data_as(ctypes.POINTER(ctypes.c_int)))
        assert status == STATUS["invalid"] and count.value == 0 and np.all(np.isnan(out)) and np.all(flags == -1)
        for impl in (b.c, b.py):
            with pytest.raises(ValueError):
                impl.ik_all(bad, *lock)
            with pytest.raises(ValueError):
                impl.ik_nearest(q, bad, *lock)
    if b.lock is not None:
        out = np.zeros(8 * b.chain.n)
        count = ctypes.c_int(5)
        status = raw_call(b, "ik_all", np.ascontiguousarray(good.reshape(16)).ctypes.data_as(dp), ctypes.c_double(np.nan),
                          out.ctypes.data_as(dp), ctypes.byref(count), None)
        assert status == STATUS["invalid"] and count.value == 0
    # NULL count and flags are allowed
    out = np.zeros(8 * b.chain.n)
    status = raw_call(b, "ik_all", np.ascontiguousarray(good.reshape(16)).ctypes.data_as(dp), *[ctypes.c_double(x) for x in lock],
                      out.ctypes.data_as(dp), None, None)
    assert status == STATUS["ok"] and np.isfinite(out[0])


@pytest.mark.parametrize("name", ["puma560", pytest.param("ur5", marks=pytest.mark.slow),
                                  pytest.param("iiwa14_lock3", marks=pytest.mark.slow)])
def test_float_precision(name):
    """Generated in float: the rows reproduce the target to 3e-5, the source configuration is among them (3e-3),
    C and NumPy agree."""
    b = built(name, "float")
    q = inner_configurations(b, 20, np.random.default_rng(4))
    T = np.asarray(targets_of(b.chain, q), dtype=np.float32).astype(np.float64)
    for i in range(len(q)):
        r = b.c.ik_all(T[i], *b.extra(np.float32(q[i])))
        p = b.py.ik_all(T[i], *b.extra(np.float32(q[i])))
        assert r.status == p.status == "ok" and r.count == p.count
        check_rows(b, r, T[i], q[i])
        # the same rows, to the float rounding of each amplified by its Jacobian's condition number (a joint
        # pair near the wrist singularity is ill-conditioned: only its sum is fixed by the pose)
        kappa = condition(b, r.q[: r.count])
        assert np.all(np.max(np.abs(r.q[: r.count] - p.q[: p.count]), axis=-1) <= 1e-5 * kappa)


def condition(b: Built, rows: np.ndarray) -> np.ndarray:
    """The condition number of each row's Jacobian (the free joints; linear rows in units of the reach)."""
    J = judge.chain_kinematics(b.numeric, rows).J
    if b.lock is not None:
        J = np.delete(J, b.lock, axis=-1)
    J = np.concatenate([J[..., :3, :] / judge.reach(b.numeric), J[..., 3:, :]], axis=-2)
    s = np.linalg.svd(J, compute_uv=False)
    return s[..., 0] / s[..., -1]


# -- strict compilation, NumPy batch, the IR additions -----------------------------------------------------------

@pytest.mark.parametrize("compiler", [cc for cc in ("gcc", "clang") if shutil.which(cc)])
@pytest.mark.parametrize("name, precision", [("puma560", "double"), ("iiwa14_lock3", "float")])
def test_strict_compile(compiler, name, precision):
    """-std=c99 -Wall -Wextra -Werror -pedantic, both compilers, both precisions, with and without a lock."""
    chain, lock = load_arm(name)
    if lock is not None:
        chain = with_ik_lock(chain, lock + 1)
    g = generate(chain, out=None, functions=FUNCTIONS, langs="c", precision=precision)
    compile_shared({k: v for k, v in g.sources.items() if k.endswith((".c", ".h"))}, compiler=compiler)
    header = g.sources[f"{g.module.prefix}.h"]
    P = g.module.prefix.upper()
    assert f"#define {P}_IK_MAX_SOLUTIONS 8\n" in header
    assert f"int {g.module.prefix}_ik_all(const {'double' if precision == 'double' else 'float'} target[16]" in header


def test_candidates_batch_in_numpy_and_c():
    """ik_candidates (the straight-line part) broadcasts in NumPy and has a C batch; both equal SymPy's evaluation."""
    b = built("ur5")
    q = inner_configurations(b, 50, np.random.default_rng(2))
    T = targets_of(b.chain, q).reshape(-1, 16)
    Q, flags = b.raw(T)
    for impl in (b.c, b.py):
        got_Q, got_flags = impl.ik_candidates(T)
        assert got_Q.shape == (50, 8, 6) and got_flags.shape == (50, 8)
        np.testing.assert_allclose(got_Q, Q, atol=1e-11)
        np.testing.assert_array_equal(got_flags, flags)


def test_atan2_in_arithmetic_within_two_ulp():
    """The candidates' atan2 (Cephes' rational atan with range reduction, no libm call) against numpy.arctan2 on
    points of every size and quadrant, the axes included: at most 2 ulp."""
    x, y = sp.symbols("x y")
    steps = Steps("t")
    out = atan2_steps(steps, "a", y, x)
    f = sp.lambdify((y, x), out, modules="numpy", cse=lambda exprs: (list(steps.steps), exprs))
    rng = np.random.default_rng(0)
    n = 200000
    xs = rng.uniform(-1, 1, n) * 10.0 ** rng.integers(-8, 8, n)
    ys = rng.uniform(-1, 1, n) * 10.0 ** rng.integers(-8, 8, n)
    xs[:8] = [1.0, -1.0, 0.0, 0.0, 1.0, -1.0, 1.0, -1.0]
    ys[:8] = [0.0, 0.5, 1.0, -1.0, 1.0, 1.0, -1.0, -1.0]
    with np.errstate(all="ignore"):
        got = np.array(f(ys, xs), dtype=float)
    want = np.arctan2(ys, xs)
    ulp = np.spacing(np.abs(want))
    assert np.max(np.abs(got - want) / ulp) <= 2.0


def test_ir_additions_print():
    """nearbyint (C nearbyint/nearbyintf, NumPy rint), a NaN literal (C99 NAN), integer module constants."""
    from skelarm_sym.backends.c.printer import PRECISIONS, CPrinter
    from skelarm_sym.backends.numpy.printer import PythonPrinter
    from skelarm_sym.ir.evaluate import evaluate
    from skelarm_sym.ir.nodes import Call1, Const, Var

    e = Call1("nearbyint", Var("x"))
    assert CPrinter(PRECISIONS["double"]).expr(e) == "nearbyint(x)"
    assert CPrinter(PRECISIONS["float"]).expr(e) == "nearbyintf(x)"
    assert PythonPrinter(False).expr(e) == "np.rint(x)"
    assert evaluate(e, {"x": 2.5}) == 2.0 and evaluate(e, {"x": -3.5}) == -4.0
    assert CPrinter(PRECISIONS["double"]).expr(Const(math.nan)) == "(double)NAN"
    assert PRECISIONS["double"].literal(8) == "8" and PRECISIONS["double"].literal(8.0) == "8.0"
    g = built("puma560").generated
    assert "\nIK_MAX_SOLUTIONS = 8\n" in g.sources["puma560.py"]
    assert "\nIK_FLAG_SINGULAR = 2\n" in g.sources["puma560.py"]


# -- model options and the command line -----------------------------------------------------------------------------

def test_no_family_explains_in_one_line(tmp_path, capsys):
    """A UR5 whose wrist axes 5 and 6 miss by 5 cm (a5 = 0.05: the offset wrist, SP6): generate --functions ik_all
    fails with the classifier's line (exit 2); without --functions the arm simply has no closed-form functions."""
    path = tmp_path / "ur5_offset.toml"
    path.write_text((ROBOTS / "ur5.toml").read_text().replace('d = 0.09465\nalpha = "-pi/2"', 'd = 0.09465\na = 0.05\nalpha = "-pi/2"'))
    assert main(["generate", "--robot", str(path), "--functions", "ik_all", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "axes 5, 6 do not meet: closest distance 0.05 m" in err
    from skelarm_sym.models.chain import load_robot

    names = {f.name for f in generate(load_robot(path), out=None, langs="python").module.functions}  # every function
    assert {"pose", "ik_solve"} <= names and not names & {"ik_candidates", "ik_all", "ik_nearest"}


def test_ik_lock_option(tmp_path, capsys):
    """--ik-lock JOINT: recorded in the header's regenerate line; check --from regenerates with it; bad values
    are one-line errors (exit 2); on a 6-joint arm it is refused."""
    out = tmp_path / "iiwa"
    assert main(["generate", "--robot", str(ROBOTS / "iiwa14.toml"), "--ik-lock", "3", "--functions", "ik_all",
                 "--out", str(out), "--lang", "python"]) == 0
    header = (out / "iiwa14.py").read_text()
    assert "--ik-lock 3" in header and "def ik_all(target, lock)" in header
    from skelarm_sym.check import load_generated

    loaded = load_generated(out)
    assert "lock" in loaded.generated.derivation.inputs and not loaded.edited
    capsys.readouterr()
    for args in (["--ik-lock", "9"], ["--ik-lock", "nosuchjoint"]):
        assert main(["generate", "--robot", str(ROBOTS / "iiwa14.toml"), *args, "--functions", "ik_all", "--out",
                     str(tmp_path / "x")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "error" in err
    assert main(["generate", "--robot", str(ROBOTS / "puma560.toml"), "--ik-lock", "3", "--out", str(tmp_path / "y")]) == 2
    assert "7-joint" in capsys.readouterr().err
    assert main(["generate", "--links", "3", "--ik-lock", "3", "--out", str(tmp_path / "z")]) == 2


def test_show_ik(capsys):
    """show --what ik: the family, the chain of subproblems, the steps and the candidates in their terms."""
    assert main(["show", "--robot", str(ROBOTS / "puma560.toml"), "--what", "ik"]) == 0
    text = capsys.readouterr().out
    assert "spherical_wrist (parallel_23)" in text and "SP3 q3" in text and "Q[7] = (" in text
    assert main(["show", "--robot", str(ROBOTS / "scara.toml"), "--what", "ik"]) == 2
    assert "6 moving joints" in capsys.readouterr().err


@pytest.mark.parametrize("name, principal", [("ur5", (True, True, True, False, True, True)), ("puma560", (True,) * 6)])
def test_principal_columns_hold_every_candidate(name, principal):
    """The columns ``derive_ik_all`` declares principal (every candidate an angle in [-pi, pi], so ik_all leaves
    them unshifted where the centre is 0) hold only such values, on random targets and on the singular ones where the
    UR wrist splits q6 from q2 + q3 + q4 (q6 = +-(sigma - phi) turned into [-pi, pi]: up to 2 pi away before) and
    the spherical wrist takes its aligned representative."""
    b = built(name)
    ik = b.generated.derivation.function("ik_candidates")
    assert ik.principal == principal
    rng = np.random.default_rng(12)
    q = rng.uniform(-np.pi, np.pi, size=(400, 6))
    q[100:200, 4] = 0.0             # wrist aligned exactly (UR: the split; PUMA: q4 = 0, q6 the whole rotation)
    q[200:300, 4] = np.pi           # UR: aligned the other way
    q[300:, 2] = 0.0                # elbow stretched (UR)
    T = targets_of(b.chain, q).reshape(-1, 16)
    cols = np.array(principal)
    for impl in (b.c, b.py):
        Q, flags = impl.ik_candidates(T)
        assert np.all(np.abs(Q[..., cols]) <= math.pi)
        if name == "ur5":  # the split happened (singular bit on rows of the aligned targets)
            assert np.any(np.asarray(flags[100:300]).astype(int) & 2)


def test_wide_limits_need_no_test_and_agree_with_the_spec():
    """Joints whose range holds every copy shifted toward its centre (more than a turn wide, or [-pi, pi] for a
    column of principal candidates with centre 0) are neither tested nor clipped in ik_all, the others are; a
    principal column with centre 0 is not shifted. On random and singular targets C and NumPy still return the
    spec's rows, within the limits (at an exact double root, the stretched elbow, SymPy's evaluation rounds to two
    rows 3e-8 apart where the C has one: there C and NumPy agree with each other and reproduce the target)."""
    import dataclasses

    from skelarm_sym.models.chain.solver_closed import _Arm

    chain, _ = load_arm("ur5")
    limits = [(-2 * math.pi, 2 * math.pi), (-3.0, 4.0), (-math.pi, math.pi), (-1.5, 2.5), (-2.0, None), (-4.0, 2.3)]
    joints = [dataclasses.replace(j, lower=lo, upper=hi) for j, (lo, hi) in zip(chain.joints, limits)]
    b = Built(dataclasses.replace(chain, joints=tuple(joints)), None)
    spec = b.generated.derivation.function("ik_candidates")
    arm = _Arm(b.chain, False, spec.principal)
    assert [arm.unshifted(j) for j in range(6)] == [True, False, True, False, False, False]
    assert [arm.always_inside(j) for j in range(6)] == [True, True, True, False, False, True]
    rows_c = b.generated.sources["ur5.c"].split("_ik_all_rows(")[1]
    assert rows_c.count("IK_LIMIT_TOL") == 3  # joint 4's two limits, joint 5's lower one
    rng = np.random.default_rng(21)
    q = inner_configurations(b, 40, rng)
    q[30:35, 4] = 0.0
    q[35:, 2] = 0.0
    T = targets_of(b.chain, q)
    for i in range(len(q)):
        want = b.spec(T[i], q[i]) if i < 30 else b.c.ik_all(T[i])
        solutions = want.solutions if i < 30 else np.asarray(want.q)[: want.count]
        for impl in (b.c, b.py):
            r = impl.ik_all(T[i])
            assert r.status == (LABELS[want.status] if i < 30 else want.status) and r.count == want.count
            rows = check_rows(b, r, T[i], tol=1e-11)
            np.testing.assert_allclose(rows, solutions, atol=1e-9)
            assert list(np.asarray(r.flags)[: r.count]) == list(np.asarray(want.flags)[: want.count])


def narrow_wrist_puma(functions: str = FUNCTIONS) -> Built:
    """The PUMA 560 with narrow, off-centre limits on joints 4 and 6 and none on joint 5: the aligned wrist's
    representative (q4 = 0, or an angle of rounding noise at q5 = pi) often misses joint 6's range."""
    import dataclasses

    chain, _ = load_arm("puma560")
    limits = {3: (-1.0, 2.0), 4: (None, None), 5: (-1.5, 1.0)}
    joints = [dataclasses.replace(j, lower=limits[k][0], upper=limits[k][1]) if k in limits else j
              for k, j in enumerate(chain.joints)]
    return Built(dataclasses.replace(chain, joints=tuple(joints)), None, functions=functions)


@pytest.mark.parametrize("name", ["puma_narrow_wrist", pytest.param("stanford", marks=pytest.mark.slow),
                                  pytest.param("iiwa14_lock3", marks=pytest.mark.slow)])
def test_an_aligned_wrist_moves_along_its_continuum(name):
    """Targets from configurations within the limits with the wrist aligned (q5 = 0; and q5 = pi where joint 5 has no
    limits, where the coupling's sign turns): joints 4 and 6 turn about one axis, so the candidates hold one
    representative, which missed joint 6's limits on 21 of 400 Stanford and 11 of 400 iiwa targets and most of the
    narrow PUMA's: the row, and the source's branch with it, was dropped, and ik_nearest from the source returned a
    far representative. Now, in C and NumPy (single calls and the NumPy batch): every target keeps the source's
    branch (its joints outside the pair), each row within the limits reproducing the target and equal to the spec's;
    ik_nearest from the source returns the source, as the spec's nearest does."""
    b = narrow_wrist_puma() if name == "puma_narrow_wrist" else built(name)
    a, w, c = b.continuum[:3]
    rng = np.random.default_rng(5)
    q = inner_configurations(b, 60, rng)
    q[:, w] = 0.0
    if not np.isfinite(b.lower[w]) and not np.isfinite(b.upper[w]):
        q[30:, w] = np.pi
    T = targets_of(b.chain, q)
    other = [k for k in range(b.chain.n) if k not in (a, c)]
    moved = 0
    for i in range(len(q)):
        spec = b.spec(T[i], q[i])
        Q, flags = b.raw(T[i].reshape(1, 16), *b.extra(q[i]))
        shifted = postprocess(Q[0], flags[0].astype(int), b.lower, b.upper, b.revolute, target=T[i].reshape(16))
        moved += shifted.count < spec.count  # a row the representative alone lost
        want, _ = nearest(spec, q[i], b.lower, b.upper, b.revolute, continuum=b.continuum)
        np.testing.assert_allclose(want, q[i], atol=1e-7)
        for impl in (b.c, b.py):
            r = impl.ik_all(T[i], *b.extra(q[i]))
            assert r.status == "ok" and r.count == spec.count
            rows = check_rows(b, r, T[i], tol=1e-11)
            assert np.min(wrapped_distance(rows[:, other], q[i, other], b.revolute[other])) <= 1e-7
            np.testing.assert_allclose(rows, spec.solutions, atol=1e-9)
            np.testing.assert_allclose(impl.ik_nearest(q[i], T[i], *b.extra(q[i])).q, q[i], atol=1e-7)
    assert moved >= (10 if name == "puma_narrow_wrist" else 1)
    if b.lock is None:  # the masked program of the array backends: lanes with and without a continuum row
        batch = b.py.ik_nearest(q, T)
        np.testing.assert_allclose(batch.q, q, atol=1e-7)
        if name == "puma_narrow_wrist" and importlib.util.find_spec("torch"):
            from skelarm_sym.generate import render_all

            module = load_python(render_all(b.generated.module, ("torch",), False)["puma560_torch.py"], "puma560_torch")
            np.testing.assert_allclose(np.asarray(module.ik_nearest(q, T).q), batch.q, atol=1e-12, rtol=0)
            np.testing.assert_allclose(np.asarray(module.ik_all(T).q), b.py.ik_all(T).q, atol=1e-12, rtol=0)


def test_the_continuum_with_wide_limits_and_far_references():
    """Joints 4 and 6 of the PUMA limited to +-1e12 rad: at most three lines of the continuum unroll (the emitted C
    was 4.5 MB at +-1e4 and generation ran out of memory at +-1e12, one line per turn of the ranges), and the member
    nearest a reference a few turns away is the spec's. With the PUMA's own limits, references far from the row
    (1e3 to 1e15 rad): ik_nearest builds the member from the row's values, within the limits, so it reproduces the
    target to rounding (built from q_ref, a reference 1e15 rad away missed it by 1e-2)."""
    import dataclasses

    chain, _ = load_arm("puma560")
    joints = [dataclasses.replace(j, lower=-1e12, upper=1e12) if k in (3, 5) else j for k, j in enumerate(chain.joints)]
    wide = Built(dataclasses.replace(chain, joints=tuple(joints)), None)
    # three lines in each of ik_nearest and ik_nearest_weighted (ik_all moves nothing: every copy fits such ranges)
    assert wide.generated.sources["puma560.c"].count("of the continuum that can cross the windows") == 6
    q = inner_configurations(built("puma560"), 1, np.random.default_rng(8))[0]
    q[4] = 0.0
    for b, far in ((wide, 20.0), (wide, -35.0), (built("puma560"), 1e3), (built("puma560"), 1e9), (built("puma560"), -1e15)):
        T = targets_of(b.chain, q[None])[0]
        ref = q.copy()
        ref[3] = far
        want, _ = nearest(b.spec(T, q), ref, b.lower, b.upper, b.revolute, continuum=b.continuum)
        for impl in (b.c, b.py):
            got = np.asarray(impl.ik_nearest(ref, T).q)
            pos, rot = judge.pose_error(b.numeric, got[None], T)
            assert max(pos.max(), rot.max()) <= 1e-11, (far, pos, rot)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
            assert np.all(got <= b.upper) and np.all(got >= b.lower)


def test_a_far_reference_on_a_joint_wider_than_a_turn_takes_its_nearest_copy():
    """PUMA joint 6 ranges over +-4.64 rad: from q_ref[5] = 20 rad (three turns away) the nearest copy within the
    limits of the source's q6 = -3.0 is -3.0 + 2 pi; only the copies k and k +- 1 around the nearest were tried, none
    fit, and ik_nearest returned a row at distance^2 369 (the source's row is at 280, another at 272). C, NumPy and
    the spec agree with a scan over every row and copy."""
    b = built("puma560")
    q = np.array([0.3, 1.0, -1.0, 0.5, 0.7, -3.0])
    T = targets_of(b.chain, q[None])[0]
    ref = q.copy()
    ref[5] = 20.0
    spec = b.spec(T, q)
    want, _ = nearest(spec, ref, b.lower, b.upper, b.revolute, continuum=b.continuum)
    best = np.inf
    for row in spec.solutions:
        d = 0.0
        for j in range(6):
            copies = row[j] + 2 * np.pi * np.arange(-10, 11)
            copies = copies[(copies >= b.lower[j]) & (copies <= b.upper[j])]
            d += np.min((copies - ref[j]) ** 2)
        best = min(best, d)
    assert np.sum((want - ref) ** 2) == pytest.approx(best, rel=1e-12) and best < 300
    for impl in (b.c, b.py):
        np.testing.assert_allclose(impl.ik_nearest(ref, T).q, want, atol=1e-12)


def scan_nearest(rows, ref, weights, b: Built) -> float:
    """The judge of a weighted nearest: the least ``sum_j weights[j] (q[j] - ref[j])^2`` over the rows and every copy
    ``q[j] + 2 pi k`` within the limits (k within 10 turns), each joint on its own (no continuum)."""
    best = np.inf
    for row in rows:
        d = 0.0
        for j in range(b.chain.n):
            copies = row[j] + 2 * np.pi * np.arange(-10, 11) if b.revolute[j] else np.array([row[j]])
            copies = copies[(copies >= b.lower[j]) & (copies <= b.upper[j])]
            d += weights[j] * np.min((copies - ref[j]) ** 2)
        best = min(best, d)
    return best


def test_ik_nearest_weighted_is_the_weighted_nearest():
    """ik_nearest_weighted(q_ref, weights, target): the ik_all row nearest q_ref in sum_j w_j (q_j - q_ref_j)^2, in C,
    NumPy (single calls and the masked batch) and PyTorch. On the narrow-limit PUMA from random references with
    weights from 1e-3 to 1e3: equal to the spec's nearest with those weights; away from the aligned wrist, as near as a
    scan of every row and copy (an independent judge); with the wrist aligned, the continuum's member is chosen in the
    weighted metric (the spec's continuum_member, itself judged by sampling in test_closed_ik_postprocess), which
    differs from the unweighted member; all ones is ik_nearest bit for bit, and only the ratios of the weights count
    (1.7e308 and 1e-300 times them, the same answer: the code divides by the largest). Weights not finite and > 0 and a q_ref
    not finite: ValueError in Python, IK_INVALID with q NaN from the C function itself."""
    b = narrow_wrist_puma(functions="ik_all,ik_nearest,ik_nearest_weighted")
    a, w, c = b.continuum[:3]
    rng = np.random.default_rng(11)
    q = inner_configurations(b, 40, rng)
    q[20:, w] = 0.0
    T = targets_of(b.chain, q)
    refs = inner_configurations(b, 40, rng)
    W = 10.0 ** rng.uniform(-3, 3, size=(40, 6))
    differs = 0
    for i in range(40):
        spec = b.spec(T[i], q[i])
        want, _ = nearest(spec, refs[i], b.lower, b.upper, b.revolute, weights=W[i], continuum=b.continuum)
        plain, _ = nearest(spec, refs[i], b.lower, b.upper, b.revolute, continuum=b.continuum)
        if i < 20:
            assert np.sum(W[i] * (want - refs[i]) ** 2) == pytest.approx(scan_nearest(spec.solutions, refs[i], W[i], b), rel=1e-12)
        else:
            differs += not np.allclose(want[[a, c]], plain[[a, c]], atol=1e-6)
        for impl in (b.c, b.py):
            r = impl.ik_nearest_weighted(refs[i], W[i], T[i])
            assert r.status == "ok"
            np.testing.assert_allclose(r.q, want, atol=1e-9)
            assert np.array_equal(np.asarray(impl.ik_nearest_weighted(refs[i], np.ones(6), T[i]).q),
                                  np.asarray(impl.ik_nearest(refs[i], T[i]).q))
    assert differs >= 5  # the weights move the continuum's member
    for i in range(0, 40, 4):  # only the ratios count: huge weights overflowed w (q - q_ref)^2 to inf, every row tied
        for impl in (b.c, b.py):
            base = np.asarray(impl.ik_nearest_weighted(refs[i], W[i], T[i]).q)
            np.testing.assert_allclose(impl.ik_nearest_weighted(refs[i], W[i] / W[i].max() * 1.7e308, T[i]).q, base, atol=1e-9)
            np.testing.assert_allclose(impl.ik_nearest_weighted(refs[i], W[i] / W[i].max() * 1e-300, T[i]).q, base, atol=1e-9)
            assert np.array_equal(np.asarray(impl.ik_nearest_weighted(refs[i], np.full(6, 1e308), T[i]).q),
                                  np.asarray(impl.ik_nearest(refs[i], T[i]).q))
    batch = b.py.ik_nearest_weighted(refs, W, T)
    np.testing.assert_allclose(batch.q, [b.py.ik_nearest_weighted(refs[i], W[i], T[i]).q for i in range(40)], atol=1e-12, rtol=0)
    if importlib.util.find_spec("torch"):
        from skelarm_sym.generate import render_all

        module = load_python(render_all(b.generated.module, ("torch",), False)["puma560_torch.py"], "puma560_torch_w")
        np.testing.assert_allclose(np.asarray(module.ik_nearest_weighted(refs, W, T).q), batch.q, atol=1e-12, rtol=0)
    for bad_w, bad_ref in ((np.r_[0.0, np.ones(5)], refs[0]), (np.r_[-1.0, np.ones(5)], refs[0]),
                           (np.r_[np.nan, np.ones(5)], refs[0]), (np.ones(6), np.r_[np.inf, refs[0][1:]])):
        for impl in (b.c, b.py):
            with pytest.raises(ValueError, match="weights|q_ref"):
                impl.ik_nearest_weighted(bad_ref, bad_w, T[0])
        lib = ctypes.CDLL(str(b.c.path))
        fn = getattr(lib, f"{b.generated.module.prefix}_ik_nearest_weighted")
        P = ctypes.POINTER(ctypes.c_double)
        fn.argtypes, fn.restype = [P, P, P, P], ctypes.c_int
        out = np.zeros(6)
        args = [np.ascontiguousarray(x, dtype=float) for x in (bad_ref, bad_w, T[0].reshape(16))]
        assert fn(*(x.ctypes.data_as(P) for x in args), out.ctypes.data_as(P)) == STATUS["invalid"]
        assert np.all(np.isnan(out))


def puma_with_limits(limits: dict) -> Built:
    """The PUMA 560 with the limits ``{coordinate: (lower, upper)}`` (None: absent)."""
    import dataclasses

    chain, _ = load_arm("puma560")
    joints = [dataclasses.replace(j, lower=limits[k][0], upper=limits[k][1]) if k in limits else j
              for k, j in enumerate(chain.joints)]
    return Built(dataclasses.replace(chain, joints=tuple(joints)), None)


@pytest.mark.parametrize("limits, q", [
    # joints 4 and 6 on limits (a corner of the continuum's box): rounding put the member 1e-16 outside, and the
    # line was skipped: ik_nearest(q, pose(q)) returned another member (distance^2 25)
    ({3: (-1.0, 0.5), 4: (None, None), 5: (1.2, 1.2 + 2 * math.pi)},
     [-1.7655046381547823, 3.57528605945932, 0.08297888745890969, 0.5, math.pi, 1.2]),
    ({3: (-math.pi / 2, math.pi / 2), 4: (None, None), 5: (-math.pi / 2, math.pi / 2)},
     [-1.9152899944325303, 1.2610125631538995, -1.046517043822345, math.pi / 2, 0.0, math.pi / 2]),
    # both joints pinned (lower == upper): ik_all found no member and returned out_of_limits
    ({3: (0.3, 0.3), 4: (None, None), 5: (-0.7, -0.7)},
     [0.059421966898915546, 3.4812804695616206, -3.0799688146111333, 0.3, 0.0, -0.7]),
])
def test_a_continuum_member_on_the_limits_is_kept(limits, q):
    """Members of the aligned wrist's continuum within IK_LIMIT_TOL of a limit are kept and clipped onto it, as step 4
    keeps any row (a new user's probe: C, NumPy and the spec all lost them)."""
    b = puma_with_limits(limits)
    q = np.array(q)
    T = targets_of(b.chain, q[None])[0]
    spec = b.spec(T, q)
    assert spec.status == STATUS["ok"]
    want, _ = nearest(spec, q, b.lower, b.upper, b.revolute, continuum=b.continuum)
    np.testing.assert_allclose(want, q, atol=1e-9)
    for impl in (b.c, b.py):
        r = impl.ik_all(T)
        assert r.status == "ok"
        check_rows(b, r, T, tol=1e-11)
        np.testing.assert_allclose(impl.ik_nearest(q, T).q, q, atol=1e-9)


def test_nearest_copy_on_a_limit_a_whole_number_of_turns_away():
    """A copy of the row's joint that lands on a limit a whole number of turns away (limits 360 degrees apart, the row
    clipped onto one): ``floor`` of the turns to the other limit rounded past it, and the copy was an ulp outside the
    limits (C, NumPy, spec); at other values it rounded short and a copy on the limit was missed for one a turn
    further. Within IK_LIMIT_TOL is within, clipped: the result is inside and the nearest."""
    from skelarm_sym.closed_ik.postprocess import nearest_copy

    assert nearest_copy(4.0168300106375785, 32.29116389294572, -2.2663552965420077, 16.58320062499675) == 16.58320062499675
    assert nearest_copy(-2.7903555779935028, -24.781504153122054, -9.073540885173088, -2.7903555779935028) == -9.073540885173088
    lo, hi = math.radians(-357), math.radians(3)
    b = puma_with_limits({0: (lo, hi)})
    q = inner_configurations(b, 1, np.random.default_rng(4))[0]
    q[0] = lo
    T = targets_of(b.chain, q[None])[0]
    ref = q.copy()
    ref[0] = 10.0
    for impl in (b.c, b.py):
        got = np.asarray(impl.ik_nearest(ref, T).q)
        assert lo <= got[0] <= hi and got[0] == pytest.approx(hi, abs=1e-12)


@pytest.mark.parametrize("name", ["puma560", "ur5"])
def test_every_non_finite_entry_is_invalid(name):
    """NaN or +-inf in any of the 12 entries read (R's through the sum of their squares, t's one by one) gives
    IK_INVALID, count 0, NaN rows, flags -1, in C and NumPy; a far but finite position (1e100 m, and IK_TRANSLATION_MAX
    itself) is unreachable with finite rows, not invalid, while one beyond IK_TRANSLATION_MAX (whose squares
    would overflow into NaN rows) is invalid, as in the spec; a huge rotation entry is not a rotation."""
    b = built(name)
    q = inner_configurations(b, 1, np.random.default_rng(2))[0]
    good = targets_of(b.chain, q[None])[0].reshape(16)
    dp = ctypes.POINTER(ctypes.c_double)
    for k in range(12):
        for value in (np.nan, np.inf, -np.inf):
            bad = good.copy()
            bad[k] = value
            out, count, flags = np.zeros(8 * b.chain.n), ctypes.c_int(5), np.zeros(8, dtype=np.intc)
            status = raw_call(b, "ik_all", np.ascontiguousarray(bad).ctypes.data_as(dp), out.ctypes.data_as(dp),
                              ctypes.byref(count), flags.ctypes.data_as(ctypes.POINTER(ctypes.c_int)))
            assert status == STATUS["invalid"] and count.value == 0 and np.all(np.isnan(out)) and np.all(flags == -1), (k, value)
            with pytest.raises(ValueError):
                b.py.ik_all(bad.reshape(4, 4))
    far = good.copy()
    far[[3, 7, 11]] = 1e100
    for impl in (b.c, b.py):
        assert impl.ik_all(far.reshape(4, 4)).status == "unreachable"
    assert f"#define {name.upper()}_IK_TRANSLATION_MAX 1e+150" in b.generated.sources[f"{name}.h"]
    edge = good.copy()
    edge[[3, 7, 11]] = [1e150, -1e150, 1e150]
    assert is_valid_target(edge)
    for impl in (b.c, b.py):
        r = impl.ik_all(edge.reshape(4, 4))
        assert r.status == "unreachable" and np.all(np.isfinite(np.asarray(r.q)[: r.count])), (impl, r)
    for k in (3, 7, 11):
        for value in (1.0000001e150, -1e151, 1e155, 1e300):
            beyond = good.copy()
            beyond[k] = value
            assert not is_valid_target(beyond)
            out, count, flags = np.zeros(8 * b.chain.n), ctypes.c_int(5), np.zeros(8, dtype=np.intc)
            status = raw_call(b, "ik_all", np.ascontiguousarray(beyond).ctypes.data_as(dp), out.ctypes.data_as(dp),
                              ctypes.byref(count), flags.ctypes.data_as(ctypes.POINTER(ctypes.c_int)))
            assert status == STATUS["invalid"] and count.value == 0 and np.all(np.isnan(out)), (k, value)
            with pytest.raises(ValueError, match="IK_TRANSLATION_MAX"):
                b.py.ik_all(beyond.reshape(4, 4))
    huge = good.copy()
    huge[5] = 1e200
    out = np.zeros(8 * b.chain.n)
    assert raw_call(b, "ik_all", np.ascontiguousarray(huge).ctypes.data_as(dp), out.ctypes.data_as(dp), None, None) == STATUS["invalid"]


def test_regular_rows_skip_the_duplicate_test_only_where_provably_distinct():
    """An exact regular row (flag 0) skips the duplicate test in double precision on all-revolute arms
    (solver_closed.REGULAR_ROWS_DISTINCT): near the UR5's stretched elbow (q3 = 0) such rows stay 1e-5 rad or more
    from every other row, while at and within the double-root tolerance the two elbows are flagged and one of them
    is dropped. Float arms and arms with a prismatic joint keep the test for every row."""
    from skelarm_sym.models.chain.solver_closed import _Arm

    b = built("ur5")
    rows_c = b.generated.sources["ur5.c"].split("_ik_all_rows(")[1]
    assert "if (flag > 0) {" in rows_c
    assert _Arm(b.chain, False, precision="double").regular_rows_distinct
    assert not _Arm(b.chain, False, precision="float").regular_rows_distinct
    assert not _Arm(load_arm("stanford")[0], False, precision="double").regular_rows_distinct
    rng = np.random.default_rng(31)
    for e in (0.0, 1e-12, -1e-9, 1e-7, -1e-6, 1e-5, -1e-4):
        q = inner_configurations(b, 4, rng)
        q[:, 2] = e
        T = targets_of(b.chain, q)
        for i in range(len(q)):
            r = b.c.ik_all(T[i])
            assert r.status == "ok"
            rows = check_rows(b, r, T[i], tol=1e-11)  # none twice
            flags = np.asarray(r.flags)[: r.count]
            if e == 0.0:  # the source's elbow pairs collapsed: one row each, flagged (the other shoulder's are not)
                assert r.count < 8 and np.any(flags & 2)
            for k in np.nonzero(flags == 0)[0]:
                others = np.delete(rows, k, axis=0)
                assert np.min(wrapped_distance(others, rows[k], b.revolute)) > 1e-5


def test_a_lock_beyond_ik_lock_max_is_refused_in_every_language():
    """ik_all took a lock of 1e300 (or 1e16) and answered ok with rows 0.2 to 1.8 off their target: the candidates
    were solved with the sine and cosine of the huge value, and the row's lock, moved by whole turns toward the
    limits' centre, was another angle. Beyond IK_LOCK_MAX (1e5 rad in double, where one unit in the last place is
    1.5e-11) the lock is refused: IK_INVALID, which the Python wrappers of C and NumPy raise as a ValueError naming the bound. Within
    it, a lock whole turns away from the target's own still gives rows on the target."""
    from skelarm_sym.closed_ik.postprocess import LOCK_MAX

    b = built("panda_lock7")
    q = inner_configurations(b, 1, np.random.default_rng(5))[0]
    T = targets_of(b.chain, q[None])[0]
    for lock in (1.5 * LOCK_MAX, -1e16, 1e300):
        for impl in (b.c, b.py):
            with pytest.raises(ValueError, match=r"or the lock is beyond IK_LOCK_MAX = 100000 in magnitude"):
                impl.ik_all(T, lock)
            with pytest.raises(ValueError, match=r"or the lock is beyond IK_LOCK_MAX"):
                impl.ik_nearest(q, T, lock)
    turns = q[b.lock] + 2 * math.pi * 15000  # 94248 rad: within the bound
    for impl in (b.c, b.py):
        r = impl.ik_all(T, turns)
        assert r.status == "ok" and r.count >= 1
        for row in np.asarray(r.q)[: r.count]:
            assert np.abs(targets_of(b.chain, row[None])[0] - T).max() < 1e-9


def test_show_ik_reads_as_atan2_states_its_tolerances_and_its_rows_solve(capsys):
    """show --what ik printed each angle as the emitted code's arithmetic atan2 (a dozen lines of polynomials and
    selects each) and named IK_LS_TOL, IK_SING_TOL and IK_SPLIT_TOL without their values (a new user's report).
    Now atan2 stays a call and the values are stated; the listing itself, evaluated in order with the double
    values, gives a row that is the source configuration."""
    assert main(["show", "--robot", str(ROBOTS / "ur5.toml"), "--what", "ik", "--format", "text"]) == 0
    text = capsys.readouterr().out
    assert "atan2(" in text and "24.858464901423062" not in text
    assert "# IK_LS_TOL = 1e-10 (float: 1e-06)" in text and "# IK_SING_TOL = 1e-09" in text and "# IK_SPLIT_TOL = 1e-12" in text
    assert "# IK_ROOT_TOL = 2e-15 (float: 1e-07)" in text
    chain, _ = load_arm("ur5")
    q = np.array([0.4, -1.1, 1.3, -0.7, 0.9, 0.2])
    T = targets_of(chain, q[None]).reshape(16)
    values = {sp.Symbol(f"target{k}"): sp.Float(T[k]) for k in range(16)}
    values.update({sp.Symbol("IK_LS_TOL"): sp.Float(1e-10), sp.Symbol("IK_SING_TOL"): sp.Float(1e-9),
                   sp.Symbol("IK_SPLIT_TOL"): sp.Float(1e-12), sp.Symbol("IK_ROOT_TOL"): sp.Float(2e-15)})
    rows = []
    for line in text.splitlines():
        if line.startswith("#") or " = " not in line:
            continue
        name, expr = line.split(" = ", 1)
        if name.startswith("Q["):
            rows.append([float(sp.sympify(x).xreplace(values)) for x in expr.split(";")[0].strip("() ").split(",")])
        else:
            values[sp.Symbol(name)] = sp.sympify(expr).xreplace(values)
    assert len(rows) == 8
    wrapped = [np.abs((np.array(r) - q + np.pi) % (2 * np.pi) - np.pi).max() for r in rows]
    assert min(wrapped) < 1e-9


SKEWED_WRIST = """<?xml version="1.0"?>
<robot name="skewed">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/><link name="l5"/><link name="l6"/>
  <link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0.01 0.02 0.3" rpy="0 0 0.3"/><axis xyz="0 0 1"/><limit lower="-3.0" upper="3.0" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.07 0.03 0.05" rpy="0.2 0 0"/><axis xyz="0 -1 0"/><limit lower="-2.0" upper="2.5" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.45 0.05 0.02" rpy="0 0.4 0"/><axis xyz="0 1 0"/><limit lower="-0.5" upper="2.0" effort="1" velocity="1"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/><origin xyz="0.1 0.02 0.03" rpy="0 0 0"/><axis xyz="1 0 0"/><limit lower="-2.0" upper="2.0" effort="1" velocity="1"/></joint>
  <joint name="j5" type="revolute"><parent link="l4"/><child link="l5"/><origin xyz="0.38 0 0" rpy="0 0 0"/><axis xyz="0.5 0 0.8660254037844386"/><limit lower="-1.2" upper="1.2" effort="1" velocity="1"/></joint>
  <joint name="j6" type="continuous"><parent link="l5"/><child link="l6"/><origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="1 0 0"/></joint>
  <joint name="jt" type="fixed"><parent link="l6"/><child link="tool"/><origin xyz="0.09 0.01 -0.02" rpy="0.3 -0.5 1.1"/></joint>
</robot>
"""


def test_a_skewed_spherical_wrist_is_exact_at_and_near_alignment(tmp_path):
    """A spherical wrist whose middle axis is at 60 degrees to the others (a new user's URDF) lost digits at the aligned
    wrist: q5's discriminant cancelled at its double root, so the two rows at q5 = 0 missed the target by 2e-8 in
    rotation and ik_nearest from the source landed up to 0.88 rad away (0 of the probe's 60 aligned targets). The
    discriminant is now written without cancellation for a skewed wrist, and its continuum (aligned at q5 = 0 only)
    is moved along as a right-angle wrist's is."""
    from skelarm_sym import reference
    from skelarm_sym.models.chain import load_robot

    path = tmp_path / "skewed.urdf"
    path.write_text(SKEWED_WRIST)
    chain = load_robot(path, tip="tool")
    g = generate(chain, langs="python", out=None, prefix="skewed", functions="ik_all,ik_nearest")
    arm = load_python(g.sources["skewed.py"], "skewed")
    numeric = chain.numeric(None)
    rng = np.random.default_rng(7)
    lower, upper = np.array([-3.0, -2.0, -0.5, -2.0, -1.2, -np.pi]), np.array([3.0, 2.5, 2.0, 2.0, 1.2, np.pi])
    for q5 in (0.0, 1e-9, 1e-6):
        for _ in range(12):
            q = rng.uniform(lower, upper)
            q[4] = q5
            T = reference.chain_kinematics(numeric, q[None]).T[0]
            r = arm.ik_all(T)
            assert r.status == "ok" and r.count >= 1
            for row in r.q[:r.count]:
                assert np.abs(reference.chain_kinematics(numeric, row[None]).T[0] - T).max() < 1e-12, (q5, row)
            near = arm.ik_nearest(q, T)
            assert np.abs(near.q - q).max() < (1e-9 if q5 == 0.0 else 1e-6), (q5, near.q, q)


def _wrist_with_axis6(tmp_path, h6) -> Built:
    """SKEWED_WRIST's arm with joint 6's axis ``h6`` (its axis 5 at 60 degrees to axis 4) and joint 5 free over
    [-3.5, 3.5], built for ik_all and ik_nearest."""
    from skelarm_sym.models.chain import load_robot

    path = tmp_path / "wrist.urdf"
    path.write_text(SKEWED_WRIST.replace('<axis xyz="1 0 0"/></joint>\n  <joint name="jt"',
                                         '<axis xyz="%.17g %.17g %.17g"/></joint>\n  <joint name="jt"' % tuple(h6))
                    .replace('lower="-1.2" upper="1.2"', 'lower="-3.5" upper="3.5"'))
    return Built(load_robot(path, tip="tool"), None, functions="ik_all,ik_nearest")


def _aligned_targets_return_their_source(b: Built, q5_values, per_value: int, seed: int) -> None:
    """For random configurations with joint 5 at each of ``q5_values`` (the wrist aligned): every ik_all row of C
    and NumPy reproduces the target, and ik_nearest from the configuration returns it."""
    from skelarm_sym import reference

    rng = np.random.default_rng(seed)
    lower, upper = np.array([-3.0, -2.0, -0.5, -2.0, -3.5, -np.pi]), np.array([3.0, 2.5, 2.0, 2.0, 3.5, np.pi])
    for q5 in q5_values:
        for _ in range(per_value):
            q = rng.uniform(lower, upper)
            q[4] = q5
            T = reference.chain_kinematics(b.numeric, q[None]).T[0]
            for impl in (b.c, b.py):
                r = impl.ik_all(T)
                assert r.status == "ok" and r.count >= 1
                for row in r.q[:r.count]:
                    assert np.abs(reference.chain_kinematics(b.numeric, row[None]).T[0] - T).max() < 1e-12
                assert np.abs(impl.ik_nearest(q, T).q - q).max() < 1e-9, (q5, q)


def test_a_wrist_aligned_at_a_half_turn_only_has_its_continuum(tmp_path):
    """A skewed wrist whose sixth axis meets the fourth only with q5 at +-pi (two equal skew twists, DH alpha4 = alpha5)
    got no continuum: the rows at q5 = pi were exact, but ik_nearest from the source landed
    up to 1.9 rad away (30 of 30 aligned targets). Its continuum is now found with h6 turned half a turn about h5,
    aligned at odd multiples of pi only, in NumPy and in C."""
    b = _wrist_with_axis6(tmp_path, (-0.5, 0.0, 0.8660254037844386))
    _aligned_targets_return_their_source(b, (np.pi, -np.pi), 10, seed=11)


def test_a_wrist_aligned_at_another_turn_has_its_continuum(tmp_path):
    """A wrist whose sixth axis meets the fourth's line with q5 at 1 rad (a file whose zero pose bends joint 5): the rows
    were exact but ik_nearest from the source landed up to 2.5 rad away on 30 of 30 aligned targets (a previous stop's
    leftover). The continuum is found at that turn, ``(a, w, b, s, 0, w0 = 1)``, in NumPy and in C."""
    h4, h5 = np.array([1.0, 0.0, 0.0]), np.array([0.5, 0.0, math.sqrt(3) / 2])
    h6 = h4 * math.cos(-1.0) + np.cross(h5, h4) * math.sin(-1.0) + h5 * (h5 @ h4) * (1 - math.cos(-1.0))  # turned back 1 rad
    b = _wrist_with_axis6(tmp_path, h6)
    assert b.continuum[:5] == (3, 4, 5, 1, 0) and abs(b.continuum[5] - 1.0) < 1e-12
    _aligned_targets_return_their_source(b, (1.0,), 12, seed=12)


def test_ik_nearest_may_write_its_answer_over_q_ref():
    """A controller's in-place call ``ur5_ik_nearest(q, T, q)`` returned IK_INVALID with q NaN: the function set q to
    NaN before it read q_ref. It reads q_ref first now, and the in-place answer is the out-of-place one, for the
    weighted variant too (the header allows it)."""
    b = built("ur5")
    lib, prefix = b.c._lib, b.generated.module.prefix
    pointer = ctypes.POINTER(ctypes.c_double)
    plain, weighted = getattr(lib, f"{prefix}_ik_nearest"), getattr(lib, f"{prefix}_ik_nearest_weighted")
    plain.argtypes, plain.restype = [pointer] * 3, ctypes.c_int
    weighted.argtypes, weighted.restype = [pointer] * 4, ctypes.c_int
    q = np.array([[0.3, -1.2, 1.4, -1.8, 0.9, 0.7], [-2.0, -0.4, -1.9, 0.6, -1.1, 2.5]])
    T = targets_of(b.chain, q)
    weights = np.array([1.0, 2.0, 0.5, 1.0, 3.0, 1.0])
    for i in range(q.shape[0]):
        start = q[i] + 0.05  # near the source, not on it: the answer differs from the reference it overwrites
        target = np.ascontiguousarray(T[i].reshape(16))
        buf = start.copy()
        assert plain(buf.ctypes.data_as(pointer), target.ctypes.data_as(pointer), buf.ctypes.data_as(pointer)) == 0
        np.testing.assert_array_equal(buf, b.c.ik_nearest(start, T[i]).q)
        assert np.abs(buf - q[i]).max() < 1e-9
        buf = start.copy()
        assert weighted(buf.ctypes.data_as(pointer), weights.ctypes.data_as(pointer), target.ctypes.data_as(pointer),
                        buf.ctypes.data_as(pointer)) == 0
        np.testing.assert_array_equal(buf, b.c.ik_nearest_weighted(start, weights, T[i]).q)


def test_continuum_members_take_the_target_as_4_x_4_as_the_other_entries_do():
    """ik_continuum_members (a straight-line function) refused a (4, 4) target (``target must have shape (..., 16)``)
    where ik_all and ik_nearest take it (a new user's report). Every Python entry now reads (..., 4, 4) as the 16
    entries, row-major: NumPy, the compiled C through ctypes and the CPython extension, PyTorch and JAX."""
    b = built("ur5")
    q = np.array([[0.3, -1.2, 1.4, -1.8, 0.0, 0.7], [0.1, -0.9, 1.1, -1.5, 0.0, -0.4]])
    T = targets_of(b.chain, q)
    entries = [("numpy", b.py), ("c", b.c), ("cpython", compile_arm(b.generated, extension=True))]
    for lang, name in (("torch", "torch"), ("jax", "jax")):
        if importlib.util.find_spec(name) is not None:
            if name == "jax":
                import jax
                jax.config.update("jax_enable_x64", True)
            g = generate(b.chain, langs=lang, out=None, prefix="members44", functions="ik_continuum_members")
            entries.append((lang, load_python(g.sources[f"members44_{lang}.py"], f"members44_{lang}")))
    for lang, impl in entries:
        for single in (0, 1):
            qq, TT = (q[single], T[single]) if single else (q, T)
            flat = np.asarray(impl.ik_continuum_members(qq, TT.reshape(*TT.shape[:-2], 16))[0])
            square = np.asarray(impl.ik_continuum_members(qq, TT)[0])
            assert flat.shape == square.shape and np.array_equal(flat, square, equal_nan=True), lang
