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

from dataclasses import dataclass

import numpy as np

from ... import reference
from ...check.scenario import EPSILONS, Scenario, solve_cutoff, tolerance
from ...check.solver_rows import CHAIN_MAX_ITER, IK_TARGETS, IKCheck, rotation_error, summary
from .reference_ik_all import missing, multistart_ik_each, pose_error, revolute_mask, same
from .reference_inverse import check_expectations
from .solver import SETTINGS

CANDIDATE_CASES = 50
"""At most this many targets for ``ik_candidates`` (its scenario)."""
CLOSED_TARGETS = 20
"""At most this many targets for the ``ik_all`` / ``ik_nearest`` rows."""
COMPLETE_TARGETS = 3
"""Targets on which the returned set is compared with the judge's 200-start numeric IK (0.3 s each)."""
LOCK_VALUE = 0.3
"""The locked joint's value in the candidates' scenario (rad or m); the rows use each target's own."""
FOUND_TOL = {"double": 1e-6, "float": 3e-3}
"""A known solution (the configuration a target was made from, the judge's) counts as returned when a row is
this close (rad or m, revolute modulo 2 pi): far below the distance between distinct solutions, far above the
rounding of an ill-conditioned one."""


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
        numeric, q, k, solve_cutoff(precision, n), np.random.default_rng(seed + 1), rounded, EPSILONS[precision],
    )
    expected.update(forward)
    condition.update(forward_condition)
    closed = [candidates_scenario(derivation, cases, seed, precision)] if "Q" in derivation.compact else []
    if "M" in derivation.compact:
        closed.append(members_scenario(derivation, cases, seed, precision))
    return [Scenario("", values, expected, condition, alternatives, size=n)] + [
        Scenario(label, {**values, **extra}, want, cond, second, size=n,
                 alternative_condition={k: v / tolerance(precision, n) for k, v in second_cond.items()})
        for label, extra, want, cond, second, second_cond in solves
    ] + closed


def chain_ik(derivation, implementations, cases: int, seed: int, precision: str) -> list:
    """Solver rows of a 3-D chain: ``ik_solve`` and ``ik_solve_position`` (:func:`pose_rows`) and the
    closed-form IK (:func:`closed_rows`)."""
    return (pose_rows(derivation, implementations, cases, seed, precision)
            + closed_rows(derivation, implementations, cases, seed, precision))


NUMERIC_SOLVERS = (("ik_solve", True), ("ik_solve_position", False))
"""The iterative solvers :func:`pose_rows` checks, each with whether its target is a whole pose (4 x 4) or
only the tool origin (3)."""


def pose_rows(derivation, implementations, cases: int, seed: int, precision: str) -> list[IKCheck]:
    """Rows of the iterative IK of a 3-D chain, for the implementations that have ``ik_solve`` or
    ``ik_solve_position``: targets are poses of random configurations strictly inside the limits, starts
    other such configurations; a problem passes when the solver says ``converged`` (or ``stalled``: the
    precision's floor, :mod:`skelarm_sym.check.solver_rows`) and the reference's pose of its answer
    (:func:`reference.chain_kinematics`) is within the allowed distance of the target (and, for ``ik_solve``,
    its rotation within the allowed angle)."""
    solvers = [(label, name, whole, getattr(impl, name, None))
               for name, whole in NUMERIC_SOLVERS for label, impl in implementations]
    solvers = [(label, name, whole, s) for label, name, whole, s in solvers if s is not None]
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
    lower, upper = one_turn(lower, upper, ~prismatic)
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
    for label, name, whole, solve in solvers:
        outcomes, worst_rotation, stalled_within = [], 0.0, 0
        for q0, target in zip(starts, targets):
            result = solve(q0, target if whole else target[:3, 3], lambda_=0.0, tol=tol, max_iter=CHAIN_MAX_ITER, **extra)
            q = np.asarray(result.q, dtype=np.float64)
            if np.all(np.isfinite(q)):
                T = reference.chain_kinematics(numeric, q).T
                error = float(np.linalg.norm(target[:3, 3] - T[:3, 3]))
                rotation = rotation_error(T[:3, :3], target[:3, :3]) if whole else 0.0
            else:
                error = rotation = float("inf")
            worst_rotation = max(worst_rotation, rotation)
            within = error <= allowed and rotation <= rotation_allowed
            stalled_within += str(result.status) == "stalled" and within
            outcomes.append((str(result.status), error, result.status == "converged" and within))
        rows.append(summary(f"{label} {name}", outcomes, tol, allowed, worst_rotation if whole else None,
                            rotation_allowed if whole else None, stalled_within=stalled_within))
    return rows


