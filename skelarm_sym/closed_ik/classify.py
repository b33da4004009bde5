"""Which closed-form IK family a chain belongs to, from its exact constants.

Geometry (product of exponentials, all in the BASE frame at ``q = 0``): joint ``k`` (base to tip)
moves about (revolute) or along (prismatic) the unit axis ``h_k`` through the point ``p_k``;
``e_k(theta)`` is that rigid motion, and the tool pose is

    T(q) = e_1(q_1) e_2(q_2) ... e_n(q_n) M,        M = T(0) (the home pose, tool transform included).

Points are in metres, angles in radians. Entries are exact SymPy numbers where the chain is exact
(zeros and ones from pi/2 angles stay exact; other constants are Floats): the chain's base and tool
transforms and every revolute offset are folded in, so ``theta_k = q_k``.

A 7-joint chain with ``lock = j`` (0-based joint index) keeps joint ``j`` at a value given at run time:
the motions after it are conjugated by ``e_j(lock)`` (``h_k -> R_j h_k``, ``p_k -> e_j p_k``,
``M -> e_j M``), a 6-joint problem whose constants depend on ``cos(lock)``, ``sin(lock)``.

Families (the 6 solved joints numbered 1..6 base to tip; "reversed" families are the same solvers
applied to the inverse chain ``T^-1``, joints 6..1):

* ``spherical_wrist``: axes 4, 5, 6 revolute and through one point (the wrist centre), with the
  positioning joints 1-3 one of ``parallel_23`` (h2 || h3: PUMA 560, KUKA KR, ABB IRB, Fanuc, Staubli,
  Kinova j2s6), ``intersect_12`` (h1 meets h2: the iiwa with joint 3 locked), ``intersect_23``, or
  ``prismatic_3`` (h1 meets h2, joint 3 prismatic: the Stanford arm);
* ``spherical_shoulder``: axes 1, 2, 3 through one point (Panda with joint 7 locked) -- the reversed
  spherical wrist;
* ``three_parallel``: h2 || h3 || h4 and h5 meets h6 (UR3/5/10, e-series); ``three_parallel_reversed``:
  h3 || h4 || h5 and h1 meets h2.

Tolerances: a property holds when its measure is at most ``ANGLE_TOL`` (sine of the angle between two
axes) or ``LENGTH_TOL`` times the chain's reach (distances); exact constants give exact zeros.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import sympy as sp

from ..models.chain.derive import canonical_joints
from ..errors import InputError
from ..models.chain import Chain, Transform
from ..models.chain.ik_scope import joint_count, unsupported

Vec = tuple[sp.Expr, sp.Expr, sp.Expr]

ANGLE_TOL = 1e-9
"""Two axes are parallel when the sine of the angle between them is at most this."""
LENGTH_TOL = 1e-9
"""Two axes meet when their distance is at most this times the chain's reach."""
LOCK_SAMPLES = (0.0, 0.7, -1.9, 2.6)
"""Lock values (rad or m) at which a locked chain's family must hold (cross-lock properties vary)."""
MAX_SOLUTIONS = 8
"""Bound on the number of candidate solutions of every family here."""


class ClosedFormError(InputError):
    """The chain has no closed-form family here; the message (one line) says which condition fails and by how much."""


