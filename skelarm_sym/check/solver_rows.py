"""Solver rows of ``check`` (a leaf module the models' ``check.py`` import): each model's iterative solvers against reachable targets, judged by its reference.

A solve counts as converged when the solver says ``converged`` AND the reference, evaluated in double at
the returned ``q``, agrees: the error is at most ``tol`` plus the rounding the check allows the emitted
position (:func:`skelarm_sym.check.scenario.tolerance` times the reach), so a solver that claims success
without reaching the target fails. A solve that ends ``stalled`` (chains) with the reference within that same
allowance passes as well, counted apart: the solver stopped where its precision could not bring the error below
``tol`` (float code on an arm whose rounding floor is near ``tol``: 2 of 20 targets of a random arm stalled at
1.3e-5 against a ``tol`` of 1e-5 and an allowance of 8e-5, a row that failed), while they are at most a quarter
of the targets (a solver whose convergence test never fires still fails). A row fails when any other target
does not converge. The targets and the reference are the model's (``models/<kind>/check.py``).
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
    stalled_within: int = 0
    """Solves that ended ``stalled`` with the reference's error within ``allowed`` (see the module docstring)."""
    worst_rotation: float | None = None
    """Chains: largest rotation error (rad) at the returned poses."""
    rotation_allowed: float | None = None
    """Chains: ``tol`` plus the rounding slack of the rotation (rad)."""

    @property
    def ok(self) -> bool:
        # a quarter at most: a solver whose convergence test never fires (every solve stalled) still fails
        return (self.targets > 0 and self.converged + self.stalled_within == self.targets
                and self.stalled_within <= self.targets // 4)

    def row(self) -> str:
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(self.statuses.items()))
        rotation = "" if self.worst_rotation is None else (
            f", rotation {self.worst_rotation:.2e} rad (allowed {self.rotation_allowed:.2e})")
        capped = self.stalled_within > self.targets // 4
        within = (f" (and {self.stalled_within} stalled within the allowance: the precision's floor near tol"
                  + (f"; more than a quarter of the targets, {self.targets // 4}, may not" if capped else "") + ")"
                  if self.stalled_within else "")
        return (f"{self.implementation}: converged {self.converged}/{self.targets}{within}; worst error {self.worst_error:.2e}"
                f" (allowed {self.allowed:.2e}: tol {self.tol:g} + rounding){rotation}; statuses: {statuses}; "
                f"{'ok' if self.ok else 'FAIL'}")


def summary(label, outcomes, tol, allowed, rotation=None, rotation_allowed=None, stalled_within: int = 0) -> IKCheck:
    """``outcomes``: ``(status, reference error, converged)`` per target; ``stalled_within``: how many of the
    targets not converged ended ``stalled`` within the allowance."""
    errors = [e for _, e, _ in outcomes]
    worst = float(np.max(np.where(np.isnan(errors), np.inf, errors))) if errors else float("nan")
    return IKCheck(label, len(outcomes), sum(1 for *_, c in outcomes if c), worst, tol, allowed,
                   dict(Counter(s for s, _, _ in outcomes)), worst_rotation=rotation, rotation_allowed=rotation_allowed,
                   stalled_within=stalled_within)


def rotation_error(R: np.ndarray, R_target: np.ndarray) -> float:
    """The angle of ``R_target R^T`` by atan2 of its sine and cosine (arccos of the cosine alone loses
    half the digits near 0: one rounding of the trace is an angle of sqrt(2 eps), 2e-8 in double)."""
    E = R_target @ R.T
    s = 0.5 * np.linalg.norm([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
    return float(np.arctan2(s, (np.trace(E) - 1.0) / 2.0))


