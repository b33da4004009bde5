"""The chains' pose and position IK, described once in the IR and printed by every backend.

``ik_solve(q0, target, [params], lambda, tol, max_iter, q, error, iterations)`` (pose, ``target`` the
4 x 4 tool pose, row-major) and ``ik_solve_position`` (``target`` the tool origin, 3), on top of the
derived ``ik_terms`` (tool pose T and Jacobian J at once):

* error ``e = [p_t - p; log3(R_t R^T)]`` in base axes (J is LOCAL_WORLD_ALIGNED, so ``dq = J^+ e``
  moves toward the target to first order);
* Levenberg-Marquardt step ``dq = J^T (J J^T + mu2 I)^-1 e`` with ``mu2 = max(c |e|, lambda^2 min(1, |e|)^2)``:
  damping proportional to the error (Fan and Yuan's delta = 1), which vanishes at the solution so the
  last steps are Gauss-Newton's and converge quadratically, yet is large near singular poses; the user's
  ``lambda`` is a floor on it only while the error is large (above 1 m or 1 rad it applies fully, and it
  fades with the square of the error below), so a usual damped-least-squares ``lambda`` shapes the path
  near singular poses but never stops the final convergence. (It faded in proportion to the error at
  first: ``lambda = 1`` then converged on 71-75 % of random targets in 100 steps, ``lambda = 3`` on none
  even in 3000, its floor ``9 |e|`` outweighing the small singular values squared; with the square, 99 % and
  98 % in 1000 steps.) A step is accepted when it lowers
  ``|e|`` (then ``c *= C_DOWN``, down to ``C_MIN``), else ``c *= C_UP``;
* geodesic acceleration: after a step that left ``|e|`` above ``GEO_GATE`` of its start, and while ``|e|`` is
  below ``GEO_ERROR``, the step gets Transtrum and Sethna's second-order correction (one pose evaluation, the
  same factors), which follows a curved valley of ``|e|`` where the straight step overshoots: near a singular
  target (a KUKA KR 6 pose whose smallest singular value is 8e-5) the plain steps crept, the attempts restarted
  and 1000 steps did not converge; with the correction 32 do;
* stationary points: where ``|J_f^T e| <= STATIONARY |J_f|_F |e|`` the step is Gauss-Newton's (``mu2 = C_MIN |e|``,
  or lambda's floor) instead of the damped one. Near a nearly aligned wrist the error left lies along J's weak
  direction; the damped step crept there while the test ended each attempt (Stanford, ``q5 = 1e-6``: 67 of 80
  targets converged in 100 steps, now 80), and at a true stationary point the longer step is rejected as the
  damped one made no progress;
* step cap: the step is scaled down whole (same direction) where a joint that turns would move more than
  ``STEP_MAX``; slides are not capped;
* joint limits: a step is clamped into ``[lower, upper]``; joints on a bound that the step pushes
  outward are removed from it (their columns zeroed, the step solved again), so the free joints still
  make the progress clamping would kill; revolute joints whose range spans 2 pi or more wrap by 2 pi;
* restarts: an attempt ends when it stalls (``c > C_MAX``, or an accepted step improving ``|e|`` by less
  than a relative ``STALL``), when a step starts at a (near) stationary point of ``|e|`` over the free
  joints (``|J_f^T e| <= STATIONARY |J_f|_F |e|``) and does not cut ``|e|`` below ``PROGRESS`` of its start
  (near a stretched elbow the error lies along a weak direction of J and the test alone misjudges it: SCARA's
  attempts restarted at errors of 1e-10), when its error is above ``PROGRESS`` times its error
  ``WINDOW`` steps earlier (unless every step of that window was accepted with ``c |e|`` above ``J J^T``'s mean
  eigenvalue: such a window is slow because of the damping, which halves with each step, as for a slide's
  target metres away or an arm described in millimetres), or after ``ATTEMPT`` steps. The next attempt starts from the best of
  ``CANDIDATES`` random configurations by tool position error, drawn from ``SHRINK`` times the limits'
  range around its centre on even restarts and from the whole range on odd ones (revolute joints whose
  range spans a turn or more: the turn nearest zero within the limits, [-pi, pi] where it fits) by xorshift64* with a fixed seed: the same input gives the
  same result in every backend. Steps of all attempts count against ``max_iter``.

Statuses: CONVERGED (``|p_t - p| <= tol`` and ``|log3| <= tol``), STALLED (the budget ran out and the best
pose found ended its attempt at or near a stationary point of ``|e|``: an unreachable target's closest
reach, or a local minimum of a reachable one, which more steps or another ``q0`` may leave; about 1 % of random
reachable targets of the 6- and 7-joint examples end so within the default 100 steps and converge within 1000),
MAX_ITER (the budget ran out otherwise; ``q`` is the best pose found), INVALID.
"""

from __future__ import annotations

import functools
import math
import operator

from ...ir.build import Array, Body, atan2, fabs, select, sqrt, total
from ...ir.nodes import Argument, Bits, Call1, Cast, Const, Function, NamedConst, Role, Type, Var, eq
from .target_rotation import NOT_A_ROTATION, refusal, rotation_faults