@dataclass(frozen=True)
class Geometry:
    """Screw geometry of the solved joints (see the module docstring).

    ``kinds[k]``: "revolute" or "prismatic"; ``axes[k]``/``points[k]``: ``h_k`` (unit) and ``p_k`` (m), base
    frame; ``home_rotation`` (3 x 3 rows) and ``home_position`` (3): ``M``; ``joints[k]``: the chain joint index;
    ``coordinates[k]``: the chain coordinate it moves. Entries may contain the lock's ``cos``/``sin`` symbols.
    """

    kinds: tuple[str, ...]
    axes: tuple[Vec, ...]
    points: tuple[Vec, ...]
    home_rotation: tuple[Vec, Vec, Vec]
    home_position: Vec
    joints: tuple[int, ...]
    coordinates: tuple[int, ...]

    def numeric(self, subs: dict | None = None) -> tuple[list[str], np.ndarray, np.ndarray]:
        """``(kinds, H (n, 3), P (n, 3))`` as floats, with ``subs`` substituted (the lock's cos/sin)."""
        subs = subs or {}

        def num(v):
            return [float(sp.sympify(x).xreplace(subs)) for x in v]

        return list(self.kinds), np.array([num(h) for h in self.axes]), np.array([num(p) for p in self.points])

    def reach(self) -> float:
        """A length scale (m): the sum of the distances between consecutive points and to the home position."""
        _, _, P = self.numeric(_lock_subs(self, 0.0))
        home = np.array([float(sp.sympify(x).xreplace(_lock_subs(self, 0.0))) for x in self.home_position])
        pts = np.vstack([np.zeros(3), P, home])
        return float(max(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)), 1e-300))


LOCK_C, LOCK_S = sp.symbols("lock_c lock_s", real=True)
"""Placeholders for ``cos(lock)``, ``sin(lock)`` (revolute lock) in a locked geometry; ``LOCK_S`` is the value of a prismatic lock."""


def _lock_subs(geom: Geometry, value: float) -> dict:
    return {LOCK_C: math.cos(value), LOCK_S: math.sin(value)}


# -- small exact vector algebra ------------------------------------------------------------------

# sums are built by one ``Add`` of all their terms: SymPy's ``a + b + c`` flattens ``a + b`` and then flattens it
# again with ``c`` (it unpacks nested sums), for the same canonical result (checked on every step of every arm)

def dot(a: Sequence, b: Sequence) -> sp.Expr:
    return sp.Add(a[0] * b[0], a[1] * b[1], a[2] * b[2])


def cross(a: Sequence, b: Sequence) -> list:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def sub(a: Sequence, b: Sequence) -> list:
    return [a[i] - b[i] for i in range(3)]


def add(a: Sequence, b: Sequence) -> list:
    return [a[i] + b[i] for i in range(3)]


def scale(t, a: Sequence) -> list:
    return [t * a[i] for i in range(3)]


def rotate(k: Sequence, c, s, v: Sequence) -> list:
    """``R(k, theta) v`` with ``c = cos theta``, ``s = sin theta`` (Rodrigues, unit ``k``)."""
    kv = dot(k, v)
    kxv = cross(k, v)
    return [c * v[i] + s * kxv[i] + (1 - c) * kv * k[i] for i in range(3)]


def turn(k: Sequence, c, s, v: Sequence) -> list:
    """``R(k, theta) v`` as ``(k.v) k + c (v - (k.v) k) + s (k x v)``: Rodrigues' formula split into the part
    along ``k`` (unchanged) and the part across it, so that an axis with exact zero components costs nothing
    for them (about ``k = z``: ``(c vx - s vy, s vx + c vy, vz)``; :func:`rotate`'s ``(1 - c)(k.v) k`` term leaves
    ``c vz + (1 - c) vz`` to compute). The same rotation; the emitted candidates use this form."""
    kv = dot(k, v)
    kxv = cross(k, v)
    along = [kv * k[i] for i in range(3)]
    return [sp.Add(along[i], c * (v[i] - along[i]), s * kxv[i]) for i in range(3)]


def _clean(v: Sequence) -> Vec:
    return tuple(sp.expand(sp.sympify(x)) for x in v)  # type: ignore[return-value]


# -- geometry of a chain -------------------------------------------------------------------------------

