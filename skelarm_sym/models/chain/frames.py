"""Segments of parallel axes and their frames, the tool offsets by Horner's rule, the Jacobian's columns in
segment axes and in tool axes (steps 2-4 and 7 of :mod:`skelarm_sym.models.chain.derive`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .algebra import Rows, Vector, _rows, _rz, _rz_times, _times_rz, _z_rotation_angle, _numeric, matmul, matvec
from .canonical import _Canonical
from .joints import E_Z, add
from .model import Transform
from .steps import _Steps


@dataclass
class _Frames:
    """Forward pass: segments of parallel axes and the angles within them.

    ``segment[k]``: the segment of joint ``k``; ``rotation[s]``: ``F_s``, the rotation of the frame of its
    first joint in base axes (rows); ``starts``/``ends``: first and last joint of each segment;
    ``trig[k]``: ``(cos, sin)`` of ``psi_k``, the angle of the frames after joint ``k`` about the segment's
    ``z`` (``None`` while nothing in the segment turned); ``theta[k]``: the joint variable;
    ``axes[k]``: ``z_k`` in base axes.
    """

    segment: list[int]
    rotation: list[Rows]
    starts: list[int]
    ends: list[int]
    trig: list[tuple[sp.Expr, sp.Expr] | None]
    theta: list[sp.Expr]
    axes: list[Vector]
    scale: list[sp.Expr] | None = None
    """``tau_s`` per segment where ``rotation[s]`` holds ``F~_s = F_s diag(1, 1, 1 / tau_s)`` (:func:`_scaled_frames`);
    ``None``: every ``rotation[s]`` is ``F_s`` itself."""
    tag: str = ""
    """Told apart in step labels from the other frames' steps (``""`` for the plain frames)."""
    columns: list[tuple[sp.Expr, sp.Expr]] | None = None
    """Per segment ``(1 / sigma_s, 1 / tau_s)`` where ``rotation[s]`` holds ``F~_s = F_s diag(sigma_s, tau_s, 1)``
    with ``sigma_s tau_s = 1`` (:func:`_twist_scaled_frames`): what turns a kept entry of the first column, and
    of the second, into the true value (a cofactor of the two needs nothing). ``None``: unscaled."""
    turns: list[tuple[sp.Expr, sp.Expr, sp.Expr]] | None = None
    """Per joint ``(k1, k2, mu)``: ``G~_k = G_k diag(mu, mu, 1) = F~_s [[c k1, -s k1, 0], [s k2, c k2, 0], [0, 0, 1]]``
    (:func:`_turned_rows`); ``None`` with ``columns``."""


def _frames(step: _Steps, joints: Sequence[_Canonical], q: Sequence[sp.Symbol]) -> _Frames:
    """Segments, their frames ``F_s`` (multiplied out entry by entry) and one angle per turning joint."""
    f = _Frames([], [], [], [], [], [], [])
    angle: sp.Expr | None = None  # psi of the previous joint
    for k, joint in enumerate(joints):
        theta = joint.multiplier * q[joint.coordinate] + joint.offset
        turn = joint.motion.turn(theta)
        beta = _z_rotation_angle(joint.before.rotation) if k else None
        if beta is not None and (turn is not None or beta == 0):  # parallel axes: the same segment
            f.ends[-1] = k
        else:
            f.starts.append(k)
            f.ends.append(k)
            if k == 0:
                f.rotation.append(_rows(joint.before.rotation))
            else:
                s = len(f.rotation) + 1
                turned = step.mat(f"G{s}_", _times_rz(f.rotation[-1], f.trig[k - 1]))  # named before any constant multiplies it
                f.rotation.append(step.mat(f"F{s}_", matmul(turned, _rows(joint.before.rotation))))
            angle, beta = None, sp.S.Zero
        if turn is not None:
            angle = step(f"th{k + 1}", _angle_sum(step, angle, _numeric(beta) + turn))
            f.trig.append((step(f"c{k + 1}", sp.cos(angle)), step(f"s{k + 1}", sp.sin(angle))))
        else:
            f.trig.append(f.trig[k - 1] if f.starts[-1] != k else None)
        f.segment.append(len(f.rotation) - 1)
        f.theta.append(theta)
        f.axes.append([row[2] for row in f.rotation[-1]])
    return f


