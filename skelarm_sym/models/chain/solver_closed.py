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

import contextlib
import functools
import math
import operator

from ...closed_ik.postprocess import INV_TWO_PI, LOCK_MAX, LOCK_MAX_FLOAT, STATUS, TWO_PI, centres
from ...ir.build import Array, Body, fabs, fmax, select
from ...ir.nodes import Argument, Bits, Call1, Cast, Const, Function, NamedConst, Role, Type, Var, eq, ne
from .solver_continuum import Continuum
from .target_rotation import NOT_A_ROTATION, refusal, rotation_faults


STATUSES = (
    ("IK_OK", STATUS["ok"], "at least one exact solution within the joint limits: all of them are returned"),
    ("IK_UNREACHABLE", STATUS["unreachable"],
     "the target is out of reach: the rows are the least-squares candidates within the limits (flag bit "
     "IK_FLAG_LEAST_SQUARES set), possibly none"),
    ("IK_OUT_OF_LIMITS", STATUS["out_of_limits"], "exact solutions exist, none within the joint limits (count 0)"),
    ("IK_INVALID", STATUS["invalid"],
     "target (or lock) not finite, the lock beyond IK_LOCK_MAX, a translation entry beyond IK_TRANSLATION_MAX, or its " + NOT_A_ROTATION + ": count 0"),
)
"""Return codes of ``ik_all`` and ``ik_nearest`` (``IK_INVALID`` is 3, as for ``ik_solve``)."""


NAMES = ("ik_all", "ik_nearest", "ik_nearest_weighted")
"""The public procedures of the closed-form IK."""


def _status(name: str) -> NamedConst:
    return NamedConst(name, Type.INT)


def _int(x: int) -> Const:
    return Const(int(x), Type.INT)


def _at(n: int, row, j: int):
    """The index of element ``j`` of row ``row`` in a row-major array of rows of ``n``."""
    start = _int(n) * row if n > 1 else row
    return start + _int(j) if j else start


WIDE_MARGIN = 1e-9
"""A revolute joint whose limits are at least pi plus this (rad) from its range's centre on both sides takes every
copy shifted toward that centre (within pi of it, up to the rounding of a few turns' arithmetic, 1e-14): its
limit tests and clipping are left out."""


REGULAR_ROWS_DISTINCT = """Why an exact regular candidate (flag 0) is no duplicate, in double precision with revolute joints:
two candidates' branches part at one subproblem on both their paths, whose flags both carry. There, with the
singular bit clear: SP4/SP3's roots are 2 atan(s / |C|) >= 2e-5 rad apart (s^2 = disc > LS_TOL r2 >= LS_TOL C^2);
SP2's common points 2 sqrt(disc) > 2e-5 sqrt(norm2) apart, which each SP1 turns into 1.4e-5 rad or more (a
chord over a radius of at most sqrt(2 norm2)); a wrist flip moves q4 (UR: q6) by pi. All far above IK_DUP_TOL =
1e-9 rad (the shifts, a multiple of 2 pi, and clipping, 1e-12, do not change that), and above the subproblems'
rounding. Not used in float (IK_DUP_TOL 1e-4 exceeds 2e-5) nor with a prismatic joint (its two roots are 2 sqrt(disc)
metres apart, which the arm's size scales)."""


