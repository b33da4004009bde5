"""The rank-revealing Gram-Schmidt of the inverse velocity (``derive.solve6.pivoted_gram_schmidt``), run on
numbers (every step evaluates at once): it reconstructs its vectors in the order taken, its diagonal
decreases, its last residual finds a smallest singular value that row order spreads over two residuals,
and vectors with no common nonzero position are factorised apart."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from skelarm_sym.derive.solve6 import pivoted_gram_schmidt


def _inline(name, expr):
    return expr


def _factor(B, threshold=0.0):
    rows = [[sp.Float(float(x), 30) if x != 0 else sp.S.Zero for x in row] for row in B]  # zeros exact, as derived
    qr, order = pivoted_gram_schmidt(_inline, rows, [(sp.Integer(i),) for i in range(len(B))], "t", sp.Float(threshold))
    return qr, [int(x[0]) for x in order]


def _numeric(qr):
    m = len(qr.Q)
    Q = np.array([[float(x) for x in q] for q in qr.Q])
    R = np.array([[0.0 if qr.R[i][k] is None else float(qr.R[i][k]) for k in range(m)] for i in range(m)])
    return Q, R


def _with_singular_values(rng, values, n):
    m = len(values)
    U, _ = np.linalg.qr(rng.normal(size=(m, m)))
    V, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return U @ np.diag(values) @ V[:m]


@pytest.mark.parametrize("seed", range(5))
def test_it_reconstructs_the_vectors_in_the_order_taken_with_a_decreasing_diagonal(seed):
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(5, 6)) * rng.uniform(0.1, 3, size=(5, 1))
    qr, order = _factor(B)
    Q, R = _numeric(qr)
    assert sorted(order) == list(range(5))
    assert np.allclose(Q @ Q.T, np.eye(5), atol=1e-12)
    assert np.allclose((R.T @ Q), B[order], atol=1e-12)  # vector taken k-th = sum_i R[i][k] Q[i]
    diagonal = np.diag(R)
    assert np.all(diagonal[:-1] >= diagonal[1:] - 1e-12) and np.all(np.triu(R) == R)


def test_the_last_residual_finds_a_near_dependency_that_row_order_spreads():
    """Two nearly parallel rows and a third nearly in their plane (the float Stanford arm's pattern): the
    smallest singular value is 2e-8 of the largest, but in row order the residuals are 5e-5 and 6e-4, both
    above a threshold of 1e-5 |B|, and the direction was kept; taken largest residual first, the last
    residual is the small one and is dropped."""
    e, d = 5e-5, 6e-4
    B = np.array([[1.0, 0.0, 0.0], [1.0, e, 0.0], [0.0, 1.0, d]])
    s = np.linalg.svd(B, compute_uv=False)
    threshold = 1e-5 * np.linalg.norm(B)
    assert s[-1] / s[0] < 3e-8
    in_row_order = np.abs(np.diag(np.linalg.qr(B.T)[1]))  # the residuals of Gram-Schmidt in row order
    assert np.all(in_row_order > threshold) and in_row_order[1:].max() < 1e-3  # the direction kept there
    pivot, order = _factor(B, threshold)
    assert [bool(k) for k in pivot.keep] == [True, True, False]  # pivoted: dropped
    assert abs(float(pivot.R[2][2])) == 0.0 and sorted(order) == [0, 1, 2]


def test_vectors_without_a_common_position_are_factorised_apart():
    """A SCARA's vertical velocity row moves with its prismatic joint alone: its QR is its own block."""
    B = np.array([[0.3, -0.2, 0.0, 0.0], [0.1, 0.4, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [1.0, 1.0, 0.0, 1.0]])
    qr, order = _factor(B)
    Q, R = _numeric(qr)
    assert sorted(order) == [0, 1, 2, 3]
    assert order.index(2) == 3  # the lone row's block comes after the group of the first row
    assert np.allclose((R.T @ Q), B[order], atol=1e-12)
    assert R[0:3, 3].tolist() == [0.0, 0.0, 0.0]  # nothing couples the blocks
    assert qr.R[3][0] is None  # below the diagonal