@functools.lru_cache(maxsize=16)
def chain_geometry(chain: Chain) -> Geometry:
    """The chain's screw geometry at ``q = 0`` (exact), one entry per moving joint; refuses what it cannot solve."""
    reason = unsupported(chain)
    if reason is not None:
        raise ClosedFormError(reason)
    joints, tool = canonical_joints(chain)
    frame = Transform.identity()
    kinds, axes, points = [], [], []
    for cj in joints:
        before = cj.before
        if cj.kind == "revolute" and sp.sympify(cj.offset) != 0:
            before = before @ Transform.rotate("z", cj.offset)
        frame = frame @ before
        kinds.append(cj.kind)
        axes.append(_clean(frame.rotation[:, 2]))
        points.append(_clean(frame.translation))
    home = frame @ tool
    rows = tuple(_clean(home.rotation[i, :]) for i in range(3))
    return Geometry(tuple(kinds), tuple(axes), tuple(points), rows, _clean(home.translation),
                    tuple(range(len(joints))), tuple(cj.coordinate for cj in joints))


def lock_geometry(geom: Geometry, lock: int) -> Geometry:
    """``geom`` with joint ``lock`` (0-based) held: later motions conjugated by ``e_lock``, written with
    :data:`LOCK_C`, :data:`LOCK_S` (revolute: cos and sin of the lock value; prismatic: ``LOCK_S`` is the value)."""
    n = len(geom.kinds)
    if not 0 <= lock < n:
        raise ClosedFormError(f"lock: joint index {lock} out of range (the chain has {n} joints)")
    h_l, p_l, kind_l = geom.axes[lock], geom.points[lock], geom.kinds[lock]

    def move_point(x):
        if kind_l == "revolute":
            return _clean(add(rotate(h_l, LOCK_C, LOCK_S, sub(x, p_l)), p_l))
        return _clean(add(x, scale(LOCK_S, h_l)))

    def move_vector(v):
        return _clean(rotate(h_l, LOCK_C, LOCK_S, v)) if kind_l == "revolute" else tuple(v)

    keep = [k for k in range(n) if k != lock]
    axes = tuple(geom.axes[k] if k < lock else move_vector(geom.axes[k]) for k in keep)
    points = tuple(geom.points[k] if k < lock else move_point(geom.points[k]) for k in keep)
    cols = [move_vector([geom.home_rotation[i][j] for i in range(3)]) for j in range(3)]
    rows = tuple(tuple(cols[j][i] for j in range(3)) for i in range(3))
    return Geometry(tuple(geom.kinds[k] for k in keep), axes, points, rows, move_point(geom.home_position),
                    tuple(geom.joints[k] for k in keep), tuple(geom.coordinates[k] for k in keep))


# -- numeric tests ----------------------------------------------------------------------------------

def _sine(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(np.cross(a, b)))


def _line_distance(pa, ha, pb, hb) -> float:
    n = np.cross(ha, hb)
    nn = np.linalg.norm(n)
    d = pb - pa
    if nn <= ANGLE_TOL:
        return float(np.linalg.norm(d - np.dot(d, ha) * ha))
    return float(abs(np.dot(d, n)) / nn)


def _concurrency(P: np.ndarray, H: np.ndarray) -> float:
    """Largest distance from the point closest (least squares) to all the lines ``(P[i], H[i])`` to any of them."""
    A = sum(np.eye(3) - np.outer(h, h) for h in H)
    b = sum((np.eye(3) - np.outer(h, h)) @ p for p, h in zip(P, H))
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    return float(max(np.linalg.norm((np.eye(3) - np.outer(h, h)) @ (x - p)) for p, h in zip(P, H)))


def _names(idx: Sequence[int], numbers: Sequence[int]) -> str:
    return ", ".join(str(numbers[i]) for i in idx)


