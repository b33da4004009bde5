"""Differential kinematics of a 3-D serial chain, as named steps of linear size.

Frames and outputs (the convention of every emitted header):

* ``T``: 4 x 4 pose of the tool frame in the base frame, row-major.
* ``J``: 6 x N geometric Jacobian, rows ``vx vy vz wx wy wz`` in base axes, reference point the
  tool origin (Pinocchio's LOCAL_WORLD_ALIGNED, the Robotics Toolbox's ``jacob0``): column ``c``
  is ``sum_k m_k [z_k x (p_e - o_k); z_k]`` over the revolute joints ``k`` moved by coordinate ``c``
  (``m_k`` the mimic multiplier, 1 normally) and ``m_k [z_k; 0]`` over prismatic ones.
* ``J_tool``: the same in the tool frame's axes, ``blockdiag(R^T, R^T) J`` (seed 003's ``J^u``).
* ``dJ``: ``dJ/dt`` in the frame of ``J``; ``twist = J dq`` (tool-origin velocity, angular
  velocity); ``acc = J ddq + dJ dq`` (classical acceleration of the tool origin, angular acceleration).

How (Khalil's customised symbolic method: one name per non-trivial intermediate, each quantity
projected into the axes where it is cheapest and rotated once; what a joint contributes comes
from its :class:`~skelarm_sym.models.chain.joints.JointType`):

1. **Canonical joints** (:func:`canonical_joints`): every joint becomes a motion about or along
   ``z`` after a constant transform; a joint about the reversed axis of a turning joint of its segment
   (slides along it between them) moves about the same axis by the negated variable (:func:`_flips_into_angles`:
   they share a frame); offsets that
   are multiples of pi/2 (revolute) and all prismatic offsets fold into the constants, and a constant
   rotation about a joint's axis (or about the last axis in the tool transform) into its angle
   (:func:`_axis_turns_into_angles`); a constant rotation next to a revolute joint (between two, before a
   prismatic joint, or in the tool transform) is written ``Rz(gamma) Rx(alpha) Rz(delta)`` and its turns go
   into the angles of the revolute joints on either side (:func:`_twists_into_angles`).
2. **Segments** (:func:`_frames`): consecutive joints whose axes are parallel (the constant
   rotation between them is about ``z``: UR5's joints 2-4, every planar arm) share one frame
   ``F_s``; their angles add up (``psi_k = psi_(k-1) + beta_k + theta_k``), one sine and one
   cosine per revolute joint (none where the sum cancels: a mimic turning back, :func:`_angle_sum`).
   Frame ``F_(s+1) = F_s Rz(psi) C`` is multiplied out entry by entry (only the entries some output uses
   are emitted).
3. **Tool offsets** (:func:`_tool_offsets`), tip to base, Horner's rule: ``W_k = p_e - o_k`` in the
   axes of ``F_s``. Within a segment ``W_k = W_(k+1) + Rz(psi_k) t_(k+1)`` (planar-arm cost);
   across segments ``W_k = Rz(psi_k) (t + C W_(k+1))``. ``p_e = o_1 + F_1 W_1``.
4. **Columns** (:func:`_columns`): ``[Jv_k; Jw_k] = F_s column_k(W_k)``; for a revolute joint
   ``F_s [e_z x W_k; e_z] = [-W_y f_0 + W_x f_1; f_2]``: two columns of ``F_s``, shared by the
   segment, six multiplications.
   Or in base axes (:func:`_column_candidates`): ``z_k x r_(k+1)`` with ``r_k = p_e - o_k`` suffix sums of
   the links (:func:`_base_offsets`; a link along the axis adds nothing, so a wrist's last column is
   exactly zero), one row of every frame taken as cofactors of the two others where an output needs it
   (:func:`_cofactor_view`: 3 operations an entry instead of carrying the row), and a column taken in the
   next frame's axes where the tool offset has a zero there (:func:`_next_frame_columns`). The last link's
   offset and column come from the two carried rows (:func:`_last_link`); for the cheapest dropped row, an
   axis's entry in that row may come from the frame before it (:func:`_propagated_views`), and the last link
   may be turned by its joint's angle instead of its frame's rows (:func:`_turned_last_axes`); with dense twists
   about ``x``, these from frames kept with their first two columns scaled (:func:`_twist_scaled_frames`: a
   twist 4 operations a row instead of 6).
5. **Pose** (:func:`_pose`): ``R = F_last Rz(psi_n) C_tool``; two of its rows are multiplied out and
   the third is their cross product (the cheapest choice is taken): the rotation chain carries
   two rows, not three. The position by Horner's rule (3.), or summed link by link in base axes with
   the dropped row's entries as cofactors (:func:`_link_shares`: a wrist's offset is then ``d R e_z``); for the
   ``pose`` function also cut at a joint, Horner's rule before it and the sum after it (:func:`_split_tips`).
   Each forward function takes the candidates cheapest for its own outputs (:func:`_choose`); where
   that differs from ``kinematics``'s choice the function reads its own output
   (:attr:`~skelarm_sym.derive.core.Derivation.variants`).
6. **Velocities** (:func:`_velocities`): ``w_k = w_(k-1) + z_k dtheta_k``, ``u_k = sum_(j>k) Jv_j
   dtheta_j`` (a suffix sum; ``u_0`` is the tool velocity); each joint type gives ``d/dt`` of its
   column from them (for a revolute joint ``[w_k x Jv_k + z_k x u_k; w_(k-1) x z_k]``, Jacobi's
   identity): no differentiation of large expressions anywhere.
7. **Tool axes** (:func:`_tool_jacobian`): ``B_s = F_s^T R`` tip to base
   (``B_s = Rz(psi) C B_(s+1)``) and ``J_tool`` columns ``B_s^T column_k(W_k)``: never ``R^T J``.

Where each stage lives (this module only puts them together): :mod:`.canonical` (1.), :mod:`.frames` (2.-4., 7.),
:mod:`.candidates` (the other columns, the pose: 4.-5.), :mod:`.price` (the estimate and the choice),
:mod:`.rates` (6.), :mod:`.signs` (the signs of the steps), :mod:`.steps` (the recorder), :mod:`.algebra`.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .algebra import Vector
from .canonical import (_Canonical, _axis_turns_into_angles, _flips_into_angles, _named_trig_constants, _twists_into_angles,
                        canonical_joints)
from .candidates import CANDIDATES_UP_TO, _Columns, _column_candidates, _dense_constants, _pose
from .frames import _columns, _frames, _scaled_frames, _tool_jacobian, _tool_offsets, _twist_scaled_frames
from .model import Chain
from .price import Pose, _choose
from .signs import _settle_signs
from .steps import _Steps
from .target_rotation import ORTHO_CONSTANT
from ...derive.core import UNBOUNDED, Derivation, FunctionSpec, Table
from ...derive.float_facts import float_facts

__all__ = ["CHAIN_FUNCTIONS", "ChainDerivation", "canonical_joints", "derive_chain"]

CHAIN_FUNCTIONS = (
    FunctionSpec("pose", ("q", "params"), ("T",), "tool pose T (4 x 4 homogeneous, row-major)"),
    FunctionSpec("jacobian", ("q", "params"), ("J",), "geometric Jacobian J (6 x N row-major: vx vy vz wx wy wz, base axes, tool origin)"),
    FunctionSpec("jacobian_tool", ("q", "params"), ("J_tool",), "the Jacobian in the tool frame's axes (6 x N row-major)"),
    FunctionSpec("jacobian_dot", ("q", "dq", "params"), ("dJ",), "dJ/dt (6 x N row-major, same frame as J)"),
    FunctionSpec("twist", ("q", "dq", "params"), ("twist",), "tool twist J dq: (vx, vy, vz, wx, wy, wz) (6)"),
    FunctionSpec(
        "acceleration", ("q", "dq", "ddq", "params"), ("acc",),
        "classical acceleration of the tool origin and angular acceleration J ddq + dJ dq (6)",
    ),
    FunctionSpec("kinematics", ("q", "dq", "ddq", "params"), ("T", "J", "dJ", "twist", "acc"), "T, J, dJ, twist and acc at once"),
)


@dataclass(frozen=True, eq=False)
class ChainDerivation(Derivation):
    """A chain's derivation: the generic one plus views of its outputs as SymPy matrices."""

    @property
    def params(self) -> tuple[sp.Symbol, ...]:
        """Named parameters (inputs ``params``), in order."""
        return self.inputs.get("params", ())

    @property
    def T(self) -> sp.Matrix:
        """Tool pose, 4 x 4."""
        return self.closed_form("T")

    @property
    def J(self) -> sp.Matrix:
        """Geometric Jacobian, 6 x N (base axes, tool origin)."""
        return self.closed_form("J")

    @property
    def J_tool(self) -> sp.Matrix:
        """Geometric Jacobian in tool axes, 6 x N."""
        return self.closed_form("J_tool")

    @property
    def dJ(self) -> sp.Matrix:
        """``dJ/dt``, 6 x N."""
        return self.closed_form("dJ")

    @property
    def twist(self) -> sp.Matrix:
        """``J dq``, 6 x 1."""
        return self.closed_form("twist")

    @property
    def acc(self) -> sp.Matrix:
        """``J ddq + dJ dq``, 6 x 1."""
        return self.closed_form("acc")