C_START = 0.01
"""Initial damping ``mu2`` per unit of error."""
C_MIN, C_MAX = 1e-8, 1e8
C_UP, C_DOWN = 4.0, 0.5
STEP_MAX = 1.0
"""Largest move of a joint that turns in one step (rad): longer steps are scaled down whole (same direction).
Slides are not capped: the tool moves linearly with a slide, and the damping and the acceptance test bound a
step that the linear model misjudges (a 1 m cap had stalled a gantry's 10 m move)."""
ATTEMPT = 25
"""Steps of one attempt before a restart."""
WINDOW, PROGRESS = 3, 0.6
"""An attempt restarts when its error is above PROGRESS times its error WINDOW steps earlier."""
STATIONARY = 0.02
"""A step starting where ``|J_f^T e| <= STATIONARY |J_f|_F |e|`` (a stationary point) ends the attempt."""
CANDIDATES = 8
"""Random configurations drawn per restart; the attempt starts from the one whose tool is nearest the target."""
SHRINK = 0.5
"""Even restarts draw bounded joints from this fraction of their range around its centre."""
SEED = 0x5EED5EED
"""The restarts' seed (xorshift64*)."""
GEO_H = 0.1
"""Fraction of the step at which the geodesic correction probes the error (a forward difference)."""
GEO_ALPHA = 0.75
"""The correction is taken only when ``|a| <= GEO_ALPHA |dq|`` (Transtrum and Sethna's bound on the acceleration)."""
GEO_GATE, GEO_ERROR = 0.5, 0.05
"""The correction is computed after a step that left ``|e|`` above ``GEO_GATE`` of its start (rejected, or slow),
while ``|e| < GEO_ERROR`` (m or rad): where the linear model fails near the solution, as at a target near a
singular pose; elsewhere the steps cost what they did."""
FLOOR_ERROR = 1.0
"""The error norm (m or rad) above which ``lambda^2`` floors the damping fully; below, the floor fades with the
square of the error."""
SETTINGS = {
    "double": {"tol": 1e-10, "pivot": 1e-13, "stall": 1e-9, "big": 1e300},
    "float": {"tol": 1e-5, "pivot": 1e-6, "stall": 1e-6, "big": 1e30},
}
"""Per precision: default tolerance (Python callers; C callers pass tol), LDL^T pivot cut-off (a pivot at
most this times the largest diagonal entry is dropped), relative stall, what an absent limit is."""

STATUSES = (
    ("IK_CONVERGED", 0, "position error and rotation error are both <= tol"),
    ("IK_STALLED", 1, "max_iter ran out and the best pose found is a stationary point of |e| (an unreachable "
                      "target: q is its closest reach found; or a local minimum: more steps or another q0 may converge)"),
    ("IK_MAX_ITER", 2, "max_iter ran out otherwise (q: the best pose found)"),
    ("IK_INVALID", 3, "q0, target, params or lambda not finite, lambda < 0, tol <= 0 or not finite, or "
                      "max_iter < 0 (q = q0, nothing computed)"),
)
"""Return codes of ``ik_solve_position``; ``ik_solve``'s are :data:`POSE_STATUSES`."""
POSE_STATUSES = STATUSES[:-1] + (
    ("IK_INVALID", 3, "q0, target, params or lambda not finite, lambda < 0, tol <= 0 or not finite, max_iter < 0, "
                      "or the target's " + NOT_A_ROTATION + " (q = q0, nothing computed)"),
)
"""Return codes of ``ik_solve`` (pose targets): the target's rotation part must be a rotation as well."""


def _status(name: str) -> NamedConst:
    return NamedConst(name, Type.INT)


def _tree(terms: list) -> object:
    """A sum of ``terms`` paired into a balanced tree (shorter dependency chains)."""
    if len(terms) == 1:
        return terms[0]
    half = len(terms) // 2
    return _tree(terms[:half]) + _tree(terms[half:])


def _less(head, terms: list) -> object:
    """``head - sum(terms)`` with the sum paired and the last term subtracted last."""
    if not terms:
        return head
    if len(terms) == 1:
        return head - terms[0]
    return (head - _tree(terms[:-1])) - terms[-1]


def limits_of(chain, precision: str) -> dict:
    """Bounds, restart ranges and periodic coordinates of ``chain`` (see the module docstring)."""
    limits = chain.limits()
    big = SETTINGS[precision]["big"]
    lower = [-big if x is None else float(x) for x in limits["lower"]]
    upper = [big if x is None else float(x) for x in limits["upper"]]
    draw_low = [-math.pi if x is None else float(x) for x in limits["lower"]]
    draw_span = [(math.pi if u is None else float(u)) - d for u, d in zip(limits["upper"], draw_low)]
    periodic = [True] * chain.n
    for j in chain.joints:
        m = float(j.multiplier)
        if j.kind != "revolute" or m != round(m):
            periodic[j.coordinate] = False
    wrapped = [k for k in range(chain.n) if periodic[k] and upper[k] - lower[k] >= 2 * math.pi]
    for k in wrapped:  # one turn, the one nearest zero within the limits (a file's +-1e16 is no place to draw from)
        centre = min(max(0.0, lower[k] + math.pi), upper[k] - math.pi)
        draw_low[k], draw_span[k] = centre - math.pi, 2 * math.pi
    near_low = [d if k in wrapped else d + s * ((1.0 - SHRINK) / 2.0) for k, (d, s) in enumerate(zip(draw_low, draw_span))]
    near_span = [s if k in wrapped else s * SHRINK for k, s in enumerate(draw_span)]
    slides = [k for k in range(chain.n) if all(j.kind == "prismatic" for j in chain.joints if j.coordinate == k)]
    return {"lower": lower, "upper": upper, "draw_low": draw_low, "draw_span": draw_span, "near_low": near_low,
            "near_span": near_span, "wrapped": wrapped, "slides": slides}


# -- helpers ------------------------------------------------------------------------------------------------

def uniform_helper() -> Function:
    """``ik_uniform(state)``: xorshift64* (Vigna), a number in [0, 1) from the top 53 bits; the state lives
    with the caller."""
    b = Body()
    state = Array("state", 1, Type.UINT64)
    s = b.var("s", state[0], Type.UINT64)
    b.set(s, Bits("^", s, Bits(">>", s, Const(12, Type.INT))))
    b.set(s, Bits("^", s, Bits("<<", s, Const(25, Type.INT))))
    b.set(s, Bits("^", s, Bits(">>", s, Const(27, Type.INT))))
    b.set(state[0], s)
    b.return_(Cast(Type.REAL, Bits(">>", Bits("*", s, Const(0x2545F4914F6CDD1D, Type.UINT64)), Const(11, Type.INT)))
              * (1.0 / 9007199254740992.0))
    return Function("ik_uniform", "a number in [0, 1) from xorshift64*", (Argument("state", Role.OUTPUT, (1,), Type.UINT64),),
                    b.statements, kind="helper", returns=Type.REAL)