class _Arm:
    """What the procedures need of the arm, as plain numbers: joints, revolute, limits, centres, lock; and what
    the candidates guarantee (``principal``: per coordinate, every candidate in ``[-pi, pi]``) and the order in
    which the duplicate test compares the joints (``order``)."""

    def __init__(self, chain, locked: bool, principal: tuple = (), columns: tuple = (), precision: str = "double",
                 continuum: tuple = (), members: int = 0, member_kind: str = "") -> None:
        self.members = members
        """Rows of ``ik_continuum_members`` (0: the arm has none)."""
        self.member_kind = member_kind
        """``"aligned"``: a UR's aligned wrist at q_ref's phi; ``"axis"``: a spherical wrist's centre on axis 1 at q_ref's q1."""
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
        self.precision = precision
        self.principal = list(principal) if principal else [False] * chain.n
        self.continuum = tuple(continuum)
        # the duplicate test's joint order: the columns with the most distinct candidates first (the joint in
        # which two rows most likely differ: one test per kept row); the result does not depend on the order
        distinct = list(columns) if columns else [0] * chain.n
        self.order = sorted(range(chain.n), key=lambda j: -distinct[j])

    @property
    def moves_continuum(self) -> bool:
        """Whether ``ik_all`` moves a continuum's row into the limits: the arm has a wrist continuum and one of its
        two joints can be outside its limits (else the row's own values always fit)."""
        return bool(self.continuum) and not (self.always_inside(self.continuum[0]) and self.always_inside(self.continuum[2]))

    @property
    def regular_rows_distinct(self) -> bool:
        """Whether a row flagged 0 (exact, regular) needs no duplicate test (see :data:`REGULAR_ROWS_DISTINCT`)."""
        return self.precision == "double" and all(self.revolute)

    def unshifted(self, j: int) -> bool:
        """Revolute joint ``j``'s candidates are in ``[-pi, pi]`` and its centre is 0: the 2 pi shift moves none."""
        return self.revolute[j] and self.principal[j] and self.centre[j] == 0.0

    def always_inside(self, j: int) -> bool:
        """Joint ``j``'s candidate, after the shift, is within its limits (no test, no clipping): its candidates
        are in ``[-pi, pi]`` and unshifted and the limits hold that interval, or the limits are at least
        ``pi + WIDE_MARGIN`` from the centre on both sides."""
        lo, hi = self.lower[j], self.upper[j]
        if not self.revolute[j] or lo is None or hi is None:
            return lo is None and hi is None
        if self.unshifted(j) and lo <= -math.pi and hi >= math.pi:
            return True
        c = self.centre[j]
        return lo <= c - math.pi - WIDE_MARGIN and hi >= c + math.pi + WIDE_MARGIN


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


def _close(d, revolute: bool, tol):
    """``|d| <= tol``, modulo 2 pi for a revolute joint: ``d`` is the difference of two angles shifted toward the
    same centre (``|d| <= 2 pi`` up to the clipping), so ``|d|`` or ``|2 pi - |d||`` (no call)."""
    if not revolute:
        return fabs(d) <= tol
    return (fabs(d) <= tol) | (fabs(TWO_PI - fabs(d)) <= tol)


def _same_row(b: Body, arm: _Arm, cand: Array, q: Array, r, diff: Var, dup: Var, depth: int, tol) -> None:
    """Joints ``arm.order[depth:]`` of ``cand`` against kept row ``r``: a nest of tests ending in ``dup = r; break``."""
    j = arm.order[depth]
    b.set(diff, cand[j] - q[_at(arm.n, r, j)])
    with b.if_(_close(diff, arm.revolute[j], tol)):
        if depth + 1 < arm.n:
            _same_row(b, arm, cand, q, r, diff, dup, depth + 1, tol)
        else:
            b.set(dup, r)
            b.break_()


