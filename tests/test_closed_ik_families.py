"""Random arms of each family (random standard-DH tables with the family's zeros, random base and tool):
classified as built, every exact candidate reproduces its target, and the configuration that made the
target is among the candidates."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skelarm_sym.closed_ik import classify
from skelarm_sym.closed_ik.evaluate import ClosedFormIK
from skelarm_sym.models.chain import reference_ik_all as judge

from closed_ik_support import (FAMILY_CONSTRAINTS, pose_errors, random_configurations, random_family_chain, targets_of,
                               wrapped_distance)

FAMILIES = list(FAMILY_CONSTRAINTS)


def check_family(family, seed, targets=100):
    rng = np.random.default_rng(seed)
    chain = random_family_chain(family, rng)
    got = classify(chain)
    assert (got.name, got.position) == family
    check_chain(chain, rng, targets, seed)


def check_chain(chain, rng, targets=100, label=None):
    """Every exact candidate of ``chain``'s closed-form IK reproduces its target (pose error at most 1e-11, the
    judge's), and the configuration that made the target is among them (1e-6), on ``targets`` random configurations."""
    ik = ClosedFormIK(chain)
    num = chain.numeric()
    rev = judge.revolute_mask(num)
    q = random_configurations(chain, targets, rng)
    T = targets_of(chain, q)
    Q, flags = ik.candidates(T.reshape(-1, 16))
    assert np.all(np.isfinite(Q))
    exact = (flags & 1) == 0  # (targets, S)
    pos, rot = pose_errors(num, Q, T)  # every candidate against its own target, in one pass
    worst = np.where(exact, np.maximum(pos, rot), -np.inf).max(axis=1)  # -inf: no exact candidate
    bad = np.flatnonzero(~(worst <= 1e-11) | ~exact.any(axis=1))
    assert len(bad) == 0, (label, bad[:5], worst[bad[:5]])
    near = np.where(exact, wrapped_distance(Q, q[:, None, :], rev), np.inf).min(axis=1)
    missed = np.flatnonzero(~(near < 1e-6))
    assert len(missed) == 0, (label, missed[:5], near[missed[:5]])