def log3_helper() -> Function:
    """``ik_log3(M, w)``: the axis-angle vector of the rotation ``M`` (row-major), accurate near 0 and pi."""
    b = Body()
    M, w = Array("M", 9), Array("w", 3)
    v0 = b.let("v0", M[7] - M[5])
    v1 = b.let("v1", M[2] - M[6])
    v2 = b.let("v2", M[3] - M[1])
    c = b.let("c", (M[0] + M[4] + M[8] - 1.0) * 0.5)
    s = b.let("s", sqrt(v0 * v0 + v1 * v1 + v2 * v2) * 0.5)
    angle = b.let("angle", atan2(s, c))
    k = b.var("k")
    with b.if_(angle < 1e-4):
        b.set(k, 0.5 + angle * angle * (1.0 / 12.0))
        for i, v in enumerate((v0, v1, v2)):
            b.set(w[i], v * k)
        b.return_()
    with b.if_(math.pi - angle > 1e-3):
        b.set(k, angle / (s + s))
        for i, v in enumerate((v0, v1, v2)):
            b.set(w[i], v * k)
        b.return_()
    b.comment("near pi: (M + M^T)/2 - cos(angle) I = (1 - cos) a a^T; its column of the largest diagonal entry")
    col = b.array("col", 3)
    i = b.var("i", select(M[0] >= M[4], select(M[0] >= M[8], Const(0, Type.INT), Const(2, Type.INT)),
                          select(M[4] >= M[8], Const(1, Type.INT), Const(2, Type.INT))), Type.INT)
    three = Const(3, Type.INT)
    b.set(col[0], (M[i] + M[three * i]) * 0.5)
    b.set(col[1], (M[three + i] + M[three * i + Const(1, Type.INT)]) * 0.5)
    b.set(col[2], (M[Const(6, Type.INT) + i] + M[three * i + Const(2, Type.INT)]) * 0.5)
    b.set(col[i], col[i] - c)
    norm = b.let("norm", sqrt(col[0] * col[0] + col[1] * col[1] + col[2] * col[2]))
    b.set(k, select(col[0] * v0 + col[1] * v1 + col[2] * v2 < 0.0, -angle, angle) / norm)
    for j in range(3):
        b.set(w[j], col[j] * k)
    return Function("ik_log3", "w = log3(M), the axis-angle vector of the rotation M (row-major)",
                    (Argument("M", Role.DATA, (9,)), Argument("w", Role.OUTPUT, (3,))), b.statements, kind="helper")


def error_helper(rows: int, suffix: str) -> Function:
    """``ik_error{suffix}(Tm, target, e, norms)``: e = [target - p; log3(R_target R^T)] at the pose Tm, and its
    position, rotation and whole norms (finite for any finite target: sums that overflow are rescaled)."""
    b = Body()
    tsize = 16 if rows == 6 else 3
    Tm, target, e, norms = Array("Tm", 16), Array("target", tsize), Array("e", rows), Array("norms", 3)
    if rows == 6:
        M = b.array("M", 9)
        for i in range(3):
            b.set(e[i], target[4 * i + 3] - Tm[4 * i + 3])
        for i in range(3):
            for j in range(3):
                b.set(M[3 * i + j], target[4 * i] * Tm[4 * j] + target[4 * i + 1] * Tm[4 * j + 1] + target[4 * i + 2] * Tm[4 * j + 2])
        b.call("ik_log3", M, e.at(3))
        b.set(norms[1], b.norm("rotation", [e[3], e[4], e[5]]))
    else:
        for i in range(3):
            b.set(e[i], target[i] - Tm[4 * i + 3])
        b.set(norms[1], 0.0)
    b.set(norms[0], b.norm("position", [e[0], e[1], e[2]]))
    b.set(norms[2], b.norm("whole", [norms[0], norms[1]]))
    what = "[target - p; log3(R_target R^T)]" if rows == 6 else "target - p"
    return Function(f"ik_error{suffix}", f"e = {what} at the pose Tm; norms = its position, rotation and whole norms",
                    (Argument("Tm", Role.STATE, (16,)), Argument("target", Role.DATA, (tsize,)),
                     Argument("e", Role.OUTPUT, (rows,)), Argument("norms", Role.OUTPUT, (3,))),
                    b.statements, kind="helper")


def _packed(r: int, c: int) -> int:
    """Index of entry (r, c), c <= r, of a lower triangle packed by rows."""
    return r * (r + 1) // 2 + c


def _triangle(rows: int) -> int:
    """Entries of a packed lower triangle of ``rows`` rows."""
    return rows * (rows + 1) // 2


def gram_helper(rows: int, n: int, suffix: str) -> Function:
    """``ik_gram{suffix}(J, G)``: G = J J^T for J's first rows, lower triangle packed by rows."""
    b = Body()
    J, G = Array("J", 6 * n), Array("G", _triangle(rows))
    for r in range(rows):
        for c in range(r + 1):
            b.set(G[_packed(r, c)], total([J[r * n + j] * J[c * n + j] for j in range(n)]))
    return Function(f"ik_gram{suffix}", f"G = J J^T for the first {rows} rows of J (lower triangle, packed by rows)",
                    (Argument("J", Role.STATE, (6 * n,)), Argument("G", Role.OUTPUT, (_triangle(rows),))),
                    b.statements, kind="helper")


def ldl_helper(rows: int, suffix: str, precision: str) -> Function:
    """``ik_ldl{suffix}(G, mu2, F)``: the unpivoted LDL^T of ``G + mu2 I`` into ``F`` (packed by rows: the
    diagonal holds 1 / D, or 0 where a pivot at most ``pivot`` times the largest diagonal entry is dropped,
    below it L), so a rank-deficient J with mu2 = 0 gives a finite step. Straight-line."""
    b = Body()
    G, F = Array("G", _triangle(rows)), Array("F", _triangle(rows))
    mu2 = Var("mu2")
    a = {}
    for r in range(rows):
        for c in range(r):
            a[r, c] = b.let(f"a{r}{c}", G[_packed(r, c)])
        a[r, r] = b.let(f"a{r}{r}", G[_packed(r, r)] + mu2)
    cut = b.let("cut", _max_tree([a[r, r] for r in range(rows)]) * SETTINGS[precision]["pivot"])
    lower, scaled = {}, {}
    for c in range(rows):
        s = b.let(f"s{c}", _less(a[c, c], [lower[c, j] * scaled[c, j] for j in range(c)]))
        kept = b.let(f"kept{c}", s > cut, Type.BOOL)
        inv = b.let(f"i{c}", select(kept, 1.0 / s, 0.0))
        b.set(F[_packed(c, c)], inv)
        for r in range(c + 1, rows):
            t = b.let(f"t{r}{c}", _less(a[r, c], [lower[r, j] * scaled[c, j] for j in range(c)]))
            lower[r, c] = b.let(f"l{r}{c}", t * inv)
            b.set(F[_packed(r, c)], lower[r, c])
            scaled[r, c] = b.let(f"ld{r}{c}", select(kept, t, 0.0))
    return Function(f"ik_ldl{suffix}", "F = the LDL^T of G + mu2 I (1/D on the diagonal, 0 for a dropped pivot; L below)",
                    (Argument("G", Role.DATA, (_triangle(rows),)), Argument("mu2", Role.SCALAR, ()),
                     Argument("F", Role.OUTPUT, (_triangle(rows),))),
                    b.statements, kind="helper")


