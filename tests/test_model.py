import math

import pytest

from skelarm_sym import InputError, PlanarArm, derive


@pytest.mark.parametrize("n", [0, -3, 1001, 2.5, "3", None, True])
def test_bad_number_of_links(n):
    with pytest.raises(ValueError, match="number of links"):
        PlanarArm(n)


@pytest.mark.parametrize(
    "lengths, message",
    [
        ((1.0, 2.0), "expected 3 link lengths, got 2"),
        ((1.0, 0.0, 1.0), "l2 must be finite and positive"),
        ((1.0, -1.0, 1.0), "l2 must be finite and positive"),
        ((1.0, 1.0, math.inf), "l3 must be finite and positive"),
        ((1.0, math.nan, 1.0), "l2 must be finite and positive"),
        ((1.0, "x", 1.0), "l2 must be a number"),
        ("1,2,3", "not a string"),
    ],
)
def test_bad_lengths(lengths, message):
    with pytest.raises(InputError, match=message):
        PlanarArm(3, lengths)
    with pytest.raises(ValueError, match=message):
        derive(3, lengths)


def test_model_is_immutable_and_normalised():
    arm = PlanarArm(2.0, [1, 0.5])
    assert arm.n == 2 and arm.lengths == (1.0, 0.5)
    with pytest.raises(AttributeError):
        arm.n = 3
