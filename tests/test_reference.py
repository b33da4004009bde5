"""The recursive reference against finite differences and the seeds' closed forms."""

import numpy as np
import pytest

from skelarm_sym import InputError, reference


def endpoint(q, l):
    return reference.kinematics(q, lengths=l).p


def test_jacobian_matches_central_differences(rng):
    for n in (1, 2, 3, 5, 9):
        q = rng.uniform(-np.pi, np.pi, n)
        l = rng.uniform(0.3, 2.0, n)
        h = 1e-6
        numeric = np.stack([(endpoint(q + h * e, l) - endpoint(q - h * e, l)) / (2 * h) for e in np.eye(n)], axis=-1)
        np.testing.assert_allclose(reference.kinematics(q, lengths=l).J, numeric, atol=1e-8)


def test_coriolis_basis_is_time_derivative_of_jacobian(rng):
    """H = dJ/dt along q(t) = q + t dq, by central differences in t."""
    for n in (1, 2, 3, 6):
        q, dq = rng.uniform(-np.pi, np.pi, (2, n))
        l = rng.uniform(0.3, 2.0, n)
        h = 1e-6
        J = lambda t: reference.kinematics(q + t * dq, lengths=l).J  # noqa: E731
        np.testing.assert_allclose(reference.kinematics(q, dq, lengths=l).H, (J(h) - J(-h)) / (2 * h), atol=1e-7)


def test_velocity_and_acceleration_by_differences(rng):
    """v = dp/dt and a = dv/dt along q(t) = q + t dq + t^2/2 ddq."""
    n = 4
    q, dq, ddq = rng.uniform(-2, 2, (3, n))
    l = rng.uniform(0.3, 2.0, n)
    path = lambda t: (q + t * dq + 0.5 * t * t * ddq, dq + t * ddq)  # noqa: E731
    h = 1e-5
    k = reference.kinematics(q, dq, ddq, l)
    p = lambda t: reference.kinematics(path(t)[0], lengths=l).p  # noqa: E731
    v = lambda t: reference.kinematics(path(t)[0], path(t)[1], lengths=l).v  # noqa: E731
    np.testing.assert_allclose(k.v, (p(h) - p(-h)) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(k.a, (v(h) - v(-h)) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(k.v, k.J @ dq, atol=1e-12)
    np.testing.assert_allclose(k.a, k.J @ ddq + k.H @ dq, atol=1e-12)


def test_two_link_jacobian_of_seeds_001_002(rng):
    q1, q2 = rng.uniform(-np.pi, np.pi, 2)
    l1, l2 = 0.7, 1.3
    s1, c1, s12, c12 = np.sin(q1), np.cos(q1), np.sin(q1 + q2), np.cos(q1 + q2)
    expected = np.array([[-l1 * s1 - l2 * s12, -l2 * s12], [l1 * c1 + l2 * c12, l2 * c12]])
    k = reference.kinematics([q1, q2], lengths=[l1, l2])
    np.testing.assert_allclose(k.J, expected, atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(k.J), l1 * l2 * np.sin(q2), atol=1e-14)


def test_three_link_jacobian_with_orientation_row_of_seed_004(rng):
    w1, w2, w3 = rng.uniform(-np.pi, np.pi, 3)
    L1, L2, L3 = 1.0, 0.8, 0.5
    J = np.array(
        [
            [-L1 * np.sin(w1) - L2 * np.sin(w1 + w2) - L3 * np.sin(w1 + w2 + w3), -L2 * np.sin(w1 + w2) - L3 * np.sin(w1 + w2 + w3), -L3 * np.sin(w1 + w2 + w3)],
            [L1 * np.cos(w1) + L2 * np.cos(w1 + w2) + L3 * np.cos(w1 + w2 + w3), L2 * np.cos(w1 + w2) + L3 * np.cos(w1 + w2 + w3), L3 * np.cos(w1 + w2 + w3)],
            [1.0, 1.0, 1.0],
        ]
    )
    k = reference.kinematics([w1, w2, w3], lengths=[L1, L2, L3])
    np.testing.assert_allclose(k.J3, J, atol=1e-15)
    assert k.phi == pytest.approx(w1 + w2 + w3)


def test_zero_velocity_gives_zero_coriolis(rng):
    q = rng.uniform(-np.pi, np.pi, (5, 7))
    k = reference.kinematics(q, np.zeros(7), rng.normal(size=(5, 7)), np.ones(7))
    assert np.all(k.H == 0) and np.all(k.v == 0)


@pytest.mark.parametrize("q2", [0.0, np.pi, -np.pi])
def test_stretched_and_folded_two_link_are_singular(q2):
    k = reference.kinematics([0.4, q2], lengths=[1.0, 0.6])
    assert abs(np.linalg.det(k.J)) < 1e-15


def test_batches_broadcast(rng):
    q = rng.uniform(-np.pi, np.pi, (4, 3, 5))
    k = reference.kinematics(q, lengths=np.ones(5))
    assert k.J.shape == (4, 3, 2, 5) and k.p.shape == (4, 3, 2) and k.joints.shape == (4, 3, 6, 2)
    single = reference.kinematics(q[2, 1], lengths=np.ones(5))
    np.testing.assert_array_equal(k.J[2, 1], single.J)


def test_bad_shapes():
    with pytest.raises(InputError, match=r"dq must have shape \(\.\.\., 3\)"):
        reference.kinematics(np.zeros(3), np.zeros(2))
    with pytest.raises(InputError, match="lengths"):
        reference.kinematics(np.zeros(3), lengths=np.ones(4))
    with pytest.raises(InputError, match="scalar"):
        reference.kinematics(1.0)
    with pytest.raises(InputError, match="finite"):
        reference.kinematics([np.nan, 0.0])