def rows_helper(arm: _Arm) -> Function:
    """``ik_all_rows(target, [lock], q, count, flags[, singular])``: the post-processing (see the module docstring);
    ``singular`` (arms with continuum members: UR, spherical wrists whose centre can lie on axis 1): 1 when a raw candidate is exact and flagged singular (a
    representative, which the limits may have dropped), else 0."""
    S, N = arm.s, arm.n
    b = Body()
    data_args, data = _inputs(arm)
    q, count, flags = Array("q", S * N), Array("count", 1, Type.INT), Array("flags", S, Type.INT)
    raw_singular = Array("singular", 1, Type.INT) if arm.members else None
    raw, raw_flags, cand = b.array("raw", S * N), b.array("raw_flags", S), b.array("cand", N)
    one, zero = _int(1), _int(0)

    rows = NamedConst("IK_MAX_SOLUTIONS", Type.INT)
    if raw_singular is not None:
        b.set(raw_singular[0], zero)
    _refuse_invalid(b, arm, data, q, count, flags)

    b.comment("the candidates, then 2. exact rows first (flag bit 1 clear), else every row, unreachable")
    b.call("ik_candidates", *data, raw, raw_flags)
    exact = b.var("exact", zero, Type.INT)
    least_squares = NamedConst("IK_FLAG_LEAST_SQUARES", Type.INT)
    with b.for_("i", 0, rows) as i:
        with b.if_(ne(Bits("%", Cast(Type.INT, raw_flags[i]), _int(2)), least_squares)):
            b.set(exact, one)
        if raw_singular is not None:
            b.set(raw_singular[0], select(eq(Cast(Type.INT, raw_flags[i]), NamedConst("IK_FLAG_SINGULAR", Type.INT)), one,
                                          raw_singular[0]))

    kept = b.var("kept", zero, Type.INT)
    flag = b.var("flag", zero, Type.INT)
    tested = not all(arm.always_inside(j) for j in range(N))
    inside = b.var("inside", zero, Type.INT) if tested else None
    dup = b.var("dup", zero, Type.INT)
    diff = b.var("diff", 0.0)
    tol = b.var("tol", 0.0)
    singular = NamedConst("IK_FLAG_SINGULAR", Type.INT)
    continuum = Continuum(b, arm, reference=False) if arm.moves_continuum else None
    with b.for_("i", 0, rows) as i:
        b.set(flag, Cast(Type.INT, raw_flags[i]))
        with b.if_(eq(exact, 0) | ne(Bits("%", flag, _int(2)), least_squares)):
            if tested:
                b.comment("3. revolute joints to the copy nearest their range's centre; 4. limits")
                b.set(inside, one)
            else:
                b.comment("3. revolute joints to the copy nearest their range's centre (each range wider than a turn "
                          "around its centre: 4. no copy is outside the limits)")
            if continuum is None:
                for j in range(N):
                    _joint_to_limits(b, arm, j, raw[_at(N, i, j)], cand[j], inside)
            else:
                a, w, c = continuum.a, continuum.w, continuum.b
                for j in range(N):
                    _joint_shift(b, arm, j, raw[_at(N, i, j)], cand[j])
                    if j not in (a, c):
                        _joint_limits(b, arm, j, cand[j], inside)
                b.comment(f"a row of the wrist's continuum (flagged singular, the wrist aligned): joints {a + 1} and {c + 1} "
                          "to the member within their limits nearest the row")
                continuum.move(b, cand[w], flag >= singular, cand[a], cand[c], cand[a], cand[c], cand[a], cand[c],
                               through_ref=True)
                for j in (a, c):
                    _joint_limits(b, arm, j, cand[j], inside)
            with (b.if_(inside > 0) if tested else contextlib.nullcontext()):
                b.comment("5. a duplicate of a kept row (max over joints, revolute modulo 2 pi) is dropped")
                b.set(dup, _int(-1))
                with (b.if_(flag > 0) if arm.regular_rows_distinct else contextlib.nullcontext()):
                    if arm.regular_rows_distinct:
                        b.comment("an exact regular row (flag 0) is no other row's duplicate: their branches part at a "
                                  "subproblem that is not singular, 1e-5 rad or more apart")
                    with b.for_("r", 0, kept) as r:
                        b.comment("the same row when every joint is within IK_DUP_TOL (IK_DUP_TOL_SINGULAR where both are "
                                  "flagged singular: a double root's two roots): nested, the joint with the most "
                                  "distinct candidates first, so a row that differs there costs one test")
                        b.set(tol, select((flag >= singular) & (flags[r] >= singular), NamedConst("IK_DUP_TOL_SINGULAR"),
                                          NamedConst("IK_DUP_TOL")))
                        _same_row(b, arm, cand, q, r, diff, dup, 0, tol)
                with b.if_(dup >= 0):
                    b.comment("the kept row takes the duplicate's singular bit")
                    with b.if_((flag >= singular) & (flags[dup] < singular)):
                        b.set(flags[dup], flags[dup] + singular)
                with b.else_():
                    b.comment("6. kept, in branch order")
                    for j in range(N):
                        b.set(q[_at(N, kept, j)], cand[j])
                    b.set(flags[kept], flag)
                    b.set(kept, kept + one)
    b.set(count[0], kept)
    _fill_rest(b, arm, q, flags, kept)
    b.comment("7. status")
    b.return_(select(eq(exact, 0), _status("IK_UNREACHABLE"), select(eq(kept, 0), _status("IK_OUT_OF_LIMITS"), _status("IK_OK"))))
    arguments = (*data_args, Argument("q", Role.OUTPUT, (S, N)), Argument("count", Role.OUTPUT, (1,), Type.INT),
                 Argument("flags", Role.OUTPUT, (S,), Type.INT),
                 *([Argument("singular", Role.OUTPUT, (1,), Type.INT)] if raw_singular is not None else []))
    return Function("ik_all_rows", "every closed-form solution within the limits, post-processed", arguments,
                    b.statements, kind="helper", returns=Type.INT, statuses=_statuses(arm, STATUSES))