# -- closed-form IK ---------------------------------------------------------------------------------------------

def _lock_coordinate(chain) -> int | None:
    from .lock import ik_lock, lock_index

    index = lock_index(chain, ik_lock(chain))
    return None if index is None else chain.joints[index].coordinate


def one_turn(lower: np.ndarray, upper: np.ndarray, revolute: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The range configurations are drawn from: a revolute joint whose limits span more than a turn gets the turn
    nearest zero within them (a URDF's +-1e16 for a joint without limits: angles of 1e15 rad carry no digits);
    the others their limits."""
    wide = revolute & (upper - lower > 2 * np.pi)
    centre = np.minimum(np.maximum(0.0, lower + np.pi), upper - np.pi)
    return np.where(wide, centre - np.pi, lower), np.where(wide, centre + np.pi, upper)


def _limits(chain) -> tuple[np.ndarray, np.ndarray]:
    limits = chain.limits()
    lower = np.array([-np.inf if v is None else v for v in limits["lower"]], dtype=float)
    upper = np.array([np.inf if v is None else v for v in limits["upper"]], dtype=float)
    return lower, upper


def _condition(numeric, rows: np.ndarray, free: np.ndarray, length: float) -> float:
    """The largest condition number of the 6 x 6 Jacobians (linear rows in reaches) at ``rows``: rounding of the
    target reaches the joints amplified this much."""
    if not len(rows):
        return 1.0
    J = reference.chain_kinematics(numeric, rows).J[..., :, free]
    J = np.concatenate([J[..., :3, :] / length, J[..., 3:, :]], axis=-2)
    s = np.linalg.svd(J, compute_uv=False)
    return float(np.max(s[..., 0] / np.maximum(s[..., -1], 1e-300)))


@dataclass
class _Targets:
    """Random configurations ``q`` (m, N) and their poses ``targets`` (m, 16) as the code sees them in its precision,
    the inputs ``values`` (``target``, and ``lock`` for a locked chain), the lock's value, the free coordinates
    (``free``: all but the lock) and a length scale for :func:`_condition`."""

    q: np.ndarray
    targets: np.ndarray
    values: dict
    lock_value: float | None
    free: np.ndarray
    length: float


def _targets(chain, seed: int, cases: int, precision: str, aligned: int | None = None) -> _Targets:
    """At most :data:`CANDIDATE_CASES` random configurations (revolute joints in [-pi, pi], prismatic ones in [-0.5,
    0.5] m; a locked joint at :data:`LOCK_VALUE`; coordinate ``aligned`` at 0 in the first half, pi in the rest) and
    their poses, rounded to ``precision``."""
    n = chain.n
    dtype = np.float64 if precision == "double" else np.float32
    rng = np.random.default_rng(seed)
    m = max(1, min(cases, CANDIDATE_CASES))
    q = np.where(revolute_mask(chain), rng.uniform(-np.pi, np.pi, (m, n)), rng.uniform(-0.5, 0.5, (m, n)))
    if aligned is not None:
        q[:, aligned] = np.where(np.arange(m) < (m + 1) // 2, 0.0, np.pi)
    lock = _lock_coordinate(chain)
    values: dict = {}
    lock_value = None
    free = np.ones(n, bool)
    if lock is not None:
        lock_value = float(np.asarray(LOCK_VALUE, dtype=dtype))
        q[:, lock] = lock_value
        values["lock"] = lock_value
        free[lock] = False
    targets = np.asarray(reference.chain_kinematics(chain.numeric(), q).T.reshape(m, 16), dtype=dtype).astype(np.float64)
    values["target"] = targets
    return _Targets(q, targets, values, lock_value, free, float(np.abs(targets[:, [3, 7, 11]]).max()) + 1.0)


def members_scenario(derivation, cases: int, seed: int, precision: str) -> Scenario:
    """``ik_continuum_members`` on poses of random configurations, ``q_ref`` the configurations themselves;
    expected: the same steps evaluated by SymPy (lambdify, double). A UR's (the aligned wrist's members): the wrist
    aligned (joint 5 at 0 for the first half, pi for the rest; in double: a float target is aligned only to float's
    rounding, where the wrist's split test and so the rows depend on that rounding, so float takes the configurations
    as drawn), its condition per case the Jacobian condition number at the configuration without joint 6, which turns
    with phi at the aligned wrist (:func:`_condition`). A spherical wrist's (the wrist centre on axis 1 at q_ref's
    q1): the configurations as drawn, the rows at the reference's own q1, its condition the whole Jacobian's."""
    from ...closed_ik.evaluate import lambdify_members_of

    chain = derivation.model
    wrist = derivation.function("ik_continuum_members").wrist
    t = _targets(chain, seed + 4, cases, precision, wrist[0] if wrist and precision == "double" else None)
    dtype = np.float64 if precision == "double" else np.float32
    q = np.asarray(t.q, dtype=dtype).astype(np.float64)
    M, mflags = lambdify_members_of(derivation)(q, t.targets, t.lock_value)
    free = t.free.copy()
    if wrist:
        free[wrist[1]] = False
    condition = np.array([_condition(chain.numeric(), q[i:i + 1], free, t.length) for i in range(len(q))])
    return Scenario("ik continuum members", {"q_ref": q, **t.values}, {"M": M, "mflags": mflags},
                    {"M": np.maximum(1.0, condition), "mflags": np.ones(len(q))}, size=chain.n)


def candidates_scenario(derivation, cases: int, seed: int, precision: str) -> Scenario:
    """``ik_candidates`` on poses of random configurations (:func:`_targets`), expected: the same steps evaluated by
    SymPy (lambdify, double arithmetic) with the tolerances of ``precision``; in float the decisions at the
    double tolerances are a second answer (a float double root of q1 1.3e-3 apart, Stanford arm, seed 2, is
    flagged singular, as the float tolerance says, where double's keeps the roots apart), and the steps from
    the target in float32 a third (decisions at a branch's reach limit as float arithmetic takes them). Its condition per
    case: the largest Jacobian condition number over the rows double calls regular (:func:`_condition`)."""
    from ...closed_ik.evaluate import lambdify_candidates

    chain = derivation.model
    t = _targets(chain, seed + 3, cases, precision)
    candidates = lambdify_candidates(derivation, precision)
    Q, flags = candidates(t.targets, t.lock_value)
    second = {}
    Q2, flags2 = Q, flags
    if precision != "double":  # near a tolerance the float code may decide as double would (its rounding either side)
        Q2, flags2 = lambdify_candidates(derivation)(t.targets, t.lock_value)
        # or as float arithmetic does: a target at a branch's reach limit that float's rounding puts beyond it
        # (a random spherical shoulder, seed 31011: the C flagged all 8 rows least squares where both double
        # evaluations keep 4 exact)
        Q3, flags3 = candidates(t.targets, t.lock_value, dtype=np.float32)
        second = {"Q": (Q2, Q3), "flags": (flags2, flags3)}
    # conditioned by the rows double calls regular: a near-double root that float flags is still as ill-conditioned
    condition = np.array([_condition(chain.numeric(), Q2[i][flags2[i] == 0], t.free, t.length) for i in range(len(Q))])
    return Scenario("ik candidates", t.values, {"Q": Q, "flags": flags},
                    {"Q": np.maximum(1.0, condition), "flags": np.ones(len(Q))}, second, size=chain.n)


class ClosedCheck:
    """One implementation's ``ik_all`` and ``ik_nearest`` on reachable targets, judged by the reference: every
    row reproduces the target (pose error of :func:`~.reference_ik_all.pose_error` at most ``allowed``), lies
    within the limits, is no duplicate; the configuration the target was made from is among the rows, and
    ``ik_nearest`` from it returns it; on a few targets every solution of the judge's 200-start numeric IK that
    fits the limits is among the rows."""

    def __init__(self, implementation: str, targets: int, allowed: float, has_all: bool = True,
                 has_nearest: bool = True, has_weighted: bool = False) -> None:
        self.implementation = implementation
        self.has_all, self.has_nearest = has_all, has_nearest  # which of them the generation emitted
        self.has_weighted = has_weighted
        self.weighted = 0
        self.targets = targets
        self.allowed = allowed
        self.solutions: list[int] = []
        self.worst = 0.0
        self.failures: list[str] = []
        self.statuses: dict[str, int] = {}
        self.found = 0
        self.nearest = 0
        self.complete = 0
        self.compared = 0

    def fail(self, text: str) -> None:
        if len(self.failures) < 3:
            self.failures.append(text)
        else:
            self.failures[-1] = "..."

    @property
    def ok(self) -> bool:
        return (self.targets > 0 and not self.failures and (self.found == self.targets or not self.has_all)
                and (self.nearest == self.targets or not self.has_nearest)
                and (self.weighted == self.targets or not self.has_weighted) and self.complete == self.compared)

    def row(self) -> str:
        count = f"{np.mean(self.solutions):.2f} ({min(self.solutions)}-{max(self.solutions)})" if self.solutions else "-"
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(self.statuses.items()))
        problems = "; " + "; ".join(self.failures) if self.failures else ""
        parts = []
        if self.has_all:
            parts.append(f"solutions per target {count}; worst pose error {self.worst:.2e} (allowed {self.allowed:.2e}); "
                         f"source configuration among them {self.found}/{self.targets}")
        if self.has_nearest:
            parts.append(f"ik_nearest from the source configuration returns it {self.nearest}/{self.targets}")
        if self.has_weighted:
            parts.append(f"ik_nearest_weighted (weights 1e-2 to 1e2) from it returns it, from a reference where the "
                         f"weights decide is as near as a scan of the rows, and with weights 1 equals ik_nearest "
                         f"{self.weighted}/{self.targets}")
        if self.has_all:
            parts.append(f"complete against the 200-start numeric IK {self.complete}/{self.compared}; statuses: {statuses}")
        return f"{self.implementation}: {self.targets} targets, {'; '.join(parts)}{problems}; {'ok' if self.ok else 'FAIL'}"


def closed_rows(derivation, implementations, cases: int, seed: int, precision: str) -> list[ClosedCheck]:
    """``ik_all`` / ``ik_nearest`` rows (see :class:`ClosedCheck`) for the implementations that have them."""
    solvers = [(label, impl) for label, impl in implementations
               if any(getattr(impl, name, None) is not None for name in ("ik_all", "ik_nearest", "ik_nearest_weighted"))]
    if not solvers:
        return []
    chain = derivation.model
    n = chain.n
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731
    rng = np.random.default_rng(seed + 4)
    numeric = chain.numeric()
    rev = revolute_mask(chain)
    lower, upper = _limits(chain)
    span = np.where(rev, np.pi, 0.5)
    lo, hi = one_turn(np.where(np.isfinite(lower), lower, -span), np.where(np.isfinite(upper), upper, span), rev)
    m = max(1, min(cases, CLOSED_TARGETS))
    q_gen = rounded(lo + (0.05 + 0.9 * rng.uniform(size=(m, n))) * (hi - lo))
    targets = rounded(reference.chain_kinematics(numeric, q_gen).T)
    lock = _lock_coordinate(chain)
    allowed = tolerance(precision, n)
    found_tol = FOUND_TOL[precision]
    # the rows reproduce the target; how near the source configuration they can lie is the target's rounding amplified
    # by the Jacobian's condition there (a random float arm near a singular configuration, condition 2.5e6: 0.25 rad)
    free = np.ones(n, bool)
    if lock is not None:
        free[lock] = False
    length = float(np.abs(np.asarray(targets).reshape(m, 16)[:, [3, 7, 11]]).max()) + 1.0
    source_tol = [max(found_tol, 10.0 * float(np.finfo(dtype).eps) * _condition(numeric, q_gen[k:k + 1], free, length))
                  for k in range(m)]
    complete = min(m, COMPLETE_TARGETS)
    each = multistart_ik_each(numeric, targets[:complete], starts=200, seeds=[seed + k for k in range(complete)],
                              fixed={lock: q_gen[:complete, lock]} if lock is not None else None)
    judged = [np.array([s for s in sols if _fits(s, lower, upper, rev)]).reshape(-1, n) for sols in each]
    rows = []
    for label, impl in solvers:
        has_all, has_nearest = getattr(impl, "ik_all", None) is not None, getattr(impl, "ik_nearest", None) is not None
        has_weighted = getattr(impl, "ik_nearest_weighted", None) is not None
        names = "/".join(name for name, has in (("ik_all", has_all), ("ik_nearest", has_nearest),
                                                ("ik_nearest_weighted", has_weighted)) if has)
        check = ClosedCheck(f"{label} {names}", m, allowed, has_all, has_nearest, has_weighted)
        draws = np.random.default_rng(seed + 5)
        weights, offsets = 10.0 ** draws.uniform(-2, 2, (m, n)), draws.uniform(-0.5, 0.5, (m, n))
        for k in range(m):
            extra = (float(q_gen[k, lock]),) if lock is not None else ()
            if has_all:
                r = impl.ik_all(targets[k], *extra)
                check.statuses[str(r.status)] = check.statuses.get(str(r.status), 0) + 1
                q = np.asarray(r.q, dtype=np.float64).reshape(-1, n)
                count = int(r.count)
                sols = q[:count]
                check.solutions.append(count)
                if r.status != "ok":
                    check.fail(f"target {k}: status {r.status}")
                if not np.all(np.isfinite(sols)) or not np.all(np.isnan(q[count:])):
                    check.fail(f"target {k}: rows not finite, or rows past count not NaN")
                    continue
                if np.any(sols < lower) or np.any(sols > upper):
                    check.fail(f"target {k}: a row outside the limits")
                if count:
                    pos, rot = pose_error(numeric, sols, targets[k])
                    worst = float(max(pos.max(), rot.max()))
                    check.worst = max(check.worst, worst)
                    if not worst <= allowed:
                        check.fail(f"target {k}: pose error {worst:.2e}")
                for a in range(count):
                    for b in range(a):
                        if same(sols[a], sols[b], rev, 1e-9 if precision == "double" else 1e-4):
                            check.fail(f"target {k}: rows {b} and {a} are one solution")
                if len(missing(sols, q_gen[k:k + 1], rev, source_tol[k])) == 0:
                    check.found += 1
                if k < len(judged):
                    check.compared += 1
                    lost = missing(sols, judged[k], rev, found_tol)
                    if len(lost) == 0:
                        check.complete += 1
                    else:
                        check.fail(f"target {k}: {len(lost)} of the numeric IK's {len(judged[k])} solutions missing")
            if has_nearest:
                r = impl.ik_nearest(q_gen[k], targets[k], *extra)
                if r.status == "ok" and same(np.asarray(r.q, dtype=np.float64), q_gen[k], np.zeros(n, bool), source_tol[k]):
                    check.nearest += 1
                else:
                    check.fail(f"target {k}: ik_nearest from the source configuration: {r.status}")
            if has_weighted:
                r = impl.ik_nearest_weighted(q_gen[k], weights[k], targets[k], *extra)
                near = r.status == "ok" and same(np.asarray(r.q, dtype=np.float64), q_gen[k], np.zeros(n, bool), source_tol[k])
                ref = q_gen[k] + offsets[k]  # no solution
                if has_all and count:  # one where the weights decide, as near as a scan of ik_all's rows and copies
                    ref = _deciding_reference(sols, q_gen[k], weights[k], lower, upper, rev, draws)
                    ref = q_gen[k] + offsets[k] if ref is None else ref
                    got = np.asarray(impl.ik_nearest_weighted(ref, weights[k], targets[k], *extra).q, dtype=np.float64)
                    best = float(np.min(_weighted_scan(sols, ref, weights[k], lower, upper, rev)))
                    rel, small = (1e-9, 1e-12) if precision == "double" else (1e-4, 1e-6)  # float: rounding
                    near = near and float(np.sum(weights[k] * (got - ref) ** 2)) <= best * (1 + rel) + small
                if has_nearest:  # all weights 1: ik_nearest's answer (bit for bit in C and NumPy; XLA may fuse the
                    # two programs' arithmetic differently)
                    plain = np.asarray(impl.ik_nearest(ref, targets[k], *extra).q, dtype=np.float64)
                    ones = np.asarray(impl.ik_nearest_weighted(ref, np.ones(n), targets[k], *extra).q, dtype=np.float64)
                    near = near and bool(np.allclose(plain, ones, rtol=0.0, atol=found_tol, equal_nan=True))
                if near:
                    check.weighted += 1
                else:
                    check.fail(f"target {k}: ik_nearest_weighted: {r.status}, not the source, farther than a row of "
                               "ik_all, or not ik_nearest with weights 1")
        rows.append(check)
    return rows


def _weighted_scan(rows: np.ndarray, ref: np.ndarray, weights: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                   revolute: np.ndarray) -> np.ndarray:
    """Per row, the least ``sum_j w_j (q_j - ref_j)^2`` over, per revolute joint, every copy ``q_j + 2 pi k`` (k
    within 10 turns) within the limits: the weighted nearest row is the least, judged without the emitted code's
    rules (a continuum's other members are not scanned: the targets here are no continuum's)."""
    turns = 2 * np.pi * np.arange(-10, 11)
    out = np.zeros(len(rows))
    for i, row in enumerate(rows):
        for x, r, w, lo, hi, rev in zip(row, ref, weights, lower, upper, revolute):
            copies = x + turns if rev else np.array([x])
            copies = copies[(copies >= lo - 1e-12) & (copies <= hi + 1e-12)]
            out[i] += w * float(np.min((copies - r) ** 2)) if len(copies) else np.inf
    return out


def _deciding_reference(rows: np.ndarray, source: np.ndarray, weights: np.ndarray, lower, upper, revolute, rng):
    """A reference between the source and another row whose weighted nearest row (:func:`_weighted_scan`) is not its
    unweighted nearest one, so that only a solver that weighs picks it; None when 40 draws find none."""
    if len(rows) < 2:
        return None
    for _ in range(40):
        other = rows[rng.integers(len(rows))]
        ref = source + rng.uniform(0.2, 0.8, source.shape) * (other - source)
        weighted = _weighted_scan(rows, ref, weights, lower, upper, revolute)
        plain = _weighted_scan(rows, ref, np.ones_like(weights), lower, upper, revolute)
        if np.argmin(weighted) != np.argmin(plain) and np.partition(weighted, 1)[1] > np.min(weighted) * (1 + 1e-6):
            return ref
    return None


def _fits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, revolute: np.ndarray) -> bool:
    """Some copy of ``q`` (revolute joints shifted by multiples of 2 pi) lies within the limits."""
    for x, lo, hi, r in zip(q, lower, upper, revolute):
        if r:
            k = np.ceil((lo - x) / (2 * np.pi)) if np.isfinite(lo) else np.floor((hi - x) / (2 * np.pi)) if np.isfinite(hi) else 0.0
            x = x + 2 * np.pi * k
        if not lo <= x <= hi:
            return False
    return True