def _angle_sum(step: _Steps, before: sp.Expr | None, turn: sp.Expr) -> sp.Expr:
    """``psi_k = psi_(k-1) + turn``, written with the terms of ``psi_(k-1)``'s step where a term cancels (PR2's finger
    tip turns back by the finger's angle: ``(psi + q) - q = psi``, the same sine and cosine)."""
    if before is None:
        return turn
    definition = step.definitions().get(before)
    if definition is not None:
        expanded = definition + turn
        if sp.count_ops(expanded) < sp.count_ops(before + turn):
            return expanded
    return before + turn


def _tool_offsets(step: _Steps, joints: Sequence[_Canonical], f: _Frames, tool: Transform) -> list[Vector]:
    """``W_k = p_e - o_k`` in the axes of joint ``k``'s segment frame, tip to base (Horner's rule)."""
    n = len(joints)
    W: list[Vector] = [None] * n
    for k in reversed(range(n)):
        W[k] = _horner_step(step, joints, f, k, joints[k + 1].before if k + 1 < n else tool,
                            W[k + 1] if k + 1 < n else None, f"W{k + 1}")
    return W


def _horner_step(step: _Steps, joints: Sequence[_Canonical], f: _Frames, k: int, nxt: Transform, w: Vector | None,
                 name: str) -> Vector:
    """One step of Horner's rule: the offset from ``o_k`` in the axes of joint ``k``'s segment frame, given the
    constant transform ``nxt`` after joint ``k`` and the offset ``w`` beyond it in the axes after ``nxt`` (``None``:
    nothing beyond it), named ``name``."""
    t = list(nxt.translation)
    if w is not None and k + 1 < len(joints) and f.segment[k + 1] == f.segment[k]:
        v = add(_rz(f.trig[k], t), w)  # same axes: the planar arm's sum
    else:
        inner = add(t, matvec(_rows(nxt.rotation), w)) if w is not None else t
        v = _rz(f.trig[k], inner)
    v[2] = v[2] + joints[k].motion.advance(f.theta[k])
    return step.vec(name, v)


def _columns(step: _Steps, joints: Sequence[_Canonical], f: _Frames, W: Sequence[Vector]) -> tuple[list[Vector], list[Vector]]:
    """Per joint, ``(Jv_k, Jw_k)`` in base axes: its type's column in segment axes, rotated by ``F_s``."""
    linear, angular = [], []
    for k, joint in enumerate(joints):
        F = f.rotation[f.segment[k]]
        lin, ang = joint.motion.column(E_Z, W[k])
        linear.append(step.vec(f"Jv{k + 1}", matvec(F, lin)))
        angular.append(step.vec(f"Jw{k + 1}", matvec(F, ang)))
    return linear, angular


def _tool_jacobian(step: _Steps, joints, f: _Frames, tool: Transform, W) -> tuple[list[Vector], list[Vector]]:
    """Per joint, its column in tool axes: ``B_s^T column_k(W_k)`` with ``B_s = F_s^T R`` built tip to base,
    ``B_s = Rz(psi_end) C B_(s+1)`` (``B_last = Rz(psi_n) C_tool``)."""
    B: list[Rows] = [None] * len(f.rotation)
    below = _rows(tool.rotation)
    for s in reversed(range(len(f.rotation))):
        B[s] = step.mat(f"B{s + 1}_", _rz_times(f.trig[f.ends[s]], below))
        if s:
            below = matmul(_rows(joints[f.starts[s]].before.rotation), B[s])
    linear, angular = [], []
    for k, joint in enumerate(joints):
        Bt = [[B[f.segment[k]][j][i] for j in range(3)] for i in range(3)]
        lin, ang = joint.motion.column(E_Z, W[k])
        linear.append(step.vec(f"Jtv{k + 1}", matvec(Bt, lin)))
        angular.append(step.vec(f"Jtw{k + 1}", matvec(Bt, ang)))
    return linear, angular