def _fill_rest(b: Body, arm: _Arm, q: Array, flags: Array, kept=None) -> None:
    """Rows ``kept`` and on (every row when ``kept`` is None): NaN, their flags -1."""
    b.comment("rows past count: NaN, flags -1")
    with b.for_("k", 0, NamedConst("IK_MAX_SOLUTIONS", Type.INT)) as k:
        with (b.if_(k >= kept) if kept is not None else contextlib.nullcontext()):
            for j in range(arm.n):
                b.set(q[_at(arm.n, k, j)], Const(math.nan))
            b.set(flags[k], _int(-1))


def _lock_max(arm: "_Arm") -> float | None:
    """IK_LOCK_MAX of ``arm``'s precision where it has a locked joint, else None."""
    return (LOCK_MAX if arm.precision == "double" else LOCK_MAX_FLOAT) if arm.locked else None


def _refuse_invalid(b: Body, arm: _Arm, data, q: Array, count: Array, flags: Array) -> None:
    """Step 1: return IK_INVALID (count 0, every row NaN) when a target entry (rows 1-3) or the lock is not finite
    (or the lock beyond IK_LOCK_MAX),
    a translation entry is beyond IK_TRANSLATION_MAX in magnitude, or the target's R is not a rotation
    (:func:`~.target_rotation.rotation_faults`, which also finds R's entries not finite)."""
    target = data[0]
    b.comment("1. invalid input: a target entry (rows 1-3) or the lock not finite; the lock beyond IK_LOCK_MAX; t beyond "
              "IK_TRANSLATION_MAX; R not a rotation")
    faults = rotation_faults(b, target)
    bad = [~Call1("isfinite", target[k]) for k in (3, 7, 11)]  # from the bits: -ffast-math keeps it
    bad += [fabs(target[k]) > NamedConst("IK_TRANSLATION_MAX") for k in (3, 7, 11)]
    if arm.locked:
        bad.append(~Call1("isfinite", data[1]))
        bad.append(fabs(data[1]) > NamedConst("IK_LOCK_MAX"))
    bad += faults
    with b.if_(functools.reduce(operator.or_, bad)):
        b.set(count[0], _int(0))
        _fill_rest(b, arm, q, flags)
        b.return_(_status("IK_INVALID"))


def _joint_to_limits(b: Body, arm: _Arm, j: int, x, cand_j, inside) -> None:
    """Steps 3-4 for joint ``j`` of a raw row: ``cand_j`` = ``x`` (a revolute joint moved to the copy nearest
    its range's centre), ``inside`` = 0 when it is outside the limits by more than IK_LIMIT_TOL, and a value
    within that tolerance clipped onto the limit."""
    _joint_shift(b, arm, j, x, cand_j)
    _joint_limits(b, arm, j, cand_j, inside)


def _joint_shift(b: Body, arm: _Arm, j: int, x, cand_j) -> None:
    """Step 3 for joint ``j``: ``cand_j`` = ``x``, a revolute joint moved to the copy nearest its range's centre."""
    if arm.revolute[j] and not arm.unshifted(j):
        _shifted(b, x, arm.centre[j], cand_j)
    else:
        b.set(cand_j, x)


def _joint_limits(b: Body, arm: _Arm, j: int, cand_j, inside) -> None:
    """Step 4 for joint ``j``: ``inside`` = 0 when ``cand_j`` is outside the limits by more than IK_LIMIT_TOL, and
    a value within that tolerance clipped onto the limit."""
    zero = _int(0)
    if arm.always_inside(j):
        return
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
    if not any(x is not None for x in arm.lower + arm.upper):
        return "every row (the arm has no joint limits)"
    if all(arm.always_inside(j) for j in range(arm.n)):
        return "every row within the joint limits (Q_MIN/Q_MAX: each range holds a whole turn about its centre)"
    return "rows outside the joint limits (Q_MIN/Q_MAX) dropped (within IK_LIMIT_TOL: clipped)"