def _by_coordinate(joints: Sequence[_Canonical], n: int, linear: Sequence[Vector], angular: Sequence[Vector]) -> sp.Matrix:
    """The 6 x n matrix whose column ``c`` sums ``m_k [linear_k; angular_k]`` over the joints moved by ``c``."""
    columns = [[sp.S.Zero] * 6 for _ in range(n)]
    for k, joint in enumerate(joints):
        for i, value in enumerate(list(linear[k]) + list(angular[k])):
            columns[joint.coordinate][i] += joint.multiplier * value
    return sp.Matrix([[columns[c][i] for c in range(n)] for i in range(6)])


_OUTPUT_OF = {"pose": "T", "jacobian": "J", "jacobian_dot": "dJ", "twist": "twist", "acceleration": "acc"}
"""The output of each forward function that may be written its own way (:func:`_choose`)."""


def derive_chain(chain: Chain, inverse: bool = True) -> ChainDerivation:
    """Derive ``T, J, J_tool, dJ, twist, acc`` of ``chain`` (see the module docstring), and with ``inverse``
    the inverse functions of :mod:`skelarm_sym.models.chain.inverse`. Linear in N (the Hessian aside). Runs with
    two Float queries answered from the number (:func:`~skelarm_sym.derive.float_facts.float_facts`)."""
    with float_facts():
        return _derive_chain(chain, inverse)


