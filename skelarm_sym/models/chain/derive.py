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

How (the planar derivation's idea in 3-D; Khalil's customised symbolic method):

1. Every joint is made a motion about or along ``z``: a constant rotation ``Q`` with ``Q z = axis``
   is folded into the constant transforms around it, and so are offsets that are multiples of pi/2
   (revolute) and all prismatic offsets. The constant transforms between two motions are
   multiplied out exactly once, so DH zeros and ones cost nothing.
2. Forward pass, base to tip: the world rotation is kept as ``R_fixed Rz(Theta)``; while the
   constant rotation between consecutive revolute joints is a rotation about ``z`` (parallel
   axes: UR5's joints 2-4, every planar arm) the angles add up (``Theta += beta + theta_k``) and
   ``R_fixed`` is not multiplied again. Each joint gets its axis ``z_k`` (a column of ``R_fixed``)
   and origin ``o_k``; one sine and one cosine per revolute joint.
3. ``r_k = p_e - o_k``; revolute columns ``z_k x r_k``.
4. Velocities: ``w_k = w_(k-1) + z_k dtheta_k`` (revolute), ``u_k = sum_(j>k) Jv_j dtheta_j`` (a suffix
   sum; ``u_0 = J_v dq`` is the tool velocity). With the Jacobi identity,
   ``d/dt (z_k x r_k) = (w x z_k) x r_k + z_k x (w_k x r_k + u_k) = w_k x Jv_k + z_k x u_k``,
   and ``d/dt z_k = w_(k-1) x z_k``: no differentiation of large expressions anywhere.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .model import Chain, Joint, Transform
from ...derive.core import Derivation, FunctionSpec, StepRecorder, Table

Vector = list  # three SymPy expressions

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


# -- small vector algebra on expression lists (exact zeros fold by themselves) -----------------------

def cross(a: Vector, b: Vector) -> Vector:
    """``a x b``."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def matvec(m: Sequence[Sequence[sp.Expr]], v: Vector) -> Vector:
    """``m v`` for a 3 x 3 ``m``."""
    return [sp.Add(*[m[i][j] * v[j] for j in range(3)]) for i in range(3)]


def matmul(a: Sequence[Sequence[sp.Expr]], b: Sequence[Sequence[sp.Expr]]) -> list[list[sp.Expr]]:
    """``a b`` for 3 x 3 matrices."""
    return [[sp.Add(*[a[i][k] * b[k][j] for k in range(3)]) for j in range(3)] for i in range(3)]


def _rows(matrix: sp.Matrix) -> list[list[sp.Expr]]:
    return [[matrix[i, j] for j in range(matrix.cols)] for i in range(matrix.rows)]


def _z_alignment(axis: Sequence[sp.Expr]) -> sp.Matrix:
    """A rotation ``Q`` with ``Q e_z = axis`` (exact for +-x, +-y, +-z)."""
    a = [sp.sympify(x) for x in axis]
    exact = {
        (0, 0, 1): sp.eye(3),
        (0, 0, -1): sp.Matrix([[1, 0, 0], [0, -1, 0], [0, 0, -1]]),
        (1, 0, 0): sp.Matrix([[0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
        (-1, 0, 0): sp.Matrix([[0, 0, -1], [0, 1, 0], [1, 0, 0]]),
        (0, 1, 0): sp.Matrix([[1, 0, 0], [0, 0, 1], [0, -1, 0]]),
        (0, -1, 0): sp.Matrix([[1, 0, 0], [0, 0, -1], [0, 1, 0]]),
    }
    key = tuple(int(x) if x.is_Integer else None for x in a)
    if key in exact:
        return exact[key]
    v = [float(x) for x in a]
    helper = [1.0, 0.0, 0.0] if abs(v[0]) < 0.9 else [0.0, 1.0, 0.0]
    u = [helper[1] * v[2] - helper[2] * v[1], helper[2] * v[0] - helper[0] * v[2], helper[0] * v[1] - helper[1] * v[0]]
    norm = math.sqrt(sum(x * x for x in u))
    u = [x / norm for x in u]
    w = [v[1] * u[2] - v[2] * u[1], v[2] * u[0] - v[0] * u[2], v[0] * u[1] - v[1] * u[0]]
    return sp.Matrix([[sp.Float(u[i]), sp.Float(w[i]), sp.Float(v[i])] for i in range(3)])


def _half_pi_multiple(expr: sp.Expr) -> bool:
    """True for exact multiples of pi/2 (0 included)."""
    expr = sp.sympify(expr)
    return expr.is_zero or (not expr.free_symbols and (expr / (sp.pi / 2)).is_Integer)


def _numeric(expr: sp.Expr) -> sp.Expr:
    """A constant with pi or radicals as a Float (so it prints as a literal); exact 0 and rationals stay."""
    expr = sp.sympify(expr)
    if expr.free_symbols or expr.is_Rational or expr.is_Float:
        return expr
    return sp.Float(expr.evalf(30), 17)


@dataclass(frozen=True)
class _Canonical:
    """A joint as a z motion: constant transform before it, kind, coordinate, multiplier, angle offset."""

    before: Transform
    kind: str
    coordinate: int
    multiplier: sp.Expr
    offset: sp.Expr


def canonical_joints(chain: Chain) -> tuple[list[_Canonical], Transform]:
    """The chain as z motions separated by constant transforms; returns the joints and the tool transform.

    ``before`` of the first joint includes the base; the tool transform includes the last ``after``.
    """
    out = []
    carry = chain.base
    for joint in chain.joints:
        Q = _z_alignment(joint.axis)
        align = Transform(rotation=sp.ImmutableMatrix(Q))
        before = carry @ joint.before @ align
        offset = sp.sympify(joint.offset)
        if joint.kind == "prismatic":
            before = before @ Transform.translate(z=offset)
            offset = sp.S.Zero
        elif _half_pi_multiple(offset):
            before = before @ Transform.rotate("z", offset)
            offset = sp.S.Zero
        out.append(_Canonical(before, joint.kind, joint.coordinate, sp.sympify(joint.multiplier), _numeric(offset)))
        carry = Transform(rotation=sp.ImmutableMatrix(Q.T)) @ joint.after
    return out, carry @ chain.tool


def _z_rotation_angle(rotation: sp.Matrix) -> sp.Expr | None:
    """``beta`` when ``rotation`` is ``Rz(beta)`` (exact where it is a multiple of pi/2), else ``None``."""
    if rotation[2, 2] != 1 or any(rotation[i, j] != 0 for i, j in ((0, 2), (1, 2), (2, 0), (2, 1))):
        return None
    c, s = rotation[0, 0], rotation[1, 0]
    if c.free_symbols or s.free_symbols:
        return None
    for k, (ck, sk) in enumerate(((1, 0), (0, 1), (-1, 0), (0, -1))):
        if c == ck and s == sk:
            return sp.Integer(k) * sp.pi / 2 if k else sp.S.Zero
    return sp.Float(math.atan2(float(s), float(c)))


class _Steps(StepRecorder):
    """A StepRecorder that also leaves a negated atom unnamed (``-x`` costs nothing where it is used)."""

    def __call__(self, label: str, expr: sp.Expr) -> sp.Expr:
        expr = sp.sympify(expr)
        if expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom:
            return expr
        return super().__call__(label, expr)


def derive_chain(chain: Chain, inverse: bool = True) -> ChainDerivation:
    """Derive ``T, J, J_tool, dJ, twist, acc`` of ``chain`` (see the module docstring), and with ``inverse``
    the inverse functions of :mod:`skelarm_sym.models.chain.inverse`. Linear in N (the Hessian aside)."""
    n = chain.n
    q = sp.symbols(f"q1:{n + 1}", real=True)
    dq = sp.symbols(f"dq1:{n + 1}", real=True)
    ddq = sp.symbols(f"ddq1:{n + 1}", real=True)
    inputs: dict[str, tuple[sp.Symbol, ...]] = {"q": q, "dq": dq, "ddq": ddq}
    if chain.parameters:
        inputs["params"] = tuple(chain.parameters)
    step = _Steps("ch")
    joints, tool = canonical_joints(chain)
    count = len(joints)

    def vec(label: str, v: Vector) -> Vector:
        return [step(f"{label}{'xyz'[i]}", sp.sympify(v[i])) for i in range(3)]

    def mat(label: str, m) -> list[list[sp.Expr]]:
        return [[step(f"{label}{i}{j}", sp.sympify(m[i][j])) for j in range(3)] for i in range(3)]

    # -- forward pass: axes, origins, rotations -------------------------------------------------------
    fixed = [[sp.S.One if i == j else sp.S.Zero for j in range(3)] for i in range(3)]
    angle: sp.Expr | None = None  # pending rotation Rz(angle) after `fixed`
    trig: tuple[sp.Expr, sp.Expr] | None = None
    position: Vector = [sp.S.Zero] * 3
    axes, origins, rates, accels = [], [], [], []

    def rotate_pending(v: Vector) -> Vector:  # Rz(angle) v
        c, s = trig
        return [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]

    def current_rotation(k: int) -> list[list[sp.Expr]]:
        if angle is None:
            return fixed
        c, s = trig
        x = [c * fixed[i][0] + s * fixed[i][1] for i in range(3)]
        y = [c * fixed[i][1] - s * fixed[i][0] for i in range(3)]
        return [[step(f"R{k}_{i}0", x[i]), step(f"R{k}_{i}1", y[i]), fixed[i][2]] for i in range(3)]

    for k, joint in enumerate(joints, start=1):
        c_rot, c_pos = _rows(joint.before.rotation), list(joint.before.translation)
        theta = joint.multiplier * q[joint.coordinate] + joint.offset
        beta = _z_rotation_angle(joint.before.rotation)
        local = rotate_pending(c_pos) if angle is not None else c_pos
        origin = vec(f"o{k}", [position[i] + matvec(fixed, local)[i] for i in range(3)])
        if angle is not None and joint.kind == "revolute" and beta is not None:
            angle = step(f"th{k}", angle + beta + theta)  # parallel axes: angles add up
        else:
            rotation = current_rotation(k - 1)
            fixed = mat(f"F{k}_", matmul(rotation, c_rot))
            angle = step(f"th{k}", theta) if joint.kind == "revolute" else None
        if angle is not None:
            trig = (step(f"c{k}", sp.cos(angle)), step(f"s{k}", sp.sin(angle)))
        axis = [fixed[i][2] for i in range(3)]
        position = origin if joint.kind == "revolute" else vec(f"p{k}", [origin[i] + axis[i] * theta for i in range(3)])
        axes.append(axis)
        origins.append(origin)
        rates.append(joint.multiplier * dq[joint.coordinate])
        accels.append(joint.multiplier * ddq[joint.coordinate])

    last = current_rotation(count)
    t_rot, t_pos = _rows(tool.rotation), list(tool.translation)
    tip = vec("pe", [position[i] + matvec(last, t_pos)[i] for i in range(3)])
    tool_rotation = [[step(f"Re{i}{j}", e) for j, e in enumerate(row)] for i, row in enumerate(matmul(last, t_rot))]

    # -- Jacobian columns --------------------------------------------------------------------------
    linear, angular = [], []
    for k, joint in enumerate(joints, start=1):
        z = axes[k - 1]
        if joint.kind == "revolute":
            r = vec(f"r{k}", [tip[i] - origins[k - 1][i] for i in range(3)])
            linear.append(vec(f"Jv{k}", cross(z, r)))
            angular.append(z)
        else:
            linear.append(z)
            angular.append([sp.S.Zero] * 3)

    # -- velocities and dJ/dt --------------------------------------------------------------------------
    omega_before, omega = [], [sp.S.Zero] * 3
    for k, joint in enumerate(joints, start=1):
        omega_before.append(omega)
        if joint.kind == "revolute":
            omega = vec(f"w{k}", [omega[i] + axes[k - 1][i] * rates[k - 1] for i in range(3)])
    omega_after = omega_before[1:] + [omega]
    suffix: list[Vector] = [None] * count  # u_k = sum_{j>k} Jv_j dtheta_j
    u = [sp.S.Zero] * 3
    for k in reversed(range(count)):
        suffix[k] = u
        u = vec(f"u{k + 1}", [u[i] + linear[k][i] * rates[k] for i in range(3)])
    velocity = u
    d_linear, d_angular = [], []
    for k, joint in enumerate(joints):
        z = axes[k]
        dz = vec(f"dz{k + 1}", cross(omega_before[k], z))
        if joint.kind == "revolute":
            a = cross(omega_after[k], linear[k])
            b = cross(z, suffix[k])
            d_linear.append(vec(f"dJv{k + 1}", [a[i] + b[i] for i in range(3)]))
            d_angular.append(dz)
        else:
            d_linear.append(dz)
            d_angular.append([sp.S.Zero] * 3)

    # -- columns by coordinate (mimic joints add to their leader's column) ------------------------------
    def by_coordinate(per_joint: list[Vector], label: str) -> list[Vector]:
        columns: list[list[sp.Expr]] = [[sp.S.Zero] * 3 for _ in range(n)]
        for k, joint in enumerate(joints):
            for i in range(3):
                columns[joint.coordinate][i] += joint.multiplier * per_joint[k][i]
        return columns

    Jv, Jw = by_coordinate(linear, "Jv"), by_coordinate(angular, "Jw")
    dJv, dJw = by_coordinate(d_linear, "dJv"), by_coordinate(d_angular, "dJw")
    J = sp.Matrix([[Jv[c][i] for c in range(n)] for i in range(3)] + [[Jw[c][i] for c in range(n)] for i in range(3)])
    dJ = sp.Matrix([[dJv[c][i] for c in range(n)] for i in range(3)] + [[dJw[c][i] for c in range(n)] for i in range(3)])
    acc_lin = [sp.Add(*[linear[k][i] * accels[k] + d_linear[k][i] * rates[k] for k in range(count)]) for i in range(3)]
    acc_ang = [sp.Add(*[angular[k][i] * accels[k] + d_angular[k][i] * rates[k] for k in range(count)]) for i in range(3)]
    RT = sp.Matrix(tool_rotation).T
    J_tool = (RT * J[:3, :]).col_join(RT * J[3:, :])
    T = sp.Matrix(tool_rotation).row_join(sp.Matrix(tip)).col_join(sp.Matrix([[0, 0, 0, 1]]))
    compact = {
        "T": T,
        "J": J,
        "J_tool": J_tool,
        "dJ": dJ,
        "twist": sp.Matrix(velocity + omega),
        "acc": sp.Matrix(acc_lin + acc_ang),
    }
    shapes = {"T": (4, 4), "J": (6, n), "J_tool": (6, n), "dJ": (6, n), "twist": (6,), "acc": (6,)}
    kinds = ", ".join(f"{j.name}: {j.kind}" for j in chain.joints)
    notes = (
        f"Model: {chain.describe()}.",
        f"Joints (base to tip): {kinds}.",
        f"Coordinates q[0..{n - 1}]: {', '.join(chain.coordinates)}; radians (revolute) or metres (prismatic);",
        "dq, ddq are their first and second time derivatives.",
        *([f"params[0..{len(chain.parameters) - 1}]: {', '.join(map(str, chain.parameters))} (metres or radians)."] if chain.parameters else []),
        "Frames: T is the 4 x 4 pose of the tool frame in the base frame (row-major, last row 0 0 0 1).",
        f"J is 6 x {n}, row-major (J[r*{n} + c]): rows vx vy vz wx wy wz in BASE axes, reference point the tool",
        "origin (Pinocchio's LOCAL_WORLD_ALIGNED); a revolute column is [z x (p_tool - o); z], a prismatic one [z; 0].",
        "J_tool is the same Jacobian in the tool frame's axes; dJ = dJ/dt in the frame of J;",
        "twist = J dq = (velocity of the tool origin, angular velocity); acc = J ddq + dJ dq = (classical",
        "acceleration of the tool origin, angular acceleration), all in base axes.",
    )
    tables, limit_notes = _limit_tables(chain)
    notes = notes + limit_notes
    derivation = ChainDerivation(
        model=chain,
        inputs=inputs,
        steps=tuple(step.steps),
        compact=compact,
        shapes=shapes,
        functions=CHAIN_FUNCTIONS,
        parameters=("params",),
        domains={"q": "finite", "dq": "finite", "ddq": "finite", "params": "finite"},
        notes=notes,
        tables=tables,
    )
    if not inverse:
        return derivation
    from .inverse import extend  # inverse functions (manipulability, Hessian, inverse velocity, rpy)

    return extend(derivation, step, joints, axes, linear, angular, tool_rotation)


def _limit_tables(chain: Chain) -> tuple[tuple[Table, ...], tuple[str, ...]]:
    """``Q_MIN``, ``Q_MAX`` (and ``DQ_MAX``) per coordinate when the model has limits, and header lines listing them."""
    limits = chain.limits()
    tables: list[Table] = []
    if any(v is not None for v in limits["lower"] + limits["upper"]):
        tables.append(Table("Q_MIN", limits["lower"], "lower joint limits in input order (rad or m); unbounded: a huge negative number", -1))
        tables.append(Table("Q_MAX", limits["upper"], "upper joint limits in input order (rad or m); unbounded: a huge number", 1))
    if any(v is not None for v in limits["velocity"]):
        tables.append(Table("DQ_MAX", limits["velocity"], "joint speed limits in input order (rad/s or m/s); unbounded: a huge number", 1))
    if not tables:
        return (), ()

    def shown(v):
        return "-" if v is None else f"{v:g}"

    rows = ", ".join(
        f"{name} [{shown(lo)}, {shown(hi)}]" + (f" |dq| <= {shown(vel)}" if vel is not None else "")
        for name, lo, hi, vel in zip(chain.coordinates, limits["lower"], limits["upper"], limits["velocity"])
    )
    return tuple(tables), tuple(textwrap.wrap(f"Joint limits (Q_MIN, Q_MAX, DQ_MAX): {rows}.", 100))