@pytest.mark.parametrize("family", FAMILIES, ids=[f"{a}-{b}" for a, b in FAMILIES])
@settings(max_examples=1, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(seed=st.integers(0, 2**32 - 1))
def test_random_arm_of_each_family(family, seed):
    check_family(family, seed)


@pytest.mark.slow
@pytest.mark.parametrize("family", FAMILIES, ids=[f"{a}-{b}" for a, b in FAMILIES])
@settings(max_examples=3, deadline=None, suppress_health_check=list(HealthCheck))
@given(seed=st.integers(0, 2**32 - 1))
def test_random_arms_of_each_family_more(family, seed):
    check_family(family, seed, targets=200)


def test_a_skewed_wrist_whose_constants_nsimplify_misread():
    """Seed 4025 of the random prismatic-third-joint arms (found by the slow test's random seeds): every row missed
    its target by up to 0.17 m, flagged exact. The wrist's discriminant took its constants through ``nsimplify``,
    which replaced one by a nearby closed form it recognised; they are now exact, or 0 within rounding."""
    check_family(("spherical_wrist", "prismatic_3"), 4025, targets=200)


def test_pose_errors_are_the_judges():
    """``pose_errors`` (one forward pass over every candidate) gives the judge's ``pose_error`` target by target;
    on configurations far from the targets, so that the errors are of order one and a wrong formula shows."""
    rng = np.random.default_rng(3)
    chain = random_family_chain(FAMILIES[0], rng)
    num = chain.numeric()
    T = targets_of(chain, random_configurations(chain, 5, rng))
    Q = random_configurations(chain, 5 * 8, rng).reshape(5, 8, chain.n)
    pos, rot = pose_errors(num, Q, T)
    for i in range(5):
        want = judge.pose_error(num, Q[i], T[i])
        assert want[0].min() > 1e-3 and want[1].min() > 1e-3
        np.testing.assert_allclose(pos[i], want[0], rtol=1e-12, atol=0)
        np.testing.assert_allclose(rot[i], want[1], rtol=1e-12, atol=0)


@pytest.mark.parametrize("family, rows", [(("three_parallel", None), (1,)), (("three_parallel", None), (2,)),
                                          (("three_parallel", None), (1, 2)), (("three_parallel_reversed", None), (2,)),
                                          (("three_parallel_reversed", None), (3,)), (("spherical_wrist", "parallel_23"), (1,))])
def test_parallel_axes_pointing_opposite_ways(family, rows, monkeypatch):
    """Parallel axes that point opposite ways (a twist of pi; a URDF's half-turn: centauro's wheel legs): three
    parallel axes took ``q4 = phi - q2 - q3`` as if they pointed the same way, every row's q4 wrong (poses 2 m off,
    flagged exact). ``phi = q2 + s3 q3 + s4 q4`` with ``s_k = h2 . h_k``."""
    import closed_ik_support

    constraints = {k: dict(v) for k, v in FAMILY_CONSTRAINTS[family].items()}
    for row in rows:
        constraints[row]["alpha"] = np.pi
    monkeypatch.setitem(closed_ik_support.FAMILY_CONSTRAINTS, family, constraints)
    for seed in (1, 2):
        check_family(family, seed)


def test_an_aligned_ur_wrist_with_a_reversed_elbow_keeps_its_continuum():
    """A UR5 whose elbow axis is reversed (DH twist pi before it): at an aligned wrist (q5 = 0) ``ik_nearest`` from a
    configuration returns it; the continuum's ``phi`` of the reference is ``q2 - q3 - q4`` there (twist pi before joint 3: h3 and h4 both point against h2)."""
    import sympy as sp

    from closed_ik_support import ur_like_chain
    from skelarm_sym import reference

    chain = ur_like_chain("ur5_reversed_elbow", twist2=sp.pi)
    assert classify(chain).name == "three_parallel"
    ik = ClosedFormIK(chain)
    num = chain.numeric()
    rng = np.random.default_rng(7)
    for _ in range(10):
        q = rng.uniform(-2.5, 2.5, 6)
        q[4] = 0.0
        T = reference.chain_kinematics(num, q[None]).T[0]
        near, _ = ik.nearest(q, T.reshape(16))
        assert np.abs(near - q).max() < 1e-9, (q, near)


@pytest.mark.parametrize("family, alphas", [(("spherical_shoulder", "intersect_12"), {0: 1.1, 1: 1.1}),
                                            (("spherical_wrist", "parallel_23"), {3: 0.9, 4: 0.9})])
def test_equal_skew_twists_with_a_bent_zero_pose_have_their_continuum(family, alphas, monkeypatch):
    """Random arms whose two skew twists are equal align at a turn of the middle joint that their random DH offsets
    make any angle ``w0``: the continuum is found there, for the wrist and for the shoulder (a reversed chain, whose
    variables are negated: ``-w0``), and ik_nearest from a configuration on it returns that configuration."""
    import closed_ik_support
    from closed_ik_support import random_family_chain
    from skelarm_sym import reference
    from skelarm_sym.closed_ik.evaluate import ClosedFormIK

    constraints = {k: dict(v) for k, v in FAMILY_CONSTRAINTS[family].items()}
    for row, alpha in alphas.items():
        constraints.setdefault(row, {})["alpha"] = alpha
    monkeypatch.setitem(closed_ik_support.FAMILY_CONSTRAINTS, family, constraints)
    rng = np.random.default_rng(0)
    chain = random_family_chain(family, rng)
    ik = ClosedFormIK(chain)
    a, w, b, s, s_odd, w0 = ik.ik.continuum
    assert abs(w0) > 0.1 and abs(abs(w0) - np.pi) > 0.1  # not a multiple of pi
    num = chain.numeric()
    for _ in range(8):
        q = rng.uniform(-2.5, 2.5, 6)
        q[w] = w0
        T = reference.chain_kinematics(num, q[None]).T[0]
        # the continuum by the forward kinematics, not by the solver: at w0 joints a and b turn about one axis
        # (q[a] + t, q[b] - s t keep the pose); at -w0 (the other sign of the turn) they do not
        for turn, still in ((w0, True), (-w0, False)):
            moved = q.copy()
            moved[w], moved[a], moved[b] = turn, q[a] + 0.7, q[b] - s * 0.7
            base = q.copy()
            base[w] = turn
            change = np.abs(reference.chain_kinematics(num, moved[None]).T[0] - reference.chain_kinematics(num, base[None]).T[0]).max()
            assert (change < 1e-12) == still, (turn, change)
        near, _ = ik.nearest(q, T.reshape(16))
        assert np.abs(near - q).max() < 1e-9, (q, near)


def test_check_judges_the_source_configuration_by_its_condition():
    """A sweep of random arms' float code (benchmarks/closed_ik_sweep.py --emitted): check failed seed 31001 because
    one target's source configuration has a Jacobian condition of 2.5e6, where float rounding of the target moves the
    exact rows 0.25 rad from it (their poses within 5e-7), against a fixed 3e-3. The check now allows the rounding
    times the condition there."""
    from closed_ik_support import random_family_chain
    from skelarm_sym.check import check_solvers, load_implementations
    from skelarm_sym.generate import generate

    chain = random_family_chain(("spherical_wrist", "intersect_12"), np.random.default_rng(31001))
    generated = generate(chain, langs="c,python", out=None, precision="float",
                         functions="ik_all,ik_nearest,ik_nearest_weighted")
    rows = check_solvers(generated, load_implementations(generated), 10, 31001, "float")
    assert rows and all(row.ok for row in rows), [row.row() for row in rows]


def test_check_takes_a_float_decision_at_a_reach_limit():
    """The float sweep's last failure (seed 31011, a spherical shoulder): one target lies at a branch's reach limit,
    and the float C flags all 8 rows least squares where the steps evaluated in double keep 4 exact, at either
    precision's tolerances. Evaluated from the float32 target (float arithmetic where NumPy keeps it) they decide as
    the C does: a third answer of the candidates' check. The emitted candidates against the double evaluations
    alone still differ there (so the third answer is what passes it)."""
    from closed_ik_support import random_family_chain
    from skelarm_sym.check import compare, load_implementations
    from skelarm_sym.closed_ik.evaluate import lambdify_candidates
    from skelarm_sym.generate import generate
    from skelarm_sym.models.chain.check import _targets

    chain = random_family_chain(("spherical_shoulder", "intersect_12"), np.random.default_rng(31011))
    generated = generate(chain, langs="c,python", out=None, precision="float",
                         functions="pose,jacobian,ik_all,ik_nearest,ik_nearest_weighted")
    implementations = load_implementations(generated)
    rows = [r for r in compare(generated, 5, 31011, "float", implementations) if "ik_candidates" in r.implementation]
    assert rows and all(r.ok for r in rows), [(r.implementation, r.output, r.abs_error) for r in rows if not r.ok]
    t = _targets(chain, 31011 + 3, 5, "float")
    in_double = [lambdify_candidates(generated.derivation, p)(t.targets, t.lock_value)[1] for p in ("float", "double")]
    in_float = lambdify_candidates(generated.derivation, "float")(t.targets, t.lock_value, dtype=np.float32)[1]
    assert all((flags != in_float).any() for flags in in_double)


def test_a_stretched_elbow_over_the_shoulder_is_exact():
    """The iiwa with joint 3 locked, stretched straight up (q2 = q4 = 0: KUKA's zero pose has it), or nearly: the
    elbow's double root came back +-4e-8 rad from rounding of its discriminant, which bent the wrist off the first
    axis where joint 2 cannot bring it back (rows 1e-8 m off, flagged only singular); with the wrist aligned too
    (q4 = q6 = 0) that bend hid the alignment and ``ik_nearest`` missed the source on 65 of 100 targets (a probe on
    pybullet's iiwa). A discriminant within rounding of a double root now gives the double root."""
    from skelarm_sym import load_robot, reference

    chain = load_robot(str(Path(__file__).resolve().parent.parent / "examples" / "robots" / "iiwa14.toml"), ik_lock=3)
    ik = ClosedFormIK(chain, lock=2)
    num = chain.numeric()
    lower = np.array([float(j.lower) for j in chain.joints])
    upper = np.array([float(j.upper) for j in chain.joints])
    rng = np.random.default_rng(1)
    for zeroed, bend in (((1, 3), 0.0), ((1, 3), 1e-9), ((1, 3), 1e-8), ((3, 5), 0.0)):
        for _ in range(25):
            q = rng.uniform(lower, upper)
            q[list(zeroed)] = 0.0
            q[3] = bend
            T = reference.chain_kinematics(num, q[None]).T[0]
            Q, flags = ik.candidates(T.reshape(1, 16), lock=q[2])
            pos, rot = pose_errors(num, Q, T[None])
            exact = (flags[0] & 1) == 0
            assert exact.any() and np.where(exact, np.maximum(pos, rot)[0], 0.0).max() <= 1e-12, (q, pos, rot)
            if zeroed == (3, 5):
                near, _ = ik.nearest(q, T.reshape(16), lock=q[2])
                assert np.abs(near - q).max() < 1e-9, (q, near)


def test_a_folded_arm_with_equal_links_stays_exact():
    """Taking a double root's rounding as the root moves the elbow angle by up to ``sqrt`` of the band and the
    shoulder-wrist distance by that over the distance, which grows as an arm folds: a band of 1e-13 of the scale put a
    UR-like arm whose forearm is 1e-4 m shorter than its upper arm, folded to 2e-7 rad of pi, 3e-11 off its targets
    (a review of the change). The band now bounds the distance's move as well."""
    from closed_ik_support import ur_like_chain
    from skelarm_sym.models.chain.reference import chain_kinematics

    chain = ur_like_chain("fold", a3=-0.4249)
    ik, num, rng = ClosedFormIK(chain), chain.numeric(), np.random.default_rng(0)
    for delta in (3e-7, 2e-7):
        q = rng.uniform(-2.5, 2.5, (20, 6))
        q[:, 2] = np.pi - delta
        T = chain_kinematics(num, q).T
        Q, flags = ik.candidates(T.reshape(-1, 16))
        pos, rot = pose_errors(num, Q, T)
        exact = (flags & 1) == 0
        assert exact.any(axis=1).all() and np.where(exact, np.maximum(pos, rot), 0.0).max() <= 1e-12