def _scaled_frames(step: _Steps, joints: Sequence[_Canonical], f: _Frames) -> _Frames:
    """The frames of ``f`` with their third columns scaled: ``F_s = F~_s diag(1, 1, tau_s)``.

    ``Rz`` commutes with ``diag(1, 1, tau)``, so ``F_(s+1) = F_s Rz(psi) C = F~_s Rz(psi) C~ diag(1, 1, tau')``
    with ``C~ = diag(1, 1, tau) C diag(1, 1, 1 / tau')``; ``tau'`` is chosen to make an entry of ``C~`` +-1.
    A dense constant rotation (a URDF twist written ``1.5708``: ``Rx`` with cosine -3.67e-6) then costs 5
    operations a row instead of 6 (``(x, y, z) -> (x, c y - s^2 z, y + c z)``), and the scales fold into the
    constants that multiply the third columns (link offsets). Where every constant is a signed permutation
    every ``tau`` stays 1 and these are the frames of ``f`` (the recorder returns the same steps)."""
    rotation: list[Rows] = [f.rotation[0]]
    scale: list[sp.Expr] = [sp.S.One]
    for s, k in enumerate(f.starts[1:], start=1):
        C = _rows(joints[k].before.rotation)
        tau = scale[-1]
        options = [tau, sp.S.One] + [x for x in (C[0][2], C[1][2], tau * C[2][2]) if x != 0] + [-x for x in (C[0][2], C[1][2], tau * C[2][2]) if x != 0]
        best = None
        for new in options:
            Ct = [[_scaled_entry(C[i][j], tau if i == 2 else 1, new if j == 2 else 1) for j in range(3)] for i in range(3)]
            cost = sum(1 for row in Ct for x in row if x != 0 and abs(x) != 1)
            if best is None or cost < best[0]:
                best = (cost, new, Ct)
        _, new, Ct = best
        turned = step.mat(f"Gz{s + 1}_", _times_rz(rotation[-1], f.trig[k - 1]))
        rotation.append(step.mat(f"Fz{s + 1}_", matmul(turned, Ct)))
        scale.append(new)
    axes = [[row[2] * scale[f.segment[k]] for row in rotation[f.segment[k]]] for k in range(len(joints))]
    return _Frames(f.segment, rotation, f.starts, f.ends, f.trig, f.theta, axes, scale, "z")


