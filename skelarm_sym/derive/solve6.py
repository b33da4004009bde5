"""Unrolled small factorisations as named steps: Gram-Schmidt QR with re-orthogonalisation (and with
pivoting, for a rank rule), adjugates of triangular factors, guarded back substitution.

Everything is straight-line: a fixed number of vectors of fixed length, no loops at run time,
no allocation. Divisions are only ever by a ``Piecewise`` that is replaced by 1 where the divisor
would be zero, so no branch evaluates a division outside the case that uses it.

Gram-Schmidt with re-orthogonalisation ("twice is enough", Giraud, Langou and Rozloznik 2005):
vector ``a_k`` is orthogonalised against the earlier unit vectors twice (modified Gram-Schmidt
order); the coefficients of both passes add up into ``R[i][k]``. The residual's norm ``R[k][k]``
then carries an absolute error of about eps |a_k|, whatever the angle between ``a_k`` and the
span of the earlier vectors: a product of the ``R[k][k]`` (a Gram determinant's square root)
keeps its digits near rank deficiency, where ``det(A^T A)`` would cancel.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import sympy as sp

from .linalg import select

Recorder = Callable[[str, sp.Expr], sp.Expr]


def guarded(value: sp.Expr, keep: sp.Expr) -> sp.Expr:
    """``value`` where ``keep`` holds, else 1: a divisor that is never evaluated as zero."""
    return sp.Piecewise((value, keep), (sp.S.One, True))


@dataclass(frozen=True)
class QR:
    """``A = Q R`` for the columns ``a_0..a_(m-1)`` of ``A`` (each of length ``l``).

    ``Q[k]``: unit vectors (or zero vectors where column ``k`` was dropped or exactly dependent);
    ``R[i][k]``: upper triangular (``None`` below the diagonal); ``keep[k]``: the condition under
    which column ``k`` counts as independent.
    """

    Q: list[list[sp.Expr]]
    R: list[list[sp.Expr | None]]
    keep: list[sp.Expr]

    @property
    def diagonal(self) -> list[sp.Expr]:
        return [self.R[k][k] for k in range(len(self.R))]


def _dot(a: Sequence[sp.Expr], b: Sequence[sp.Expr]) -> sp.Expr:
    return sp.Add(*[x * y for x, y in zip(a, b)])


def _project(step: Recorder, q: Sequence[sp.Expr], v: Sequence[sp.Expr], c_name: str, v_name: str):
    """``(c, v - c q)`` with ``c = q . v``, each named: one projection of Gram-Schmidt."""
    c = step(c_name, _dot(q, v))
    return c, [step(f"{v_name}_{e}", x - c * y) for e, (x, y) in enumerate(zip(v, q))]


def _norm(step: Recorder, v: Sequence[sp.Expr], label: str, k: int) -> sp.Expr:
    """``|v|``, its square named first (``sqrt(x**2)`` alone would be ``Abs(x)``)."""
    return step(f"{label}n{k}", sp.sqrt(step(f"{label}nn{k}", sp.Add(*[x**2 for x in v]))))


def gram_schmidt(step: Recorder, columns: Sequence[Sequence[sp.Expr]], label: str) -> QR:
    """Gram-Schmidt QR with re-orthogonalisation of ``columns`` (see the module docstring). A residual of
    exactly zero gives ``Q[k] = 0`` (no division by zero); a rank rule is :func:`pivoted_gram_schmidt`'s."""
    m = len(columns)
    Q: list[list[sp.Expr]] = []
    R: list[list[sp.Expr | None]] = [[None] * m for _ in range(m)]
    keep: list[sp.Expr] = []
    for k, column in enumerate(columns):
        v = [sp.sympify(x) for x in column]
        coefficient = [sp.S.Zero] * k
        for sweep in range(2):
            for i in range(k):
                if all(x == 0 for x in Q[i]):
                    continue
                c, v = _project(step, Q[i], v, f"{label}c{sweep}_{i}_{k}", f"{label}v{sweep}_{i}_{k}")
                coefficient[i] = coefficient[i] + c
        norm = _norm(step, v, label, k)
        kept = sp.StrictGreaterThan(norm, 0)
        inv = step(f"{label}i{k}", 1 / guarded(norm, kept))
        q = [step(f"{label}q{k}_{e}", x * inv) for e, x in enumerate(v)]  # v = 0 exactly where norm = 0
        for i in range(k):
            value = coefficient[i]
            R[i][k] = step(f"{label}R{i}_{k}", value) if value != 0 else sp.S.Zero
        R[k][k] = norm
        Q.append(q)
        keep.append(kept)
    return QR(Q, R, keep)


