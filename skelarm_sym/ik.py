"""Pose and position IK for 3-D chains on top of emitted functions (the NumPy side of ``X_ik_solve``).

``solve_pose(module, q0, target, ...)`` takes any module (or object) with ``pose(q)`` and
``jacobian(q)`` (the emitted NumPy module or the compiled C wrapper; ``ik_terms(q)`` returning both
at once is used when present) and runs the algorithm of the emitted C ``X_ik_solve`` (same
constants, same random restarts, so both end with the same status on the same input):

* error ``e = [p_t - p; log3(R_t R^T)]`` in base axes (the Jacobian of this project is
  LOCAL_WORLD_ALIGNED: ``dq = J^+ e`` moves toward the target to first order);
* Levenberg-Marquardt step ``dq = J^T (J J^T + mu2 I)^-1 e`` with ``mu2 = max(lambda^2, c |e|)`` (damping
  proportional to the error, Fan and Yuan's delta = 1: it vanishes at the solution, so the last steps
  are Gauss-Newton's and converge quadratically, yet stays large enough near singular poses, where
  ``(c |e|)^2`` collapses): a step is accepted when it lowers ``|e|`` (then ``c`` is multiplied by
  ``C_DOWN``, down to ``C_MIN``), else ``c`` is multiplied by ``C_UP``;
* joint limits: a step is clamped into ``[lower, upper]``; joints on a bound that the step pushes
  outward are removed from the step (their columns zeroed, the step solved again), so the free
  joints still make the progress clamping would kill;
* restarts: an attempt ends when it stalls (``c > C_MAX``, or an accepted step improving ``|e|`` by
  less than a relative ``STALL``), when it starts a step at a (near) stationary point of ``|e|`` over
  the free joints (``|J_f^T e| <= STATIONARY |J_f|_F |e|``: a local minimum, typically against a
  limit), when its error is above ``PROGRESS`` times its error ``WINDOW`` steps earlier, or after
  ``ATTEMPT`` steps. The next attempt starts from the best of ``CANDIDATES`` random configurations
  by tool position error (a start whose tool is already near the target's usually lies in the basin
  of a solution within the limits); they are drawn uniformly from ``SHRINK`` times the limits' range
  around its centre on even restarts (0, 2, ...) and from the whole range on odd ones (periodic
  joints: always the whole range; unbounded joints: ``[-pi, pi]``), by a xorshift64* generator
  seeded by ``seed``; steps of all attempts count against ``max_iter`` (candidates do not: they
  cost a pose each, not a step).

Statuses: ``converged`` (``|p_t - p| <= tol`` and ``|log3| <= tol``), ``stalled`` (the budget ran out
and the best pose found ended its attempt at or near a stationary point of ``|e|``: no lowering step,
a small gradient, or ``|e|`` not multiplied by PROGRESS in WINDOW steps (an attempt the budget ends is
judged by its last window); an unreachable target's closest reach; ``q`` is that pose), ``max_iter`` (the budget ran out otherwise; ``q`` is the best pose found),
``invalid`` (non-finite q0/target/lambda, lambda < 0, tol <= 0, max_iter < 0: ``ValueError``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

C_START = 0.01
"""Initial damping ``mu2`` per unit of error."""
C_MIN, C_MAX = 1e-8, 1e8
C_UP, C_DOWN = 4.0, 0.5
STEP_MAX = 1.0
"""Largest joint move of one step (rad or m): longer steps are scaled down whole (same direction)."""
ATTEMPT = 25
"""Steps of one attempt before a restart."""
WINDOW, PROGRESS = 3, 0.6
"""An attempt restarts when its error is above PROGRESS times its error WINDOW steps earlier."""
TWO_PI = 2.0 * np.pi
STALL = 1e-9
"""An accepted step improving |e| by less than this relative amount ends the attempt (stationary point)."""
SEED = 0x5EED5EED
"""Default restart seed (the emitted C uses this one)."""
STATIONARY = 0.02
"""A step starting where ``|J_f^T e| <= STATIONARY |J_f|_F |e|`` (a stationary point) ends the attempt."""
CANDIDATES = 8
"""Random configurations drawn per restart; the attempt starts from the one whose tool is nearest the target."""
SHRINK = 0.5
"""Even restarts draw bounded joints from this fraction of their range around its centre."""
UNBOUNDED_RANGE = np.pi
"""Restarts draw unbounded joints from [-pi, pi]."""
DEFAULT_TOL = {"double": 1e-10, "float": 1e-5}
PIVOT = 1e-13
"""LDL^T pivots at most this times the largest diagonal entry are dropped (their unknown set to 0)."""
_MASK64 = (1 << 64) - 1


@dataclass(frozen=True)
class IKResult:
    """Final pose ``q``, ``status``, ``position_error`` (m), ``rotation_error`` (rad), ``iterations``
    (steps taken over all attempts) and ``restarts``."""

    q: np.ndarray
    status: str
    position_error: float
    rotation_error: float
    iterations: int
    restarts: int = 0

    @property
    def error(self) -> tuple[float, float]:
        return (self.position_error, self.rotation_error)


class XorShift:
    """xorshift64* (Vigna), the generator of the emitted C solver's restarts."""

    def __init__(self, seed: int) -> None:
        self.state = (int(seed) ^ 0x9E3779B97F4A7C15) & _MASK64 or 0x9E3779B97F4A7C15

    def uniform(self) -> float:
        """A double in [0, 1) from the top 53 bits."""
        s = self.state
        s ^= s >> 12
        s ^= (s << 25) & _MASK64
        s ^= s >> 27
        self.state = s
        return (((s * 0x2545F4914F6CDD1D) & _MASK64) >> 11) * (1.0 / 9007199254740992.0)


