"""The joint kinds of a chain behind one small protocol: what the derivation needs from each joint.

The derivation (:mod:`skelarm_sym.models.chain.derive`) first makes every joint a motion about or
along the ``z`` axis of its own frame (frame ``k``: the joint's frame before its motion). It then
asks the joint's :class:`JointType` (Pinocchio's joint models are the example) for

* its **motion**: the angle it turns the frames after it about ``z`` (:meth:`~JointType.turn`) and
  the distance it moves them along ``z`` (:meth:`~JointType.advance`), and where a constant
  offset of its coordinate goes (:meth:`~JointType.fold_offset`);
* its **Jacobian column** (:meth:`~JointType.column`) from its axis ``z`` and ``w``, the tool origin
  relative to a point of the axis, both in one set of axes: the derivation uses the joint's segment
  axes (``z = e_z``: the column is nearly free) and rotates the result into base or tool axes, or
  base axes directly, whichever costs less;
* its **velocity terms**: its share of the angular velocity (:meth:`~JointType.angular_rate`),
  and the time derivative of its column (:meth:`~JointType.column_rate`);
* its **Hessian terms**: how its motion turns the columns of the joints after it
  (:meth:`~JointType.turns_columns`) and how its own column follows a motion of the tool point
  (:meth:`~JointType.follows_tool`). ``dJ_k/dq_i`` is ``turns_columns`` of joint ``i`` applied to
  column ``k`` for ``i <= k``, and ``follows_tool`` of joint ``k`` with ``dp = Jv_i`` for ``i > k``.

Vectors are lists of three SymPy expressions; exact zeros fold by themselves, so a prismatic
joint's zero angular column costs nothing. Frames: every vector handed to a method is in one set
of axes (stated per method), and so is what it returns.
"""

from __future__ import annotations

from typing import Protocol, Sequence

import sympy as sp

from .model import Transform

Vector = list  # three SymPy expressions

ZERO: Vector = [sp.S.Zero] * 3
E_Z: Vector = [sp.S.Zero, sp.S.Zero, sp.S.One]