def pivoted_gram_schmidt(
    step: Recorder,
    vectors: Sequence[Sequence[sp.Expr]],
    carried: Sequence[Sequence[sp.Expr]],
    label: str,
    threshold: sp.Expr,
) -> tuple[QR, list[list[sp.Expr]]]:
    """Gram-Schmidt QR of ``vectors`` taken largest residual first, with a rank rule: rank-revealing.

    Without pivoting a rank rule on the residuals can miss a near-dependency spread over several of them
    (float Stanford arm: the smallest singular value of its scaled Jacobian 1e-8 of the largest, below
    float's epsilon, but two residuals of 5e-5 and 6e-4 against a threshold of 3e-5: the direction was
    kept, and the solve gave |dq| = 1e7). Here step ``k`` takes, of the vectors not yet taken, the one
    whose residual against ``Q[0..k-1]`` is longest (compared squared; a tie keeps the earlier one), so
    the residuals decrease and the first at most ``threshold`` ends the rank: it and every later one are
    dropped (``R[k][k] = 0``, ``Q[k] = 0``). The remaining vectors are projected on each new ``Q[k]`` as it
    is made (modified Gram-Schmidt); the one taken is projected on all earlier ``Q`` once more ("twice is
    enough"), both coefficients adding up in ``R``: as many projections as :func:`gram_schmidt`'s.

    The choice is straight-line: at step ``k`` one bubbling pass of compare-and-swap from the last vector
    to position ``k`` (selects of the residual, the coefficients so far and ``carried``). ``carried[i]``:
    values that travel with vector ``i`` (a row's scale, its right-hand side); returned in the order
    taken, beside the QR of the vectors in that order (``R[i][k]``: vector ``k`` taken on ``Q[i]``).
    """
    groups = _orthogonal_groups(vectors)
    if len(groups) > 1:  # factorised apart: their QR is block diagonal, their rank the sum
        return _combined([pivoted_gram_schmidt(step, [vectors[i] for i in group], [carried[i] for i in group],
                                               f"{label}g{g}", threshold) for g, group in enumerate(groups)])
    m = len(vectors)
    slots = [{"v": [sp.sympify(x) for x in vector], "c": [], "x": list(carried[i])} for i, vector in enumerate(vectors)]
    Q: list[list[sp.Expr]] = []
    R: list[list[sp.Expr | None]] = [[None] * m for _ in range(m)]
    keep: list[sp.Expr] = []
    order: list[list[sp.Expr]] = []
    for k in range(m):
        squares = {s: step(f"{label}p{k}_{s}", sp.Add(*[x**2 for x in slots[s]["v"]])) for s in range(k, m)}
        for s in reversed(range(k + 1, m)):  # one bubbling pass: the longest residual ends at position k
            longer = step(f"{label}gt{k}_{s}", sp.StrictGreaterThan(squares[s], squares[s - 1]))
            low, high = slots[s - 1], slots[s]
            swapped = {}
            for key in ("v", "c", "x"):
                pairs = list(zip(low[key], high[key]))
                swapped[key] = (
                    [step(f"{label}{key}{k}_{s}_{e}L", select(longer, b, a)) for e, (a, b) in enumerate(pairs)],
                    [step(f"{label}{key}{k}_{s}_{e}H", select(longer, a, b)) for e, (a, b) in enumerate(pairs)],
                )
            squares[s - 1], squares[s] = (step(f"{label}pp{k}_{s}L", select(longer, squares[s], squares[s - 1])),
                                          step(f"{label}pp{k}_{s}H", select(longer, squares[s - 1], squares[s])))
            slots[s - 1] = {key: swapped[key][0] for key in swapped}
            slots[s] = {key: swapped[key][1] for key in swapped}
        taken = slots[k]
        v, coefficient = taken["v"], list(taken["c"])
        for i in range(k):  # the second pass of the one taken
            c, v = _project(step, Q[i], v, f"{label}r{i}_{k}", f"{label}w{i}_{k}")
            coefficient[i] = coefficient[i] + c
        norm = _norm(step, v, label, k)
        kept = step(f"{label}keep{k}", sp.StrictGreaterThan(norm, threshold))
        inv = step(f"{label}i{k}", 1 / guarded(norm, kept))
        q = [step(f"{label}q{k}_{e}", sp.Piecewise((x * inv, kept), (sp.S.Zero, True))) for e, x in enumerate(v)]
        for i in range(k):
            R[i][k] = step(f"{label}R{i}_{k}", coefficient[i])
        R[k][k] = step(f"{label}d{k}", sp.Piecewise((norm, kept), (sp.S.Zero, True)))
        Q.append(q)
        keep.append(kept)
        order.append(taken["x"])
        for s in range(k + 1, m):  # the vectors left, projected on the new Q[k]
            c, v_left = _project(step, q, slots[s]["v"], f"{label}c{k}_{s}", f"{label}u{k}_{s}")
            slots[s] = {"v": v_left, "c": slots[s]["c"] + [c], "x": slots[s]["x"]}
    return QR(Q, R, keep), order


