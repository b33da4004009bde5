"""Closed-form IK with all solutions: the post-processing of ``docs/closed-form-ik.md``, written once in the IR.

The candidates come from the straight-line ``ik_candidates(target, [lock], Q, flags)`` (lowered from
:func:`skelarm_sym.closed_ik.derive.derive_ik_all`); these procedures choose among them, statement for
statement as :func:`skelarm_sym.closed_ik.postprocess.postprocess` and ``nearest`` do in NumPy:

* ``ik_all_rows`` (a helper): validation, candidates, exact rows first, 2 pi shifts toward each range's centre,
  limits, duplicates, order, count and status;
* ``ik_all(target, [lock], q, count, flags)``: every solution, one per row of ``q`` (``IK_MAX_SOLUTIONS`` x N,
  NaN past ``count``), ``flags`` per row (-1 past ``count``);
* ``ik_nearest(q_ref, target, [lock], q)``: the returned row nearest ``q_ref``, each revolute joint moved to
  its copy within the limits nearest ``q_ref`` (NaN when there is no row).

Everything that depends on the arm (which joints are revolute, the limits, the centres) is unrolled at
generation time; the loops over rows and over kept rows run at run time (at most ``IK_MAX_SOLUTIONS``).
"""

from __future__ import annotations

import math

from ...closed_ik.postprocess import STATUS, centres
from ...ir.build import Array, Body, fabs, select
from ...ir.nodes import Argument, Bits, Call1, Cast, Const, Function, NamedConst, Role, Type, Var, eq, ne

TWO_PI = 2.0 * math.pi
INV_TWO_PI = 1.0 / TWO_PI

STATUSES = (
    ("IK_OK", STATUS["ok"], "at least one exact solution within the joint limits: all of them are returned"),
    ("IK_UNREACHABLE", STATUS["unreachable"],
     "the target is out of reach: the rows are the least-squares candidates within the limits (flag bit "
     "IK_FLAG_LEAST_SQUARES set), possibly none"),
    ("IK_OUT_OF_LIMITS", STATUS["out_of_limits"], "exact solutions exist, none within the joint limits (count 0)"),
    ("IK_INVALID", STATUS["invalid"],
     "target (or lock) not finite, or its rotation part not a rotation (|R^T R - I| > IK_ORTHO_TOL or det R <= 0): "
     "count 0"),
)
"""Return codes of ``ik_all`` and ``ik_nearest`` (``IK_INVALID`` is 3, as for ``ik_solve``)."""


def _status(name: str) -> NamedConst:
    return NamedConst(name, Type.INT)


def _int(x: int) -> Const:
    return Const(int(x), Type.INT)


def _at(n: int, row, j: int):
    """The index of element ``j`` of row ``row`` in a row-major array of rows of ``n``."""
    start = _int(n) * row if n > 1 else row
    return start + _int(j) if j else start


class _Arm:
    """What the procedures need of the arm, as plain numbers: joints, revolute, limits, centres, lock."""

    def __init__(self, chain, locked: bool) -> None:
        limits = chain.limits()
        self.n = chain.n
        self.s = 8
        revolute = [False] * chain.n
        for j in chain.joints:
            revolute[j.coordinate] = j.kind == "revolute"
        self.revolute = revolute
        self.lower = [None if x is None else float(x) for x in limits["lower"]]
        self.upper = [None if x is None else float(x) for x in limits["upper"]]
        inf = float("inf")
        self.centre = [float(c) for c in centres([-inf if x is None else x for x in self.lower],
                                                 [inf if x is None else x for x in self.upper])]
        self.locked = locked


def _inputs(arm: _Arm) -> tuple[list[Argument], list]:
    """The call data of every procedure: ``target`` and (locked arms) ``lock``; and their IR names."""
    args = [Argument("target", Role.DATA, (4, 4), domain="finite", batched=False,
                     doc="tool pose T (4 x 4, row-major; the last row is not read)")]
    names: list = [Array("target", 16)]
    if arm.locked:
        args.append(Argument("lock", Role.SCALAR, (), domain="finite", batched=False,
                             doc="the locked joint's value (rad or m)"))
        names.append(Var("lock"))
    return args, names


def _shifted(b: Body, x, centre: float, out) -> None:
    """``out = x + 2 pi k`` with ``k = nearbyint((centre - x) / 2 pi)``: the copy of a revolute angle nearest
    ``centre``. One turn toward the centre by selects (no branch, no call: the candidates are atan2 values, or sums
    of three, and centres within pi of 0, so this is the copy for every one here), then ``nearbyint`` only for what
    is still more than pi away (a branch not taken here). Where ``|centre - x|`` is an odd multiple of pi the copy
    may differ from ``nearbyint``'s by a turn: both are equally near."""
    d = centre - x
    b.set(out, x + select(d > math.pi, TWO_PI, select(d < -math.pi, -TWO_PI, 0.0)))
    with b.if_(fabs(centre - out) > math.pi):
        b.set(out, out + TWO_PI * Call1("nearbyint", (centre - out) * INV_TWO_PI))


