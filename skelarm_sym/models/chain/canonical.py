"""The chain as motions about or along ``z`` separated by constant transforms (step 1 of
:mod:`skelarm_sym.models.chain.derive`), constant rotations about joint axes moved into the angles, and the
sines and cosines of named parameters as steps."""

from __future__ import annotations

import math
from dataclasses import dataclass

import sympy as sp

from .algebra import _numeric, _split_z, _z_alignment
from .joints import JointType, joint_type
from .model import Chain, Transform
from .steps import _Steps


@dataclass(frozen=True)
class _Canonical:
    """A joint as a z motion: constant transform before it, joint type, coordinate, multiplier, angle offset."""

    before: Transform
    motion: JointType
    coordinate: int
    multiplier: sp.Expr
    offset: sp.Expr

    @property
    def kind(self) -> str:
        """The joint type's name (``revolute``, ``prismatic``)."""
        return self.motion.kind


def _turns(motion: JointType) -> bool:
    return motion.turn(sp.S.One) is not None


def canonical_joints(chain: Chain) -> tuple[list[_Canonical], Transform]:
    """The chain as z motions separated by constant transforms; returns the joints and the tool transform.

    ``before`` of the first joint includes the base; the tool transform includes the last ``after``.
    Offsets that are multiples of pi/2 (revolute) and all prismatic offsets are in the constants
    (:meth:`JointType.fold_offset`); other revolute offsets stay in the angle.
    """
    out = []
    carry = chain.base
    for joint in chain.joints:
        motion = joint_type(joint.kind)
        Q = _z_alignment(joint.axis)
        fold, offset = motion.fold_offset(sp.sympify(joint.offset))
        before = carry @ joint.before @ Transform(rotation=sp.ImmutableMatrix(Q)) @ fold
        out.append(_Canonical(before, motion, joint.coordinate, sp.sympify(joint.multiplier), _numeric(offset)))
        carry = Transform(rotation=sp.ImmutableMatrix(Q.T)) @ joint.after
    return out, carry @ chain.tool


_FLIP = sp.ImmutableMatrix([[1, 0, 0], [0, -1, 0], [0, 0, -1]])
"""``Rx(pi)``: turns ``z`` into ``-z``; ``Rx(pi) Rz(theta) = Rz(-theta) Rx(pi)``."""


def _flips_into_angles(joints: list[_Canonical], tool: Transform) -> tuple[list[_Canonical], Transform]:
    """The canonical chain with a joint whose axis is the reversed axis of a turning joint of its segment (the
    constant rotations between them take ``z`` to ``-z``, slides along the axis between them) written about the
    same axis with the variable negated: ``[P, t] M(theta) = [P Rx(pi), t] M(-theta) Rx(pi)`` for a turn or a
    slide ``M`` along ``z``, ``P Rx(pi)`` a turn about ``z`` that :func:`_axis_turns_into_angles` folds into the
    angle, and ``Rx(pi)`` carried into the next constant (or the tool transform). The joint then shares the
    segment and the angles add up: PR2's finger tip, about ``-z`` and mimicking the finger joint, turns by
    ``q - q = 0``: no frame multiplied by a turn that the next one undoes (and, where the finger shares its
    segment with the joint before, no sine and cosine of its own: :func:`~.frames._angle_sum`). A SCARA's quill
    slides along the elbow's reversed axis and its wrist turns about it: both flipped, the wrist's angle is
    ``q1 + q2 - q4``, one sine and cosine instead of a product of frames. A slide is flipped only where it then
    joins the segment (no turn before it) and a turning joint of the same axis follows; the first joint keeps
    its constant."""
    out = list(joints)
    turned = False  # the segment so far (as frames._frames builds it) has a turning joint
    for k, joint in enumerate(out):
        P = joint.before.rotation
        turns = _turns(joint.motion)
        if k and turned and list(P[:, 2]) == [0, 0, -1] and (
                turns or (P * _FLIP == sp.eye(3) and _turn_follows(out, k + 1, _FLIP))):
            joint = out[k] = _Canonical(Transform(sp.ImmutableMatrix(P * _FLIP), joint.before.translation),
                                        joint.motion, joint.coordinate, -joint.multiplier, _numeric(-joint.offset))
            P = joint.before.rotation
            if k + 1 < len(out):
                after = out[k + 1]
                out[k + 1] = _Canonical(Transform(rotation=_FLIP) @ after.before, after.motion, after.coordinate,
                                        after.multiplier, after.offset)
            else:
                tool = Transform(rotation=_FLIP) @ tool
        joins = k > 0 and list(P[:, 2]) == [0, 0, 1] and (turns or P == sp.eye(3))
        turned = turns or (joins and turned)
    return out, tool