def _orthogonal_groups(vectors: Sequence[Sequence[sp.Expr]]) -> list[list[int]]:
    """The vectors' indices in groups, in order of first index, such that vectors of different groups have no
    nonzero entry at a common position (they are orthogonal whatever the values): a SCARA's vertical velocity
    row, which only its prismatic joint moves, apart from its other rows."""
    support = [{e for e, x in enumerate(vector) if x != 0} for vector in vectors]
    group_of = list(range(len(vectors)))

    def root(i: int) -> int:
        while group_of[i] != i:
            i = group_of[i]
        return i

    for i in range(len(vectors)):
        for j in range(i):
            if support[i] & support[j]:
                a, b = root(i), root(j)
                group_of[max(a, b)] = min(a, b)
    groups: dict[int, list[int]] = {}
    for i in range(len(vectors)):
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


def _combined(parts: list[tuple[QR, list[list[sp.Expr]]]]) -> tuple[QR, list[list[sp.Expr]]]:
    """One QR (block diagonal ``R``) and one order from the QRs of groups of mutually orthogonal vectors."""
    m = sum(len(qr.Q) for qr, _ in parts)
    Q: list[list[sp.Expr]] = []
    R: list[list[sp.Expr | None]] = [[None] * m for _ in range(m)]
    keep: list[sp.Expr] = []
    order: list[list[sp.Expr]] = []
    start = 0
    for qr, taken in parts:
        size = len(qr.Q)
        for i in range(size):
            for k in range(start, m):
                R[start + i][k] = qr.R[i][k - start] if k - start < size and qr.R[i][k - start] is not None else (
                    None if k < start + i else sp.S.Zero)
        Q.extend(qr.Q)
        keep.extend(qr.keep)
        order.extend(taken)
        start += size
    return QR(Q, R, keep), order


def adjugate_upper(step: Recorder, R: Sequence[Sequence[sp.Expr | None]], label: str) -> list[list[sp.Expr]]:
    """``adj(R) = det(R) R^-1`` of an upper triangular ``R`` without a division (finite when ``R`` is singular).

    With ``Z[i][j] = (R^-1)[i][j] * prod_{l=i..j} R[l][l]`` (a polynomial): ``Z[j][j] = 1``,
    ``Z[i][j] = -sum_{k=i+1..j} R[i][k] Z[k][j] prod_{l=i+1..k-1} R[l][l]``; then
    ``adj[i][j] = Z[i][j] prod_{l outside i..j} R[l][l]`` (upper triangular).
    """
    m = len(R)
    d = [R[k][k] for k in range(m)]

    def prod(indices) -> sp.Expr:
        return sp.Mul(*[d[l] for l in indices])

    Z = [[sp.S.Zero] * m for _ in range(m)]
    for j in range(m):
        Z[j][j] = sp.S.One
        for i in reversed(range(j)):
            total = sp.Add(*[R[i][k] * Z[k][j] * prod(range(i + 1, k)) for k in range(i + 1, j + 1)])
            Z[i][j] = step(f"{label}Z{i}_{j}", -total)
    adj = [[sp.S.Zero] * m for _ in range(m)]
    for i in range(m):
        for j in range(i, m):
            outside = [l for l in range(m) if l < i or l > j]
            adj[i][j] = step(f"{label}adj{i}_{j}", Z[i][j] * prod(outside))
    return adj