def _twist_scaled_frames(step: _Steps, joints: Sequence[_Canonical], f: _Frames) -> _Frames | None:
    """The frames of ``f`` with their first two columns scaled, ``F~_s = F_s diag(S_s, 1 / S_s, 1)``, where every
    segment after the first starts with a rotation about ``x`` (a twist ``Rx(alpha_s)``, ``S_s = sin alpha_s``)
    and some twist is dense (a URDF's ``1.5708``; ``None`` otherwise).

    The frame after joint ``k``'s motion is kept as ``G~_k = G_k diag(mu, mu, 1)`` with ``mu`` the sine of the
    twist that follows it (``F~_s``'s first column scale where none follows): a twist then costs 4 operations a
    row, ``(x, y, z) -> (x, c / S^2 y + z, -y + c z)`` (with ``c = cos alpha``), instead of 6, and the axis (the
    third column) is exact. The joint's rotation pays for it: ``k2 = mu S_s`` multiplies its sine and cosine
    (:func:`_turned_rows`; 2 operations a joint, shared by the rows; none where every twist has the same
    ``|sin|`` and ``k1 = mu / S_s`` is +-1). A cofactor of the first two columns (an axis's entry in the row
    the Jacobian does not carry) needs no unscaling (``S_s / S_s = 1``); the link offsets fold the scales into
    their constants. The values are the URDF's: only the constants ``c / S^2`` and ``mu S`` are rounded. Only
    for twists within 45 degrees of a quarter turn (``|cos alpha| <= |sin alpha|``): a row's kept entries mix
    ``c / S^2 y~`` with ``z``, which amplifies their rounding by ``|cot alpha|`` (a URDF's 3.14159, sine 2.65e-6,
    would lose 5 digits)."""
    starts = f.starts[1:]
    sines = []
    for k in starts:
        C = _rows(joints[k].before.rotation)
        if [C[0][0], C[0][1], C[0][2], C[1][0], C[2][0]] != [1, 0, 0, 0, 0] or C[2][1] == 0 or C[1][1] != C[2][2] \
                or C[1][2] != -C[2][1] or any(sp.sympify(x).free_symbols for row in C for x in row):
            return None
        if abs(C[1][1]) > abs(C[2][1]):  # |cot alpha| > 1: the scales would amplify rounding (by |cot alpha|)
            return None
        sines.append(sp.sympify(C[2][1]))
    if all(abs(x) == 1 for x in sines) or any(t is None for t in f.trig):
        return None
    n = len(joints)
    rotation: list[Rows] = [f.rotation[0]]
    columns = [(sp.S.One, sp.S.One)]
    sigma = [sp.S.One]
    turns: list[tuple[sp.Expr, sp.Expr, sp.Expr]] = [None] * n
    for s in range(len(f.starts)):
        following = sines[s] if s < len(sines) else None
        for k in range(f.starts[s], f.ends[s] + 1):
            mu = following if k == f.ends[s] and following is not None else sigma[s]
            turns[k] = (_scaled_entry(mu, 1, sigma[s]), _scaled_entry(mu, sigma[s], 1) if s else mu, mu)
        if following is None:
            break
        k = f.ends[s]
        C = _rows(joints[f.starts[s + 1]].before.rotation)
        Ct = [[1, 0, 0], [0, _scaled_entry(C[1][1], 1, _scaled_entry(following, following, 1)), -1], [0, 1, C[2][2]]]
        G = step.mat(f"Gy{s + 2}_", _turned_rows(step, f, k, rotation[s], turns[k]))
        rotation.append(step.mat(f"Fy{s + 2}_", matmul(G, Ct)))
        columns.append((_scaled_entry(1, 1, following), following))
        sigma.append(following)
    return _Frames(f.segment, rotation, f.starts, f.ends, f.trig, f.theta, f.axes, None, "y", columns, turns)


def _turned_rows(step: _Steps, f: _Frames, k: int, M: Rows, turn: tuple[sp.Expr, sp.Expr, sp.Expr]) -> Rows:
    """``F~_s [[c k1, -s k1, 0], [s k2, c k2, 0], [0, 0, 1]]`` for joint ``k`` (``(c, s) = f.trig[k]``): the
    kept rows of ``G~_k``; the scaled sine and cosine are steps of their own, shared by the rows."""
    c, s = f.trig[k]
    k1, k2, _ = turn

    def times(x, factor, name):
        return x * factor if abs(factor) == 1 else step(f"{name}{f.tag}{k + 1}", x * factor)

    c1, s1, c2, s2 = times(c, k1, "ck"), times(s, k1, "sk"), times(c, k2, "cK"), times(s, k2, "sK")
    return [[r[0] * c1 + r[1] * s2, -r[0] * s1 + r[1] * c2, r[2]] for r in M]


def _actual(f: _Frames, s: int, M: Rows) -> Rows:
    """``M`` (a matrix in the axes of segment ``s``'s frame as :func:`_scaled_frames` keeps it) with its third
    column times ``tau_s``: the true matrix."""
    if f.scale is None or f.scale[s] == 1:
        return M
    return [[r[0], r[1], r[2] * f.scale[s]] for r in M]


def _scaled_entry(x: sp.Expr, times: sp.Expr, over: sp.Expr) -> sp.Expr:
    """``x times / over`` for the constants of :func:`_scaled_frames`: exact where all three are, else a double
    (exactly +-1 or 0 where the double is: ``x / x`` is 1 in floating point, and prints as no product)."""
    value = sp.sympify(x) * times / over
    if not value.has(sp.Float):
        return value
    number = float(value)
    return sp.Integer(int(number)) if number in (0.0, 1.0, -1.0) else sp.Float(number)
