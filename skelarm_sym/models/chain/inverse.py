"""Inverse differential kinematics of a 3-D chain as named steps: manipulability and its gradient,
the kinematic Hessian, damped inverse velocity, the roll-pitch-yaw Jacobian.

Hooked into :func:`skelarm_sym.models.chain.derive.derive_chain` by :func:`extend`, which adds steps,
outputs and function specs to the chain's derivation. All functions are straight-line (fixed size,
no loops, no allocation); the small factorisations are those of :mod:`skelarm_sym.derive.solve6`.

* ``manipulability``: ``w = prod of the singular values of J`` = ``sqrt(det(J J^T))`` for N >= 6,
  ``sqrt(det(J^T J))`` for N < 6, as ``prod_k R[k][k]`` of a Gram-Schmidt QR with
  re-orthogonalisation of ``J^T`` (N >= 6: the six rows of J) or of ``J`` (N < 6: its N columns).
  ``manipulability_position`` likewise for the 3 x N linear rows.
* ``jacobian_hessian``: ``Hs[(r*N + c)*N + j] = d J[r][c] / d q[j]`` (shape 6 x N x N). Per moving
  joint pair (``k`` the column's joint, ``i`` the differentiating one, base-to-tip order, ``col_k``
  its 6-vector ``[Jv_k; Jw_k]``): ``i <= k`` and ``i`` revolute: ``z_i x col_k`` (both halves);
  ``i > k`` and ``k`` revolute: ``[z_k x Jv_i; 0]``; every other pair (a prismatic ``i <= k``, a
  prismatic ``k`` with ``i > k``): zero. Mimic joints add up with their multipliers.
* ``manipulability_gradient``: with ``A = Q R`` the QR above (``A = J^T`` or ``J``),
  ``dw/dq_j = sum G[x][b] dA[x][b]/dq_j``, ``G = Q adj(R)^T`` (``= w A^+T``): the adjugate of the
  triangular factor has no division, so the gradient stays finite at singular poses (where ``w``
  itself is not differentiable, the value is that of this formula).
* ``inverse_velocity``: ``dq = J^T (J J^T + lambda^2 I)^-1 twist``, the minimiser of
  ``|J dq - twist|^2 + lambda^2 |dq|^2`` of least norm, in two QR stages:
  1. Gram-Schmidt on the rows of ``B = S J``, ``S = diag(1/L, 1/L, 1/L, 1, 1, 1)`` with ``L`` the
     chain's reach (sum of its constant translations; 1 if that is zero), so the rank rule does not
     depend on the unit of length, taken largest residual first (rank-revealing, see
     :func:`~skelarm_sym.derive.solve6.pivoted_gram_schmidt`; rows of J that are identically zero are
     left out): ``P B^T = Q R``; where ``min(lambda, 1) <= RANK_TOL * |B|_F`` a row whose residual is at
     most ``RANK_TOL * |B|_F`` is dropped (row ``k`` of ``R`` and ``Q[k]`` set to zero) and so is every
     later one; up to ``sqrt(RANK_TOL) * |B|_F`` a row of rounding itself (a 25th of that: 4 eps), which a
     small damping would turn into ``s / lambda^2``. With more damping no row is dropped: the damping
     bounds what a small singular value ``s`` adds (``s / (s^2 + lambda^2)``).
  2. ``dq = Q z`` with ``z`` the least-squares solution of ``[S^-1 R^T; lambda I] z = [twist; 0]`` (the
     rows in the order taken), by a second Gram-Schmidt QR and a guarded back substitution; every row divided by ``max(1, lambda)``
     first (the same solution), so no entry overflows for any finite lambda and the answer tends to 0,
     the limit, as lambda grows.
  With ``lambda = 0`` at a singular pose this is the minimum-norm least-squares solution of the
  Jacobian with the dropped rows' residuals removed (``numpy.linalg.pinv`` with a relative cut-off
  near RANK_TOL); finite always. ``inverse_velocity_position``: the same for the 3 linear rows and
  a linear velocity ``v`` (no scaling needed).
* ``jacobian_rpy``: ``JA = blockdiag(I, E^-1) J`` for the tool's roll, pitch, yaw
  (``R = Rz(yaw) Ry(pitch) Rx(roll)``), ``omega = E d(rpy)/dt``. With ``c = cos(pitch)`` from
  ``R``: ``E^-1 = [[cy/c, sy/c, 0], [-sy, cy, 0], [cy tp, sy tp, 1]]``, ``tp = tan(pitch)``. Where
  ``c^2 <= RANK_TOL`` (pitch within about 1e-7 of +-pi/2 in double; gimbal lock) the roll and yaw
  rows are set to zero and the pitch row is ``[-sin(yaw), cos(yaw), 0]`` with yaw read from ``R``
  as ``atan2(-R01, R11)`` (the roll = 0 convention): finite, documented.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import sympy as sp

from ...derive.core import RANK_TOL, FunctionSpec
from ...derive.solve6 import adjugate_upper, damped_least_squares, gram_schmidt, guarded

INVERSE_FUNCTIONS = (
    FunctionSpec("ik_terms", ("q", "params"), ("T", "J"), "tool pose T and Jacobian J at once (the terms of an IK step)"),
    FunctionSpec("manipulability", ("q", "params"), ("w",), "manipulability w = product of the singular values of J (1)"),
    FunctionSpec(
        "manipulability_position", ("q", "params"), ("w_position",),
        "position manipulability: product of the singular values of the 3 x N linear rows of J (1)",
    ),
    FunctionSpec(
        "jacobian_hessian", ("q", "params"), ("Hs",),
        "kinematic Hessian Hs[(r*N + c)*N + j] = dJ[r][c]/dq[j] (6 x N x N)",
    ),
    FunctionSpec("manipulability_gradient", ("q", "params"), ("grad",), "gradient dw/dq of the manipulability (N)"),
    FunctionSpec(
        "inverse_velocity", ("q", "twist", "params", "lambda"), ("dq",),
        "damped least-squares joint rates dq = J^T (J J^T + lambda^2 I)^+ twist (N)",
    ),
    FunctionSpec(
        "inverse_velocity_position", ("q", "v", "params", "lambda"), ("dq_position",),
        "damped least-squares joint rates for a tool-origin velocity v (3 linear rows of J) (N)",
    ),
    FunctionSpec(
        "jacobian_rpy", ("q", "params"), ("JA",),
        "analytical Jacobian for roll-pitch-yaw rates, blockdiag(I, E(rpy)^-1) J (6 x N row-major)",
    ),
)


def characteristic_length(chain, step=None) -> sp.Expr:
    """``L``: the sum of the lengths of the chain's constant translations (base excluded); 1 if zero.

    With ``step``, symbolic squared lengths are named first (so ``sqrt(a**2)`` prints as a square root,
    not as ``Abs``)."""
    parts = [t.translation for j in chain.joints for t in (j.before, j.after)] + [chain.tool.translation]
    squares = [sp.Add(*[sp.sympify(x) ** 2 for x in v]) for v in parts]
    if step is not None:
        squares = [step(f"reach{i}", e) if e.free_symbols else e for i, e in enumerate(squares)]
    total = sp.Add(*[sp.sqrt(e) for e in squares])
    if not total.free_symbols:
        value = float(total)
        return sp.Float(value, 17) if value > 0 else sp.S.One
    return total


def _hessian(step, joints, axes, linear, angular, n) -> list[list[list[sp.Expr]]]:
    """``H[r][c][j] = dJ[r][c]/dq_j`` from per-joint cross products (see the module docstring): for ``i <= k``
    joint ``i`` turns column ``k`` (``turns_columns``), for ``i > k`` column ``k`` follows the tool point,
    which joint ``i`` moves by ``Jv_i`` (``follows_tool``); each joint type says what it contributes."""
    H = [[[sp.S.Zero] * n for _ in range(n)] for _ in range(6)]
    zero = [sp.S.Zero] * 3
    for k, jk in enumerate(joints):
        for i, ji in enumerate(joints):
            if i <= k:
                term = ji.motion.turns_columns(axes[i], linear[k], angular[k])
            else:
                follow = jk.motion.follows_tool(axes[k], linear[i])
                term = None if follow is None else (follow, zero)
            if term is None:
                continue
            factor = sp.sympify(jk.multiplier) * sp.sympify(ji.multiplier)
            for r, value in enumerate(list(term[0]) + list(term[1])):
                if value != 0:
                    H[r][jk.coordinate][ji.coordinate] += factor * value
    return [[[step(f"H{r}_{c}_{j}", H[r][c][j]) for j in range(n)] for c in range(n)] for r in range(6)]


def _manipulability(step, rows: Sequence[Sequence[sp.Expr]], label: str):
    """``(w, qr, by_rows)``: QR of the rows (when there are no more rows than columns) or columns."""
    m, n = len(rows), len(rows[0])
    by_rows = n >= m
    vectors = rows if by_rows else [[rows[r][c] for r in range(m)] for c in range(n)]
    qr = gram_schmidt(step, vectors, label)
    w = step(f"{label}w", sp.Mul(*qr.diagonal))
    return w, qr, by_rows


QUADRATIC_UP_TO = 16
"""``jacobian_hessian`` (6 N^2 outputs) and ``manipulability_gradient`` (about 36 N^2 operations) are
emitted for chains of up to this many coordinates; longer chains get the other inverse functions
(all linear in N), so that generation stays linear."""
QUADRATIC = ("jacobian_hessian", "manipulability_gradient")


def extend(derivation, step, joints, axes, linear, angular, tool_rotation):
    """The chain's derivation with the inverse functions added (see the module docstring)."""
    chain = derivation.model
    n = chain.n
    quadratic = n <= QUADRATIC_UP_TO
    J = derivation.compact["J"]
    rows = [[step(f"Jc{r}_{c}", J[r, c]) for c in range(n)] for r in range(6)]
    tol = RANK_TOL.symbol
    lam = sp.Symbol("lambda", real=True)
    mu = step("mu", 1 / guarded(lam, sp.StrictGreaterThan(lam, 1)))  # 1 / max(1, lambda)
    twist = sp.symbols("xi_vx xi_vy xi_vz xi_wx xi_wy xi_wz", real=True)
    velocity = sp.symbols("nu_x nu_y nu_z", real=True)

    w, qr, by_rows = _manipulability(step, rows, "mw")
    w_position, _, _ = _manipulability(step, rows[:3], "mp")

    grad = []
    if quadratic:
        H = _hessian(step, joints, axes, linear, angular, n)
        adj = adjugate_upper(step, qr.R, "madj")
        count = len(qr.R)
        length = len(qr.Q[0])
        # G[x][b] = sum_i Q[i][x] adj[b][i]; A[x][b] = J[b][x] (by rows) or J[x][b] (by columns)
        G = [[step(f"mG{x}_{b}", sp.Add(*[qr.Q[i][x] * adj[b][i] for i in range(b, count)])) for b in range(count)] for x in range(length)]
        for j in range(n):
            terms = [G[x][b] * (H[b][x][j] if by_rows else H[x][b][j]) for x in range(length) for b in range(count)]
            grad.append(step(f"mgrad{j}", sp.Add(*terms)))

    reach = characteristic_length(chain, step)
    if reach.free_symbols:
        reach = step("reach", guarded(reach, sp.StrictGreaterThan(reach, 0)))
    ireach = step("ireach", 1 / reach) if reach.free_symbols else sp.Float(1 / float(reach), 17) if reach != 1 else sp.S.One
    dq = damped_least_squares(step, rows, [ireach] * 3 + [sp.S.One] * 3, twist, lam, mu, tol, "iv")
    dq_position = damped_least_squares(step, rows[:3], [sp.S.One] * 3, velocity, lam, mu, tol, "ip")

    JA = _jacobian_rpy(step, rows, tool_rotation, tol)

    outputs = {
        "w": sp.Matrix([w]),
        "w_position": sp.Matrix([w_position]),
        **({"Hs": sp.Matrix([H[r][c][j] for r in range(6) for c in range(n) for j in range(n)]),
            "grad": sp.Matrix(grad)} if quadratic else {}),
        "dq": sp.Matrix(dq),
        "dq_position": sp.Matrix(dq_position),
        "JA": sp.Matrix(JA),
    }
    shapes = {"w": (1,), "w_position": (1,), "Hs": (6, n, n), "grad": (n,), "dq": (n,), "dq_position": (n,), "JA": (6, n)}
    notes = (
        "Inverse functions: w = product of J's singular values (sqrt(det(J J^T)) for N >= 6, else sqrt(det(J^T J)));",
        f"Hs[(r*{n} + c)*{n} + j] = dJ[r][c]/dq[j]; grad = dw/dq; dq = J^T (J J^T + lambda^2 I)^-1 twist by two QR",
        "stages (rows of J scaled by 1/reach for the rank rule, taken largest Gram-Schmidt residual first; with",
        "lambda <= RANK_TOL times the Frobenius norm, a row whose residual is at most that is dropped, a row of rounding",
        "(RANK_TOL/25 of it) while lambda <= sqrt(RANK_TOL) times it, so",
        "lambda = 0 at a singular pose gives the minimum-norm least-squares rates, finite);",
        "JA = blockdiag(I, E(rpy)^-1) J with R = Rz(yaw) Ry(pitch) Rx(roll):",
        "where cos(pitch)^2 <= RANK_TOL the roll and yaw rows of E^-1 are zero (finite at gimbal lock).",
    )
    if not quadratic:
        notes = notes + (
            f"jacobian_hessian and manipulability_gradient (quadratic in N) are emitted for N <= {QUADRATIC_UP_TO} only.",
        )
    domains = dict(derivation.domains)
    domains.update({"twist": "finite", "v": "finite", "lambda": "nonnegative"})
    inputs = dict(derivation.inputs)
    inputs.update({"twist": twist, "v": velocity, "lambda": (lam,)})
    return dataclasses.replace(
        derivation,
        inputs=inputs,
        steps=tuple(step.steps),
        compact={**derivation.compact, **outputs},
        shapes={**derivation.shapes, **shapes},
        functions=tuple(derivation.functions) + tuple(f for f in INVERSE_FUNCTIONS if quadratic or f.name not in QUADRATIC),
        parameters=tuple(derivation.parameters) + ("lambda",),
        scalars=tuple(derivation.scalars) + ("lambda",),
        domains=domains,
        constants=tuple(derivation.constants) + (RANK_TOL,),
        notes=tuple(derivation.notes) + notes,
        _cache={},
    )