def rotation_log(R: np.ndarray) -> np.ndarray:
    """Axis-angle vector of a rotation matrix, accurate near angle 0 and near pi.

    Near 0: ``vee(R - R^T)/2`` times ``angle/sin(angle)`` (series below 1e-4); away from pi: the same with
    ``angle = atan2(|v|/2, (tr R - 1)/2)``; within 1e-3 of pi the axis comes from the symmetric part
    ``(R + R^T)/2 - cos(angle) I = (1 - cos) a a^T``: the column of its largest diagonal entry, signed
    by ``v`` (which is ``2 sin(angle) a``)."""
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    c = (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) / 2.0
    s = np.sqrt(v @ v) / 2.0
    angle = np.arctan2(s, c)
    if angle < 1e-4:
        return v * (0.5 + angle * angle / 12.0)
    if np.pi - angle > 1e-3:
        return v * (angle / (2.0 * s))
    B = (R + R.T) / 2.0
    i = int(np.argmax(np.diag(B)))
    col = B[:, i].copy()
    col[i] -= c
    axis = col / np.sqrt(col @ col)
    if axis @ v < 0:
        axis = -axis
    return axis * angle


def gram(J: np.ndarray, free: np.ndarray | None = None) -> np.ndarray:
    """``J_f J_f^T`` for the ``free`` columns of ``J``: ``J J^T`` minus the other columns' outer products
    (as the emitted C computes it: the Gram matrix is kept while steps are rejected and downdated
    when joints are blocked)."""
    G = J @ J.T
    if free is not None and not free.all():
        Jb = J[:, ~free]
        G = G - Jb @ Jb.T
    return G


def solve_damped(J: np.ndarray, e: np.ndarray, mu2: float, free: np.ndarray | None = None,
                 G: np.ndarray | None = None) -> np.ndarray:
    """``dq = J^T (J J^T + mu2 I)^-1 e`` over the ``free`` columns (others 0), by an unpivoted LDL^T of
    the small symmetric matrix (``G``: its ``J_f J_f^T`` part, from :func:`gram` when not given); a
    pivot at most ``PIVOT`` times the largest diagonal entry is dropped (its unknown set to zero), so
    a rank-deficient ``J`` with ``mu2 = 0`` gives a finite step. The emitted C does the same
    operations in the same order."""
    Jf = J if free is None else np.where(free, J, 0.0)
    m = Jf.shape[0]
    A = np.array(gram(J, free) if G is None else G, dtype=float)
    A[np.diag_indices(m)] += mu2
    cut = PIVOT * max(float(np.max(np.diag(A))), 0.0)
    L = np.zeros((m, m))
    d = np.zeros(m)
    for k in range(m):
        s = A[k, k] - sum(L[k, j] * L[k, j] * d[j] for j in range(k))
        d[k] = s if s > cut else 0.0
        for i in range(k + 1, m):
            t = A[i, k] - sum(L[i, j] * L[k, j] * d[j] for j in range(k))
            L[i, k] = t / d[k] if d[k] != 0.0 else 0.0
    y = np.array(e, dtype=float)
    for i in range(m):
        y[i] -= sum(L[i, j] * y[j] for j in range(i))
    for i in range(m):
        y[i] = y[i] / d[i] if d[i] != 0.0 else 0.0
    for i in range(m - 1, -1, -1):
        y[i] -= sum(L[j, i] * y[j] for j in range(i + 1, m))
    return Jf.T @ y


