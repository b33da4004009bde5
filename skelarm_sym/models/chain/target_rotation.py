"""The test that a pose target's rotation part is a rotation, written once in the IR for ``ik_solve`` and ``ik_all``.

A target ``T`` (4 x 4, row-major, base frame) is refused (``IK_INVALID``) when its upper-left 3 x 3 ``R`` is not a
rotation: an entry of the Gram matrix ``R^T R`` off the identity by more than ``IK_ORTHO_TOL`` (1e-6; float 1e-4,
so data rounded to float32 passes in double), or ``det R <= 0`` (a reflection). Neither solver can reach such a
target: the closed form would return rows for some other rotation, and the iterative solver's rotation error
``log3(R_t R^T)`` is meaningless off SO(3).

Imports neither NumPy nor the closed-form IK: the forward-only generation path loads this module.
"""

from __future__ import annotations

import sympy as sp

from ...derive.core import Constant
from ...ir.build import Body, fabs
from ...ir.nodes import Call1, NamedConst

ORTHO_TOL = 1e-6
"""Largest ``|R^T R - I|`` entry accepted as a rotation (double precision)."""
ORTHO_TOL_FLOAT = 1e-4
"""The same in float precision (float32 rounding of a rotation is about 1e-7, products of it 1e-6)."""

ORTHO_CONSTANT = Constant(
    sp.Symbol("IK_ORTHO_TOL"), {"double": ORTHO_TOL, "float": ORTHO_TOL_FLOAT},
    "ik_solve and ik_all refuse a target whose |R^T R - I| exceeds this anywhere (or whose det R <= 0)",
)
"""The module constant of :func:`rotation_faults` (emitted only where a function uses it)."""

NOT_A_ROTATION = "rotation part not a rotation (|R^T R - I| > IK_ORTHO_TOL or det R <= 0)"
"""How a status's meaning names the refusal."""


def refusal(precision: str, translation: bool = False, lock_max: float | None = None) -> str:
    """The error a Python caller gets for ``IK_INVALID`` once its arguments have passed their checks (finite,
    shapes, ranges): the rotation test, and for ``ik_all`` / ``ik_nearest`` (``translation``) the translation's
    bound, and (``lock_max``, an arm with a locked joint) the lock's, which Python does not test first."""
    tol = ORTHO_TOL if precision == "double" else ORTHO_TOL_FLOAT
    rotation = f"its rotation part is not a rotation (|R^T R - I| above IK_ORTHO_TOL = {tol:g}, or det R <= 0)"
    if translation:
        lock = "" if lock_max is None else f"; or the lock is beyond IK_LOCK_MAX = {lock_max:g} in magnitude"
        return (f"the target is refused: {rotation}, or a translation entry is beyond IK_TRANSLATION_MAX (no arm "
                f"reaches it){lock}")
    return f"the target is refused: {rotation}"


def rotation_faults(b: Body, target) -> list:
    """The IR conditions that refuse ``target`` (16 entries, row-major) as not a rotation, with ``m{i}{j}`` (the
    Gram matrix's upper triangle) and ``det`` declared in ``b``: the Gram matrix's trace not finite (one test for
    R's nine entries being finite: an entry above 1e154 makes it infinite, and is off the identity anyway), an
    entry off the identity by more than ``IK_ORTHO_TOL``, ``det R`` not positive. Any true: refuse."""
    R = [[target[4 * i + j] for j in range(3)] for i in range(3)]
    gram = {}
    for i in range(3):
        for j in range(i, 3):
            gram[i, j] = b.let(f"m{i}{j}", R[0][i] * R[0][j] + R[1][i] * R[1][j] + R[2][i] * R[2][j])
    det = b.let("det", R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1])
                - R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0])
                + R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]))
    tol = NamedConst("IK_ORTHO_TOL")
    faults = [~Call1("isfinite", gram[0, 0] + gram[1, 1] + gram[2, 2])]
    faults += [fabs(gram[i, j] - 1.0 if i == j else gram[i, j]) > tol for i in range(3) for j in range(i, 3)]
    faults.append(~(det > 0.0))
    return faults
