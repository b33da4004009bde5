"""Post-processing of the raw candidates: the spec the emitted ``X_ik_all``/``X_ik_nearest`` follow, in NumPy.

Input: ``Q`` (S, N) raw candidates in branch order and ``flags`` (S) from :func:`~.derive.derive_ik_all`
(bit 1: least squares, bit 2: singular), the joint limits ``lower``/``upper`` (N, rad or m; +-inf where
absent) and ``revolute`` (N, bool). Steps, each a loop over at most S rows (and N joints):

1. **Invalid input** (``STATUS["invalid"]``, count 0): a non-finite target entry (or lock value, or one beyond
   ``LOCK_MAX`` in magnitude), a
   translation entry beyond ``TRANSLATION_MAX`` (no arm reaches it, and the candidates' squares of it would
   overflow into NaN rows), or a rotation part that is not a rotation: ``max |R^T R - I| > ORTHO_TOL`` or
   ``det R < 0``.
2. **Exact or least squares**: if any candidate has flag bit 1 clear, only those (exact) candidates are
   kept; otherwise every candidate is kept and the status becomes ``unreachable`` (least-squares poses;
   every returned row has bit 1 set).
3. **2 pi shifts** (revolute joints only): ``q + 2 pi k`` with ``k = round((c - q) / 2 pi)`` (NumPy rounding,
   half to even), ``c`` the centre of the joint's range (:func:`centres`): ``(lower + upper) / 2`` when it spans
   at most 2 pi, else the point nearest zero at least ``pi + s`` inside both limits, ``s = min(1, (upper - lower -
   2 pi) / 2)`` (0 without limits, or for +-2 pi: the result lies in ``[-pi, pi]``). When several copies fit (a range wider than 2 pi) the one returned is the copy nearest
   zero, not the middle of a range like ``[-1e5, -83]`` (at -5e4 rad one unit in the last place is 7e-12 rad,
   and the poses of such rows missed the target by 1e-11).
   **A continuum** (a spherical wrist's, ``continuum = (a, w, b, s, s_odd, w0)`` of :func:`~.derive.wrist_continuum`): a row
   flagged singular whose wrist angle ``q[w]`` is within ``WRIST_ALIGNED_TOL`` of ``w0 + k pi`` (``w0 = 0`` unless
   the zero pose bends the wrist) has joints a and b on one axis, ``q[a] + sigma q[b]`` fixed modulo 2 pi
   (``sigma = s`` for even ``k``, ``s_odd`` for odd ``k``: ``-s`` for a wrist that flips, 0 for a skewed one, aligned
   at even ``k`` only). Its ``q[a]``, ``q[b]`` become the member within both joints' limits nearest the row's own values
   (:func:`continuum_member`): the row itself when it fits; when it does not, the member the least turn
   away, which step 4 then keeps. (Moving along the line changes the pose by at most twice the wrist's distance
   from the multiple of pi, in rotation-matrix entries.)
4. **Limits**: a candidate with any joint below ``lower - LIMIT_TOL`` or above ``upper + LIMIT_TOL`` is dropped;
   joints within ``LIMIT_TOL`` outside are clipped onto the limit.
5. **Duplicates**: a candidate within ``DUP_TOL`` (max over joints; revolute differences taken modulo
   2 pi) of an earlier kept one, or within ``DUP_TOL_SINGULAR`` where both are flagged singular, is dropped
   (the earlier one stays, its flags OR-ed with the duplicate's singular bit). Double roots and repeated
   branches of singular cases collapse here.
6. **Order**: the kept rows in branch order (deterministic; a branch keeps its index as the target moves,
   ``branch`` reports it). ``count`` = their number; rows past ``count`` are NaN.
7. **Status**: ``ok`` (at least one exact solution within limits, all of them returned), ``unreachable``
   (least-squares rows, possibly 0 of them), ``out_of_limits`` (exact solutions exist, none within the
   limits; count 0), ``invalid``.

:func:`nearest` then picks, among the returned rows, the one nearest ``q_ref`` in the (weighted) Euclidean
norm, each revolute joint taking the copy ``q + 2 pi k`` within limits nearest ``q_ref`` and a continuum row's
joints a and b the member within limits nearest ``q_ref`` (:func:`continuum_member`); ties go to the lower row.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..models.chain.target_rotation import ORTHO_TOL  # one definition, ik_solve's too

STATUS = {"ok": 0, "unreachable": 1, "out_of_limits": 2, "invalid": 3}
"""Status codes (the emitted ``X_ik_all`` returns these numbers: ``X_IK_OK``, ``X_IK_UNREACHABLE``,
``X_IK_OUT_OF_LIMITS``, ``X_IK_INVALID``; invalid is 3 as for ``X_ik_solve``, so one ``X_IK_INVALID`` serves both)."""
LIMIT_TOL = 1e-12
"""Joints this far (rad or m) outside a limit are clipped onto it; further out, the candidate is dropped."""
DUP_TOL = 1e-9
"""Candidates closer than this (max over joints, rad or m) are one solution."""
DUP_TOL_SINGULAR = 1e-6
"""Candidates both flagged singular and closer than this are one solution: the two roots of a double root part by
about the square root of rounding (3e-8 rad seen on the PUMA 560 and UR5), which DUP_TOL keeps as two rows."""
WRIST_ALIGNED_TOL = 1e-11
"""A row flagged singular with its wrist angle this close (rad) to a multiple of pi is a member of the wrist's
continuum (step 3); moving it along the continuum changes its pose by at most twice that distance. Targets from
poses with the wrist exactly aligned leave the candidates' wrist angle within 6.5e-12 of it (3000 targets each: the
Panda's shoulder with joint 7 locked; 3.4e-12 on the Kinova j2s6, 1.6e-12 on the iiwa 14)."""
TRANSLATION_MAX = 1e150
"""Largest ``|t_i|`` (m) of a target accepted: the candidates square translations (about 1.3e154 overflows a
double; every arm here gave NaN rows from 1e155 m), and no arm reaches a hundredth of that."""
TRANSLATION_MAX_FLOAT = 1e18
"""The same for code emitted in float (squares overflow a float from about 1.8e19)."""
LOCK_MAX, LOCK_MAX_FLOAT = 1e5, 64.0
"""Largest ``|lock|`` (rad or m) accepted for a locked joint: beyond it one unit in the last place of the value
exceeds the IK tolerance (1.5e-11 rad at 1e5 in double, 7.6e-6 at 64 in float), and the row's turn nearest the
limits no longer holds the angle the candidates were solved with (a lock of 1e300 gave status ok with rows 1.6 off
their target)."""
LIMIT_TOL_FLOAT, DUP_TOL_FLOAT, DUP_TOL_SINGULAR_FLOAT, WRIST_ALIGNED_TOL_FLOAT = 1e-5, 1e-4, 1e-4, 1e-4
"""The same for code emitted in float: float candidates carry
about 1e-6 rad of rounding (more near a singular pose), so equal branches differ by more than 1e-9 (singular
rows keep the same tolerance as the others in float)."""
TWO_PI = 2.0 * np.pi
INV_TWO_PI = 1.0 / TWO_PI
"""Turns are counted by multiplying with this, as the emitted code does (a division can round a half-turn tie the
other way)."""