def _bounds(n: int, limits) -> tuple[np.ndarray, np.ndarray]:
    if limits is None:
        return np.full(n, -np.inf), np.full(n, np.inf)
    if isinstance(limits, dict):
        lower, upper = limits["lower"], limits["upper"]
    else:
        lower, upper = limits
    lo = np.array([-np.inf if x is None else x for x in lower], dtype=float)
    hi = np.array([np.inf if x is None else x for x in upper], dtype=float)
    if lo.shape != (n,) or hi.shape != (n,) or np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo > hi):
        raise ValueError(f"limits must be {n} pairs lower <= upper")
    return lo, hi


def chain_options(chain) -> dict:
    """``limits`` and ``periodic`` of a :class:`~skelarm_sym.models.chain.Chain` for :func:`solve_pose`:
    a coordinate is periodic when every joint it drives is revolute with an integer multiplier (moving
    it by 2 pi leaves the pose unchanged)."""
    periodic = [True] * chain.n
    for j in chain.joints:
        m = float(j.multiplier)
        if j.kind != "revolute" or m != round(m):
            periodic[j.coordinate] = False
    return {"limits": chain.limits(), "periodic": tuple(periodic)}


def _terms(module):
    if hasattr(module, "ik_terms"):
        return module.ik_terms
    return lambda q: (module.pose(q), module.jacobian(q))


