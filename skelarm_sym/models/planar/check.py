"""Check scenarios and solver rows for planar arms: the recursive reference and NumPy linear algebra judge."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ... import reference
from ...check.scenario import DAMPINGS, Scenario, solve_cutoff, tolerance
from ...check.solver_rows import IK_TARGETS, IKCheck, summary
from .solver import default_tol

def check_cases(n: int, cases: int, seed: int = 0, lengths: Sequence[float] | None = None):
    """Random configurations plus singular (stretched, folded) and zero-velocity ones.

    Returns ``(q, dq, ddq, l)`` with ``q`` etc. of shape ``(m, n)``, ``l`` ``(n,)``.
    """
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (cases, n))
    dq = rng.uniform(-np.pi, np.pi, (cases, n))
    ddq = rng.uniform(-np.pi, np.pi, (cases, n))
    folded = np.zeros(n)
    folded[1:] = np.pi
    special_q = np.stack([np.zeros(n), folded, q[0] if cases else np.zeros(n)])
    special_dq = np.stack([dq[0] if cases else np.ones(n), np.zeros(n), np.zeros(n)])
    special_ddq = np.stack([np.zeros(n), ddq[0] if cases else np.ones(n), np.zeros(n)])
    l = np.asarray(lengths, dtype=float) if lengths is not None else rng.uniform(0.2, 2.0, n)
    return (np.concatenate([q, special_q]), np.concatenate([dq, special_dq]), np.concatenate([ddq, special_ddq]), l)


def planar_scenarios(derivation, cases: int, seed: int, precision: str) -> list[Scenario]:
    """Scenarios for a planar arm: forward outputs from the recursion, solves from NumPy linear algebra."""

    n = derivation.n
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731 - inputs as the code sees them
    q, dq, ddq, l = (rounded(x) for x in check_cases(n, cases, seed, derivation.model.lengths))
    m = len(q)
    rng = np.random.default_rng(seed + 1)
    reach = float(l.sum())
    # commanded velocities of the arm's own size (lengths per second), so errors in dq are relative to O(1)
    v = rounded(rng.uniform(-1, 1, (m, 2)) * reach)
    twist = rounded(rng.uniform(-1, 1, (m, 3)) * [reach, reach, 1.0])
    k = reference.kinematics(q, dq, ddq, l)
    reachable = reference.kinematics(rng.uniform(-np.pi, np.pi, (m, n)), None, None, l).p
    target = rounded(np.where(rng.uniform(size=(m, 1)) < 0.5, reachable, rng.uniform(-1.2 * reach, 1.2 * reach, (m, 2))))
    values = {"q": q, "dq": dq, "ddq": ddq, "l": l, "v": v, "twist": twist, "target": target}
    forward = {"p": k.p, "J": k.J, "H": k.H, "v": k.v, "a": k.a, "w": reference.manipulability(k.J)[:, None]}
    # Rounding in a sum scales with the sum of its terms' sizes, not with the result, which can cancel:
    # compare each output with the natural size of its terms.
    rates = np.abs(np.cumsum(dq, axis=-1))
    accels = np.abs(np.cumsum(ddq, axis=-1))
    sizes = {
        "p": np.full(m, reach),
        "J": np.full(m, reach),
        "H": (l * rates).sum(axis=-1),
        "v": (l * rates).sum(axis=-1),
        "a": (l * (rates**2 + accels)).sum(axis=-1),
        "w": np.sum(k.J**2, axis=(-2, -1)),  # a product of two lengths of J's rows
    }
    condition = {
        name: np.maximum(1.0, size / np.maximum(1.0, np.abs(forward[name]).reshape(m, -1).max(axis=-1)))
        for name, size in sizes.items()
    }
    scenarios = [Scenario("", values, forward, condition, size=n)]
    rcond = solve_cutoff(precision, n)
    D3 = np.array([1.0 / reach, 1.0 / reach, 1.0])  # the orientation row against lengths measured in reaches
    for lam in DAMPINGS:
        lam_run = float(rounded(lam * reach))  # lambda is a length: damp in proportion to the arm
        solves = {
            "dq": reference.damped_least_squares(k.J, v, lam_run, rcond),
            "q_next": reference.damped_least_squares(k.J, target - k.p, lam_run, rcond),
        }
        if "twist" in derivation.inputs:
            solves["dq3"] = reference.damped_least_squares(k.J3, twist, lam_run, rcond, D3)
        expected = {name: s.x for name, s in solves.items()}
        expected["q_next"] = q + expected["q_next"]
        condition = {name: s.condition for name, s in solves.items()}
        scenarios.append(Scenario(f"lambda={lam:g}*reach", {**values, "lambda": lam_run}, expected, condition, size=n))
    return scenarios


def planar_ik(derivation, implementations, cases: int, seed: int, precision: str) -> list[IKCheck]:
    """IK rows of a planar arm (nothing when ``ik_solve`` is not emitted)."""
    n = derivation.n
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731 - inputs as the code sees them
    l = rounded(check_cases(n, 0, seed, derivation.model.lengths)[3])
    rng = np.random.default_rng(seed + 2)
    m = max(1, min(cases, IK_TARGETS))
    targets = rounded(reference.kinematics(rng.uniform(-np.pi, np.pi, (m, n)), None, None, l).p)
    starts = rounded(rng.uniform(-np.pi, np.pi, (m, n)))
    starts[0] = 0.0  # the stretched pose: singular, the case issue 12 (2) was about
    tol = default_tol(precision, float(l.sum()))
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
        rows.append(summary(f"{label} ik_solve", outcomes, tol, allowed))
    return rows
