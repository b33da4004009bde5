"""Check scenarios for 3-D chains: the NumPy twist-propagation reference is the judge.

Configurations: random joint values (revolute in [-pi, pi], prismatic in [-0.5, 0.5] m), rates
and accelerations in [-2, 2], plus the zero configuration at rest and a configuration with rates
but no accelerations. Named parameters get random values in [0.2, 1.2]. Expected outputs come
from :func:`skelarm_sym.models.chain.reference.chain_kinematics` (seed 001's forward recursion and seed
003's columns), never from the derivation.

Tolerance scaling (``condition``): rounding in a sum scales with its terms, not with the result;
a Jacobian entry sums lever arms up to the chain's reach ``L`` (the sum of its constant
translations and prismatic travel), a rate term ``L |dq|_1``, an acceleration ``L (|dq|_1^2 + |ddq|_1)``.
"""

from __future__ import annotations

import numpy as np

from ... import reference
from ...check.scenario import EPSILONS, Scenario, solve_cutoff, tolerance
from ...check.solver_rows import CHAIN_MAX_ITER, IK_TARGETS, IKCheck, rotation_error, summary
from .reference_inverse import check_expectations
from .solver import SETTINGS


def chain_scenarios(derivation, cases: int, seed: int, precision: str) -> list[Scenario]:
    """Scenarios for a :class:`~skelarm_sym.models.chain.Chain` derivation (see the module docstring)."""
    chain = derivation.model
    n = chain.n
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731 - inputs as the code sees them
    rng = np.random.default_rng(seed)
    prismatic = np.zeros(n, dtype=bool)
    for joint in chain.joints:
        prismatic[joint.coordinate] |= joint.kind == "prismatic"
    span = np.where(prismatic, 0.5, np.pi)
    q = rng.uniform(-1, 1, (cases, n)) * span
    dq = rng.uniform(-2, 2, (cases, n))
    ddq = rng.uniform(-2, 2, (cases, n))
    q = rounded(np.concatenate([q, np.zeros((1, n)), q[:1] if cases else np.zeros((1, n))]))
    dq = rounded(np.concatenate([dq, np.zeros((1, n)), dq[:1] if cases else np.ones((1, n))]))
    ddq = rounded(np.concatenate([ddq, np.zeros((1, n)), np.zeros((1, n))]))
    params = rounded(rng.uniform(0.2, 1.2, len(chain.parameters)))
    numeric = chain.numeric(params if chain.parameters else None)
    k = reference.chain_kinematics(numeric, q, dq, ddq)
    expected = {"T": k.T, "J": k.J, "J_tool": k.J_tool, "dJ": k.dJ, "twist": k.twist, "acc": k.acc}
    transforms = [numeric.base, numeric.tool] + [m for j in numeric.joints for m in (j.before, j.after)]
    reach = sum(float(np.linalg.norm(m[:3, 3])) for m in transforms) + np.sum(np.abs(q) * prismatic, axis=-1) + 1.0
    rate = np.sum(np.abs(dq), axis=-1)
    accel = np.sum(np.abs(ddq), axis=-1)
    sizes = {
        "T": reach, "J": reach, "J_tool": reach, "dJ": reach * (rate + 1), "twist": reach * (rate + 1),
        "acc": reach * (rate**2 + accel + 1),
    }
    condition = {
        name: np.maximum(1.0, size / np.maximum(1.0, np.abs(expected[name]).reshape(len(q), -1).max(axis=-1)))
        for name, size in sizes.items()
    }
    values = {"q": q, "dq": dq, "ddq": ddq}
    if chain.parameters:
        values["params"] = params
    forward, forward_condition, alternatives, solves = check_expectations(
        numeric, q, k, solve_cutoff(precision, n), np.random.default_rng(seed + 1), rounded,
    )
    expected.update(forward)
    condition.update(forward_condition)
    return [Scenario("", values, expected, condition, alternatives, size=n)] + [
        Scenario(label, {**values, **extra}, want, cond, size=n) for label, extra, want, cond in solves
    ]


def chain_ik(derivation, implementations, cases: int, seed: int, precision: str) -> list[IKCheck]:
    """Pose-IK rows of a 3-D chain: for the implementations that have ``ik_solve``."""
    solvers = [(label, getattr(impl, "ik_solve", None)) for label, impl in implementations]
    solvers = [(label, s) for label, s in solvers if s is not None]
    if not solvers:
        return []

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
    tol = SETTINGS[precision]["tol"]
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
                error, rotation = float(np.linalg.norm(target[:3, 3] - T[:3, 3])), rotation_error(T[:3, :3], target[:3, :3])
            else:
                error = rotation = float("inf")
            worst_rotation = max(worst_rotation, rotation)
            good = result.status == "converged" and error <= allowed and rotation <= rotation_allowed
            outcomes.append((str(result.status), error, good))
        rows.append(summary(f"{label} ik_solve", outcomes, tol, allowed, worst_rotation, rotation_allowed))
    return rows