@dataclass(frozen=True)
class IKAll:
    """Result of :func:`postprocess`: ``q`` (S, N), rows past ``count`` NaN; ``flags`` (S) per row (-1 past
    count); ``branch`` (S) each row's branch index (-1 past count); ``count``; ``status`` (a :data:`STATUS` value)."""

    q: np.ndarray
    flags: np.ndarray
    branch: np.ndarray
    count: int
    status: int

    @property
    def solutions(self) -> np.ndarray:
        """The ``count`` returned rows, (count, N)."""
        return self.q[: self.count]


def is_valid_target(target: np.ndarray) -> bool:
    """Step 1: finite, translation within ``TRANSLATION_MAX``, rotation part orthonormal within ``ORTHO_TOL``
    with determinant > 0."""
    T = np.asarray(target, dtype=float).reshape(4, 4)
    if not np.all(np.isfinite(T)) or not np.all(np.abs(T[:3, 3]) <= TRANSLATION_MAX):
        return False
    R = T[:3, :3]
    return bool(np.max(np.abs(R.T @ R - np.eye(3))) <= ORTHO_TOL and np.linalg.det(R) > 0)


def centres(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Step 3's centre of each joint's range: its middle when it spans at most a turn; else the point nearest zero
    at least ``pi + s`` inside both limits, ``s`` the smaller of 1 rad and half the excess over a turn (so the copies
    keep some room from the limits, and a range just over a turn keeps its middle); absent limits count as
    infinite."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    with np.errstate(invalid="ignore"):
        width = upper - lower
        narrow = width <= TWO_PI
        middle = np.where(narrow, 0.5 * (lower + upper), 0.0)
        room = np.where(narrow, 0.0, np.minimum(1.0, 0.5 * (width - TWO_PI)))
    return np.where(narrow, middle, np.minimum(np.maximum(0.0, lower + np.pi + room), upper - np.pi - room))


def shift(q: np.ndarray, lower, upper, revolute) -> np.ndarray:
    """Step 3: revolute joints of ``q`` (..., N) shifted by multiples of 2 pi to the copy nearest their range's centre."""
    q = np.array(q, dtype=float)
    c = centres(lower, upper)
    rev = np.asarray(revolute, bool)
    k = np.round((c - q) / TWO_PI)
    return np.where(rev, q + TWO_PI * k, q)


def continuum_sign(q_w: float, flag: int, s: int, tol: float = WRIST_ALIGNED_TOL, s_odd: int | None = None,
                   w0: float = 0.0) -> int:
    """``sigma`` of a row's continuum (``q[a] + sigma q[b]`` fixed), or 0 when the row is not a member of one: its flag
    has the singular bit and its wrist angle ``q_w`` is within ``tol`` of ``w0 + k pi``; ``sigma = s`` for even ``k``,
    ``s_odd`` for odd ``k`` (``-s`` by default: a wrist that flips; 0: a skewed wrist, aligned at even ``k`` only)."""
    shifted = q_w - w0 if w0 else q_w
    k = np.rint(shifted / np.pi)
    if not flag & 2 or abs(shifted - np.pi * k) > tol:
        return 0
    return s if k % 2 == 0 else (-s if s_odd is None else s_odd)


def _window(low: float, high: float, d: float) -> tuple[float, float]:
    """Where a nearest point's offset ``t`` (rad) can lie: ``t`` within ``[low, high]`` (a joint's limits less the
    row's value; +-inf where absent), nearest ``d`` (the reference's offset). A copy ``t - 2 pi`` within the limits
    is nearer ``d`` where ``t > d + pi``, and ``t + 2 pi`` where ``t < d - pi``, so the window is
    ``[max(low, min(high - 2 pi, d - pi)), min(high, max(low + 2 pi, d + pi))]``: at most one turn wide."""
    return max(low, min(high - TWO_PI, d - np.pi)), min(high, max(low + TWO_PI, d + np.pi))


def continuum_member(x: float, y: float, ref: tuple[float, float], sigma: int, lower: tuple[float, float],
                     upper: tuple[float, float], weights: tuple[float, float] = (1.0, 1.0),
                     tol: float = LIMIT_TOL) -> tuple[float, float] | None:
    """The member ``(x', y')`` of the continuum through ``(x, y)`` (``x' + sigma y' = x + sigma y`` modulo 2 pi, rad)
    within ``lower <= (x', y') <= upper`` (per joint; +-inf where absent) nearest ``ref`` in the weighted norm
    ``w_a (x' - ref_a)^2 + w_b (y' - ref_b)^2``; ``None`` when no member is within the limits.

    In offsets from the row, ``u = x' - x`` and ``v = sigma (y' - y)``, the members are the lines ``u + v = 2 pi m``;
    on each, the nearest point within the limits is the unconstrained one clamped to the line's segment in the
    windows of ``u`` and ``v`` (:func:`_window`, at most a turn wide each: at most three lines cross them). The
    member is built from the row, ``x' = x + u``, ``y' = y + sigma (2 pi m - u)``: on the continuum to the rounding of
    those offsets, whatever the reference's magnitude. As in step 4, limits are met within ``tol`` (rad) and the
    member clipped onto them: a member on a limit, or on a corner of two, is kept when rounding puts it just past."""
    da, db = ref[0] - x, sigma * (ref[1] - y)
    ua = _window(lower[0] - tol - x, upper[0] + tol - x, da)
    wb = _window(lower[1] - tol - y, upper[1] + tol - y, ref[1] - y)
    vb = wb if sigma > 0 else (-wb[1], -wb[0])
    best, best_d = None, np.inf
    for m in range(-int(np.floor(-(ua[0] + vb[0]) * INV_TWO_PI)), int(np.floor((ua[1] + vb[1]) * INV_TWO_PI)) + 1):
        e = TWO_PI * m
        lo, hi = max(ua[0], e - vb[1]), min(ua[1], e - vb[0])
        if lo > hi:
            continue
        u = min(max((weights[0] * da + weights[1] * (e - db)) / (weights[0] + weights[1]), lo), hi)
        d = weights[0] * (u - da) ** 2 + weights[1] * (e - u - db) ** 2
        if d < best_d:
            best_d = d
            best = (float(np.clip(x + u, lower[0], upper[0])), float(np.clip(y + sigma * (e - u), lower[1], upper[1])))
    return best


def _difference(a: np.ndarray, b: np.ndarray, revolute) -> np.ndarray:
    d = a - b
    return np.where(revolute, (d + np.pi) % TWO_PI - np.pi, d)


def postprocess(Q, flags, lower, upper, revolute, target=None, dup_tol: float = DUP_TOL,
                limit_tol: float = LIMIT_TOL, dup_tol_singular: float = DUP_TOL_SINGULAR, continuum: tuple = (),
                aligned_tol: float = WRIST_ALIGNED_TOL) -> IKAll:
    """Steps 1-7 of the module docstring for one target. ``Q`` (S, N), ``flags`` (S); ``Q = None`` means the
    caller found the input invalid; ``target`` (16) enables step 1's rotation check; ``continuum``: the wrist's
    ``(a, w, b, s, s_odd, w0)`` (:func:`~.derive.wrist_continuum`) or ``()``."""
    lower = np.asarray(lower, float)
    upper = np.asarray(upper, float)
    revolute = np.asarray(revolute, bool)
    N = lower.shape[0]
    S = 0 if Q is None else np.asarray(Q).shape[0]
    out_q = np.full((max(S, 1), N), np.nan)
    out_f = np.full(max(S, 1), -1, dtype=int)
    out_b = np.full(max(S, 1), -1, dtype=int)
    if Q is None or (target is not None and not is_valid_target(target)) or not np.all(np.isfinite(Q)):
        return IKAll(out_q[:S] if S else out_q, out_f[:S] if S else out_f, out_b[:S] if S else out_b, 0, STATUS["invalid"])
    Q = np.asarray(Q, float)
    flags = np.asarray(flags, int)
    exact = (flags & 1) == 0
    keep = exact if exact.any() else np.ones(S, bool)
    count = 0
    for i in range(S):
        if not keep[i]:
            continue
        q = shift(Q[i], lower, upper, revolute)
        if continuum:
            a, w, b, s, s_odd, w0 = continuum
            sigma = continuum_sign(q[w], flags[i], s, aligned_tol, s_odd, w0)
            member = sigma and continuum_member(q[a], q[b], (q[a], q[b]), sigma, (lower[a], lower[b]), (upper[a], upper[b]),
                                                tol=limit_tol)
            if member:
                q[a], q[b] = member
        if np.any(q < lower - limit_tol) or np.any(q > upper + limit_tol):
            continue
        q = np.clip(q, lower, upper)
        dup = False
        for r in range(count):
            tol = dup_tol_singular if flags[i] & 2 and out_f[r] & 2 else dup_tol
            if np.max(np.abs(_difference(q, out_q[r], revolute))) <= tol:
                out_f[r] |= flags[i] & 2
                dup = True
                break
        if dup:
            continue
        out_q[count], out_f[count], out_b[count] = q, flags[i], i
        count += 1
    if not exact.any():
        status = STATUS["unreachable"]
    elif count == 0:
        status = STATUS["out_of_limits"]
    else:
        status = STATUS["ok"]
    return IKAll(out_q, out_f, out_b, count, status)


def nearest_copy(x: float, ref: float, lo: float, hi: float, tol: float = LIMIT_TOL) -> float:
    """The copy ``x + 2 pi k`` within ``[lo, hi]`` (+-inf where absent; ``x`` is within) nearest ``ref`` (rad): the
    nearest copy when it is within, else the last one below ``hi`` (the nearest copy is above the range) or the first
    one above ``lo`` (below it). As in step 4, within ``tol`` of a limit counts as within, clipped onto it (a copy a
    whole number of turns from ``x`` that lands on a limit rounds to either side of it)."""
    y = x + TWO_PI * np.rint((ref - x) * INV_TWO_PI)
    if y > hi + tol:
        y = x + TWO_PI * np.floor((hi + tol - x) * INV_TWO_PI)
    if y < lo - tol:
        y = x - TWO_PI * np.floor((x - (lo - tol)) * INV_TWO_PI)
    return float(min(max(y, lo), hi))


def nearest(result: IKAll, q_ref, lower, upper, revolute, weights=None, continuum: tuple = (),
            aligned_tol: float = WRIST_ALIGNED_TOL, limit_tol: float = LIMIT_TOL,
            members: tuple | None = None) -> tuple[np.ndarray | None, int]:
    """The returned row nearest ``q_ref`` (N): ``(q, row)``, each revolute joint moved to its copy within limits
    nearest ``q_ref``, a continuum row's joints a and b to the member within limits nearest ``q_ref``
    (``continuum``: see :func:`postprocess`); ``(None, -1)`` when ``result`` has no rows. ``weights`` (N): metric
    weights (default 1). ``members``: ``(M (R, N), flags (R))``, more rows to choose from (a UR's aligned-wrist
    continuum at the reference's own ``phi``, :attr:`~.derive.ClosedIK.members`; the caller passes them where a raw
    candidate is exact and flagged singular, as a representative is, even when the limits dropped its row): those
    with flag bit 1 clear, each
    revolute joint moved to its copy within limits nearest ``q_ref``, within the limits (``limit_tol``) as rows are;
    a member nearer than every row is returned with ``row`` -1 (the continuum's representative's branch is not
    known here), also where ``result`` has no rows. A member with the wrist aligned too is moved along the wrist's
    continuum (``continuum``) like a row, its wrist pair judged within the limits after the move (code emitted in
    double; float code does not move members, whose wrist angle carries float's rounding)."""
    if result.count == 0 and members is None:
        return None, -1
    q_ref = np.asarray(q_ref, float)
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    rev = np.asarray(revolute, bool)
    w = np.ones_like(q_ref) if weights is None else np.asarray(weights, float)
    w = w / np.max(w)  # the same nearest row; no product overflows (the emitted code divides alike)
    best, best_d, best_i = None, np.inf, -1

    def along_continuum(q: np.ndarray, row: np.ndarray, flag: int) -> bool:
        """A row of the wrist's continuum: joints a and b to the member within the limits nearest q_ref; whether
        there is one."""
        if continuum:
            a, wj, b, s, s_odd, w0 = continuum
            sigma = continuum_sign(row[wj], flag, s, aligned_tol, s_odd, w0)
            member = sigma and continuum_member(row[a], row[b], (q_ref[a], q_ref[b]), sigma,
                                                (lower[a], lower[b]), (upper[a], upper[b]), (w[a], w[b]), limit_tol)
            if member:
                q[a], q[b] = member
                return True
        return False

    for i in range(result.count):
        q = result.q[i].copy()
        for j in np.nonzero(rev)[0]:
            q[j] = nearest_copy(q[j], q_ref[j], lower[j], upper[j], limit_tol)
        along_continuum(q, result.q[i], result.flags[i])
        d = float(np.sum(w * (q - q_ref) ** 2))
        if d < best_d:
            best, best_d, best_i = q, d, i
    if members is not None:
        M, mflags = np.asarray(members[0], float), np.asarray(members[1], int)
        pair = (continuum[0], continuum[2]) if continuum else ()
        for m in range(M.shape[0]):
            if mflags[m] & 1:
                continue
            q, ok, pair_ok = M[m].copy(), True, True
            for j in range(q.shape[0]):
                x = q[j]
                if rev[j]:  # a copy within the limits: nearest_copy's, unless it clipped a value with none there
                    q[j] = nearest_copy(x, q_ref[j], lower[j], upper[j], limit_tol)
                    fits = bool(abs(q[j] - (x + TWO_PI * np.rint((q[j] - x) * INV_TWO_PI))) <= limit_tol)
                    if j in pair:  # the wrist's pair: judged after its move below
                        pair_ok &= fits
                    else:
                        ok &= fits
                else:
                    ok &= bool(lower[j] - limit_tol <= x <= upper[j] + limit_tol)
                    q[j] = min(max(x, lower[j]), upper[j])
            if pair:  # a spherical wrist's member with the wrist aligned too, moved into the limits where it must
                ok &= along_continuum(q, M[m], int(mflags[m])) or pair_ok
            if not ok:
                continue
            d = float(np.sum(w * (q - q_ref) ** 2))
            if d < best_d:
                best, best_d, best_i = q, d, -1
    return best, best_i