def _close(d, revolute: bool):
    """``|d| <= IK_DUP_TOL``, modulo 2 pi for a revolute joint: ``d`` is the difference of two angles shifted
    toward the same centre (``|d| <= 2 pi`` up to the clipping), so ``|d|`` or ``|2 pi - |d||`` (no call)."""
    tol = NamedConst("IK_DUP_TOL")
    if not revolute:
        return fabs(d) <= tol
    return (fabs(d) <= tol) | (fabs(TWO_PI - fabs(d)) <= tol)


def _same_row(b: Body, arm: _Arm, cand: Array, q: Array, r, diff: Var, dup: Var, j: int) -> None:
    """Joint ``j`` and on of ``cand`` against kept row ``r``: a nest of tests ending in ``dup = r; break``."""
    b.set(diff, cand[j] - q[_at(arm.n, r, j)])
    with b.if_(_close(diff, arm.revolute[j])):
        if j + 1 < arm.n:
            _same_row(b, arm, cand, q, r, diff, dup, j + 1)
        else:
            b.set(dup, r)
            b.break_()


def rows_helper(arm: _Arm) -> Function:
    """``ik_all_rows(target, [lock], q, count, flags)``: the post-processing (see the module docstring)."""
    S, N = arm.s, arm.n
    b = Body()
    data_args, data = _inputs(arm)
    q, count, flags = Array("q", S * N), Array("count", 1, Type.INT), Array("flags", S, Type.INT)
    raw, raw_flags, cand = b.array("raw", S * N), b.array("raw_flags", S), b.array("cand", N)
    one, zero = _int(1), _int(0)

    b.comment("nothing yet: NaN rows, flags -1, count 0")
    rows = NamedConst("IK_MAX_SOLUTIONS", Type.INT)
    with b.for_("k", 0, rows * _int(N)) as k:
        b.set(q[k], Const(math.nan))
    with b.for_("k", 0, rows) as k:
        b.set(flags[k], _int(-1))
    b.set(count[0], zero)

    _refuse_invalid(b, arm, data)

    b.comment("the candidates, then 2. exact rows first (flag bit 1 clear), else every row, unreachable")
    b.call("ik_candidates", *data, raw, raw_flags)
    exact = b.var("exact", zero, Type.INT)
    least_squares = NamedConst("IK_FLAG_LEAST_SQUARES", Type.INT)
    with b.for_("i", 0, rows) as i:
        with b.if_(ne(Bits("%", Cast(Type.INT, raw_flags[i]), _int(2)), least_squares)):
            b.set(exact, one)

    kept = b.var("kept", zero, Type.INT)
    flag = b.var("flag", zero, Type.INT)
    inside = b.var("inside", zero, Type.INT)
    dup = b.var("dup", zero, Type.INT)
    diff = b.var("diff", 0.0)
    with b.for_("i", 0, rows) as i:
        b.set(flag, Cast(Type.INT, raw_flags[i]))
        with b.if_(eq(exact, 0) | ne(Bits("%", flag, _int(2)), least_squares)):
            b.comment("3. revolute joints to the copy nearest their range's centre; 4. limits")
            b.set(inside, one)
            for j in range(N):
                _joint_to_limits(b, arm, j, raw[_at(N, i, j)], cand[j], inside)
            with b.if_(inside > 0):
                b.comment("5. a duplicate of a kept row (max over joints, revolute modulo 2 pi) is dropped")
                b.set(dup, _int(-1))
                with b.for_("r", 0, kept) as r:
                    b.comment("the same row when every joint is within IK_DUP_TOL: nested, so a row that differs "
                              "in its first joint costs one test")
                    _same_row(b, arm, cand, q, r, diff, dup, 0)
                with b.if_(dup >= 0):
                    b.comment("the kept row takes the duplicate's singular bit")
                    singular = NamedConst("IK_FLAG_SINGULAR", Type.INT)
                    with b.if_((flag >= singular) & (flags[dup] < singular)):
                        b.set(flags[dup], flags[dup] + singular)
                with b.else_():
                    b.comment("6. kept, in branch order")
                    for j in range(N):
                        b.set(q[_at(N, kept, j)], cand[j])
                    b.set(flags[kept], flag)
                    b.set(kept, kept + one)
    b.set(count[0], kept)
    b.comment("7. status")
    b.return_(select(eq(exact, 0), _status("IK_UNREACHABLE"), select(eq(kept, 0), _status("IK_OUT_OF_LIMITS"), _status("IK_OK"))))
    arguments = (*data_args, Argument("q", Role.OUTPUT, (S, N)), Argument("count", Role.OUTPUT, (1,), Type.INT),
                 Argument("flags", Role.OUTPUT, (S,), Type.INT))
    return Function("ik_all_rows", "every closed-form solution within the limits, post-processed", arguments,
                    b.statements, kind="helper", returns=Type.INT, statuses=STATUSES)