def _detect(kinds, H, P, tol, numbers) -> tuple[list[tuple[str, str | None]], str]:
    """Every family of a 6-joint problem (problem order) that applies, in order of preference, and the
    reasons of those that do not (one line). ``numbers``: the 1-based chain joint numbers for messages."""
    reasons = []

    # spherical wrist (joints 4, 5, 6 = indices 3, 4, 5)
    def wrist(offset_kinds, Hh, Pp, nums, label) -> tuple[list[str], str]:
        w = [3, 4, 5]
        if not all(offset_kinds[i] == "revolute" for i in w):
            return [], f"{label}: joints {_names(w, nums)} are not all revolute"
        for i, j in ((3, 4), (4, 5)):
            if _sine(Hh[i], Hh[j]) <= ANGLE_TOL:
                return [], f"{label}: axes {nums[i]}, {nums[j]} are parallel"
        c = _concurrency(Pp[w], Hh[w])
        if c > tol:
            return [], f"{label}: axes {_names(w, nums)} do not meet: closest distance {c:.4g} m"
        r = [offset_kinds[i] == "revolute" for i in range(3)]

        def par(i, j):
            return _sine(Hh[i], Hh[j]) <= ANGLE_TOL

        def mt(i, j):
            return not par(i, j) and _line_distance(Pp[i], Hh[i], Pp[j], Hh[j]) <= tol

        # the wrist centre (for the degenerate test of SP3)
        wc = _closest_point(Pp[3], Hh[3], Pp[4], Hh[4])
        found = []
        if all(r) and par(1, 2) and not par(0, 1):
            found.append("parallel_23")
        if r[0] and r[1] and mt(0, 1):
            if r[2] and _sine(wc - Pp[2], Hh[2]) * np.linalg.norm(wc - Pp[2]) > tol:
                found.append("intersect_12")
            if not r[2]:
                found.append("prismatic_3")
        if all(r) and mt(1, 2):
            found.append("intersect_23")
        if found:
            return found, ""
        why = []
        if not par(1, 2):
            why.append(f"axes {nums[1]}, {nums[2]} not parallel (sine {_sine(Hh[1], Hh[2]):.3g})")
        if not mt(0, 1):
            why.append(f"axes {nums[0]}, {nums[1]} do not meet (distance {_line_distance(Pp[0], Hh[0], Pp[1], Hh[1]):.4g} m)")
        if not mt(1, 2):
            why.append(f"axes {nums[1]}, {nums[2]} do not meet (distance {_line_distance(Pp[1], Hh[1], Pp[2], Hh[2]):.4g} m)")
        return [], f"{label}: no solved positioning structure for joints {_names(range(3), nums)}: " + ", ".join(why or ["joint kinds"])

    def three_parallel(kk, Hh, Pp, nums, label) -> tuple[bool, str]:
        if not all(k == "revolute" for k in kk):
            return False, f"{label}: needs six revolute joints"
        for i, j in ((1, 2), (2, 3)):
            if _sine(Hh[i], Hh[j]) > ANGLE_TOL:
                return False, f"{label}: axes {_names([1, 2, 3], nums)} are not parallel (sine {_sine(Hh[i], Hh[j]):.3g} between {nums[i]} and {nums[j]})"
        for i, j in ((0, 1), (4, 1), (4, 5)):
            if _sine(Hh[i], Hh[j]) <= ANGLE_TOL:
                return False, f"{label}: axes {nums[i]}, {nums[j]} are parallel"
        d = _line_distance(Pp[4], Hh[4], Pp[5], Hh[5])
        if d > tol:
            return False, f"{label}: axes {nums[4]}, {nums[5]} do not meet: closest distance {d:.4g} m (offset wrist: needs SP6, not covered)"
        return True, ""

    found: list[tuple[str, str | None]] = []
    fams, why = wrist(kinds, H, P, numbers, "spherical wrist")
    found += [("spherical_wrist", f) for f in fams]
    reasons.append(why)
    rk, rH, rP, rn = kinds[::-1], H[::-1], P[::-1], numbers[::-1]
    fams, why = wrist(rk, rH, rP, rn, "spherical shoulder")
    found += [("spherical_shoulder", f) for f in fams]
    reasons.append(why)
    ok, why = three_parallel(kinds, H, P, numbers, "three parallel")
    if ok:
        found.append(("three_parallel", None))
    reasons.append(why)
    ok, why = three_parallel(rk, rH, rP, rn, "three parallel (reversed)")
    if ok:
        found.append(("three_parallel_reversed", None))
    reasons.append(why)
    return found, "; ".join(r for r in reasons if r)


def _closest_point(pa, ha, pb, hb) -> np.ndarray:
    n = np.cross(ha, hb)
    t = np.dot(np.cross(pb - pa, hb), n) / np.dot(n, n)
    return pa + t * ha


