"""The two Float queries answered from the number while a chain is derived
(:func:`skelarm_sym.derive.float_facts.float_facts`): the same answers as SymPy's own deduction, SymPy's
behaviour back on leaving (also after an error, and only when the outermost of nested uses ends), and a chain
derived with them gives the same steps and outputs as one derived without."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import sympy as sp

from skelarm_sym.derive.float_facts import float_facts
from skelarm_sym.models.chain import derive as chain_derive
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]
VALUES = [0.0, -0.0, 1.5, -2.25, 1e-300, -1e-300, 5e-324, math.inf, -math.inf, math.nan, 3.0, -7.0]
QUERIES = ("is_zero", "is_extended_negative")


def _answers() -> list[tuple]:
    # a new Float each time: SymPy keeps the facts it deduced on the object
    return [(v, q, getattr(sp.Float(v), q)) for v in VALUES for q in QUERIES]


def test_answers_are_sympys_and_sympy_is_back_on_leaving():
    plain = _answers()
    assert (0.0, "is_zero", True) in plain and (-math.inf, "is_extended_negative", True) in plain
    with float_facts():
        fast = _answers()
        assert "is_zero" in sp.Float.__dict__  # the direct answers are in place
    assert [a[2] for a in fast] == [a[2] for a in plain]
    assert "is_zero" not in sp.Float.__dict__ and "is_extended_negative" not in sp.Float.__dict__
    assert _answers() == plain


def test_nested_uses_restore_once_and_an_error_restores_too():
    with float_facts():
        with float_facts():
            pass
        assert "is_zero" in sp.Float.__dict__  # the outer use is still on
    assert "is_zero" not in sp.Float.__dict__
    with pytest.raises(RuntimeError):
        with float_facts():
            raise RuntimeError("inside")
    assert "is_zero" not in sp.Float.__dict__


@pytest.mark.fresh_derivation
def test_a_chain_derived_with_them_is_the_chain_derived_without():
    chain = load_robot(ROOT / "tests" / "fixtures" / "robots" / "ur_like.urdf")  # Float offsets and rotations
    fast = chain_derive.derive_chain(chain, inverse=False)
    plain = chain_derive._derive_chain(chain, inverse=False)  # the same code, SymPy's own queries
    assert "is_zero" not in sp.Float.__dict__
    assert [str(s) for s in fast.steps] == [str(s) for s in plain.steps] and len(fast.steps) > 50
    assert {k: str(v) for k, v in fast.compact.items()} == {k: str(v) for k, v in plain.compact.items()}
    assert fast.variants == plain.variants
