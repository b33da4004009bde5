"""Solver rows of ``check`` (a leaf module the models' ``check.py`` import): each model's iterative solvers against reachable targets, judged by its reference.

A solve counts as converged when the solver says ``converged`` AND the reference, evaluated in double at
the returned ``q``, agrees: the error is at most ``tol`` plus the rounding the check allows the emitted
position (:func:`skelarm_sym.check.scenario.tolerance` times the reach), so a solver that claims success
without reaching the target fails. A row fails when any target does not converge. The targets and the
reference are the model's (``models/<kind>/check.py``).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np


IK_TARGETS = 20
"""At most this many targets per solver (``check --cases`` caps it further)."""
CHAIN_MAX_ITER = 1000


@dataclass(frozen=True)
class IKCheck:
    """Outcome of one implementation's IK solver on the check's reachable targets."""

    implementation: str
    """e.g. ``"C ik_solve"``."""
    targets: int
    converged: int
    """Solves that ended ``converged`` with the reference agreeing (see the module docstring)."""
    worst_error: float
    """Largest reference error ``|target - p(q)|`` at the returned poses (for chains: position, m)."""
    tol: float
    allowed: float
    """``tol`` plus the rounding slack the reference comparison allows."""
    statuses: dict = field(default_factory=dict)
    """Status name -> count, as the solver reported them."""
    worst_rotation: float | None = None
    """Chains: largest rotation error (rad) at the returned poses."""
    rotation_allowed: float | None = None
    """Chains: ``tol`` plus the rounding slack of the rotation (rad)."""

    @property
    def ok(self) -> bool:
        return self.targets > 0 and self.converged == self.targets

    def row(self) -> str:
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(self.statuses.items()))
        rotation = "" if self.worst_rotation is None else (
            f", rotation {self.worst_rotation:.2e} rad (allowed {self.rotation_allowed:.2e})")
        return (f"{self.implementation}: converged {self.converged}/{self.targets}; worst error {self.worst_error:.2e}"
                f" (allowed {self.allowed:.2e}: tol {self.tol:g} + rounding){rotation}; statuses: {statuses}; "
                f"{'ok' if self.ok else 'FAIL'}")


def summary(label, outcomes, tol, allowed, rotation=None, rotation_allowed=None) -> IKCheck:
    """``outcomes``: ``(status, reference error, converged)`` per target."""
    errors = [e for _, e, _ in outcomes]
    worst = float(np.max(np.where(np.isnan(errors), np.inf, errors))) if errors else float("nan")
    return IKCheck(label, len(outcomes), sum(1 for *_, c in outcomes if c), worst, tol, allowed,
                   dict(Counter(s for s, _, _ in outcomes)), rotation, rotation_allowed)


def rotation_error(R: np.ndarray, R_target: np.ndarray) -> float:
    """The angle of ``R_target R^T`` by atan2 of its sine and cosine (arccos of the cosine alone loses
    half the digits near 0: one rounding of the trace is an angle of sqrt(2 eps), 2e-8 in double)."""
    E = R_target @ R.T
    s = 0.5 * np.linalg.norm([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
    return float(np.arctan2(s, (np.trace(E) - 1.0) / 2.0))