def _derive_chain(chain: Chain, inverse: bool) -> ChainDerivation:
    n = chain.n
    q = sp.symbols(f"q1:{n + 1}", real=True)
    dq = sp.symbols(f"dq1:{n + 1}", real=True)
    ddq = sp.symbols(f"ddq1:{n + 1}", real=True)
    inputs: dict[str, tuple[sp.Symbol, ...]] = {"q": q, "dq": dq, "ddq": ddq}
    if chain.parameters:
        inputs["params"] = tuple(chain.parameters)
    step = _Steps("ch")
    joints, tool = canonical_joints(chain)
    joints, tool = _named_trig_constants(step, *_twists_into_angles(*_axis_turns_into_angles(*_flips_into_angles(joints, tool))))
    frames = _frames(step, joints, q)
    W = _tool_offsets(step, joints, frames, tool)
    linear, angular = _columns(step, joints, frames, W)
    dense = _dense_constants(joints, frames)
    scaled = _scaled_frames(step, joints, frames) if dense and len(joints) <= CANDIDATES_UP_TO else None
    poses, pose_alone, dropped = _pose(step, joints, frames, tool, W, scaled)
    rows = ((None, 0, 1, 2) if dense else (dropped,)) if len(joints) <= CANDIDATES_UP_TO else ((None,) if dense else ())
    twisted = _twist_scaled_frames(step, joints, frames) if scaled is not None else None
    columns = _column_candidates(step, joints, frames, tool, W, linear, angular, dq, ddq, rows, twisted)
    chosen = _choose(step, poses, columns, pose_alone)
    tool_linear, tool_angular = _tool_jacobian(step, joints, frames, tool, W)

    def values(pose: Pose, c: _Columns) -> dict[str, list[Vector]]:
        return {"T": [*pose[0], pose[1]], "J": [*c.linear, *c.angular], "dJ": [*c.rates.d_linear, *c.rates.d_angular],
                "twist": [c.rates.twist], "acc": [c.rates.acc]}

    groups = values(*chosen["kinematics"])  # every function's outputs but where another needs fewer operations
    groups["J_tool"] = [*tool_linear, *tool_angular]
    variants: dict[str, dict[str, str]] = {}
    for function, output in _OUTPUT_OF.items():
        own = values(*chosen[function])[output]
        if any(x is not y for x, y in zip(own, groups[output])):
            variants[function] = {output: f"{output}@{function}"}
            groups[f"{output}@{function}"] = own

    def keys(*functions: str) -> list[str]:
        return [variants.get(f, {}).get(_OUTPUT_OF[f], _OUTPUT_OF[f]) for f in functions]

    functions = [keys("pose"), keys("jacobian"), keys("jacobian_dot"), keys("twist", "acceleration"), ["J_tool"],
                 ["T", "J", "dJ", "twist", "acc"]]
    groups, axes = _settle_signs(step, groups, functions, chosen["kinematics"][1].axes)
    count = len(joints)
    compact = {}
    order = ["T", "J", "J_tool", "dJ", "twist", "acc"]
    for key in order + [k for k in groups if k not in order]:
        group, output = groups[key], key.split("@")[0]
        if output == "T":
            compact[key] = sp.Matrix(group[:3]).row_join(sp.Matrix(group[3])).col_join(sp.Matrix([[0, 0, 0, 1]]))
        elif output in ("J", "J_tool", "dJ"):
            compact[key] = _by_coordinate(joints, n, group[:count], group[count:])
        else:
            compact[key] = sp.Matrix(group[0])
    shapes = {"T": (4, 4), "J": (6, n), "J_tool": (6, n), "dJ": (6, n), "twist": (6,), "acc": (6,)}
    tables, limit_notes = _limit_tables(chain)
    derivation = ChainDerivation(
        model=chain,
        inputs=inputs,
        steps=tuple(step.steps),
        compact=compact,
        shapes=shapes,
        functions=CHAIN_FUNCTIONS,
        parameters=("params",),
        domains={"q": "finite", "dq": "finite", "ddq": "finite", "params": "finite"},
        notes=_notes(chain) + limit_notes,
        tables=tables,
        variants=variants,
        constants=(ORTHO_CONSTANT,),  # ik_solve's; emitted only where a function uses it
    )
    if not inverse:
        return derivation
    from .inverse import extend  # inverse functions (manipulability, Hessian, inverse velocity, rpy)

    return extend(derivation, step, joints, axes, groups["J"][:count], groups["J"][count:], groups["T"][:3])


