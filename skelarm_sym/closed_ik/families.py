"""Each family's chain of subproblems, as straight-line steps with all branches side by side.

A *problem* is six joints in product-of-exponentials form (see :mod:`.classify`): kinds, unit axes
``H[k]`` and points ``P[k]`` (base frame, q = 0; indices 0..5 here, joints 1..6 in the docs), and the
target motion ``G = T_target M^-1`` as ``RG`` (3 x 3, rows) and ``tG`` (3): a point ``x0`` of the last link
at ``q = 0`` is at ``RG x0 + tG`` in the target pose, and ``RG = R_1 ... R_6`` (prismatic joints rotate
nothing). Solvers return :class:`Branch` es: the six joint variables in problem order with their flags.

Spherical wrist (``H[3..5]`` through the wrist centre ``W0``): ``W = RG W0 + tG`` depends on joints 1-3
only (joints 4-6 fix ``W0``). Positioning, by structure:

* ``parallel_23`` (h2 || h3): rotations about h2, h3 keep the component along h2, so
  ``(W - p1) . R(h1, q1) h2 = h2 . (W0 - p1)`` (SP4, 2 branches); ``V = e1^-1 W``;
  ``|R(h3, q3)(W0 - p3) - (p2 - p3)|^2 = |V - p2|^2`` (SP3, 2); ``R(h2, q2)(e3 W0 - p2) = V - p2`` (SP1).
* ``intersect_12`` (h1, h2 meet at ``O``): ``|e3 W0 - O| = |W - O|`` (SP3 for q3, 2), then
  ``R(h1, -q1)(W - O) = R(h2, q2)(e3 W0 - O)`` (SP2, 2); ``prismatic_3``: the same with
  ``e3 W0 = W0 + d3 h3`` (a quadratic in d3).
* ``intersect_23`` (h2, h3 meet at ``O``): ``|R(h1, -q1)(W - p1) + p1 - O| = |W0 - O|`` (SP3, 2), then
  ``R(h2, -q2)(V - O) = R(h3, q3)(W0 - O)`` (SP2, 2).

Orientation: ``Rw = R3^T R2^T R1^T RG = R4 R5 R6``: ``h4 . R(h5, q5) h6 = h4 . Rw h6`` (SP4, 2);
``R(h4, q4) R(h5, q5) h6 = Rw h6`` (SP1); ``R(h6, q6) x = R5^T R4^T Rw x`` with ``x = h6 x h5`` (SP1:
finite when the wrist is aligned, where q4 takes the representative 0 and q6 the rest). 8 branches.

Three parallel axes (h2 || h3 || h4, h5 meets h6 at ``Q0``; the UR family): ``W = RG Q0 + tG``;
``(W - p1) . R(h1, q1) h2 = h2 . (Q0 - p1)`` (SP4 q1); ``h2 . R(h5, q5) h6 = h2 . R1^T RG h6`` (SP4 q5);
``R(h6, q6) (RG^T R1 h2) = R5^T h2`` (SP1 q6); ``phi = q2 + s3 q3 + s4 q4`` (``s_k = h2 . h_k``, +-1) from
``R(h2, phi) x = R1^T RG R6^T R5^T x``, ``x = h2 x h5`` (SP1); ``P4 = e2 e3 p4 = V - R(h2, phi)(Q0 - p4)``;
``|R(h3, q3)(p4 - p3) - (p2 - p3)|^2 = |P4 - p2|^2`` (SP3 q3); SP1 q2; ``q4 = s4 (phi - q2 - s3 q3)``. 8 branches.
At the wrist singularity (h6 turned by q5 parallel to h2: q6's SP1 is a continuum) only ``sigma = phi +- q6`` is
fixed; the representative takes ``phi`` from an SP3 that puts joint 4's point at the distance from p2 nearest the
middle of the 2R arm's range (so the arm reaches it whenever the target is reachable), and ``q6 = +-(sigma - phi)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .classify import add, closest_point, cross, dot, sub, turn
from .subproblems import (Angle, Steps, _select, any_of, choose_parts, indicator, positive, sp1, sp1_parts, sp2, sp3, sp3_parts, sp4,
                          sp_line, unit_disc)


ALIGNED_TOL = 1e-13
"""Spherical wrist: with ``q5`` at most this (rad) from 0 or +-pi and q4's SP1 a continuum, q4 is the representative 0
(the orientation error of doing so is at most that distance). Targets from the emitted pose at an exactly aligned
wrist leave ``q5`` at about 1.2e-14 (PUMA 560, iiwa 14): 1e-14 missed them. Further out (up to 6.5e-12 on the
Panda's shoulder, 3.4e-12 on the Kinova j2s6) q4 is the SP1's angle, exact for that ``q5``, and the post-processing
moves the row along the continuum where it must (``postprocess.WRIST_ALIGNED_TOL``): a representative there would
cost twice that distance in every row."""
PI_DOUBLE = sp.Float(math.pi, 17)
"""pi as the emitted code has it (3.141592653589793)."""
SPLIT_TOL = 1e-12
"""UR wrist: below this sine between h6 and ``R5^T h2`` the representative split of q6 and phi (``q2 + s3 q3 + s4 q4``) is used
(its pose error is about the sine times the arm's size; above it the regular path's rounding noise, about
1e-16 over the sine in q6, stays within the reach of the 2R arm except at the workspace's edge)."""
SPLIT_TOL_FLOAT = 1e-5
"""The same in code emitted in float, whose rounding leaves an aligned wrist's sine at about 1e-7 to 1e-6: with the
double tolerance the split was never taken there, q6 and phi came from rounding noise, and 23 of 500 reachable
aligned UR5 targets came back unreachable (least-squares rows 0.14 of the reach off). The split's pose error, at
most about 1e-5 of the arm's size, is within float's 3e-5."""
SPLIT_SYMBOL = sp.Symbol("IK_SPLIT_TOL", positive=True)
"""The split's tolerance in the steps: a module constant of the emitted code (:data:`SPLIT_TOL` in double,
:data:`SPLIT_TOL_FLOAT` in float); the NumPy spec evaluates the steps with :data:`SPLIT_TOL`."""


AXIS_TOL = 1e-12
"""Spherical wrist: the wrist centre this close to axis 1 (``|h1 x (W - p1)|^2 <= AXIS_TOL^2 (|W - p1|^2 + L^2)``, ``L``
the arm's size in m) is on joint 1's continuum, and ``ik_continuum_members``' rows at the reference's ``q1`` are exact
(their pose error is about that distance; rounding leaves a target built on the axis at about 1e-16 of it)."""
AXIS_TOL_FLOAT = 1e-6
"""The same in code emitted in float, whose rounding leaves such a wrist centre about 1e-7 off the axis (a member's
pose error is then about 1e-6 of the arm's size, within float's 3e-5)."""
AXIS_SYMBOL = sp.Symbol("IK_AXIS_TOL", positive=True)
"""The axis test's tolerance in the steps: a module constant of the emitted code (:data:`AXIS_TOL` in double,
:data:`AXIS_TOL_FLOAT` in float); the NumPy spec evaluates the steps with :data:`AXIS_TOL`."""


@dataclass(frozen=True)
class Branch:
    """One candidate: ``angles[k]`` the joint variables of problem joints 0..5 (rad or m)."""

    angles: tuple[Angle, ...]

    @property
    def ls(self) -> sp.Expr:
        """1 when any subproblem of the branch fell back to least squares."""
        return any_of(*[a.ls for a in self.angles])

    @property
    def singular(self) -> sp.Expr:
        """1 when any subproblem of the branch met a continuum or a double root."""
        return any_of(*[a.singular for a in self.angles])


@dataclass(frozen=True)
class Problem:
    """Six joints and a target motion (see the module docstring); entries are SymPy expressions or steps."""

    kinds: tuple[str, ...]
    H: tuple[Sequence[sp.Expr], ...]
    P: tuple[Sequence[sp.Expr], ...]
    RG: tuple[Sequence[sp.Expr], ...]
    tG: Sequence[sp.Expr]

    def reversed(self, steps: Steps) -> "Problem":
        """The inverse chain: joints 6..1 with negated variables, target ``G^-1``."""
        RT = tuple(tuple(self.RG[j][i] for j in range(3)) for i in range(3))
        t = steps.vec("tGr", [-x for x in matvec(RT, self.tG)])
        return Problem(self.kinds[::-1], self.H[::-1], self.P[::-1], RT, t)


def matvec(m: Sequence[Sequence[sp.Expr]], v: Sequence[sp.Expr]) -> list:
    """``m v`` for a 3 x 3 ``m`` given by rows."""
    return [m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2] for i in range(3)]


def tmatvec(m: Sequence[Sequence[sp.Expr]], v: Sequence[sp.Expr]) -> list:
    """``m^T v`` for a 3 x 3 ``m`` given by rows."""
    return [m[0][i] * v[0] + m[1][i] * v[1] + m[2][i] * v[2] for i in range(3)]


def _rot(a: Angle, k, v, inverse: bool = False) -> list:
    if a.c is None:  # prismatic joint: no rotation
        return list(v)
    return turn(k, a.c, -a.s if inverse else a.s, v)


def _sq(v) -> sp.Expr:
    return dot(v, v)


def _half_turn(steps: Steps, label: str, a: Angle, same: sp.Expr) -> Angle:
    """``a + pi`` wrapped into [-pi, pi] (``a`` itself where ``same`` is 1): the wrist flip's angle, no atan2."""
    turned = _select((a.theta - PI_DOUBLE, a.theta > 0), (a.theta + PI_DOUBLE, True))
    out = _select((a.theta, same > 0), (turned, True))
    # in [-pi, pi] when a is: a - pi for a in (0, pi], a + pi for a in [-pi, 0] (rounding is monotonic)
    return Angle((steps.principal if steps.is_principal(a.theta) else steps)(label, out), None, None, a.ls, a.singular)


def spherical_wrist(steps: Steps, prob: Problem, position: str, flip: bool = False, members: list | None = None,
                    ref: sp.Expr | None = None, reach: float = 1.0) -> list[Branch]:
    """The eight candidates of a spherical-wrist problem with positioning structure ``position``.

    ``members`` (a list, with ``ref``, joint 1's variable in the reference configuration): filled with one
    ``(branches, exact)``: the wrist centre on axis 1's continuum at ``q1 = ref``. There joint 1 turns the wrist
    centre about itself, so every ``q1`` keeps the positioning's ``q2``, ``q3`` (the candidates hold a
    representative, rounding noise or 0) and the wrist takes the rest: the eight branches with ``q1 = ref`` and
    their own wrist, and ``exact`` 1 where ``W`` is within ``IK_AXIS_TOL`` times ``reach`` (the arm's size, m) and its
    distance from ``p1`` of axis 1 (the rows' pose error is about that distance).

    ``flip``: the wrist's axes satisfy ``h4 . h5 = 0``, ``h5 . h6 = 0`` and ``h4 || h6`` (every arm here), so the
    second root of q5 is ``-q5`` and its branch is ``(q4 + pi, -q5, q6 + pi)``: ``R(h4, q4 + pi) R(h5, -q5)
    R(h6, q6 + pi) = R(h4, q4) R(h5, q5) R(h6, q6)`` (``R(h4, pi)`` turns ``h5`` to ``-h5``, and ``R(h4, pi) R(h6, pi)``
    is the identity), about one point; so half the wrist's subproblems (and 12 of an arm's 34 angles) are
    additions. Where q4 is a continuum's representative (the wrist aligned) the second branch is the first: one
    representative, as when both were solved."""
    H, P, RG, tG = prob.H, prob.P, prob.RG, prob.tG
    W0 = steps.vec("W0", closest_point(P[3], H[3], P[4], H[4]))
    W = steps.vec("W", add(matvec(RG, W0), tG))
    arms: list[tuple[Angle, Angle, Angle]] = []
    if position == "parallel_23":
        q1s = sp4(steps, "q1", sub(W, P[0]), H[1], H[0], dot(H[1], sub(W0, P[0])))
        for i, q1 in enumerate(q1s):
            V = steps.vec(f"V{i}", add(_rot(q1, H[0], sub(W, P[0]), inverse=True), P[0]))
            q3s = sp3(steps, f"q3_{i}", H[2], sub(W0, P[2]), sub(P[1], P[2]), _sq(sub(V, P[1])))
            for j, q3 in enumerate(q3s):
                X = steps.vec(f"X{i}{j}", add(_rot(q3, H[2], sub(W0, P[2])), P[2]))
                q2 = sp1(steps, f"q2_{i}{j}", H[1], sub(X, P[1]), sub(V, P[1]))
                arms.append((q1, q2, q3))
    elif position in ("intersect_12", "prismatic_3"):
        O = steps.vec("O12", closest_point(P[0], H[0], P[1], H[1]))
        WO = steps.vec("WO", sub(W, O))
        if position == "intersect_12":
            q3s = sp3(steps, "q3", H[2], sub(W0, P[2]), sub(O, P[2]), _sq(WO))
        else:
            q3s = sp_line(steps, "d3", H[2], W0, O, _sq(WO))
        for j, q3 in enumerate(q3s):
            if q3.c is None:
                X = steps.vec(f"X{j}", [W0[i] + q3.theta * H[2][i] for i in range(3)])
            else:
                X = steps.vec(f"X{j}", add(_rot(q3, H[2], sub(W0, P[2])), P[2]))
            for k, (m1, q2) in enumerate(sp2(steps, f"q12_{j}", H[0], WO, H[1], sub(X, O))):
                arms.append((m1.negated(), q2, q3))
    elif position == "intersect_23":
        O = steps.vec("O23", closest_point(P[1], H[1], P[2], H[2]))
        m1s = sp3(steps, "q1", H[0], sub(W, P[0]), sub(O, P[0]), _sq(sub(W0, O)))
        for i, m1 in enumerate(m1s):
            V = steps.vec(f"V{i}", add(_rot(m1, H[0], sub(W, P[0])), P[0]))
            for k, (m2, q3) in enumerate(sp2(steps, f"q23_{i}", H[1], sub(V, O), H[2], sub(W0, O))):
                arms.append((m1.negated(), m2.negated(), q3))
    else:
        raise ValueError(f"unknown positioning structure {position!r}")

    x6 = steps.vec("x6", cross(H[5], H[4]))
    g6 = steps.vec("g6", matvec(RG, H[5]))
    gx = steps.vec("gx", matvec(RG, x6))
    out = []
    for a, (q1, q2, q3) in enumerate(arms):
        out += _spherical_wrist_branches(steps, H, x6, g6, gx, q1, q2, q3, f"{a}", flip)
    if members is not None:
        # the wrist centre on axis 1: at most IK_AXIS_TOL times the arm's size and its distance from p1 off it (a
        # wrist centre near p1 has its direction from rounding, its distance from the axis is still that small)
        d = sub(W, P[0])
        off = steps.vec("Wa", cross(H[0], d))
        on_axis = steps("onaxis", indicator(_sq(off) <= AXIS_SYMBOL**2 * (steps("Wd2", _sq(d)) + sp.Float(reach, 17)**2)))
        c, s = steps("q1mc", sp.cos(ref)), steps("q1ms", sp.sin(ref))
        group = []
        for a, (q1, q2, q3) in enumerate(arms):  # each arm's positioning, joint 1 at the reference's angle
            group += _spherical_wrist_branches(steps, H, x6, g6, gx, Angle(ref, c, s, q1.ls, sp.S.One), q2, q3, f"m{a}", flip)
        members.append((group, on_axis))
    return out


def _spherical_wrist_branches(steps: Steps, H, x6, g6, gx, q1: Angle, q2: Angle, q3: Angle, a: str,
                              flip: bool) -> list[Branch]:
    """The wrist's two branches (two roots of q5, q4 and q6 for each) for the positioning ``q1, q2, q3``
    (see :func:`spherical_wrist`); ``a`` labels the steps."""
    out: list[Branch] = []
    # each rotation's result named: nested, SymPy builds products of large sums (seconds for a locked arm),
    # and the lowering's CSE finds the same shared terms anyway
    g1 = steps.vec(f"g1_{a}", _rot(q1, H[0], g6, True))
    x1 = steps.vec(f"x1_{a}", _rot(q1, H[0], gx, True))
    u = steps.vec(f"u{a}", _rot(q3, H[2], steps.vec(f"g2_{a}", _rot(q2, H[1], g1, True)), True))
    w = steps.vec(f"w{a}", _rot(q3, H[2], steps.vec(f"x2_{a}", _rot(q2, H[1], x1, True)), True))
    q5s = sp4(steps, f"q5_{a}", H[3], H[5], H[4], dot(H[3], u), unit_disc(H[3], H[5], H[4], u))
    first_aligned = sp.S.Zero  # set by the first root, read by its flip
    for b, q5 in enumerate(q5s):
        if flip and b == 1:
            first = out[-1].angles
            # the first root's q4 is the continuum's representative only where aligned (q5 within ALIGNED_TOL of
            # 0 or +-pi): there the original branches coincide. Where q4's SP1 is merely flagged a continuum (q5 up
            # to about 1e-9 from it) q4 is the SP1's exact angle and the flip is another exact solution; copying
            # the first row there lost it (and the source's row with it on 24-39 of 60 targets at q5 = 1e-10)
            same = first_aligned
            q5f = Angle(steps(f"q5f_{a}", _select((first[4].theta, same > 0), (-first[4].theta, True))), None, None,
                        q5.ls, q5.singular)
            out.append(Branch((q1, q2, q3, _half_turn(steps, f"q4f_{a}", first[3], same), q5f,
                               _half_turn(steps, f"q6f_{a}", first[5], same))))
            continue
        r5 = steps.vec(f"r5_{a}{b}", _rot(q5, H[4], H[5]))
        q4 = sp1(steps, f"q4_{a}{b}", H[3], r5, u)
        # the wrist aligned to rounding (q5 within ALIGNED_TOL of 0 or +-pi and q4's SP1 a continuum): q4 = 0 and
        # q6 takes the whole rotation (off by at most that distance there; the SP1 would return an angle of
        # rounding noise, pi as often as 0, another in each language, which may miss the joint's limits)
        q5a = steps(f"q5a_{a}{b}", sp.Abs(q5.theta))
        aligned = sp.And(sp.Or(q5a <= ALIGNED_TOL, q5a >= PI_DOUBLE - ALIGNED_TOL), q4.singular > 0)
        if flip and b == 0:
            first_aligned = steps(f"aligned{a}", indicator(aligned))
        q4 = Angle(steps(f"q4r_{a}{b}", _select((sp.S.Zero, aligned), (q4.theta, True))),
                   steps(f"q4rc_{a}{b}", _select((sp.S.One, aligned), (q4.c, True))),
                   steps(f"q4rs_{a}{b}", _select((sp.S.Zero, aligned), (q4.s, True))), q4.ls, q4.singular)
        y = steps.vec(f"y{a}{b}", _rot(q5, H[4], steps.vec(f"w4_{a}{b}", _rot(q4, H[3], w, True)), True))
        q6 = sp1(steps, f"q6_{a}{b}", H[5], x6, y)
        out.append(Branch((q1, q2, q3, q4, q5, q6)))
    return out


def three_parallel(steps: Steps, prob: Problem, flip: bool = False, members: list | None = None,
                   phi_ref: sp.Expr | None = None, s0: int = 1, signs: tuple[int, int] = (1, 1)) -> list[Branch]:
    """The eight candidates of a three-parallel-axes problem (h2 || h3 || h4, h5 meets h6).

    ``signs``: ``(h2 . h3, h2 . h4)``, each +1 or -1: the three joints turn about h2 by
    ``phi = q2 + s3 q3 + s4 q4`` (an axis reversed by a URDF's half-turn turns the other way).

    ``flip``: ``h2 . h5 = 0``, ``h5 . h6 = 0`` and ``h2 || h6`` (UR arms), so the second root of q5 is ``-q5`` and
    ``R(h2, phi + pi) R(h5, -q5) R(h6, q6 + pi) = R(h2, phi) R(h5, q5) R(h6, q6)`` (as for the spherical wrist): q6
    and phi = q2 + s3 q3 + s4 q4 of the second root are half turns of the first's, no subproblem; q3, q2 are solved
    for its own wrist point. Where q6 is a continuum's representative (the wrist aligned) the second root's
    branches are the first's.

    ``members`` (a list, with ``flip``): filled with, per root of q1, ``(branches, exact)``: the aligned wrist's
    continuum at ``phi = phi_ref`` (an expression of the reference configuration), the 2R arm's two branches for it
    and ``q6`` moved to keep ``phi + sigma q6`` (``sigma = s0`` where q5 is an even multiple of pi, ``-s0`` where odd;
    ``s0 = h2 . h6``), and ``exact`` 1 where the first root's q6 is the continuum's representative (split). Those are
    members of the same continuum as the candidates' representative, the one at the reference's own ``phi``."""
    H, P, RG, tG = prob.H, prob.P, prob.RG, prob.tG
    Q0 = steps.vec("Q0", closest_point(P[4], H[4], P[5], H[5]))
    W = steps.vec("W", add(matvec(RG, Q0), tG))
    g6 = steps.vec("g6", matvec(RG, H[5]))
    x = steps.vec("x2", cross(H[1], H[4]))
    v = steps.vec("v4", sub(Q0, P[3]))
    o, pv = sub(P[2], P[1]), sub(P[3], P[2])  # the 2R arm: |R(h3, q3) pv + o|^2 over q3
    o_perp = sub(o, [dot(o, H[2]) * c for c in H[2]])
    p_perp = sub(pv, [dot(pv, H[2]) * c for c in H[2]])
    middle = _sq(o) + _sq(pv) + 2 * dot(o, H[2]) * dot(H[2], pv)
    spread = 2 * sp.sqrt(_sq(o_perp) * _sq(p_perp))
    dmin2, dmax2 = steps("dmin2", middle - spread), steps("dmax2", middle + spread)
    out = []
    for i, q1 in enumerate(sp4(steps, "q1", sub(W, P[0]), H[1], H[0], dot(H[1], sub(Q0, P[0])))):
        g = steps.vec(f"g{i}", _rot(q1, H[0], g6, True))
        a = steps.vec(f"a{i}", tmatvec(RG, _rot(q1, H[0], H[1])))
        V = steps.vec(f"V{i}", add(_rot(q1, H[0], sub(W, P[0]), True), P[0]))
        u = steps.vec(f"u{i}", sub(V, P[1]))
        uh = steps(f"uh{i}", dot(u, H[1]))
        m = steps(f"m{i}", _sq(u) + _sq(v) - 2 * uh * dot(H[1], v))
        # joint 4's point over phi: distance^2 from p2 in [m - s, m + s]; the representative takes the middle of that
        # range's overlap with the 2R arm's [dmin2, dmax2], away from both edges (their middle clamped onto the arm's
        # range sat on its stretched or folded edge wherever they barely overlap, a double root that rounding,
        # float's above all, left least squares); where they do not overlap, the arm's edge nearest m, least squares
        s = steps(f"ms{i}", 2 * sp.sqrt(positive((_sq(u) - uh * uh) * (_sq(v) - dot(H[1], v) ** 2))))
        lo = steps(f"mlo{i}", _select((m - s, m - s > dmin2), (dmin2, True)))
        hi = steps(f"mhi{i}", _select((m + s, m + s < dmax2), (dmax2, True)))
        dstar = steps(f"dstar{i}", _select((0.5 * (lo + hi), lo <= hi), (dmax2, m > dmax2), (dmin2, m < dmin2), (m, True)))
        firsts: tuple = ()
        for j, q5 in enumerate(sp4(steps, f"q5_{i}", H[1], H[5], H[4], dot(H[1], g),
                                   unit_disc(H[1], H[5], H[4], g))):
            if flip and j == 1:
                q5_0, q6_0, phi_0, split_0 = firsts
                # the first root's q6 is the continuum's representative only where split (sine at most SPLIT_TOL);
                # where q6's SP1 is merely flagged singular (sine up to about 1e-9) the flip is another exact
                # solution, with its own 2R arm; copying the first root's rows there lost it (and a reachable target
                # came back unreachable where only the flip's 2R arm reaches)
                same = steps(f"same{i}", split_0)
                q5 = Angle(steps(f"q5f_{i}", _select((q5_0.theta, same > 0), (-q5_0.theta, True))), None, None,
                           q5.ls, q5.singular)
                q6 = _half_turn(steps, f"q6f_{i}", q6_0, same)
                turned = _half_turn(steps, f"phif_{i}", phi_0, same)
                phi = Angle(turned.theta, steps(f"phifc_{i}", _select((phi_0.c, same > 0), (-phi_0.c, True))),
                            steps(f"phifs_{i}", _select((phi_0.s, same > 0), (-phi_0.s, True))), phi_0.ls, phi_0.singular)
                out += _three_parallel_arm(steps, H, P, V, Q0, q1, q5, q6, phi, f"{i}{j}", signs)
                continue
            b = steps.vec(f"b{i}{j}", _rot(q5, H[4], H[1], True))
            q6r = sp1_parts(steps, f"q6_{i}{j}", H[5], a, b)
            # wrist aligned (h6 after q5 parallel to h2): q6 and phi share one rotation angle sigma and
            # the split is free; the representative puts joint 4's point at the distance from p2 nearest the
            # middle of both its range over phi and the 2R arm's range [dmin, dmax], so the 2R arm reaches it.
            # the split is taken where h6 and R5^T h2 are within SPLIT_TOL (sine): below it q6's SP1 is noise
            # (q5 = 1e-16 from an exactly aligned target); above it the regular path is exact to rounding
            bb = cross(H[5], b)
            bb2, b2 = steps(f"bb{i}{j}", dot(bb, bb)), steps(f"b2{i}{j}", dot(b, b))  # named: cheap relational
            sel = steps(f"split{i}{j}", indicator(bb2 <= SPLIT_SYMBOL**2 * b2))
            pick = sel > 0
            x5 = steps.vec(f"x5_{i}{j}", _rot(q5, H[4], x, True))
            z = _rot(q1, H[0], steps.vec(f"Rx5_{i}{j}", matvec(RG, x5)), True)
            sigma = sp1_parts(steps, f"sig{i}{j}", H[1], x, steps.vec(f"z{i}{j}", z))
            # one atan2 for sigma (split) or q6 (regular), one for phi's two forms: the inputs are selected, so
            # each path's angle, cosine and sine are bit for bit its own. Where split, phi's regular form below
            # is computed from sigma's cosine and sine, finite and unused
            t6 = choose_parts(steps, f"t6{i}{j}", pick, sigma, q6r).angle(steps, f"t6{i}{j}")
            y = _rot(q1, H[0], steps.vec(f"Rx6_{i}{j}", matvec(RG, steps.vec(f"x6_{i}{j}", _rot(t6, H[5], x5, True)))), True)
            phir = sp1_parts(steps, f"phi{i}{j}", H[1], x, steps.vec(f"y{i}{j}", y))
            phis = sp3_parts(steps, f"phis{i}{j}", H[1], v, u, dstar)[0][0]
            r5h6 = _rot(q5, H[4], H[5])
            h2r = steps(f"h2r{i}{j}", dot(H[1], r5h6))
            sgn = steps(f"sgn{i}{j}", _select((sp.S.One, h2r >= 0), (-sp.S.One, True)))
            ls = steps(f"phils{i}{j}", _select((phis.ls, pick), (phir.ls, True)))
            phi = choose_parts(steps, f"ph{i}{j}", pick, phis, phir, ls, q6r.singular).angle(steps, f"phit{i}{j}")
            # split: q6 = +-(sigma - phi), in [-2 pi, 2 pi]; one turn toward 0 puts it in [-pi, pi] like every
            # other angle here (the post-processing's shift would do the same for a centre of 0; done here, the
            # column needs none: solver_closed)
            split = steps(f"q6s{i}{j}", sgn * (t6.theta - phi.theta))
            wrapped = _select((split - 2 * PI_DOUBLE, split > PI_DOUBLE), (split + 2 * PI_DOUBLE, split < -PI_DOUBLE),
                              (split, True))
            q6 = Angle(steps.principal(f"q6t{i}{j}", _select((wrapped, pick), (t6.theta, True))), None, None,
                       q6r.ls, steps(f"q6sg{i}{j}", any_of(sel, q6r.singular)))
            firsts = (q5, q6, phi, sel)
            out += _three_parallel_arm(steps, H, P, V, Q0, q1, q5, q6, phi, f"{i}{j}", signs)
            if members is not None and flip and j == 0:
                members.append((_continuum_members(steps, H, P, V, Q0, q1, q5, q6, phi, phi_ref, s0, f"{i}", signs), sel))
    return out


def _continuum_members(steps: Steps, H, P, V, Q0, q1: Angle, q5: Angle, q6: Angle, phi: Angle, phi_ref: sp.Expr,
                       s0: int, label: str, signs: tuple[int, int]) -> list[Branch]:
    """The aligned wrist's continuum at ``phi_ref``: ``q6`` moved by ``sigma (phi - phi_ref)`` (``phi + sigma q6`` is
    the rotation about h2 there), the 2R arm's two branches for the wrist point that ``phi_ref`` puts joint 4's point
    at (see :func:`three_parallel`)."""
    even = steps(f"mev{label}", indicator(sp.Abs(q5.theta) <= PI_DOUBLE / 2))
    sigma = s0 * (2 * even - 1)
    # wrapped into [-pi, pi] by its sine and cosine: phi_ref is any number, and phi at +-pi (atan2 of a signed zero)
    # would otherwise give q6 a turn's difference between languages
    moved = steps(f"q6mu{label}", q6.theta + sigma * (phi.theta - phi_ref))
    q6m = Angle(steps(f"q6m{label}", sp.atan2(steps(f"q6ms{label}", sp.sin(moved)), steps(f"q6mc{label}", sp.cos(moved)))),
                None, None, q6.ls, sp.S.One)
    phim = Angle(phi_ref, steps(f"phimc{label}", sp.cos(phi_ref)), steps(f"phims{label}", sp.sin(phi_ref)),
                 sp.S.Zero, sp.S.One)
    return _three_parallel_arm(steps, H, P, V, Q0, q1, q5, q6m, phim, f"m{label}", signs)


def _three_parallel_arm(steps: Steps, H, P, V, Q0, q1: Angle, q5: Angle, q6: Angle, phi: Angle, label: str,
                        signs: tuple[int, int]) -> list[Branch]:
    """The two branches of the 2R arm (q2, q3; ``q4 = s4 (phi - q2 - s3 q3)``, ``(s3, s4) = signs``: see
    :func:`three_parallel`) for the wrist angles q1, q5, q6, phi."""
    s3, s4 = signs
    out = []
    P4 = steps.vec(f"P4_{label}", sub(V, _rot(phi, H[1], sub(Q0, P[3]))))
    for k, q3 in enumerate(sp3(steps, f"q3_{label}", H[2], sub(P[3], P[2]), sub(P[1], P[2]), _sq(sub(P4, P[1])))):
        X = add(_rot(q3, H[2], sub(P[3], P[2])), P[2])
        q2 = sp1(steps, f"q2_{label}{k}", H[1], steps.vec(f"X{label}{k}", sub(X, P[1])), sub(P4, P[1]))
        q4 = Angle(steps(f"q4_{label}{k}", s4 * (phi.theta - q2.theta - s3 * q3.theta)), None, None, phi.ls, phi.singular)
        out.append(Branch((q1, q2, q3, q4, q5, q6)))
    return out