def back_substitute(step: Recorder, R: Sequence[Sequence[sp.Expr | None]], rhs: Sequence[sp.Expr], label: str) -> list[sp.Expr]:
    """``z`` with ``R z = rhs`` for upper triangular ``R``; ``z[k] = 0`` where ``R[k][k]`` is not positive."""
    m = len(R)
    z: list[sp.Expr] = [sp.S.Zero] * m
    for k in reversed(range(m)):
        diag = R[k][k]
        kept = sp.StrictGreaterThan(diag, 0)
        inv = step(f"{label}i{k}", 1 / guarded(diag, kept))
        value = rhs[k] - sp.Add(*[R[k][j] * z[j] for j in range(k + 1, m)])
        z[k] = step(f"{label}z{k}", sp.Piecewise((value * inv, kept), (sp.S.Zero, True)))
    return z


ROUNDING_SHARE = sp.Rational(1, 25)
"""The part of the rank tolerance (100 eps: 4 eps) below which a Gram-Schmidt residual of a 3-D chain's Jacobian is
rounding itself, dropped under a small damping (:func:`damped_least_squares`; a planar arm's, whose tolerance grows
with its links, takes the whole tolerance)."""


def damped_least_squares(step: Recorder, rows: Sequence[Sequence[sp.Expr]], scales: Sequence[sp.Expr], rhs: Sequence[sp.Expr],
                         lam: sp.Expr, mu: sp.Expr, tol: sp.Expr, label: str, scaled_when_dropping: bool = False,
                         lam_scale: sp.Expr | None = None, rounding_share: sp.Expr = ROUNDING_SHARE) -> list[sp.Expr]:
    """``dq = M^T (M M^T + lambda^2 I)^+ rhs`` (n entries), ``M = rows`` (m rows of n), the minimiser of
    ``|M dq - rhs|^2 + lambda^2 |dq|^2`` of least norm, in two QR stages:

    1. Gram-Schmidt on the rows of ``B = diag(scales) M`` taken largest residual first (rank-revealing,
       :func:`pivoted_gram_schmidt`; rows that are identically zero are left out): ``P B^T = Q R``; where
       ``min(lambda, 1) <= tol |B|_F`` a row whose residual is at most ``tol |B|_F`` is dropped (and every later
       one); with a damping up to ``sqrt(tol) |B|_F`` a row of rounding itself (a residual at most
       ``rounding_share`` of that, :data:`ROUNDING_SHARE` by default), which the damping would turn into
       ``s / lambda^2``. With more damping no row is dropped: the damping bounds what a small singular value
       ``s`` adds (``s / (s^2 + lambda^2)``).
    2. ``dq = Q z`` with ``z`` the least-squares solution of ``[diag(scales)^-1 R^T; lambda I] z = [rhs; 0]``, by
       a second Gram-Schmidt QR and a guarded back substitution.

    With ``lambda = 0`` at a singular pose: the minimum-norm least-squares solution with the dropped rows'
    residuals removed (``numpy.linalg.pinv`` with a relative cut-off near ``tol``); finite always. Its error follows
    ``cond(B)``, not its square.

    ``lam_scale``: ``lambda`` times it is the damping in the scaled rows' units, which the rule reads (None: 1).
    ``scaled_when_dropping`` (a planar arm's ``inverse_velocity3``): where the damping is negligible (that product at
    most ``tol |B|_F``) the second stage solves the scaled problem ``min |B dq - diag(scales) rhs|^2``: the same
    solution where the rows are consistent, and where they are not (a singular pose) the least-squares compromise
    between rows of different units measured in scaled units, which no unit of length changes (and whose rounding
    does not grow with the scales' spread, as the unscaled rows' does: about eps / min(scales)^2 relative).

    ``scales[r]``: the factor row ``r`` is multiplied by for the rank rule (1/L or 1). ``mu = 1/max(1, lambda)``:
    the second stage solves the same least-squares problem with every row divided by ``max(1, lambda)``,
    ``min |mu M dq - mu rhs|^2 + (mu lambda)^2 |dq|^2``, whose entries stay below ``|M|`` and 1 for every
    finite lambda (``lambda^2`` overflows from 1.8e154 in double, 1.8e19 in float), and whose solution tends
    to 0 as lambda grows (exactly 0 once ``mu`` underflows).
    """
    n = len(rows[0])
    # a row of J that is identically zero (a SCARA's wx, wy) leaves the solution alone: it is not factorised
    live = [r for r, row in enumerate(rows) if any(x != 0 for x in row)]
    rows, scales, rhs = [rows[r] for r in live], [scales[r] for r in live], [rhs[r] for r in live]
    m = len(rows)
    scaled = [[step(f"{label}b{r}_{c}", x * scales[r]) for c, x in enumerate(row)] for r, row in enumerate(rows)]
    frob = step(f"{label}F", sp.sqrt(step(f"{label}FF", sp.Add(*[x**2 for row in scaled for x in row]))))
    factor = [step(f"{label}f{r}", mu / scales[r]) for r in range(m)]
    damping = step(f"{label}lam", lam * mu)  # min(lambda, 1)
    limit = step(f"{label}tau", tol * frob)
    # the rank rule serves the undamped solve: a row whose residual is at most the limit is dropped while the damping
    # is at most the limit too. A row of rounding (a stretched arm's, an aligned wrist's) is dropped while the damping
    # is at most sqrt(tol) |B|_F, the geometric mean of the limit and the matrix: kept, a rounding direction of singular
    # value s adds s / lambda^2 (UR5 at q5 = 0, lambda = 1e-12: |dq| 6698 for 2.97)
    rule = step(f"{label}lams", damping * lam_scale) if lam_scale is not None else damping
    kept_from = step(f"{label}kf", sp.sqrt(tol) * frob)
    # between the limit and that bound only rounding itself goes (ROUNDING_SHARE of the limit, a few eps): a real
    # direction resolved to a percent (float UR5 at q5 = 1e-4: 77 eps of |B|) carries the damped answer there
    threshold = step(f"{label}th", sp.Piecewise((limit, sp.LessThan(rule, limit)),
                                                (limit * rounding_share, sp.LessThan(rule, kept_from)), (sp.S.Zero, True)))
    if scaled_when_dropping:
        dropping = sp.LessThan(rule, limit)  # and the damping negligible: the scaled problem's answer
        factor = [step(f"{label}g{r}", sp.Piecewise((mu, dropping), (factor[r], True))) if scales[r] != 1 else factor[r]
                  for r in range(m)]
        rhs = [step(f"{label}t{r}", sp.Piecewise((rhs[r] * scales[r], dropping), (rhs[r], True))) if scales[r] != 1 else rhs[r]
               for r in range(m)]
    # rows taken longest residual first (rank-revealing); each row's factor and right-hand side go with it
    # (the order of a least-squares problem's rows does not change its solution)
    first, order = pivoted_gram_schmidt(step, scaled, [(factor[r], rhs[r]) for r in range(m)], f"{label}A", threshold)
    columns = []
    for k in range(m):
        top = [sp.S.Zero if r < k else step(f"{label}M{r}_{k}", first.R[k][r] * order[r][0]) for r in range(m)]
        bottom = [damping if e == k else sp.S.Zero for e in range(m)]
        columns.append(top + bottom)
    second = gram_schmidt(step, columns, f"{label}B")
    c = [step(f"{label}c{k}", mu * sp.Add(*[second.Q[k][r] * order[r][1] for r in range(m)])) for k in range(m)]
    z = back_substitute(step, second.R, c, f"{label}s")
    return [step(f"{label}x{j}", sp.Add(*[first.Q[k][j] * z[k] for k in range(m)])) for j in range(n)]