def _refuse_invalid(b: Body, arm: _Arm, data) -> None:
    """Step 1: return IK_INVALID when a target entry (rows 1-3) or the lock is not finite, or the target's
    R is not a rotation (Gram matrix off the identity by more than IK_ORTHO_TOL, or det R <= 0)."""
    target = data[0]
    b.comment("1. invalid input: a target entry (rows 1-3) or the lock not finite; R not a rotation")
    with b.for_("k", 0, 12) as k:
        with b.if_(~Call1("isfinite", target[k])):
            b.return_(_status("IK_INVALID"))
    if arm.locked:
        with b.if_(~Call1("isfinite", data[1])):
            b.return_(_status("IK_INVALID"))
    R = [[target[4 * i + j] for j in range(3)] for i in range(3)]
    gram = {}
    for i in range(3):
        for j in range(i, 3):
            gram[i, j] = b.let(f"m{i}{j}", R[0][i] * R[0][j] + R[1][i] * R[1][j] + R[2][i] * R[2][j])
    det = b.let("det", R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1])
                - R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0])
                + R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]))
    tol = NamedConst("IK_ORTHO_TOL")
    off = [fabs(gram[i, j] - (1.0 if i == j else 0.0)) > tol for i in range(3) for j in range(i, 3)]
    with b.if_(off[0] | off[1] | off[2] | off[3] | off[4] | off[5] | ~(det > 0.0)):
        b.return_(_status("IK_INVALID"))


def _joint_to_limits(b: Body, arm: _Arm, j: int, x, cand_j, inside) -> None:
    """Steps 3-4 for joint ``j`` of a raw row: ``cand_j`` = ``x`` (a revolute joint moved to the copy nearest
    its range's centre), ``inside`` = 0 when it is outside the limits by more than IK_LIMIT_TOL, and a value
    within that tolerance clipped onto the limit."""
    zero = _int(0)
    if arm.revolute[j]:
        _shifted(b, x, arm.centre[j], cand_j)
    else:
        b.set(cand_j, x)
    lo, hi = arm.lower[j], arm.upper[j]
    tests = []
    if lo is not None:
        tests.append(cand_j < lo - NamedConst("IK_LIMIT_TOL"))
    if hi is not None:
        tests.append(cand_j > hi + NamedConst("IK_LIMIT_TOL"))
    if tests:
        b.set(inside, select(tests[0] if len(tests) == 1 else tests[0] | tests[1], zero, inside))
    clipped = cand_j
    if hi is not None:
        clipped = select(cand_j > hi, hi, clipped)
    if lo is not None:
        clipped = select(cand_j < lo, lo, clipped)
    if tests:
        b.set(cand_j, clipped)


def _doc_limits(arm: _Arm) -> str:
    return ("Q_MIN/Q_MAX" if any(x is not None for x in arm.lower + arm.upper) else "none (the arm has no limits)")


def all_solver(arm: _Arm) -> Function:
    """``ik_all(target, [lock], q, count, flags)``: the public face of ``ik_all_rows``."""
    S, N = arm.s, arm.n
    b = Body()
    data_args, data = _inputs(arm)
    status = b.var("status", _int(0), Type.INT)
    b.call("ik_all_rows", *data, Array("q", S * N), Array("count", 1, Type.INT), Array("flags", S, Type.INT), result=status)
    b.return_(status)
    arguments = (
        *data_args,
        Argument("q", Role.OUTPUT, (S, N), doc=f"the solutions, one per row ({S} x {N}, row-major); NaN past count"),
        Argument("count", Role.OUTPUT, (1,), Type.INT, optional=True, fields=("count",), doc="rows of q that hold a solution"),
        Argument("flags", Role.OUTPUT, (S,), Type.INT, optional=True,
                 doc="per row: bit IK_FLAG_LEAST_SQUARES, bit IK_FLAG_SINGULAR; -1 past count"),
    )
    lock = "lock: the locked joint's value, the same in every row. " if arm.locked else ""
    doc = (
        f"Every closed-form IK solution of the tool pose target (4 x 4 row-major), at most IK_MAX_SOLUTIONS = {S},",
        f"one per row of q ({S} x {N}, row-major): exact candidates only when any exists, revolute joints shifted by",
        "multiples of 2 pi to the copy nearest the middle of their range, rows outside the joint limits",
        f"({_doc_limits(arm)}) dropped (within IK_LIMIT_TOL: clipped), duplicates (IK_DUP_TOL) dropped, in the",
        "derivation's branch order (deterministic: a branch keeps its row as the target moves). Rows past count are",
        "NaN, their flags -1. flags: IK_FLAG_LEAST_SQUARES (the target is out of reach: a least-squares pose),",
        "IK_FLAG_SINGULAR (one member of a continuum, or a double root)." + (" " + lock.strip() if lock else ""),
        "No iteration: the same time for every target.",
    )
    return Function("ik_all", "every closed-form IK solution within the joint limits", arguments, b.statements,
                    kind="procedure", returns=Type.INT, statuses=STATUSES, doc=doc, result="IKAllResult")