def _turn_follows(joints: list[_Canonical], j: int, pushed: sp.Matrix) -> bool:
    """Whether, with the rotation ``pushed`` in front of joint ``j``'s constant, a turning joint about the same axis
    (either sign) follows, across slides that keep to it."""
    for joint in joints[j:]:
        P = pushed * joint.before.rotation
        if _turns(joint.motion):
            return list(P[:, 2]) in ([0, 0, 1], [0, 0, -1])
        if P == sp.eye(3):
            pushed = sp.eye(3)
        elif P * _FLIP == sp.eye(3):
            pushed = _FLIP
        else:
            return False
    return False


def _axis_turns_into_angles(joints: list[_Canonical], tool: Transform) -> tuple[list[_Canonical], Transform]:
    """The canonical chain with constant rotations about joint axes moved into the angles (free at run time):
    one about a turning joint's axis right before it (``[P Rz(beta), t] Rz(theta) = [P, t] Rz(theta + beta)``)
    and one about the last axis at the start of the tool transform
    (``Rz(theta) [Rz(beta) P, t] = Rz(theta + beta) [P, Rz(-beta) t]``), ``P`` a signed permutation
    (:func:`_split_z`). Panda's TCP, turned by -pi/4 about the flange axis, costs one addition so."""
    out = []
    for joint in joints:
        split = _split_z(joint.before.rotation) if _turns(joint.motion) else None
        if split is not None:
            joint = _Canonical(Transform(sp.ImmutableMatrix(split[0]), joint.before.translation), joint.motion,
                               joint.coordinate, joint.multiplier, _numeric(joint.offset + split[1]))
        out.append(joint)
    split = _split_z(tool.rotation.T) if _turns(out[-1].motion) else None
    if split is not None:  # tool rotation = Rz(beta) P with beta = -split[1], P = split[0]^T
        beta = -split[1]
        shift = Transform.rotate("z", -beta).rotation * tool.translation
        tool = Transform(sp.ImmutableMatrix(split[0].T), sp.ImmutableMatrix(shift))
        last = out[-1]
        out[-1] = _Canonical(last.before, last.motion, last.coordinate, last.multiplier, _numeric(last.offset + beta))
    return out, tool


def _twists_into_angles(joints: list[_Canonical], tool: Transform) -> tuple[list[_Canonical], Transform]:
    """The canonical chain with each constant rotation after a revolute joint or before one written ``Rz(gamma)
    Rx(alpha) Rz(delta)`` (z-x-z angles) and its turns about the joint axes moved into the angles: ``Rz(gamma)``
    into the revolute joint before (``Rz(theta') [Rz(gamma) C', t] = Rz(theta' + gamma) [C', Rz(-gamma) t]``),
    ``Rz(delta)`` into a revolute joint after (``[C' Rz(delta), t] Rz(theta) = [C', t] Rz(theta + delta)``);
    before a prismatic joint or in the tool transform ``Rz(delta)`` stays in the constant. Multiples of pi/2 stay
    in the constant (a signed permutation, free). A URDF whose joint frames are turned about their axes (iCub,
    Romeo, TIAGo: every entry of the constant rotations a decimal) then carries its frames' rows through
    ``Rx(alpha)``, 6 operations a row instead of 15, for one addition per angle that takes a turn; Panda's
    finger, a prismatic joint in a hand turned by -pi/4, gets a signed permutation before it (pose 133 -> 113).
    Only where the constant gets fewer entries other than 0 and +-1 and the rebuilt rotation is the URDF's to
    1e-15: the values are the same rigid motions (the angles rounded once, to a double)."""
    out, n = list(joints), len(joints)
    for k in range(n + 1):  # k = n: the tool transform
        constant = out[k].before if k < n else tool
        C = constant.rotation
        turns = k < n and _turns(out[k].motion)
        before_turns = k > 0 and _turns(out[k - 1].motion)
        if C.free_symbols or not (turns or before_turns) or (k == n and any(constant.translation[:2])):
            continue  # (a tool offset off the last axis would turn with it: the Jacobian would pay for the pose)
        split = _zxz(C)
        if split is None:
            continue
        gamma, alpha, delta = split
        g0, gr = _quarter(gamma) if before_turns else (gamma, 0.0)
        d0, dr = _quarter(delta)
        if not turns and dr:  # before a prismatic joint or in the tool: Rz(delta) stays in the constant
            d0, dr = delta, 0.0
        if gr == 0.0 and dr == 0.0:
            continue
        a0, ar = _quarter(alpha)
        rotation = _rz_matrix(g0) * _rx_matrix(alpha if ar else a0) * _rz_matrix(d0)
        if _dense_entries(rotation) >= _dense_entries(C):
            continue
        rebuilt = _rz_matrix(gr) * rotation * _rz_matrix(dr)
        if any(abs(float(rebuilt[i, j]) - float(C[i, j])) > 1e-15 for i in range(3) for j in range(3)):
            continue  # a turn kept in neither place: not the same rotation to a double
        translation = constant.translation
        if gr:
            translation = sp.ImmutableMatrix([sp.Float(float(x), 17) if x.is_Float else x for x in _rz_matrix(-gr) * translation])
            prev = out[k - 1]
            out[k - 1] = _Canonical(prev.before, prev.motion, prev.coordinate, prev.multiplier, _numeric(prev.offset + sp.Float(gr)))
        constant = Transform(sp.ImmutableMatrix(rotation), sp.ImmutableMatrix(translation))
        if k == n:
            tool = constant
        else:
            joint = out[k]
            out[k] = _Canonical(constant, joint.motion, joint.coordinate, joint.multiplier,
                                _numeric(joint.offset + sp.Float(dr)) if dr else joint.offset)
    for k, joint in enumerate(out):  # two turns that cancel to rounding (iCub: -3.67e-6 + 3.67e-6 = 2.2e-16): no addition
        if joint.offset != joints[k].offset and joint.offset.is_Float and abs(float(joint.offset)) <= 1e-15:
            out[k] = _Canonical(joint.before, joint.motion, joint.coordinate, joint.multiplier, sp.S.Zero)
    return out, tool