def closest_point(pa: Sequence, ha: Sequence, pb: Sequence, hb: Sequence) -> list:
    """The point of line ``(pa, ha)`` closest to line ``(pb, hb)`` (their intersection when they meet), exact."""
    n = cross(ha, hb)
    t = dot(cross(sub(pb, pa), hb), n) / dot(n, n)
    return [sp.expand(x) for x in add(pa, scale(t, ha))]


# -- the family --------------------------------------------------------------------------------------

SUBPROBLEM_CHAINS = {
    ("spherical_wrist", "parallel_23"): ("SP4 q1 (wrist centre height along h2)", "SP3 q3 (distance shoulder-wrist)",
                                         "SP1 q2", "SP4 q5", "SP1 q4", "SP1 q6"),
    ("spherical_wrist", "intersect_12"): ("SP3 q3 (distance from the 1-2 intersection to the wrist centre)",
                                          "SP2 q1, q2", "SP4 q5", "SP1 q4", "SP1 q6"),
    ("spherical_wrist", "prismatic_3"): ("SP3' d3 (distance along the prismatic axis: a quadratic)",
                                         "SP2 q1, q2", "SP4 q5", "SP1 q4", "SP1 q6"),
    ("spherical_wrist", "intersect_23"): ("SP3 q1 (distance from the 2-3 intersection)", "SP2 q2, q3",
                                          "SP4 q5", "SP1 q4", "SP1 q6"),
    ("three_parallel", None): ("SP4 q1 (height of the 5-6 intersection along h2)", "SP4 q5", "SP1 q6",
                               "SP1 phi = q2+-q3+-q4", "SP3 q3", "SP1 q2", "q4 by subtraction"),
}


@dataclass(frozen=True)
class Family:
    """A chain's closed-form family and the geometry its solver uses.

    ``name``: "spherical_wrist", "spherical_shoulder", "three_parallel" or "three_parallel_reversed";
    ``position``: the positioning structure of a (reversed) spherical wrist ("parallel_23", "intersect_12",
    "intersect_23", "prismatic_3"), else ``None``; ``reversed``: solved on ``T^-1`` with the joints in reverse
    order; ``joints``: chain joint indices (0-based) of the six solved joints, base to tip; ``lock``: the locked
    joint's index or ``None``; ``subproblems``: the chain of subproblems (in the solver's joint numbering, which
    is reversed when ``reversed``); ``axes``, ``points``: ``h_k``, ``p_k`` of the six joints (base frame, q = 0,
    lock = 0; exact where the model is); ``special_points``: named points (wrist centre, intersections), same
    frame; ``max_solutions``: the bound S on the candidates.
    """

    name: str
    position: str | None
    reversed: bool
    joints: tuple[int, ...]
    lock: int | None
    subproblems: tuple[str, ...]
    axes: tuple[Vec, ...]
    points: tuple[Vec, ...]
    special_points: tuple[tuple[str, Vec], ...]
    max_solutions: int = MAX_SOLUTIONS

    def describe(self) -> str:
        """One line: family, structure, lock, subproblem chain."""
        fam = self.name + (f" ({self.position})" if self.position else "")
        lock = f", joint {self.lock + 1} locked" if self.lock is not None else ""
        order = " [solved on T^-1, joints reversed]" if self.reversed else ""
        return f"{fam}{lock}{order}: " + "; ".join(self.subproblems)


def problem_geometry(chain: Chain, lock: int | None = None) -> Geometry:
    """The six solved joints' geometry (locked, if ``lock`` is given); refuses other joint counts."""
    geom = chain_geometry(chain)
    reason = joint_count(chain.name, len(geom.kinds), lock)
    if reason is not None:
        raise ClosedFormError(reason)
    return lock_geometry(geom, lock) if lock is not None else geom


