"""Issue 13 (2): `check` judges the inverse functions by NumPy's SVD, not by the generator's own rank rule."""

import numpy as np
import pytest

from skelarm_sym import reference
from skelarm_sym.check import compare, run_check, solve_cutoff
from skelarm_sym.derive import RANK_TOL
from skelarm_sym.generate import generate

SOLVES = ("inverse_velocity", "inverse_velocity3", "ik_step")


def _failures(results):
    return sorted({r.implementation for r in results if not r.ok})


def test_millimetre_arm_in_float_passes_check_for_the_right_reason():
    """`check --precision float --lengths 500,500,500 --links 3` passed before because its reference dropped
    the same direction as the code; now the reference keeps it, and the code must too."""
    results = run_check(3, lengths=[500.0, 500.0, 500.0], precision="float", cases=60, langs=("c",))
    assert _failures(results) == []
    names = {r.implementation for r in results}
    assert any("inverse_velocity3 [lambda=0*reach]" in x for x in names)


@pytest.mark.parametrize("precision", ["double", "float"])
def test_a_wrong_rank_decision_fails_check(precision, monkeypatch):
    """Generate with a rank tolerance that declares ordinary poses singular: check must say FAIL for
    every undamped solve (and nothing else)."""
    monkeypatch.setitem(RANK_TOL.values, precision, 0.3)
    generated = generate(3, out=None, langs=("c", "python"), precision=precision)
    results = compare(generated, cases=40, precision=precision)
    failed = _failures(results)
    for lang in ("C", "Python"):
        for name in SOLVES:
            assert f"{lang} {name} [lambda=0*reach]" in failed, (lang, name, failed)
    assert all(any(s in f for s in SOLVES) for f in failed), failed


def test_reference_is_numpy_pinv_and_lstsq(rng):
    """The reference itself: pinv with a relative cutoff undamped, the augmented least squares damped."""
    J = rng.normal(size=(50, 3, 5))
    J[:10, 2] = J[:10, 0] * 1e-17  # rank two
    rhs = rng.normal(size=(50, 3))
    cutoff = solve_cutoff("double", 5)
    s = reference.damped_least_squares(J, rhs, 0.0, cutoff)
    for k in range(50):
        np.testing.assert_allclose(s.x[k], np.linalg.pinv(J[k], rcond=cutoff) @ rhs[k], rtol=1e-9, atol=1e-9)
    assert np.all(s.rank[:10] == 2) and np.all(s.rank[10:] == 3)
    d = reference.damped_least_squares(J, rhs, 0.3, cutoff)
    for k in range(50):
        want = np.linalg.lstsq(np.vstack([J[k], 0.3 * np.eye(5)]), np.r_[rhs[k], np.zeros(5)], rcond=None)[0]
        np.testing.assert_allclose(d.x[k], want, rtol=1e-10, atol=1e-12)
    # row scaling changes nothing at full rank, and makes the rank-deficient answer independent of units
    scaled = reference.damped_least_squares(J[10:], rhs[10:], 0.0, cutoff, [1e-3, 1e-3, 1.0])
    np.testing.assert_allclose(scaled.x, s.x[10:], rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("kwargs, message", [
    ({"cases": 0}, "cases must be at least 1, got 0"),  # it returned an empty, passing table
    ({"cases": -1}, "cases must be at least 1"),  # "negative dimensions are not allowed"
    ({"cases": 2.5}, "cases must be a whole number, got 2.5"),
    ({"cases": 10**11}, "cases must be at most 100000, got 100000000000"),  # a traceback: 4.37 TiB
    ({"cases": True}, "cases must be a whole number"),
    ({"seed": "x"}, "seed must be a whole number, got 'x'"),
    ({"seed": -3}, "seed must be at least 0"),
])
def test_run_check_refuses_bad_cases_and_seeds_before_the_work(kwargs, message, monkeypatch):
    import skelarm_sym.check.comparison as comparison

    monkeypatch.setattr(comparison, "generate", lambda *a, **k: pytest.fail("generated before checking its arguments"))
    with pytest.raises(ValueError, match=message):
        run_check(2, **kwargs)