def ldl_solve_helper(rows: int, n: int, suffix: str) -> Function:
    """``ik_ldl_solve{suffix}(J, F, e, dq)``: dq = J^T (G + mu2 I)^-1 e from the factors ``F`` of
    :func:`ldl_helper` (a dropped pivot's unknown is 0). Straight-line."""
    b = Body()
    J, F, e, dq = Array("J", 6 * n), Array("F", _triangle(rows)), Array("e", rows), Array("dq", n)
    y = {}
    for r in range(rows):
        y[r] = b.let(f"y{r}", _less(e[r], [F[_packed(r, j)] * y[j] for j in range(r)]))
    z = {}
    for r in range(rows - 1, -1, -1):
        z[r] = b.let(f"z{r}", _less(y[r] * F[_packed(r, r)], [F[_packed(j, r)] * z[j] for j in range(rows - 1, r, -1)]))
    for j in range(n):
        b.set(dq[j], _tree([J[r * n + j] * z[r] for r in range(rows)]))
    return Function(f"ik_ldl_solve{suffix}", "dq = J^T (G + mu2 I)^-1 e from the LDL^T factors F",
                    (Argument("J", Role.STATE, (6 * n,)), Argument("F", Role.DATA, (_triangle(rows),)),
                     Argument("e", Role.DATA, (rows,)), Argument("dq", Role.OUTPUT, (n,))),
                    b.statements, kind="helper")


def _max_tree(values: list) -> object:
    out = values[0]
    for v in values[1:]:
        out = select(v > out, v, out)
    return out


# -- the solver ---------------------------------------------------------------------------------------------