def cross(a: Sequence[sp.Expr], b: Sequence[sp.Expr]) -> Vector:
    """``a x b``."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def add(a: Sequence[sp.Expr], b: Sequence[sp.Expr]) -> Vector:
    """``a + b``."""
    return [x + y for x, y in zip(a, b)]


def scale(a: Sequence[sp.Expr], factor: sp.Expr) -> Vector:
    """``factor a``."""
    return [x * factor for x in a]


def half_pi_multiple(expr: sp.Expr) -> bool:
    """True for exact multiples of pi/2 (0 included)."""
    expr = sp.sympify(expr)
    return bool(expr.is_zero) or (not expr.free_symbols and bool((expr / (sp.pi / 2)).is_Integer))


class JointType(Protocol):
    """What the chain derivation needs from one kind of joint (see the module docstring)."""

    kind: str

    def fold_offset(self, offset: sp.Expr) -> tuple[Transform, sp.Expr]:
        """Split a constant offset of the joint variable into a constant transform applied before the
        motion (free at run time) and what stays in the variable."""
        ...

    def turn(self, theta: sp.Expr) -> sp.Expr | None:
        """The angle the joint turns the frames after it about its ``z`` axis, or ``None``."""
        ...

    def advance(self, theta: sp.Expr) -> sp.Expr:
        """The distance the joint moves the frames after it along its ``z`` axis."""
        ...

    def column(self, z: Sequence[sp.Expr], w: Sequence[sp.Expr]) -> tuple[Vector, Vector]:
        """``(linear, angular)`` Jacobian column from the joint axis ``z`` and ``w``, the tool origin minus a
        point of the axis (both in the same axes, and so is the column)."""
        ...

    def angular_rate(self, z: Vector, rate: sp.Expr) -> Vector:
        """The joint's share of the angular velocity: ``z`` its axis, ``rate`` its variable's rate."""
        ...

    def column_rate(self, omega_before: Vector, omega_after: Vector, z: Vector, linear: Vector,
                    angular: Vector, suffix: Vector, axis_rate: Vector | None = None) -> tuple[Vector, Vector]:
        """``d/dt`` of its column (all vectors in base axes): ``omega_before``/``omega_after`` the angular
        velocity of the link before/after it, ``suffix`` the velocity the joints after it give the tool point;
        ``axis_rate``: ``d z/dt = omega_before x z`` written another way where the derivation has one."""
        ...

    def turns_columns(self, z: Vector, linear: Vector, angular: Vector) -> tuple[Vector, Vector] | None:
        """``d column / d theta`` of this joint for a column at or after it (``None``: zero)."""
        ...

    def follows_tool(self, z: Vector, dp: Vector) -> Vector | None:
        """Change of its linear column when the tool point moves by ``dp`` (``None``: none)."""
        ...


class Revolute:
    """A rotation by ``theta`` about ``z``: column ``[z x (p_e - o); z]``."""

    kind = "revolute"

    def fold_offset(self, offset: sp.Expr) -> tuple[Transform, sp.Expr]:
        """Multiples of pi/2 become a constant rotation (a signed permutation: free); others stay in the angle."""
        if half_pi_multiple(offset):
            return Transform.rotate("z", offset), sp.S.Zero
        return Transform.identity(), offset

    def turn(self, theta: sp.Expr) -> sp.Expr:
        return theta

    def advance(self, theta: sp.Expr) -> sp.Expr:
        return sp.S.Zero

    def column(self, z: Sequence[sp.Expr], w: Sequence[sp.Expr]) -> tuple[Vector, Vector]:
        return cross(z, w), list(z)  # with z = e_z: (-w_y, w_x, 0), e_z

    def angular_rate(self, z: Vector, rate: sp.Expr) -> Vector:
        return scale(z, rate)

    def column_rate(self, omega_before, omega_after, z, linear, angular, suffix, axis_rate=None):
        # d/dt (z x r) = (w x z) x r + z x (w x r + u) = w x (z x r) + z x u (Jacobi); d/dt z = w_before x z
        return add(cross(omega_after, linear), cross(z, suffix)), axis_rate or cross(omega_before, z)

    def turns_columns(self, z, linear, angular):
        return cross(z, linear), cross(z, angular)

    def follows_tool(self, z, dp):
        return cross(z, dp)


class Prismatic:
    """A translation by ``theta`` along ``z``: column ``[z; 0]``."""

    kind = "prismatic"

    def fold_offset(self, offset: sp.Expr) -> tuple[Transform, sp.Expr]:
        """Every offset is a constant translation along ``z``."""
        return Transform.translate(z=offset), sp.S.Zero

    def turn(self, theta: sp.Expr) -> None:
        return None

    def advance(self, theta: sp.Expr) -> sp.Expr:
        return theta

    def column(self, z: Sequence[sp.Expr], w: Sequence[sp.Expr]) -> tuple[Vector, Vector]:
        return list(z), list(ZERO)

    def angular_rate(self, z: Vector, rate: sp.Expr) -> Vector:
        return list(ZERO)

    def column_rate(self, omega_before, omega_after, z, linear, angular, suffix, axis_rate=None):
        return axis_rate or cross(omega_before, z), list(ZERO)  # the axis turns with the link before it

    def turns_columns(self, z, linear, angular):
        return None  # a translation moves a later axis and the tool point alike

    def follows_tool(self, z, dp):
        return None  # [z; 0] does not depend on where the tool is


JOINT_TYPES: dict[str, JointType] = {joint.kind: joint for joint in (Revolute(), Prismatic())}
"""Every supported joint kind by the name the robot files use."""


def joint_type(kind: str) -> JointType:
    """The :class:`JointType` of a joint kind (``KeyError`` naming the kinds when unknown)."""
    try:
        return JOINT_TYPES[kind]
    except KeyError:
        raise KeyError(f"unknown joint kind {kind!r}; known: {', '.join(JOINT_TYPES)}") from None