def _solve(module, q0, target, lam, tol, max_iter, limits, position_only, seed, params, periodic) -> IKResult:
    q = np.array(q0, dtype=float)
    target = np.asarray(target, dtype=float)
    if q.ndim != 1:
        raise ValueError(f"q0 must be a vector, got shape {q.shape}")
    lam, tol = float(lam), float(tol)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(target)) and np.isfinite(lam) and lam >= 0
            and np.isfinite(tol) and tol > 0 and int(max_iter) == max_iter and max_iter >= 0):
        raise ValueError("q0, target, lambda must be finite, lambda >= 0, tol > 0 and finite, max_iter a whole number >= 0")
    max_iter = int(max_iter)
    n = q.size
    lo, hi = _bounds(n, limits)
    wrap = np.zeros(n, dtype=bool) if periodic is None else np.array(periodic, dtype=bool)
    if wrap.shape != (n,):
        raise ValueError(f"periodic must have {n} entries")
    wrap &= hi - lo >= TWO_PI  # a move by 2 pi stays within the limits
    low_draw = np.where(np.isfinite(lo), lo, -UNBOUNDED_RANGE)
    span_draw = np.where(np.isfinite(hi), hi, UNBOUNDED_RANGE) - low_draw
    # even restarts: SHRINK times the range around its centre (periodic joints: the whole range)
    low_near = np.where(wrap, low_draw, low_draw + span_draw * ((1.0 - SHRINK) / 2.0))
    span_near = np.where(wrap, span_draw, span_draw * SHRINK)
    rows = 3 if position_only else 6
    raw = _terms(module)
    terms = (lambda x: raw(x, *params)) if params else raw
    pt, Rt = target[:3, 3], target[:3, :3]
    mu2_floor = lam * lam

    def evaluate(x):
        T, J = terms(x)
        dp = pt - T[:3, 3]
        if position_only:
            return dp, np.asarray(J)[:3], float(np.sqrt(dp @ dp)), 0.0
        dr = rotation_log(Rt @ T[:3, :3].T)
        return np.concatenate([dp, dr]), np.asarray(J), float(np.sqrt(dp @ dp)), float(np.sqrt(dr @ dr))

    def position_error(x):
        dp = pt - np.asarray(terms(x)[0])[:3, 3]
        return float(np.sqrt(dp @ dp))

    rng = XorShift(seed)
    q = np.clip(q, lo, hi)
    e, J, pe, re = evaluate(q)
    en = float(np.sqrt(e @ e))
    best = (en, q, pe, re, False)
    c, attempt, restarts, it = C_START, 0, 0, 0
    checkpoint = window_start = en
    best_here, stationary = True, False
    while True:
        if pe <= tol and re <= tol:
            return IKResult(q, "converged", pe, re, it, restarts)
        if it == max_iter:
            # the budget ends inside the attempt holding the best pose: stalled when that attempt
            # is at a stationary point or no longer lowers |e| geometrically (as a window would judge)
            if best_here and attempt > 0 and (stationary or en > PROGRESS * (window_start if attempt % WINDOW == 0 else checkpoint)):
                best = best[:4] + (True,)
            break
        mu2 = max(mu2_floor, c * en)
        G = gram(J)
        dq = solve_damped(J, e, mu2, G=G)
        blocked = (((q <= lo) & (dq < 0)) | ((q >= hi) & (dq > 0))) & ~wrap
        Jf = J
        if blocked.any():
            G = gram(J, ~blocked)
            dq = solve_damped(J, e, mu2, ~blocked, G)
            Jf = np.where(blocked, 0.0, J)
        g = Jf.T @ e
        stationary = float(g @ g) <= STATIONARY * STATIONARY * float(np.trace(G)) * en * en  # trace = |J_f|_F^2
        big = float(np.max(np.abs(dq)))
        if big > STEP_MAX:
            dq = dq * (STEP_MAX / big)
        trial = q + dq
        if wrap.any():
            trial = np.where(wrap & (trial > hi), trial - TWO_PI, np.where(wrap & (trial < lo), trial + TWO_PI, trial))
        trial = np.clip(trial, lo, hi)
        et, Jt, pet, ret = evaluate(trial)
        ent = float(np.sqrt(et @ et))
        it += 1
        attempt += 1
        stalled = False
        if ent < en:
            stalled = en - ent <= STALL * en
            q, e, J, pe, re, en = trial, et, Jt, pet, ret, ent
            c = max(c * C_DOWN, C_MIN)
        else:
            c *= C_UP
            stalled = c > C_MAX
        if en < best[0]:
            best, best_here = (en, q, pe, re, stalled), True
        elif stalled and en == best[0]:
            best, best_here = (en, q, pe, re, True), True
        if pe <= tol and re <= tol:
            continue
        slow = stationary
        if attempt % WINDOW == 0:
            slow = slow or en > PROGRESS * checkpoint
            window_start, checkpoint = checkpoint, en
        if (stalled or slow or attempt >= ATTEMPT) and it < max_iter:
            if (stalled or slow) and best_here:  # this attempt's best is a stationary point (or near one)
                best = best[:4] + (True,)
            best_here = False
            low, span = (low_near, span_near) if restarts % 2 == 0 else (low_draw, span_draw)
            near = np.inf
            for _ in range(CANDIDATES):
                x = low + span * np.array([rng.uniform() for _ in range(n)])
                d = position_error(x)
                if d < near:
                    near, q = d, x
            e, J, pe, re = evaluate(q)
            en = float(np.sqrt(e @ e))
            c, attempt = C_START, 0
            checkpoint = window_start = en
            restarts += 1
            if en < best[0]:
                best, best_here = (en, q, pe, re, False), True
    en, q, pe, re, stalled = best
    return IKResult(q, "stalled" if stalled else "max_iter", pe, re, it, restarts)


def solve_pose(module, q0, target, lam: float = 0.0, tol: float = 1e-10, max_iter: int = 100, limits=None,
               seed: int = SEED, params=(), periodic=None) -> IKResult:
    """Pose IK to ``target`` (4 x 4). ``limits``: ``(lower, upper)`` sequences or ``Chain.limits()``
    (``None`` entries: unbounded); ``params``: extra arguments of ``pose``/``jacobian`` (symbolic
    parameters). See the module docstring."""
    target = np.asarray(target, dtype=float)
    if target.shape != (4, 4):
        raise ValueError(f"target must have shape (4, 4), got {target.shape}")
    return _solve(module, q0, target, lam, tol, max_iter, limits, False, seed, tuple(params), periodic)


def solve_position(module, q0, target_position, lam: float = 0.0, tol: float = 1e-10, max_iter: int = 100,
                   limits=None, seed: int = SEED, params=(), periodic=None) -> IKResult:
    """Position-only IK of the tool origin to ``target_position`` (3); the 3 linear rows of J."""
    p = np.asarray(target_position, dtype=float)
    if p.shape != (3,):
        raise ValueError(f"target_position must have shape (3,), got {p.shape}")
    target = np.eye(4)
    target[:3, 3] = p
    return _solve(module, q0, target, lam, tol, max_iter, limits, True, seed, tuple(params), periodic)
