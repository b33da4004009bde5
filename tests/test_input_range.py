"""A finite number beyond the range of a float module's precision is named as such: a float64 1e39 given
to a float32 function said "q must be finite", which it is."""

from __future__ import annotations

import numpy as np
import pytest

from skelarm_sym.generate import generate


@pytest.fixture(scope="module")
def arm_float():
    return generate(3, lengths=(1.0, 0.8, 0.5), precision="float", out=None, langs="c,python", functions="position")


def _implementations(generated):
    from skelarm_sym.check import load_implementations

    return dict(load_implementations(generated))


@pytest.mark.parametrize("label", ["C", "Python"])
def test_a_float64_beyond_float32_is_refused_by_name(arm_float, label):
    position = _implementations(arm_float)[label].position
    for q in (np.array([1e39, 0.0, 0.0]), np.array([[0.0, 0.0, 0.0], [0.0, -2e39, 0.0]])):
        with pytest.raises(ValueError, match=r"q holds -?[12]e\+39, beyond the range of float32 \(\|x\| <= 3\.40282e\+38\)"):
            position(q)
    with pytest.raises(ValueError, match="q must be finite"):
        position(np.array([np.inf, 0.0, 0.0]))
    edge = np.array([3.4e38, 0.0, 0.0])  # within float32: computed (sin and cos of a huge angle are finite)
    assert np.all(np.isfinite(position(edge)))
    assert np.allclose(position(np.array([0.0, 0.0, 0.0])), [2.3, 0.0])



@pytest.mark.parametrize("label", ["C", "Python"])
def test_python_ints_beyond_int64_are_numbers(arm_float, label):
    """``position([10**40, 0, 0])`` said "q must hold real numbers, got object": they are numbers, out of range here."""
    position = _implementations(arm_float)[label].position
    with pytest.raises(ValueError, match=r"q holds 1e\+40, beyond the range of float32"):
        position([10**40, 0, 0])
    with pytest.raises(ValueError, match="q holds a number beyond the range of float64"):
        position([10**400, 0, 0])
    with pytest.raises(ValueError, match="q must hold real numbers, got object"):
        position([1.0, None, 0])
    assert np.allclose(position([2**70 * 0, 0, 0]), [2.3, 0.0])


def test_a_double_module_takes_a_huge_python_int_as_its_float():
    generated = generate(2, lengths=(1.0, 0.5), out=None, langs="c,python", functions="position")
    for label, implementation in _implementations(generated).items():
        expected = implementation.position(np.array([float(10**40), 0.0]))
        np.testing.assert_array_equal(implementation.position([10**40, 0]), expected, err_msg=label)