class _PoseIK:
    """Writes one solver (rows 6: pose, 3: position) into a :class:`Body`, part by part: the locals, the
    checks and start, one Levenberg-Marquardt step (with blocked joints), its acceptance, the windowed
    progress test with its restart, and the end. Each method is one part of the algorithm of the module
    docstring; the attributes are the solver's locals."""

    def __init__(self, chain, rows: int, params: int, precision: str) -> None:
        self.n, self.rows, self.params, self.s = chain.n, rows, params, SETTINGS[precision]
        self.tsize = 16 if rows == 6 else 3
        self.suffix = "_pose" if rows == 6 else "_position"
        self.gsize = _triangle(rows)
        self.lim = limits_of(chain, precision)
        self.b = Body()
        self.q0, self.target, self.q = Array("q0", self.n), Array("target", self.tsize), Array("q", self.n)
        self.err_out, self.iters = Array("error", 2 if rows == 6 else 1), Array("iterations", 1, Type.INT)
        self.lam, self.tol, self.max_iter = Var("lambda"), Var("tol"), Var("max_iter", Type.INT)
        self.param_args = [Array("params", params)] if params else []
        self.zero, self.one = Const(0, Type.INT), Const(1, Type.INT)
        self._declare()

    def _declare(self) -> None:
        b, n, rows, lim = self.b, self.n, self.rows, self.lim
        for name in ("lo", "hi", "draw_lo", "draw_span", "near_lo", "near_span"):
            key = {"lo": "lower", "hi": "upper", "draw_lo": "draw_low", "near_lo": "near_low"}.get(name, name)
            setattr(self, name, b.array(name, n, values=lim[key], const=True))
        self.Tm, self.Tt = b.array("Tm", 16), b.array("Tt", 16)
        self.J, self.Jt, self.Jf = b.array("J", 6 * n), b.array("Jt", 6 * n), b.array("Jf", 6 * n)
        self.e, self.et = b.array("e", rows), b.array("et", rows)
        self.trial, self.dq, self.best_q = b.array("trial", n), b.array("dq", n), b.array("best_q", n)
        self.G, self.Gf, self.F = b.array("G", self.gsize), b.array("Gf", self.gsize), b.array("F", self.gsize)
        self.norms = b.array("norms", 3)
        self.r2, self.acc = b.array("r2", rows), b.array("acc", n)
        self.blocked = b.array("blocked", n, Type.INT)
        self.state = b.array("state", 1, Type.UINT64, values=[Const(SEED ^ 0x9E3779B97F4A7C15, Type.UINT64)])
        for name in ("pe", "re", "en", "pet", "ret", "ent", "mu2", "big", "scale", "gg", "ff", "aa", "vv"):
            setattr(self, name, b.var(name, 0.0))
        self.c = b.var("c", C_START)
        self.checkpoint, self.window_start = b.var("checkpoint", 0.0), b.var("window_start", 0.0)
        self.best_en, self.best_pe = b.var("best_en", 0.0), b.var("best_pe", 0.0)
        self.best_re = b.var("best_re", 0.0) if rows == 6 else None
        for name, value in (("gram_ready", 0), ("any_", 0), ("it", 0), ("attempt", 0), ("stalled", 0), ("slow", 0),
                            ("stationary", 0), ("curved", 0), ("restarts", 0), ("best_stalled", 0), ("best_here", 1),
                            ("damped", 1)):
            setattr(self, name, b.var(name.rstrip("_"), value, Type.INT))
        self.scratch = (b.var("nearest", 0.0), b.var("u", 0.0), b.var("d", 0.0))
        self.mu2_floor = b.let("mu2_floor", self.lam * self.lam)

    # -- small pieces -----------------------------------------------------------------------------------
    def copy(self, dst: Array, src: Array, size: int) -> None:
        with self.b.for_("k", 0, size) as k:
            self.b.set(dst[k], src[k])

    def evaluate(self, x: Array, T: Array, JJ: Array, ee: Array) -> None:
        """T, J, e and the norms at the pose x."""
        self.b.call("ik_terms", x, *self.param_args, T, JJ)
        self.b.call(f"ik_error{self.suffix}", T, self.target, ee, self.norms)

    def take_norms(self, pe: Var, re: Var, en: Var) -> None:
        self.b.set(pe, self.norms[0])
        self.b.set(re, self.norms[1])
        self.b.set(en, self.norms[2])

    def remember_best(self, stalled) -> None:
        b = self.b
        b.set(self.best_en, self.en)
        b.set(self.best_pe, self.pe)
        if self.best_re is not None:
            b.set(self.best_re, self.re)
        if stalled is not None:
            b.set(self.best_stalled, stalled)
            b.set(self.best_here, self.one)
        self.copy(self.best_q, self.q, self.n)

    # -- the parts -------------------------------------------------------------------------------------
    def start(self) -> None:
        """Checks (INVALID), q0 clamped into the limits, the first error."""
        b, n = self.b, self.n
        self.copy(self.q, self.q0, n)
        b.set(self.iters[0], 0)
        for k in range(2 if self.rows == 6 else 1):
            b.set(self.err_out[k], Const(math.inf))
        lam, tol = self.lam, self.tol
        with b.if_(~Call1("isfinite", lam) | (lam < 0.0) | ~Call1("isfinite", tol) | ~(tol > 0.0) | (self.max_iter < 0)):
            b.return_(_status("IK_INVALID"))
        read = 12 if self.rows == 6 else self.tsize  # a pose target's last row is not read
        for name, size, tested in (("q0", n, n), ("target", self.tsize, read)) + ((("params", self.params, self.params),) if self.params else ()):
            with b.for_("k", 0, tested) as k:
                with b.if_(~Call1("isfinite", Array(name, size)[k])):
                    b.return_(_status("IK_INVALID"))
        if self.rows == 6:
            with b.if_(functools.reduce(operator.or_, rotation_faults(b, self.target))):
                b.return_(_status("IK_INVALID"))
        q, lo, hi = self.q, self.lo, self.hi
        with b.for_("k", 0, n) as k:
            b.set(q[k], select(q[k] < lo[k], lo[k], select(q[k] > hi[k], hi[k], q[k])))
        self.evaluate(q, self.Tm, self.J, self.e)
        self.take_norms(self.pe, self.re, self.en)
        self.remember_best(None)
        b.set(self.checkpoint, self.en)
        b.set(self.window_start, self.en)

    def converged_or_out_of_budget(self) -> None:
        """At the top of each step: CONVERGED, or (budget spent) the judgement of the last attempt."""
        b = self.b
        with b.if_((self.pe <= self.tol) & (self.re <= self.tol)):
            b.set(self.err_out[0], self.pe)
            if self.rows == 6:
                b.set(self.err_out[1], self.re)
            b.set(self.iters[0], self.it)
            b.return_(_status("IK_CONVERGED"))
        with b.if_(eq(self.it, self.max_iter)):
            b.comment("the budget ends inside the attempt holding the best pose: stalled when that attempt is at a "
                      "stationary point or no longer lowers |e| geometrically: the steps of its window run so far by "
                      f"less than {PROGRESS} to the power of their share of the window")
            steps = _mod(self.attempt, WINDOW)
            previous = select(eq(steps, 0), self.window_start, self.checkpoint)
            share = functools.reduce(lambda rest, k: select(eq(steps, k), PROGRESS ** (k / WINDOW), rest),
                                     range(1, WINDOW), PROGRESS)
            with b.if_((self.best_here > 0) & (self.attempt > 0) & eq(self.damped, 0)
                       & ((self.stationary > 0) | (self.en > previous * share))):
                b.set(self.best_stalled, self.one)
            b.break_()

    def damped_step(self) -> None:
        """dq by the damped least squares, solved again without the joints it pushes past a bound; the
        stationarity test on the free joints."""
        b, n, rows = self.b, self.n, self.rows
        fade = select(self.en < FLOOR_ERROR, self.en * (1.0 / FLOOR_ERROR), 1.0)
        floor = self.mu2_floor * fade * fade
        b.set(self.mu2, select(self.c * self.en > floor, self.c * self.en, floor))
        with b.if_(eq(self.gram_ready, 0)):
            b.call(f"ik_gram{self.suffix}", self.J, self.G)
            b.set(self.gram_ready, self.one)
        self.solve(self.J, self.G, self.e, self.dq)
        q, dq, lo, hi, blocked = self.q, self.dq, self.lo, self.hi, self.blocked
        with b.for_("k", 0, n) as k:
            b.set(blocked[k], select(((q[k] <= lo[k]) & (dq[k] < 0.0)) | ((q[k] >= hi[k]) & (dq[k] > 0.0)), self.one, self.zero))
        for p in self.lim["wrapped"]:
            b.set(blocked[p], self.zero)  # periodic: wraps by 2 pi instead
        b.set(self.any_, self.zero)
        with b.for_("k", 0, n) as k:
            with b.if_(blocked[k] > 0):
                b.set(self.any_, self.one)
        with b.if_(self.any_ > 0):
            b.comment("blocked columns zeroed, their outer products taken out of G, the step solved again")
            with b.for_("r", 0, rows) as r:
                with b.for_("k", 0, n) as k:
                    index = r * Const(n, Type.INT) + k
                    b.set(self.Jf[index], select(blocked[k] > 0, 0.0, self.J[index]))
            self.copy(self.Gf, self.G, self.gsize)
            with b.for_("k", 0, n) as k:
                with b.if_(blocked[k] > 0):
                    for r in range(rows):
                        for cc in range(r + 1):
                            g = self.Gf[_packed(r, cc)]
                            b.set(g, g - self.J[Const(r * n, Type.INT) + k] * self.J[Const(cc * n, Type.INT) + k])
            self.solve(self.Jf, self.Gf, self.e, dq)
            self.gradient(self.Jf, self.Gf)
        with b.else_():
            self.gradient(self.J, self.G)
        b.comment(f"stationary point of |e| over the free joints: |J_f^T e| <= {STATIONARY} |J_f|_F |e|")
        b.set(self.stationary, select(self.gg <= self.ff * self.en * self.en * (STATIONARY * STATIONARY), self.one, self.zero))
        with b.if_(self.stationary > 0):
            b.comment(f"at a stationary point the step is Gauss-Newton's (mu2 = {C_MIN:g} |e|, or lambda's floor): along a weak "
                      "direction of J (a nearly aligned wrist) it reaches the solution the damped step creeps toward; at a "
                      "true stationary point it is rejected, and the attempt ends as before")
            b.set(self.mu2, select(self.en * C_MIN > floor, self.en * C_MIN, floor))
            with b.if_(self.any_ > 0):
                self.solve(self.Jf, self.Gf, self.e, dq)
            with b.else_():
                self.solve(self.J, self.G, self.e, dq)
        b.comment("the window is damping-bound while every step's c |e| (the damping that halves with each accepted "
                  "step; not lambda's floor) outweighs J J^T's mean eigenvalue")
        b.set(self.damped, select(self.c * self.en * float(rows) > self.ff, self.damped, self.zero))
        with b.if_((self.curved > 0) & (self.en < GEO_ERROR)):
            self.geodesic()

    def geodesic(self) -> None:
        """Geodesic acceleration (Transtrum and Sethna, 2012): the second directional derivative of e along
        dq from one pose evaluation at ``q + GEO_H dq``, ``r2 = 2 (e(q + h dq) - e + h J dq) / h^2``, and the
        correction ``a = J^T (G + mu2 I)^-1 r2`` with the step's own factors; ``dq += a / 2`` when
        ``|a| <= GEO_ALPHA |dq|``. It bends the step along a curved valley of |e| (a target near a singular
        pose), where the straight step overshoots and the damping alone would creep."""
        b, n, rows = self.b, self.n, self.rows
        q, dq, trial = self.q, self.dq, self.trial
        with b.for_("k", 0, n) as k:
            b.set(trial[k], q[k] + dq[k] * GEO_H)
        b.call("pose", trial, *self.param_args, self.Tt)
        b.call(f"ik_error{self.suffix}", self.Tt, self.target, self.et, self.norms)
        with b.for_("r", 0, rows) as r:
            jv = total([self.J[r * Const(n, Type.INT) + Const(j, Type.INT)] * dq[j] for j in range(n)])
            b.set(self.r2[r], (self.et[r] - self.e[r] + jv * GEO_H) * (2.0 / (GEO_H * GEO_H)))
        with b.if_(self.any_ > 0):
            b.call(f"ik_ldl_solve{self.suffix}", self.Jf, self.F, self.r2, self.acc)
        with b.else_():
            b.call(f"ik_ldl_solve{self.suffix}", self.J, self.F, self.r2, self.acc)
        b.set(self.aa, 0.0)
        b.set(self.vv, 0.0)
        with b.for_("k", 0, n) as k:
            b.set(self.aa, self.aa + self.acc[k] * self.acc[k])
            b.set(self.vv, self.vv + dq[k] * dq[k])
        with b.if_(self.aa <= self.vv * (GEO_ALPHA * GEO_ALPHA)):
            with b.for_("k", 0, n) as k:
                b.set(dq[k], dq[k] + self.acc[k] * 0.5)

    def solve(self, JJ: Array, GG: Array, ee: Array, out: Array) -> None:
        """out = JJ^T (GG + mu2 I)^-1 ee, the factors kept in F."""
        self.b.call(f"ik_ldl{self.suffix}", GG, self.mu2, self.F)
        self.b.call(f"ik_ldl_solve{self.suffix}", JJ, self.F, ee, out)

    def gradient(self, JJ: Array, GG: Array) -> None:
        """gg = |J^T e|^2 and ff = |J|_F^2 (the trace of G) over the free joints."""
        b, n, rows = self.b, self.n, self.rows
        b.set(self.ff, total([GG[_packed(r, r)] for r in range(rows)]))
        b.set(self.gg, 0.0)
        with b.for_("k", 0, n) as k:
            g = total([JJ[Const(r * n, Type.INT) + k] * self.e[r] for r in range(rows)])
            b.set(self.gg, self.gg + g * g)

    def trial_step(self) -> None:
        """The trial pose: the step scaled so that no joint that turns moves more than STEP_MAX rad (slides are not
        capped), wrapped by 2 pi where periodic, clamped."""
        b, n, trial, lo, hi = self.b, self.n, self.trial, self.lo, self.hi
        b.set(self.big, 0.0)
        slides = self.lim["slides"]
        if not slides:
            with b.for_("k", 0, n) as k:
                b.set(self.big, select(fabs(self.dq[k]) > self.big, fabs(self.dq[k]), self.big))
        else:
            b.comment("the slides' moves are not capped: the tool moves linearly with each")
            for k in range(n):
                if k not in slides:
                    b.set(self.big, select(fabs(self.dq[k]) > self.big, fabs(self.dq[k]), self.big))
        b.set(self.scale, select(self.big > STEP_MAX, STEP_MAX / self.big, 1.0))
        with b.for_("k", 0, n) as k:
            b.set(trial[k], self.q[k] + self.dq[k] * self.scale)
        for p in self.lim["wrapped"]:
            with b.if_(trial[p] > hi[p]):
                b.set(trial[p], trial[p] - 2 * math.pi)
            with b.else_():
                with b.if_(trial[p] < lo[p]):
                    b.set(trial[p], trial[p] + 2 * math.pi)
        with b.for_("k", 0, n) as k:
            b.set(trial[k], select(trial[k] < lo[k], lo[k], select(trial[k] > hi[k], hi[k], trial[k])))
        self.evaluate(trial, self.Tt, self.Jt, self.et)
        self.take_norms(self.pet, self.ret, self.ent)
        b.set(self.it, self.it + self.one)
        b.set(self.attempt, self.attempt + self.one)

    def accept_or_reject(self) -> None:
        """Levenberg-Marquardt: a lower error is taken and lowers the damping; else the damping grows."""
        b, one, zero = self.b, self.one, self.zero
        b.set(self.curved, select(self.ent > self.en * GEO_GATE, one, zero))
        with b.if_(self.ent < self.en):
            b.comment(f"a step that cut |e| below {PROGRESS} of its start was not taken at a stationary point (the error lay "
                      "along a weak direction of J, as near a stretched elbow)")
            b.set(self.stationary, select(self.ent <= self.en * PROGRESS, zero, self.stationary))
            b.set(self.stalled, select(self.en - self.ent <= self.en * self.s["stall"], one, zero))
            self.copy(self.q, self.trial, self.n)
            self.copy(self.Tm, self.Tt, 16)
            self.copy(self.J, self.Jt, 6 * self.n)
            self.copy(self.e, self.et, self.rows)
            b.set(self.gram_ready, zero)
            b.set(self.pe, self.pet)
            b.set(self.re, self.ret)
            b.set(self.en, self.ent)
            b.set(self.c, select(self.c * C_DOWN > C_MIN, self.c * C_DOWN, C_MIN))
        with b.else_():
            b.set(self.c, self.c * C_UP)
            b.set(self.stalled, select(self.c > C_MAX, one, zero))
            b.set(self.damped, zero)
        with b.if_((self.en < self.best_en) | ((self.stalled > 0) & eq(self.en, self.best_en))):
            self.remember_best(self.stalled)

    def progress_and_restart(self) -> None:
        """The windowed progress test; an attempt that stalls, is slow or is long ends in a restart."""
        b, one, zero = self.b, self.one, self.zero
        with b.if_(~((self.pe <= self.tol) & (self.re <= self.tol))):
            b.set(self.slow, self.stationary)
            with b.if_(eq(_mod(self.attempt, WINDOW), 0)):
                b.comment("a window of accepted, damping-bound steps is not slow: each step halves the damping")
                with b.if_((self.en > self.checkpoint * PROGRESS) & eq(self.damped, 0)):
                    b.set(self.slow, one)
                b.set(self.damped, one)
                b.set(self.window_start, self.checkpoint)
                b.set(self.checkpoint, self.en)
            with b.if_(((self.stalled > 0) | (self.slow > 0) | (self.attempt >= ATTEMPT)) & (self.it < self.max_iter)):
                with b.if_(((self.stalled > 0) | (self.slow > 0)) & (self.best_here > 0)):
                    b.comment("this attempt's best is (near) a stationary point")
                    b.set(self.best_stalled, one)
                b.set(self.best_here, zero)
                _restart(b, self.n, self.rows, self.q, self.trial, self.Tt, self.Jt, self.target, self.param_args,
                         self.restarts, (self.near_lo, self.near_span), (self.draw_lo, self.draw_span), self.scratch)
                b.set(self.restarts, self.restarts + one)
                b.set(self.gram_ready, zero)
                self.evaluate(self.q, self.Tm, self.J, self.e)
                self.take_norms(self.pe, self.re, self.en)
                b.set(self.c, C_START)
                b.set(self.curved, zero)
                b.set(self.damped, one)
                b.set(self.attempt, zero)
                b.set(self.checkpoint, self.en)
                b.set(self.window_start, self.en)
                with b.if_(self.en < self.best_en):
                    self.remember_best(zero)

    def finish(self) -> None:
        """Out of budget: the best pose found, STALLED or MAX_ITER."""
        b = self.b
        self.copy(self.q, self.best_q, self.n)
        b.set(self.err_out[0], self.best_pe)
        if self.best_re is not None:
            b.set(self.err_out[1], self.best_re)
        b.set(self.iters[0], self.it)
        b.return_(select(self.best_stalled > 0, _status("IK_STALLED"), _status("IK_MAX_ITER")))

    def body(self):
        self.start()
        with self.b.while_(True):
            self.converged_or_out_of_budget()
            self.damped_step()
            self.trial_step()
            self.accept_or_reject()
            self.progress_and_restart()
        self.finish()
        return self.b.statements