def _doc_continuum(arm: _Arm, choice: str) -> tuple[str, ...]:
    """The doc line on the wrist's continuum (none for an arm without one)."""
    if not arm.continuum:
        return ()
    a, w, b, s, s_odd, w0 = arm.continuum
    multiple = "multiple" if s and s_odd else "even multiple" if s else "odd multiple"
    part = "shoulder" if a > b else "wrist"  # a spherical shoulder's continuum is of the reversed chain's joints 3, 2, 1
    where = f"a {multiple} of pi" if not w0 else f"{w0:.17g} plus a {multiple} of pi"
    return (f"An aligned {part} (a row flagged singular, joint {w + 1} within IK_WRIST_ALIGNED_TOL of "
            f"{where}) turns joints {a + 1} and {b + 1}",
            f"about one axis: such a row takes {choice}.")


def all_solver(arm: _Arm) -> Function:
    """``ik_all(target, [lock], q, count, flags)``: the public face of ``ik_all_rows``."""
    S, N = arm.s, arm.n
    b = Body()
    data_args, data = _inputs(arm)
    status = b.var("status", _int(0), Type.INT)
    extra = [b.array("singular", 1, Type.INT)] if arm.members else []
    b.call("ik_all_rows", *data, Array("q", S * N), Array("count", 1, Type.INT), Array("flags", S, Type.INT), *extra,
           result=status)
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
        "multiples of 2 pi to the copy nearest the middle of their range,",
        f"{_doc_limits(arm)}, duplicates (IK_DUP_TOL) dropped, in the",
        "derivation's branch order (deterministic: a branch keeps its row as the target moves). Rows past count are",
        "NaN, their flags -1. flags: IK_FLAG_LEAST_SQUARES (the target is out of reach: a least-squares pose),",
        "IK_FLAG_SINGULAR (one member of a continuum, or a double root)." + (" " + lock.strip() if lock else ""),
        *_doc_continuum(arm, "the member within the limits nearest the row (the row itself when it fits)"),
        "No iteration: the same time for every target.",
    )
    return Function("ik_all", "every closed-form IK solution within the joint limits", arguments, b.statements,
                    kind="procedure", returns=Type.INT, statuses=_statuses(arm, STATUSES), doc=doc, result="IKAllResult",
                    refused=refusal(arm.precision, translation=True, lock_max=_lock_max(arm)))


NEAREST_STATUSES = STATUSES[:-1] + (
    ("IK_INVALID", STATUS["invalid"],
     "q_ref not finite (or a weight not finite or not > 0), the target (or lock) not finite, the lock beyond IK_LOCK_MAX, "
     "a translation entry beyond "
     "IK_TRANSLATION_MAX, or its " + NOT_A_ROTATION + ": q NaN"),
)
"""``ik_nearest``'s and ``ik_nearest_weighted``'s return codes: ``ik_all``'s, and the reference (and weights) tested too."""


def _statuses(arm: "_Arm", statuses: tuple) -> tuple:
    """``statuses`` as ``arm`` meets them: an arm without a locked joint has no lock to test (nor IK_LOCK_MAX)."""
    if arm.locked:
        return statuses
    return tuple((name, value, meaning.replace("target (or lock) not finite, the lock beyond IK_LOCK_MAX", "target not finite"))
                 for name, value, meaning in statuses)


def _nearest_copy(b: Body, arm: _Arm, j: int, x, ref, y) -> None:
    """``y`` = the copy ``x + 2 pi k`` of revolute joint ``j`` within the limits nearest ``ref`` (the nearest copy,
    else the last one below the upper limit or the first one above the lower limit; within IK_LIMIT_TOL of a limit
    clipped onto it): ``postprocess.nearest_copy``."""
    b.set(y, x + TWO_PI * Call1("nearbyint", (ref - x) * INV_TWO_PI))
    lo, hi, tol = arm.lower[j], arm.upper[j], NamedConst("IK_LIMIT_TOL")
    if hi is not None:
        b.set(y, select(y > hi + tol, x + TWO_PI * Call1("floor", ((hi + tol) - x) * INV_TWO_PI), y))
    if lo is not None:
        b.set(y, select(y < lo - tol, x - TWO_PI * Call1("floor", (x - (lo - tol)) * INV_TWO_PI), y))
    if hi is not None:
        b.set(y, select(y > hi, hi, y))
    if lo is not None:
        b.set(y, select(y < lo, lo, y))