def nearest_solver(arm: _Arm) -> Function:
    """``ik_nearest(q_ref, target, [lock], q)``: the solution of ``ik_all`` nearest ``q_ref``."""
    S, N = arm.s, arm.n
    b = Body()
    data_args, data = _inputs(arm)
    q_ref, q = Array("q_ref", N), Array("q", N)
    rows, count, flags = b.array("rows", S * N), b.array("count", 1, Type.INT), b.array("flags", S, Type.INT)
    near = b.array("near", N)
    status = b.var("status", _int(0), Type.INT)
    best = b.var("best", _int(-1), Type.INT)
    best_d = b.var("best_d", 0.0)
    dist = b.var("dist", 0.0)
    k = b.var("k", 0.0)
    y = b.var("y", 0.0)
    found = b.var("found", _int(0), Type.INT)
    b.call("ik_all_rows", *data, rows, count, flags, result=status)
    for j in range(N):
        b.set(q[j], Const(math.nan))
    with b.for_("i", 0, count[0]) as i:
        b.comment("each revolute joint: the copy q + 2 pi (k + m), m = 0, -1, 1, within the limits nearest q_ref")
        for j in range(N):
            x = rows[_at(N, i, j)]
            if not arm.revolute[j]:
                b.set(near[j], x)
                continue
            b.set(k, Call1("nearbyint", (q_ref[j] - x) * INV_TWO_PI))
            b.set(found, _int(0))
            b.set(y, x)
            for m in (0, -1, 1):
                xm = x + TWO_PI * (k + float(m)) if m else x + TWO_PI * k
                tests = []
                if arm.lower[j] is not None:
                    tests.append(xm >= arm.lower[j])
                if arm.upper[j] is not None:
                    tests.append(xm <= arm.upper[j])
                better = eq(found, 0) | (fabs(xm - q_ref[j]) < fabs(y - q_ref[j]))
                cond = better if not tests else (tests[0] & better if len(tests) == 1 else tests[0] & tests[1] & better)
                with b.if_(cond):
                    b.set(y, xm)
                    b.set(found, _int(1))
            b.set(near[j], y)
        b.set(dist, sum(((near[j] - q_ref[j]) * (near[j] - q_ref[j]) for j in range(1, N)),
                        (near[0] - q_ref[0]) * (near[0] - q_ref[0])))
        with b.if_((best < 0) | (dist < best_d)):
            b.set(best, i)
            b.set(best_d, dist)
            for j in range(N):
                b.set(q[j], near[j])
    b.return_(status)
    arguments = (
        Argument("q_ref", Role.STATE, (N,), domain="finite", batched=False, doc="the configuration to be near (rad or m)"),
        *data_args,
        Argument("q", Role.OUTPUT, (N,), doc="the solution nearest q_ref; NaN when there is none"),
    )
    doc = (
        "The ik_all solution nearest q_ref (Euclidean, rad and m alike): each revolute joint takes the copy q + 2 pi k",
        "within the joint limits nearest q_ref[j] (the copy ik_all returns when no other fits), then the row with the",
        "least squared distance (ties: the lower row). Returns ik_all's status; q is NaN when ik_all returns no row",
        "(IK_OUT_OF_LIMITS, IK_UNREACHABLE with no row within the limits, IK_INVALID).",
    )
    return Function("ik_nearest", "the closed-form IK solution nearest a configuration", arguments, b.statements,
                    kind="procedure", returns=Type.INT, statuses=STATUSES, doc=doc, result="IKNearestResult")


def closed_solvers(derivation, names, precision: str) -> list[Function]:
    """The helper and the procedures named in ``names`` (``ik_all``, ``ik_nearest``) for a derivation that has
    ``ik_candidates``; ``precision`` changes nothing here (the tolerances are module constants)."""
    wanted = [name for name in ("ik_all", "ik_nearest") if name in names]
    if not wanted:
        return []
    arm = _Arm(derivation.model, "lock" in derivation.inputs)
    out = [rows_helper(arm)]
    if "ik_all" in wanted:
        out.append(all_solver(arm))
    if "ik_nearest" in wanted:
        out.append(nearest_solver(arm))
    return out