def _notes(chain: Chain) -> tuple[str, ...]:
    """Header lines: the model, its coordinates and the frames of every output."""
    n = chain.n
    kinds = ", ".join(f"{j.name}: {j.kind}" for j in chain.joints)
    mimics = [f"{j.name} = {_coefficient(j.multiplier)}q[{j.coordinate}] ({chain.coordinates[j.coordinate]})"
              + _plus(j.offset) for j in chain.followers()]
    return (
        f"Model: {chain.describe()}.",
        f"Joints (base to tip): {kinds}.",
        *(_wrap(f"Mimic joints (moved by another joint's coordinate): {'; '.join(mimics)}.") if mimics else ()),
        f"Coordinates q[0..{n - 1}]: {', '.join(chain.coordinates)}; radians (revolute) or metres (prismatic);",
        "dq, ddq are their first and second time derivatives.",
        *(_URDF_ANGLES if (chain.source or "").lower().endswith(".urdf") else ()),
        *([f"params[0..{len(chain.parameters) - 1}]: {', '.join(map(str, chain.parameters))} (metres or radians)."] if chain.parameters else []),
        "Frames: T is the 4 x 4 pose of the tool frame in the base frame (row-major, last row 0 0 0 1).",
        f"J is 6 x {n}, row-major (J[r*{n} + c]): rows vx vy vz wx wy wz in BASE axes, reference point the tool",
        "origin (Pinocchio's LOCAL_WORLD_ALIGNED); a revolute column is [z x (p_tool - o); z], a prismatic one [z; 0].",
        "J_tool is the same Jacobian in the tool frame's axes; dJ = dJ/dt in the frame of J;",
        "twist = J dq = (velocity of the tool origin, angular velocity); acc = J ddq + dJ dq = (classical",
        "acceleration of the tool origin, angular acceleration), all in base axes.",
    )