def _distance(near: Array, q_ref: Array, weights, n: int):
    """``sum_j w_j (near_j - q_ref_j)^2`` (``weights`` None: every ``w_j`` 1), summed from joint 0 on."""
    def term(j):
        square = (near[j] - q_ref[j]) * (near[j] - q_ref[j])
        return weights[j] * square if weights is not None else square
    return sum((term(j) for j in range(1, n)), term(0))


def _nearer_member(b: Body, arm: _Arm, data, q_ref: Array, weights, q: Array, near: Array, raw_singular: Array, best,
                   best_d, dist, x, y, status, continuum: Continuum | None) -> None:
    """Where a raw candidate is exact and flagged singular (``raw_singular``; its row may have been dropped at the
    limits, even every row: IK_OUT_OF_LIMITS becomes IK_OK when a member is taken): the members of the continuum at
    q_ref (``ik_continuum_members``, those with flag bit 1 clear: a UR's aligned wrist at q_ref's own phi, a spherical
    wrist's centre on axis 1 at q_ref's q1), each revolute joint at its copy within the limits nearest q_ref (none
    there: not a member within the limits), a prismatic joint within the limits, a member with the wrist aligned too
    moved along that continuum (``continuum``); one nearer than the chosen row replaces it
    (``postprocess.nearest``'s ``members``)."""
    N, R = arm.n, arm.members
    M, mflags = b.array("M", R * N), b.array("mflags", R)
    ok = b.var("m_ok", _int(0), Type.INT)
    pair = (continuum.a, continuum.b) if continuum is not None else ()
    pair_ok = b.var("m_pair", _int(0), Type.INT) if pair else None
    tol = NamedConst("IK_LIMIT_TOL")
    with b.if_(raw_singular[0] > 0):  # a split representative is flagged singular: none, no member
        b.comment("a UR's aligned wrist: the continuum's members at q_ref's phi = q2 +- q3 +- q4, where nearer than the row"
                  if arm.member_kind == "aligned" else
                  "the wrist centre on axis 1: the continuum's members at q_ref's joint 1, where nearer than the row")
        b.call("ik_continuum_members", q_ref, *data, M, mflags)
        with b.for_("m", 0, _int(R)) as m:
            with b.if_(ne(Bits("%", Cast(Type.INT, mflags[m]), _int(2)), NamedConst("IK_FLAG_LEAST_SQUARES", Type.INT))):
                b.set(ok, _int(1))
                if pair:
                    b.set(pair_ok, _int(1))
                for j in range(N):
                    b.set(x, M[_at(N, m, j)])
                    if arm.revolute[j]:
                        _nearest_copy(b, arm, j, x, q_ref[j], y)
                        within = ok if j not in pair else pair_ok  # the wrist's pair: judged after its move below
                        b.set(within, select(fabs(y - (x + TWO_PI * Call1("nearbyint", (y - x) * INV_TWO_PI))) <= tol, within,
                                             _int(0)))
                        b.set(near[j], y)
                        continue
                    lo, hi = arm.lower[j], arm.upper[j]
                    clipped = x
                    if lo is not None:
                        b.set(ok, select(x < lo - tol, _int(0), ok))
                    if hi is not None:
                        b.set(ok, select(x > hi + tol, _int(0), ok))
                        clipped = select(x > hi, hi, clipped)
                    if lo is not None:
                        clipped = select(x < lo, lo, clipped)
                    b.set(near[j], clipped)
                if continuum is not None:
                    a, w, c = continuum.a, continuum.w, continuum.b
                    b.comment(f"a member with the wrist aligned too: joints {a + 1} and {c + 1} to the member within their "
                              "limits nearest q_ref (within them where the representative's own copies are not)")
                    b.set(continuum.found, _int(0))
                    continuum.move(b, M[_at(N, m, w)], None, M[_at(N, m, a)], M[_at(N, m, c)], q_ref[a], q_ref[c],
                                   near[a], near[c])
                    b.set(ok, select((continuum.found > 0) | (pair_ok > 0), ok, _int(0)))
                b.set(dist, _distance(near, q_ref, weights, N))
                with b.if_((ok > 0) & ((best < 0) | (dist < best_d))):
                    b.set(best, _int(arm.s))  # a member, no row
                    b.set(best_d, dist)
                    for j in range(N):
                        b.set(q[j], near[j])
        b.set(status, select((best >= 0) & eq(status, _status("IK_OUT_OF_LIMITS")), _status("IK_OK"), status))