def _zxz(C: sp.Matrix) -> tuple[float, float, float] | None:
    """``(gamma, alpha, delta)`` with ``C = Rz(gamma) Rx(alpha) Rz(delta)`` (to 1e-15), ``sin alpha`` not 0; else
    ``None`` (a turn about ``z`` alone, which :func:`_axis_turns_into_angles` and the segments take)."""
    m = [[float(C[i, j]) for j in range(3)] for i in range(3)]
    sa = math.hypot(m[2][0], m[2][1])
    if sa < 1e-9:
        return None
    alpha = math.atan2(sa, m[2][2])
    gamma = math.atan2(m[0][2], -m[1][2])
    delta = math.atan2(m[2][0], m[2][1])
    back = _rz_matrix(gamma) * _rx_matrix(alpha) * _rz_matrix(delta)
    if any(abs(float(back[i, j]) - m[i][j]) > 1e-15 for i in range(3) for j in range(3)):
        return None
    return gamma, alpha, delta


def _quarter(angle: float) -> tuple[sp.Expr, float]:
    """``(q, r)``: ``angle = q + r`` with ``q`` an exact multiple of pi/2 and ``r`` the rest, 0.0 where it is
    rounding only (below 1e-15; a rest of 1e-13, as in SO-101's URDF, is a turn and is kept)."""
    k = round(angle / (math.pi / 2))
    rest = angle - k * math.pi / 2
    return sp.Integer(k) * sp.pi / 2, (rest if abs(rest) > 1e-15 else 0.0)


def _rz_matrix(angle) -> sp.Matrix:
    c, s = _trig(angle)
    return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _rx_matrix(angle) -> sp.Matrix:
    c, s = _trig(angle)
    return sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])


def _trig(angle) -> tuple[sp.Expr, sp.Expr]:
    """Cosine and sine: exact for a SymPy multiple of pi/2, else doubles."""
    if isinstance(angle, sp.Basic):
        return sp.cos(angle), sp.sin(angle)
    return sp.Float(math.cos(angle), 17), sp.Float(math.sin(angle), 17)


def _dense_entries(C: sp.Matrix) -> int:
    return sum(1 for x in C if x not in (-1, 0, 1))


def _named_trig_constants(step: _Steps, joints: list[_Canonical], tool: Transform) -> tuple[list[_Canonical], Transform]:
    """Every sine and cosine of a named parameter in the constant transforms (``cos(alpha)`` for a
    parameter ``alpha``) as a step of its own, used everywhere by that name (the trigonometric block
    evaluates it once)."""
    transforms = [j.before for j in joints] + [tool]
    atoms = set().union(*[m.atoms(sp.sin, sp.cos) for t in transforms for m in (t.rotation, t.translation)])
    if not atoms:
        return joints, tool
    names = {a: step(f"k{i}", a) for i, a in enumerate(sorted(atoms, key=sp.default_sort_key))}

    def named(t: Transform) -> Transform:
        return Transform(t.rotation.xreplace(names), t.translation.xreplace(names))

    return [_Canonical(named(j.before), j.motion, j.coordinate, j.multiplier, j.offset) for j in joints], named(tool)