def _solver_arguments(rows: int, n: int, params: int, default_tol: float) -> tuple[Argument, ...]:
    tsize_shape = (4, 4) if rows == 6 else (3,)
    return (
        Argument("q0", Role.STATE, (n,), domain="finite", batched=False, doc="start pose (rad or m)"),
        Argument("target", Role.DATA, tsize_shape, domain="finite", batched=False,
                 doc="tool pose (4 x 4, row-major; the last row is not read)" if rows == 6 else "tool origin (3)"),
        *([Argument("params", Role.PARAMETER, (params,), domain="finite", batched=False, doc="named parameters")] if params else []),
        Argument("lambda", Role.SCALAR, (), domain="nonnegative", batched=False, default=Const(0.0),
                 doc="damping floor while the error is large (>= 0)"),
        Argument("tol", Role.SCALAR, (), domain="positive", batched=False, default=Const(default_tol),
                 doc="stop when the position (m) and rotation (rad) errors are <= tol" if rows == 6 else
                 "stop when the position error (m) is <= tol"),
        Argument("max_iter", Role.SCALAR, (), Type.INT, batched=False, default=Const(100, Type.INT),
                 doc="at most this many steps over all attempts"),
        Argument("q", Role.OUTPUT, (n,), doc="the solution, or the best pose found"),
        Argument("error", Role.OUTPUT, (2 if rows == 6 else 1,), optional=True,
                 fields=("position_error", "rotation_error") if rows == 6 else ("error",),
                 doc="position error (m) and rotation error (rad) at q" if rows == 6 else "position error (m) at q"),
        Argument("iterations", Role.OUTPUT, (1,), Type.INT, optional=True, fields=("iterations",), doc="steps taken"),
    )