_URDF_ANGLES = (
    "URDF angles within 1e-12 of a multiple of pi/2, or written as its rounded decimal with 8 or more decimals",
    "(1.57079632679), are taken as that multiple exactly: a tool that reads the decimals as written differs by",
    "their rounding (half a unit in the last decimal, rad) times the reach (3.7e-10 m: ur_description's UR5, 1.570796327).",
)
"""Header lines of a chain from a URDF: the rule of :func:`~.urdf.written_angle`, which explains a difference
from a library that reads the decimals as written (Pinocchio on Kinova's URDF: 1e-11 to 2e-10)."""


def _plus(offset: sp.Expr) -> str:
    """`` + c`` or `` - c`` for a nonzero offset ``c``; nothing for 0."""
    c = sp.sympify(offset)
    if c == 0:
        return ""
    return f" - {_text(-c)}" if c.could_extract_minus_sign() else f" + {_text(c)}"


def _coefficient(multiplier: sp.Expr) -> str:
    """``multiplier`` as the factor written before ``q[c]``: nothing for 1, ``-`` for -1, else ``m*``."""
    m = sp.sympify(multiplier)
    return "" if m == 1 else "-" if m == -1 else f"{_text(m)}*"


def _text(x: sp.Expr) -> str:
    """A number as a header writes it: a float's shortest decimal (``0.5``), else SymPy's text (``pi/2``)."""
    return repr(float(x)) if x.is_Float else str(x)


def _unbounded(sign: str) -> str:
    """What a table's entry without a limit holds in each language (:data:`~skelarm_sym.derive.core.UNBOUNDED`)."""
    return (f"unbounded: {sign}inf in NumPy, {sign}{UNBOUNDED['double']:g} in C "
            f"({sign}{UNBOUNDED['float']:g} in float)")


def _limit_tables(chain: Chain) -> tuple[tuple[Table, ...], tuple[str, ...]]:
    """``Q_MIN``, ``Q_MAX`` (and ``DQ_MAX``) per coordinate when the model has limits, and header lines listing them."""
    limits = chain.limits()
    tables: list[Table] = []
    if any(v is not None for v in limits["lower"] + limits["upper"]):
        tables.append(Table("Q_MIN", limits["lower"], f"lower joint limits in input order (rad or m); {_unbounded('-')}", -1))
        tables.append(Table("Q_MAX", limits["upper"], f"upper joint limits in input order (rad or m); {_unbounded('')}", 1))
    if any(v is not None for v in limits["velocity"]):
        tables.append(Table("DQ_MAX", limits["velocity"], f"joint speed limits in input order (rad/s or m/s); {_unbounded('')}", 1))
    if not tables:
        return (), ()

    def shown(v):
        return "-" if v is None else f"{v:g}"

    rows = ", ".join(
        f"{name} [{shown(lo)}, {shown(hi)}]" + (f" |dq| <= {shown(vel)}" if vel is not None else "")
        for name, lo, hi, vel in zip(chain.coordinates, limits["lower"], limits["upper"], limits["velocity"])
    )
    limited = [j for j in chain.followers() if j.lower is not None or j.upper is not None or j.velocity is not None]
    narrowed = " Each coordinate's range keeps the mimic joints that follow it within their own limits." if limited else ""
    return tuple(tables), tuple(_wrap(f"Joint limits (Q_MIN, Q_MAX, DQ_MAX; -: none): {rows}.{narrowed}"))


def _wrap(text: str) -> list[str]:
    """``text`` in lines of at most 100 characters, a word longer than that (a joint's name) on a line of its own,
    never cut: a note names joints whole, as the header's lists of joints do."""
    return textwrap.wrap(text, 100, break_long_words=False, break_on_hyphens=False)