def _doc_members(arm: _Arm) -> tuple[str, ...]:
    """The lines of ``ik_nearest``'s documentation on ``ik_continuum_members``."""
    if arm.member_kind == "aligned":
        return ("An aligned UR wrist (a continuum of joint 6 and phi = q2 +- q3 +- q4, signs of h2 . h3 and h2 . h4, one representative in ik_all): the members",
                "at q_ref's own phi (ik_continuum_members) count as rows too; one taken where every ik_all row is outside the",
                "limits turns IK_OUT_OF_LIMITS into IK_OK.")
    return ("The wrist centre on axis 1 (joint 1 turns it about itself: a continuum of joint 1, one representative in ik_all): the",
            "rows at q_ref's own joint 1 (ik_continuum_members, each with its own wrist) count as rows too; one taken where every",
            "ik_all row is outside the limits turns IK_OUT_OF_LIMITS into IK_OK.")


def nearest_solver(arm: _Arm, weighted: bool = False) -> Function:
    """``ik_nearest(q_ref, target, [lock], q)``: the solution of ``ik_all`` nearest ``q_ref``; ``weighted``:
    ``ik_nearest_weighted(q_ref, weights, target, [lock], q)``, nearest in ``sum_j weights[j] (q[j] - q_ref[j])^2``
    (the spec's ``nearest`` with ``weights``)."""
    S, N = arm.s, arm.n
    name = "ik_nearest_weighted" if weighted else "ik_nearest"
    b = Body()
    data_args, data = _inputs(arm)
    q = Array("q", N)
    # q_ref read into a local first: q may be q_ref (a controller's in-place call), and q is set to NaN below
    q_ref = b.array("ref", N)
    for j in range(N):
        b.set(q_ref[j], Array("q_ref", N)[j])
    given = Array("weights", N) if weighted else None
    # the weights divided by the largest: the same nearest row, and no product overflows (1e308 times a square did)
    weights = b.array("w", N) if weighted else None
    rows, count, flags = b.array("rows", S * N), b.array("count", 1, Type.INT), b.array("flags", S, Type.INT)
    near = b.array("near", N)
    status = b.var("status", _int(0), Type.INT)
    best = b.var("best", _int(-1), Type.INT)
    best_d = b.var("best_d", 0.0)
    dist = b.var("dist", 0.0)
    y = b.var("y", 0.0)
    x = b.var("x", 0.0)
    continuum = None
    if arm.continuum:
        pair = (weights[arm.continuum[0]], weights[arm.continuum[2]]) if weighted else None
        continuum = Continuum(b, arm, reference=True, weights=pair)
    for j in range(N):
        b.set(q[j], Const(math.nan))
    b.comment("q_ref not finite" + (", or a weight not finite or not > 0" if weighted else "") + ": IK_INVALID, q NaN")
    bad = [~Call1("isfinite", q_ref[j]) for j in range(N)]
    if weighted:
        bad += [~(given[j] > 0.0) | ~Call1("isfinite", given[j]) for j in range(N)]
    with b.if_(functools.reduce(operator.or_, bad)):
        b.return_(_status("IK_INVALID"))
    if weighted:
        largest = b.let("w_max", functools.reduce(fmax, [given[j] for j in range(N)]))
        for j in range(N):
            b.set(weights[j], given[j] / largest)
    raw_singular = b.array("singular", 1, Type.INT) if arm.members else None
    b.call("ik_all_rows", *data, rows, count, flags, *([raw_singular] if arm.members else []), result=status)
    with b.for_("i", 0, NamedConst("IK_MAX_SOLUTIONS", Type.INT)) as i:
        # a constant bound and a break, not a bound of count[0]: the row index is then the same for every problem of a
        # batch, and array backends read rows[...] directly instead of through a chain of selects per lane
        with b.if_(i >= count[0]):
            b.break_()
        b.comment("each revolute joint: the copy q + 2 pi k within the limits nearest q_ref (the nearest copy, else the last "
                  "one below the upper limit or the first one above the lower limit; within IK_LIMIT_TOL of a limit "
                  "clipped onto it)")
        for j in range(N):
            b.set(x, rows[_at(N, i, j)])
            if not arm.revolute[j]:
                b.set(near[j], x)
                continue
            _nearest_copy(b, arm, j, x, q_ref[j], y)
            b.set(near[j], y)
        if continuum is not None:
            a, w, c = continuum.a, continuum.w, continuum.b
            b.comment(f"a row of the wrist's continuum: joints {a + 1} and {c + 1} to the member within their limits "
                      "nearest q_ref" + (" (weighted)" if weighted else ""))
            continuum.move(b, rows[_at(N, i, w)], flags[i] >= NamedConst("IK_FLAG_SINGULAR", Type.INT), rows[_at(N, i, a)],
                           rows[_at(N, i, c)], q_ref[a], q_ref[c], near[a], near[c])
        b.set(dist, _distance(near, q_ref, weights, N))
        with b.if_((best < 0) | (dist < best_d)):
            b.set(best, i)
            b.set(best_d, dist)
            for j in range(N):
                b.set(q[j], near[j])
    if arm.members:
        # float members are not moved along the wrist's continuum: their wrist angle carries float's rounding (4e-5
        # rad), which the move turned into pose errors of 1e-4
        _nearer_member(b, arm, data, q_ref, weights, q, near, raw_singular, best, best_d, dist, x, y, status,
                       continuum if arm.precision == "double" else None)
    b.return_(status)
    arguments = (
        Argument("q_ref", Role.STATE, (N,), domain="finite", batched=False, doc="the configuration to be near (rad or m)"),
        *([Argument("weights", Role.DATA, (N,), domain="positive", batched=False,
                    doc="the metric's weight of each joint (finite, > 0): sum_j weights[j] (q[j] - q_ref[j])^2")]
          if weighted else []),
        *data_args,
        Argument("q", Role.OUTPUT, (N,), doc="the solution nearest q_ref; NaN when there is none"),
    )
    metric = ("in sum_j weights[j] (q[j] - q_ref[j])^2 (rad and m alike; weights finite and > 0)" if weighted
              else "(Euclidean, rad and m alike)")
    doc = (
        f"The ik_all solution nearest q_ref {metric}: each revolute joint takes the copy q + 2 pi k",
        "within the joint limits nearest q_ref[j], then the row with the",
        "least distance (ties: the lower row). Returns ik_all's status; q is NaN when ik_all returns no row",
        "(IK_OUT_OF_LIMITS, IK_UNREACHABLE with no row within the limits, IK_INVALID; also IK_INVALID for q_ref not finite"
        + (" or a weight that is not finite or not > 0)." if weighted else ")."),
        "q may be q_ref (an in-place call).",
        *_doc_continuum(arm, "the member within the limits nearest q_ref" + (" in the weighted metric" if weighted else "")),
        *(_doc_members(arm) if arm.members else ()),
    )
    summary = ("the closed-form IK solution nearest a configuration, in a weighted metric" if weighted
               else "the closed-form IK solution nearest a configuration")
    return Function(name, summary, arguments, b.statements,
                    kind="procedure", returns=Type.INT, statuses=_statuses(arm, NEAREST_STATUSES), doc=doc, result="IKNearestResult",
                    refused=refusal(arm.precision, translation=True, lock_max=_lock_max(arm)))


