"""Singularities of the planar chain in closed form: Jacobian minors, det J, manipulability.

Every 2 x 2 minor of the planar Jacobian has a short closed form. With
``j_k = sum_{a >= k} l_a (-sin theta_a, cos theta_a)``, the minor of columns ``i < j`` is

    m_ij = jx_i jy_j - jx_j jy_i = sum_{a = i}^{j-1} sum_{b >= j} l_a l_b sin(theta_b - theta_a)

(the pairs with both ``a, b >= j`` cancel), and ``theta_b - theta_a = q_{a+1} + ... + q_b``.
From the minors, without any trigonometric simplification:

* ``det J = m_12`` for n = 2 (``l1 l2 sin q2``, seed 002);
* ``det J3 = m_12 - m_13 + m_23`` for n = 3 (expanding along the row of ones; ``l1 l2 sin q2``);
* ``det(J J^T) = sum_{i<j} m_ij^2`` for any n (Cauchy-Binet), so ``w = sqrt(sum m_ij^2)``.

The tests compare these with ``Derivation.J`` expanded, and numerically with the reference.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import sympy as sp

from ...derive.core import Derivation


def minor(derivation: Derivation, i: int, j: int) -> sp.Expr:
    """``m_ij``, the minor of Jacobian columns ``i < j`` (1-based, as in the seeds)."""
    if not 1 <= i < j <= derivation.n:
        raise ValueError(f"need 1 <= i < j <= {derivation.n}, got {i}, {j}")
    q, l = derivation.q, derivation.l
    return sp.Add(*[
        l[a - 1] * l[b - 1] * sp.sin(sp.Add(*q[a:b]))
        for a in range(i, j)
        for b in range(j, derivation.n + 1)
    ])


def determinant(derivation: Derivation) -> sp.Expr | None:
    """``det J`` where the Jacobian is square: J (2 x 2) for n = 2, J3 (3 x 3) for n = 3; else ``None``."""
    if derivation.n == 2:
        return minor(derivation, 1, 2)
    if derivation.n == 3:
        return sp.expand(minor(derivation, 1, 2) - minor(derivation, 1, 3) + minor(derivation, 2, 3))
    return None


def manipulability(derivation: Derivation) -> sp.Expr:
    """``w = sqrt(det(J J^T)) = sqrt(sum_{i<j} m_ij^2)``; 0 for one link (J has one column)."""
    n = derivation.n
    if n == 2:
        return sp.Abs(minor(derivation, 1, 2))
    return sp.sqrt(sp.Add(*[minor(derivation, i, j) ** 2 for i in range(1, n + 1) for j in range(i + 1, n + 1)]))


@dataclass(frozen=True)
class Singularities:
    """Singular configurations: a readable statement plus the solution sets SymPy found."""

    statement: str
    solutions: dict[str, sp.Set]


def singular_configurations(derivation: Derivation) -> Singularities:
    """Where the Jacobian loses rank, solved by SymPy where it can be.

    n = 2 and n = 3: ``det J = 0`` (``det J3 = 0``) solved for each joint angle over
    ``(-pi, pi]`` (one turn: ``-pi`` is the pose ``pi``). Any n >= 2: ``w = 0`` holds on the family ``q2, ..., qn`` in
    ``{0, pi}`` (every link on one line), verified here by substituting each member
    into every minor (for n <= 8; 2^(n-1) members). Special length ratios (a link
    folding back onto an equal one) add further singular poses.
    """
    n = derivation.n
    q = derivation.q
    interval = sp.Interval.Lopen(-sp.pi, sp.pi)  # one turn, each pose once (-pi is pi), as the w line lists them
    if n == 1:
        return Singularities("n = 1: J has one column, so rank J < 2 everywhere (w = 0).", {})
    solutions: dict[str, sp.Set] = {}
    lines = []
    det = determinant(derivation)
    if det is not None:
        for qk in q:
            if det.has(qk):
                solutions[str(qk)] = sp.solveset(det, qk, interval)
        which = "J" if n == 2 else "J3"
        found = ", ".join(f"{k} in {sp.sstr(v)}" for k, v in solutions.items())
        lines.append(f"det {which} = {sp.sstr(det)} = 0 where {found}.")
    members = [dict(zip(q[1:], signs)) for signs in product((0, sp.pi), repeat=n - 1)] if n <= 8 else []
    verified = all(
        minor(derivation, i, j).xreplace(m) == 0 for m in members for i in range(1, n + 1) for j in range(i + 1, n + 1)
    )
    family = ", ".join(str(x) for x in q[1:])
    if members and verified:
        lines.append(f"w = 0 (rank J < 2) for {family} each in {{0, pi}}: all links on one line "
                     f"(checked on all {len(members)} such poses).")
    else:
        lines.append(f"w = 0 (rank J < 2) for {family} each in {{0, pi}}: all links on one line.")
    return Singularities("\n".join(lines), solutions)
