"""Closed-form inverse kinematics with all solutions (issue 18, phase 1).

One job per module:

* :mod:`.classify` -- the chain's screw geometry at ``q = 0`` (exact SymPy) and its family
  (spherical wrist, spherical shoulder, three parallel axes), or a one-line reason why none applies;
* :mod:`.subproblems` -- Paden-Kahan / IK-Geo subproblems 1-4 (and a prismatic distance problem) as
  straight-line SymPy steps, branches side by side, special cases as ``Piecewise`` selects;
* :mod:`.families` -- each family's chain of subproblems;
* :mod:`.derive` -- :func:`derive_ik_all`: named steps plus the outputs ``Q`` (S x N) and ``flags`` (S);
* :mod:`.postprocess` -- the post-processing spec in NumPy (2 pi shifts into limits, drop, dedupe,
  status, nearest);
* :mod:`.evaluate` -- the derivation evaluated in NumPy, independent of the IR (:mod:`.numpy_source`: the steps
  printed directly; ``sympy.lambdify`` as its fallback).

Judge: :mod:`skelarm_sym.models.chain.reference_ik_all` (NumPy only, imports nothing from here).
"""

from .classify import ClosedFormError, Family, classify, explain
from .derive import ClosedIK, derive_ik_all
from .postprocess import STATUS, IKAll, nearest, postprocess

__all__ = [
    "ClosedFormError", "Family", "classify", "explain", "ClosedIK", "derive_ik_all",
    "STATUS", "IKAll", "nearest", "postprocess",
]
