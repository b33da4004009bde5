"""Random arms of each family (random standard-DH tables with the family's zeros, random base and tool):
classified as built, every exact candidate reproduces its target, and the configuration that made the
target is among the candidates."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skelarm_sym.closed_ik import classify
from skelarm_sym.closed_ik.evaluate import ClosedFormIK
from skelarm_sym.models.chain import reference_ik_all as judge

from closed_ik_support import FAMILY_CONSTRAINTS, random_configurations, random_family_chain, targets_of, wrapped_distance

FAMILIES = list(FAMILY_CONSTRAINTS)


def check_family(family, seed, targets=100):
    rng = np.random.default_rng(seed)
    chain = random_family_chain(family, rng)
    got = classify(chain)
    assert (got.name, got.position) == family
    ik = ClosedFormIK(chain)
    num = chain.numeric()
    rev = judge.revolute_mask(num)
    q = random_configurations(chain, targets, rng)
    T = targets_of(chain, q)
    Q, flags = ik.candidates(T.reshape(-1, 16))
    assert np.all(np.isfinite(Q))
    for i in range(targets):
        exact = Q[i][(flags[i] & 1) == 0]
        pos, rot = judge.pose_error(num, exact, T[i])
        assert max(pos.max(), rot.max()) <= 1e-11, (seed, i)
        assert np.min(wrapped_distance(exact, q[i], rev)) < 1e-6, (seed, i)


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