SUCCESS_BY_LAMBDA = (
    "Measured success (1000 random reachable poses and starts, tol 1e-10, 100 steps) for lambda = 0 / 1e-3 / 1e-2 / 0.1:",
    "UR5 100.0 / 100.0 / 100.0 / 99.9 %, Panda 99.3 / 99.3 / 99.3 / 99.4 %, PUMA 560 99.9 / 99.9 / 99.9 / 99.8 %.",
)
"""The pose IK's success against lambda, stated in every header (examples/robots/{ur5,panda,puma560}.toml,
targets and starts drawn within the limits as benchmarks/ik_success.py draws them; tests/test_user_reports.py
measures UR5's again)."""


def _success_lines(precision: str) -> tuple[str, ...]:
    """:data:`SUCCESS_BY_LAMBDA`, said to be the double build's where ``precision`` is another (its tol 1e-10 is
    out of a float's reach: there the figures describe the algorithm, not this build)."""
    if precision == "double":
        return SUCCESS_BY_LAMBDA
    first = SUCCESS_BY_LAMBDA[0].replace("Measured success (", "Measured success of the double-precision build (", 1)
    return (first, *SUCCESS_BY_LAMBDA[1:])


def _solver_doc(rows: int, default_tol: float, limited: bool = True, precision: str = "double") -> tuple[str, ...]:
    """The solver's documentation lines; ``limited``: some coordinate has a position limit (else the files
    have no Q_MIN/Q_MAX, and the lines say what happens instead)."""
    return (
        ("Pose IK: Levenberg-Marquardt on e = [p_target - p; log3(R_target R^T)] (base axes), step" if rows == 6 else
         "Position IK of the tool origin: Levenberg-Marquardt on e = p_target - p with the 3 linear rows of J, step"),
        f"dq = J^T (J J^T + mu2 I)^-1 e with mu2 = max(c |e|, lambda^2 min(1, |e|/{FLOOR_ERROR:g})^2), c starting at {C_START:g},",
        f"times {C_UP:g} after a rejected step and {C_DOWN:g} after an accepted one: lambda damps while the error is large",
        "and fades as it vanishes, so it shapes the path near singular poses and never stops the convergence.",
        f"After a step that left |e| above {GEO_GATE:g} of its start, while |e| < {GEO_ERROR:g}, the step gets a geodesic",
        "(second-order) correction from one more pose evaluation: it follows curved valleys near singular targets.",
        *(_success_lines(precision) if rows == 6 else ()),
        *(("Joint limits (Q_MIN/MAX) are kept by clamping; joints a step pushes past a bound are removed from it;",
           "revolute joints with a range of 2 pi or more wrap by 2 pi. An attempt ends when it stalls at a stationary",
           f"point of |e|, makes too little progress (not counting steps slowed by the damping) or takes {ATTEMPT} steps;",
           f"the next starts from the best of {CANDIDATES} random configurations within the limits (xorshift64*, a fixed",
           "seed: the same input gives the same result). Slides are not capped; other joints move at most",
           f"{STEP_MAX:g} rad a step.")
          if limited else
          ("The arm has no position limits (no Q_MIN/Q_MAX): nothing is clamped, and revolute joints wrap by 2 pi.",
           "An attempt ends when it stalls at a stationary point of |e|, makes too little progress (not counting steps",
           f"slowed by the damping) or takes {ATTEMPT} steps; the next starts from the best of {CANDIDATES} random",
           "configurations, each coordinate drawn from [-pi, pi] (xorshift64*, a fixed seed: the same input gives the",
           f"same result). Slides are not capped; other joints move at most {STEP_MAX:g} rad a step.")),
        f"Steps of all attempts count against max_iter. A tol of {default_tol:g} is reachable in this precision for an",
        "arm of unit size. target: " + ("4 x 4 row-major; error[0] = position error (m), error[1] = rotation error (rad)."
                                          if rows == 6 else "3 numbers; error[0] = position error (m)."),
        "On INVALID, q = q0 and error is HUGE_VAL (infinite). q may be q0 itself.",
    )