def classify(chain: Chain, lock: int | None = None) -> Family:
    """The chain's family (see the module docstring); :class:`ClosedFormError` with a one-line reason otherwise.

    ``lock``: 0-based index of the joint held at a run-time value (7-joint chains).
    """
    geom = problem_geometry(chain, lock)
    tol = LENGTH_TOL * geom.reach()
    numbers = [j + 1 for j in geom.joints]
    samples = LOCK_SAMPLES if lock is not None else (0.0,)
    common = None
    triples = [True, True]  # joints 1-3 and 4-6 of the problem meet at one point at every sampled lock value
    for value in samples:
        kinds, H, P = geom.numeric(_lock_subs(geom, value))
        found, reasons = _detect(kinds, H, P, tol, numbers)
        for k, idx in enumerate(([0, 1, 2], [3, 4, 5])):
            triples[k] &= all(kinds[i] == "revolute" for i in idx) and _concurrency(P[idx], H[idx]) <= tol
        lockinfo = f" (joint {lock + 1} locked at {value:g})" if lock is not None else ""
        if not found:
            raise ClosedFormError(f"{chain.name}{lockinfo}: no closed-form family: {reasons}")
        common = found if common is None else [f for f in common if f in found]
        if not common:
            raise ClosedFormError(f"{chain.name}: no family holds at every value of the locked joint {lock + 1}")
    found = common[0]
    name, position = found
    if all(triples):
        # two spherical triples a fixed distance apart (an iiwa with its elbow, joint 4, locked): one centre stays
        # on a sphere about the other, so the tool's position has two degrees of freedom, not three, and a target
        # reached has a one-parameter family of solutions. Where they meet only at some lock values, those values
        # are singular and the others solve: not refused
        lockinfo = f" (joint {lock + 1} locked)" if lock is not None else ""
        raise ClosedFormError(f"{chain.name}{lockinfo}: no closed-form family: axes {_names(range(3), numbers)} meet at one "
                              f"point and so do axes {_names(range(3, 6), numbers)}: the two points keep their distance, so "
                              "a target has a continuum of solutions or none")
    rev = name in ("spherical_shoulder", "three_parallel_reversed")
    base_name = {"spherical_shoulder": "spherical_wrist", "three_parallel_reversed": "three_parallel"}.get(name, name)
    at_zero = {LOCK_C: sp.S.One, LOCK_S: sp.S.Zero}
    axes = tuple(tuple(sp.sympify(x).xreplace(at_zero) for x in h) for h in geom.axes)
    points = tuple(tuple(sp.sympify(x).xreplace(at_zero) for x in p) for p in geom.points)
    order = list(range(6))[::-1] if rev else list(range(6))
    Hs, Ps = [axes[i] for i in order], [points[i] for i in order]
    special = []
    if base_name == "spherical_wrist":
        special.append(("wrist centre" if not rev else "shoulder centre", tuple(closest_point(Ps[3], Hs[3], Ps[4], Hs[4]))))
        if position in ("intersect_12", "prismatic_3"):
            special.append(("intersection of the first two solved axes", tuple(closest_point(Ps[0], Hs[0], Ps[1], Hs[1]))))
        if position == "intersect_23":
            special.append(("intersection of solved axes 2, 3", tuple(closest_point(Ps[1], Hs[1], Ps[2], Hs[2]))))
    else:
        special.append(("intersection of solved axes 5, 6", tuple(closest_point(Ps[4], Hs[4], Ps[5], Hs[5]))))
    return Family(name, position, rev, tuple(geom.joints), lock, SUBPROBLEM_CHAINS[(base_name, position)],
                  axes, points, tuple(special))


def explain(chain: Chain, lock: int | None = None) -> str:
    """One line: the family and its subproblems, or which condition fails and by how much. ``lock``: the locked
    joint's 0-based index; ``None``: the lock ``load_robot(..., ik_lock=)`` recorded in ``chain``, if any."""
    if lock is None:
        from ..models.chain.lock import ik_lock, lock_index

        lock = lock_index(chain, ik_lock(chain))
    try:
        return classify(chain, lock).describe()
    except ClosedFormError as exc:
        return str(exc)
