"""The emitted IK solvers against reachable targets: one ``check`` row per implementation and solver.

Planar arms (derivations with ``position`` and ``ik_step``, hence an emitted ``ik_solve``):
targets are the reference endpoint positions (:func:`skelarm_sym.reference.kinematics`) of random
configurations, so every one is reachable; starts are random, the first one the stretched pose
``q = 0`` (singular). Each solve runs with the per-precision default ``tol``
(``default_ik_tol``: the per-precision tolerance times the reach), undamped (``lambda = 0``: the solver damps itself), and
``max_iter = 200`` (the default). 3-D chains whose compiled library has the pose IK
(``CompiledArm.ik_solve_pose``, the emitted C ``{prefix}_ik_solve``): targets are reference poses
(:func:`skelarm_sym.reference.chain_kinematics`) of random configurations within the joint limits,
``tol`` the wrapper's default (:data:`skelarm_sym.ik.DEFAULT_TOL`), ``max_iter = CHAIN_MAX_ITER``
(the solver restarts from random poses; each start gets a few dozen steps).

A solve counts as converged when the solver says ``converged`` AND the reference, evaluated in
double at the returned ``q``, agrees: ``|target - p(q)| <= tol + slack``, where ``slack`` is the
rounding the check allows the emitted position (:func:`skelarm_sym.check.tolerance` times the
reach), so a solver that claims success without reaching the target fails. The row fails when
any target does not converge.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from . import reference
from .backends.common import default_ik_tol
from .check import check_cases, tolerance

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


def _summary(label, outcomes, tol, allowed, rotation=None, rotation_allowed=None) -> IKCheck:
    """``outcomes``: ``(status, reference error, converged)`` per target."""
    errors = [e for _, e, _ in outcomes]
    worst = float(np.max(np.where(np.isnan(errors), np.inf, errors))) if errors else float("nan")
    return IKCheck(label, len(outcomes), sum(1 for *_, c in outcomes if c), worst, tol, allowed,
                   dict(Counter(s for s, _, _ in outcomes)), rotation, rotation_allowed)


def planar_ik(derivation, implementations, cases: int, seed: int, precision: str) -> list[IKCheck]:
    """IK rows of a planar arm (nothing when ``ik_solve`` is not emitted)."""
    names = {f.name for f in derivation.functions}
    if not {"position", "ik_step"} <= names:
        return []
    n = derivation.n
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731 - inputs as the code sees them
    l = rounded(check_cases(n, 0, seed, derivation.model.lengths)[3])
    rng = np.random.default_rng(seed + 2)
    m = max(1, min(cases, IK_TARGETS))
    targets = rounded(reference.kinematics(rng.uniform(-np.pi, np.pi, (m, n)), None, None, l).p)
    starts = rounded(rng.uniform(-np.pi, np.pi, (m, n)))
    starts[0] = 0.0  # the stretched pose: singular, the case issue 12 (2) was about
    tol = default_ik_tol(precision, float(l.sum()))
    allowed = tol + tolerance(precision, n) * float(l.sum())
    rows = []
    for label, impl in implementations:
        solve = getattr(impl, "ik_solve", None)
        if solve is None:
            continue
        extra = {"l": l} if "l" in derivation.inputs else {}
        outcomes = []
        for q0, target in zip(starts, targets):
            result = solve(q0, target=target, lambda_=0.0, tol=tol, max_iter=200, **extra)
            q = np.asarray(result.q, dtype=np.float64)
            error = float(np.linalg.norm(target - reference.kinematics(q, None, None, l).p)) if np.all(np.isfinite(q)) else float("inf")
            outcomes.append((str(result.status), error, result.status == "converged" and error <= allowed))
        rows.append(_summary(f"{label} ik_solve", outcomes, tol, allowed))
    return rows


def _rotation_error(R: np.ndarray, R_target: np.ndarray) -> float:
    """The angle of ``R_target R^T`` by atan2 of its sine and cosine (arccos of the cosine alone loses
    half the digits near 0: one rounding of the trace is an angle of sqrt(2 eps), 2e-8 in double)."""
    E = R_target @ R.T
    s = 0.5 * np.linalg.norm([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
    return float(np.arctan2(s, (np.trace(E) - 1.0) / 2.0))


def chain_ik(derivation, implementations, cases: int, seed: int, precision: str) -> list[IKCheck]:
    """Pose-IK rows of a 3-D chain: only for implementations that have ``ik_solve_pose``."""
    solvers = [(label, getattr(impl, "ik_solve_pose", None)) for label, impl in implementations]
    solvers = [(label, s) for label, s in solvers if s is not None]
    if not solvers:
        return []
    from .check import EPSILONS
    from .ik import DEFAULT_TOL

    chain = derivation.model
    n = chain.n
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731
    rng = np.random.default_rng(seed + 2)
    prismatic = np.zeros(n, dtype=bool)
    for joint in chain.joints:
        prismatic[joint.coordinate] |= joint.kind == "prismatic"
    limits = chain.limits()
    span = np.where(prismatic, 0.5, np.pi)
    lower = np.array([-s if v is None else v for v, s in zip(limits["lower"], span)], dtype=float)
    upper = np.array([s if v is None else v for v, s in zip(limits["upper"], span)], dtype=float)
    params = rounded(rng.uniform(0.2, 1.2, len(chain.parameters)))
    numeric = chain.numeric(params if chain.parameters else None)
    m = max(1, min(cases, IK_TARGETS))
    # targets strictly inside the limits (a target on a bound is reachable only exactly there)
    inner = lambda u: lower + (0.05 + 0.9 * u) * (upper - lower)  # noqa: E731
    targets = rounded(reference.chain_kinematics(numeric, inner(rng.uniform(size=(m, n)))).T)
    starts = rounded(inner(rng.uniform(size=(m, n))))
    tol = DEFAULT_TOL[precision]
    reach = float(np.abs(targets[:, :3, 3]).max()) + 1.0
    allowed = tol + tolerance(precision, n) * reach
    rotation_allowed = tol + tolerance(precision, n) + 100 * EPSILONS[precision]
    extra = {"params": params} if chain.parameters else {}
    rows = []
    for label, solve in solvers:
        outcomes, worst_rotation = [], 0.0
        for q0, target in zip(starts, targets):
            result = solve(q0, target, lambda_=0.0, tol=tol, max_iter=CHAIN_MAX_ITER, **extra)
            q = np.asarray(result.q, dtype=np.float64)
            if np.all(np.isfinite(q)):
                T = reference.chain_kinematics(numeric, q).T
                error, rotation = float(np.linalg.norm(target[:3, 3] - T[:3, 3])), _rotation_error(T[:3, :3], target[:3, :3])
            else:
                error = rotation = float("inf")
            worst_rotation = max(worst_rotation, rotation)
            good = result.status == "converged" and error <= allowed and rotation <= rotation_allowed
            outcomes.append((str(result.status), error, good))
        rows.append(_summary(f"{label} ik_solve_pose", outcomes, tol, allowed, worst_rotation, rotation_allowed))
    return rows


def check_ik(generated, implementations, cases: int = 100, seed: int = 0, precision: str = "double") -> list[IKCheck]:
    """IK rows for ``generated`` with its loaded ``implementations`` (``[(label, module)]``); empty
    when the model has no emitted IK solver."""
    from .models.chain import Chain
    from .models.planar import PlanarArm

    derivation = generated.derivation
    if isinstance(derivation.model, PlanarArm):
        return planar_ik(derivation, implementations, cases, seed, precision)
    if isinstance(derivation.model, Chain):
        return chain_ik(derivation, implementations, cases, seed, precision)
    return []