def solver(chain, rows: int, params: int, precision: str) -> Function:
    """``ik_solve`` (rows 6: pose) or ``ik_solve_position`` (rows 3), see the module docstring."""
    default_tol = SETTINGS[precision]["tol"]
    body = _PoseIK(chain, rows, params, precision).body()
    name = "ik_solve" if rows == 6 else "ik_solve_position"
    summary = "pose IK of the tool frame" if rows == 6 else "position IK of the tool origin"
    return Function(name, summary, _solver_arguments(rows, chain.n, params, default_tol), body, kind="procedure",
                    returns=Type.INT, statuses=POSE_STATUSES if rows == 6 else STATUSES, doc=_solver_doc(rows, default_tol, _has_position_limits(chain), precision),
                    result="IKResult" if rows == 6 else "IKPositionResult", refused=refusal(precision) if rows == 6 else "")


def _has_position_limits(chain) -> bool:
    limits = chain.limits()
    return any(v is not None for v in limits["lower"] + limits["upper"])


def _mod(x, m: int) -> Bits:
    """``x mod m`` for a non-negative int ``x``."""
    return Bits("%", x, Const(m, Type.INT))


def _restart(b: Body, n, rows, q, trial, Tt, Jt, target, param_args, restarts, near, whole, scratch) -> None:
    """The best of CANDIDATES random starts by tool position error; even restarts near the centre."""
    nearest, u, d = scratch
    b.set(nearest, 0.0)
    with b.for_("m", 0, CANDIDATES) as m:
        with b.for_("k", 0, n) as k:
            b.call("ik_uniform", Array("state", 1, Type.UINT64), result=u)
            even = eq(_mod(restarts, 2), 0)
            low = select(even, near[0][k], whole[0][k])
            span = select(even, near[1][k], whole[1][k])
            b.set(trial[k], low + span * u)
        b.call("ik_terms", trial, *param_args, Tt, Jt)
        ds = []
        for i in range(3):
            ds.append(target[4 * i + 3] - Tt[4 * i + 3] if rows == 6 else target[i] - Tt[4 * i + 3])
        b.set(d, sqrt(ds[0] * ds[0] + ds[1] * ds[1] + ds[2] * ds[2]))
        with b.if_(eq(m, 0) | (d < nearest)):
            b.set(nearest, d)
            with b.for_("k", 0, n) as k:
                b.set(q[k], trial[k])


def chain_solvers(derivation, names, precision: str) -> list[Function]:
    """The helpers and the solvers named in ``names`` (``ik_solve``, ``ik_solve_position``)."""
    chain = derivation.model
    n = chain.n
    params = len(derivation.inputs.get("params", ()))
    wanted = [(6, "ik_solve"), (3, "ik_solve_position")]
    out: list[Function] = [uniform_helper()]
    if "ik_solve" in names:
        out.append(log3_helper())
    for rows, name in wanted:
        if name in names:
            suffix = "_pose" if rows == 6 else "_position"
            out += [error_helper(rows, suffix), gram_helper(rows, n, suffix), ldl_helper(rows, suffix, precision),
                    ldl_solve_helper(rows, n, suffix)]
    for rows, name in wanted:
        if name in names:
            out.append(solver(chain, rows, params, precision))
    return out
