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
            angle = step(f"th{k + 1}", (angle if angle is not None else 0) + _numeric(beta) + turn)
            f.trig.append((step(f"c{k + 1}", sp.cos(angle)), step(f"s{k + 1}", sp.sin(angle))))
        else:
            f.trig.append(f.trig[k - 1] if f.starts[-1] != k else None)
        f.segment.append(len(f.rotation) - 1)
        f.theta.append(theta)
        f.axes.append([row[2] for row in f.rotation[-1]])
    return f


def _tool_offsets(step: _Steps, joints: Sequence[_Canonical], f: _Frames, tool: Transform) -> list[Vector]:
    """``W_k = p_e - o_k`` in the axes of joint ``k``'s segment frame, tip to base (Horner's rule)."""
    n = len(joints)
    W: list[Vector] = [None] * n
    for k in reversed(range(n)):
        nxt = joints[k + 1].before if k + 1 < n else tool
        t = list(nxt.translation)
        if k + 1 < n and f.segment[k + 1] == f.segment[k]:
            v = add(_rz(f.trig[k], t), W[k + 1])  # same axes: the planar arm's sum
        else:
            inner = add(t, matvec(_rows(nxt.rotation), W[k + 1])) if k + 1 < n else t
            v = _rz(f.trig[k], inner)
        v[2] = v[2] + joints[k].motion.advance(f.theta[k])
        W[k] = step.vec(f"W{k + 1}", v)
    return W


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