def _jacobian_rpy(step, rows, R, tol) -> list[sp.Expr]:
    """``blockdiag(I, E^-1) J`` row-major (see the module docstring)."""
    n = len(rows[0])
    c2 = step("rpy_c2", R[0][0] ** 2 + R[1][0] ** 2)
    regular = step("rpy_regular", sp.StrictGreaterThan(c2, tol))
    ic2 = step("rpy_ic2", 1 / guarded(c2, regular))
    c = step("rpy_c", sp.sqrt(c2))
    ic = step("rpy_ic", 1 / guarded(c, regular))
    # yaw at gimbal lock (roll = 0): R01 = -sin(yaw), R11 = cos(yaw)
    g = step("rpy_g", sp.sqrt(step("rpy_gg", R[0][1] ** 2 + R[1][1] ** 2)))
    ig = step("rpy_ig", 1 / guarded(g, sp.StrictGreaterThan(g, 0)))
    cy = step("rpy_cy", sp.Piecewise((R[0][0] * ic, regular), (R[1][1] * ig, True)))
    sy = step("rpy_sy", sp.Piecewise((R[1][0] * ic, regular), (-R[0][1] * ig, True)))
    zero = sp.S.Zero
    E = [
        [step("rpy_E00", sp.Piecewise((R[0][0] * ic2, regular), (zero, True))),
         step("rpy_E01", sp.Piecewise((R[1][0] * ic2, regular), (zero, True))), zero],
        [-sy, cy, zero],
        [step("rpy_E20", sp.Piecewise((-R[0][0] * R[2][0] * ic2, regular), (zero, True))),
         step("rpy_E21", sp.Piecewise((-R[1][0] * R[2][0] * ic2, regular), (zero, True))),
         sp.Piecewise((sp.S.One, regular), (zero, True))],
    ]
    out = [rows[r][c] for r in range(3) for c in range(n)]
    for i in range(3):
        for cidx in range(n):
            out.append(step(f"JA{i}_{cidx}", sp.Add(*[E[i][k] * rows[3 + k][cidx] for k in range(3)])))
    return out