def closed_solvers(derivation, names, precision: str) -> list[Function]:
    """The helper and the procedures named in ``names`` (``ik_all``, ``ik_nearest``) for a derivation that has
    ``ik_candidates``; ``precision`` decides whether an exact regular row skips the duplicate test (see
    :data:`REGULAR_ROWS_DISTINCT`; the tolerances themselves are module constants)."""
    wanted = [name for name in NAMES if name in names]
    if not wanted:
        return []
    spec = derivation.function("ik_candidates")
    Q = derivation.compact["Q"]
    columns = tuple(len(set(Q[:, j])) for j in range(Q.cols))
    members = derivation.compact["M"].rows if any(f.name == "ik_continuum_members" for f in derivation.functions) else 0
    kind = ("aligned" if derivation.function("ik_continuum_members").wrist else "axis") if members else ""
    arm = _Arm(derivation.model, "lock" in derivation.inputs, getattr(spec, "principal", ()), columns, precision,
               getattr(spec, "continuum", ()), members, kind)
    out = [rows_helper(arm)]
    if "ik_all" in wanted:
        out.append(all_solver(arm))
    if "ik_nearest" in wanted:
        out.append(nearest_solver(arm))
    if "ik_nearest_weighted" in wanted:
        out.append(nearest_solver(arm, weighted=True))
    return out
