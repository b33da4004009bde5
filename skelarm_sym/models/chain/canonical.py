"""The chain as motions about or along ``z`` separated by constant transforms (step 1 of
:mod:`skelarm_sym.models.chain.derive`), constant rotations about joint axes moved into the angles, and the
sines and cosines of named parameters as steps."""

from __future__ import annotations

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
