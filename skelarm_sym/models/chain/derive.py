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
   ``z`` after a constant transform; offsets that are multiples of pi/2 (revolute) and all
   prismatic offsets fold into the constants, and a constant rotation about a joint's axis (or
   about the last axis in the tool transform) into its angle (:func:`_axis_turns_into_angles`).
2. **Segments** (:func:`_frames`): consecutive joints whose axes are parallel (the constant
   rotation between them is about ``z``: UR5's joints 2-4, every planar arm) share one frame
   ``F_s``; their angles add up (``psi_k = psi_(k-1) + beta_k + theta_k``), one sine and one
   cosine per revolute joint. Frame ``F_(s+1) = F_s Rz(psi) C`` is multiplied out entry by entry
   (only the entries some output uses are emitted).
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
   next frame's axes where the tool offset has a zero there (:func:`_next_frame_columns`).
5. **Pose** (:func:`_pose`): ``R = F_last Rz(psi_n) C_tool``; two of its rows are multiplied out and
   the third is their cross product (the cheapest choice is taken): the rotation chain carries
   two rows, not three. The position by Horner's rule (3.), or summed link by link in base axes with
   the dropped row's entries as cofactors (:func:`_summed_tip`: a wrist's offset is then ``d R e_z``).
   Each forward function takes the candidates cheapest for its own outputs (:func:`_choose`); where
   that differs from ``kinematics``'s choice the function reads its own output
   (:attr:`~skelarm_sym.derive.core.Derivation.variants`).
6. **Velocities** (:func:`_velocities`): ``w_k = w_(k-1) + z_k dtheta_k``, ``u_k = sum_(j>k) Jv_j
   dtheta_j`` (a suffix sum; ``u_0`` is the tool velocity); each joint type gives ``d/dt`` of its
   column from them (for a revolute joint ``[w_k x Jv_k + z_k x u_k; w_(k-1) x z_k]``, Jacobi's
   identity): no differentiation of large expressions anywhere.
7. **Tool axes** (:func:`_tool_jacobian`): ``B_s = F_s^T R`` tip to base
   (``B_s = Rz(psi) C B_(s+1)``) and ``J_tool`` columns ``B_s^T column_k(W_k)``: never ``R^T J``.
"""

from __future__ import annotations

import functools
import math
import textwrap
from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .model import Chain, Transform
from .joints import E_Z, JointType, add, cross, joint_type
from ...derive.core import Derivation, FunctionSpec, StepRecorder, Table

Vector = list  # three SymPy expressions
Rows = list  # 3 x 3 as rows of SymPy expressions
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


# -- small algebra on expression lists (exact zeros fold by themselves) -----------------------------

def matvec(m: Sequence[Sequence[sp.Expr]], v: Sequence[sp.Expr]) -> Vector:
    """``m v`` for a 3 x 3 ``m``."""
    return [sp.Add(*[m[i][j] * v[j] for j in range(3)]) for i in range(3)]


def matmul(a: Sequence[Sequence[sp.Expr]], b: Sequence[Sequence[sp.Expr]]) -> Rows:
    """``a b`` for 3 x 3 matrices."""
    return [[sp.Add(*[a[i][k] * b[k][j] for k in range(3)]) for j in range(3)] for i in range(3)]


def _rows(matrix: sp.Matrix) -> Rows:
    return [[matrix[i, j] for j in range(matrix.cols)] for i in range(matrix.rows)]


def _rz(trig: tuple[sp.Expr, sp.Expr] | None, v: Sequence[sp.Expr]) -> Vector:
    """``Rz(psi) v`` for ``trig = (cos psi, sin psi)``; ``v`` itself when ``trig`` is ``None``."""
    if trig is None:
        return list(v)
    c, s = trig
    return [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]


def _times_rz(m: Sequence[Sequence[sp.Expr]], trig) -> Rows:
    """``m Rz(psi)``: the first two columns of ``m`` mixed."""
    if trig is None:
        return [list(r) for r in m]
    c, s = trig
    return [[c * r[0] + s * r[1], c * r[1] - s * r[0], r[2]] for r in m]


def _rz_times(trig, m: Sequence[Sequence[sp.Expr]]) -> Rows:
    """``Rz(psi) m``: the first two rows of ``m`` mixed."""
    if trig is None:
        return [list(r) for r in m]
    c, s = trig
    return [[c * a - s * b for a, b in zip(m[0], m[1])], [s * a + c * b for a, b in zip(m[0], m[1])], list(m[2])]


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


def _numeric(expr: sp.Expr) -> sp.Expr:
    """A constant with pi or radicals as a Float (so it prints as a literal); exact 0 and rationals stay."""
    expr = sp.sympify(expr)
    if expr.free_symbols or expr.is_Rational or expr.is_Float:
        return expr
    return sp.Float(expr.evalf(30), 17)


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


def _split_z(rotation: sp.Matrix) -> tuple[sp.Matrix, sp.Expr] | None:
    """``(P, beta)`` with ``rotation = P Rz(beta)`` and ``P`` a signed permutation, when ``rotation`` takes
    ``z`` exactly to a base axis and ``beta`` is not a multiple of pi/2 (else ``None``: nothing to gain)."""
    if rotation.free_symbols:
        return None
    column = [rotation[i, 2] for i in range(3)]
    if not all(x.is_Integer for x in column) or sorted(abs(int(x)) for x in column) != [0, 0, 1]:
        return None
    j = (next(i for i in range(3) if column[i] != 0) + 1) % 3
    beta = math.atan2(-float(rotation[j, 1]), float(rotation[j, 0]))
    if abs(beta / (math.pi / 2) - round(beta / (math.pi / 2))) < 1e-12:
        return None
    c, s = math.cos(beta), math.sin(beta)
    turned = [[float(rotation[i, 0]) * c - float(rotation[i, 1]) * s, float(rotation[i, 0]) * s + float(rotation[i, 1]) * c,
               float(rotation[i, 2])] for i in range(3)]  # rotation Rz(-beta)
    P = [[round(x) for x in row] for row in turned]
    if any(abs(x - y) > 1e-9 for row, prow in zip(turned, P) for x, y in zip(row, prow)):
        return None
    return sp.Matrix(P), sp.Float(beta)


# -- canonical joints ---------------------------------------------------------------------------------

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


class _Steps(StepRecorder):
    """A StepRecorder that leaves a negated atom unnamed (``-x`` costs nothing where it is used), keeps
    groups of steps that belong together (for :func:`_normalise_signs`) and names vectors and matrices."""

    def __call__(self, label: str, expr: sp.Expr) -> sp.Expr:
        expr = sp.sympify(expr)
        if expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom:
            return expr
        return super().__call__(label, expr)

    groups: list[tuple[sp.Symbol, ...]]
    """Steps that belong together (a vector; a row or a column of a matrix): candidates for one sign flip."""

    def replace_steps(self, steps: Sequence[tuple[sp.Symbol, sp.Expr]]) -> None:
        """Take ``steps`` (symbols of the recorded steps, new right-hand sides) as the recorded steps."""
        self.steps = list(steps)
        self._definitions = dict(self.steps)
        self._known = {}
        for symbol, rhs in self.steps:
            self._known.setdefault(rhs, symbol)

    def _group(self, entries: Sequence[sp.Expr]) -> None:
        symbols = tuple(e for e in entries if isinstance(e, sp.Symbol) and e.name.startswith(f"_{self._tag}_"))
        if len(symbols) > 1:
            self.__dict__.setdefault("groups", []).append(symbols)

    def vec(self, label: str, v: Sequence[sp.Expr]) -> Vector:
        out = [self(f"{label}{'xyz'[i]}", sp.sympify(v[i])) for i in range(3)]
        self._group(out)
        return out

    def mat(self, label: str, m: Sequence[Sequence[sp.Expr]]) -> Rows:
        out = [[self(f"{label}{i}{j}", sp.sympify(m[i][j])) for j in range(3)] for i in range(3)]
        for i in range(3):
            self._group(out[i])
            self._group([row[i] for row in out])
        return out


# -- the derivation, stage by stage (see the module docstring) -------------------------------------

def _skeleton(e: sp.Expr, ids: dict[sp.Symbol, int]) -> tuple:
    """``e`` reduced to what decides its negations: sums, products (with their coefficient), symbols, signs.
    A symbol is written as its number in ``ids`` (given one if it has none): the search asks "is it flipped?"
    thousands of times, and a set of integers answers without SymPy's hash, a Python method."""
    if e.is_Symbol:
        return ("sym", ids.setdefault(e, len(ids)))
    if e.is_Number:
        return ("num", -1 if e.is_negative else 1)
    if e.is_Add:
        return ("add", tuple(_skeleton(a, ids) for a in e.args))
    if e.is_Mul:
        coeff, factors = e.as_coeff_mul()
        return ("mul", -1 if coeff.is_negative else 1, abs(coeff) == 1, tuple(_skeleton(f, ids) for f in factors))
    return ("other", tuple(_skeleton(a, ids) for a in e.args))


def _skeleton_atoms(node: tuple) -> set[int]:
    """The numbers of the symbols in a skeleton."""
    found: set[int] = set()
    stack = [node]
    while stack:
        e = stack.pop()
        if e[0] == "sym":
            found.add(e[1])
        elif e[0] == "mul":
            stack.extend(e[3])
        elif e[0] != "num":
            stack.extend(e[1])
    return found


def _sign(node: tuple, flips: set) -> int:
    """-1 where SymPy would see a minus sign in front of ``node`` once the symbols in ``flips`` (their numbers,
    see :func:`_skeleton`) are negated."""
    op = node[0]
    if op == "sym":
        return -1 if node[1] in flips else 1
    if op == "num":
        return node[1]
    if op == "mul":
        sign = node[1]
        for f in node[3]:
            if f[0] == "sym" and f[1] in flips:
                sign = -sign
        return sign
    return 1


def _negated_atom(node: tuple, sign: int) -> int | None:
    if node[0] == "sym" and sign < 0:
        return node[1]
    if node[0] == "mul" and node[2] and len(node[3]) == 1 and node[3][0][0] == "sym" and sign < 0:
        return node[3][0][1]
    return None


def _negations(node: tuple, flips: set, outer: int = 1) -> tuple[int, tuple[tuple[int, bool], ...]]:
    """Negations the expression with skeleton ``node`` pays as printed (times ``outer``, with the symbols in
    ``flips`` negated), and the atoms it uses negated on their own.

    Paid: a sum whose terms are all negative, a product with coefficient -1 that is not a subtracted term
    (the rule of the operation counts). Returned apart: each ``-x`` for an atom ``x`` that is a term of a
    sum (``(x, False)``: a subtraction, free once) or the whole expression (``(x, True)``), because CSE
    shares a repeated ``-x`` as one negated temporary (see :func:`_hoisted`)."""
    alone = _negated_atom(node, outer * _sign(node, flips))
    if alone is not None:
        return 0, ((alone, True),)
    count, atoms = 0, []
    stack = [(node, outer, False)]
    while stack:
        e, out, paid = stack.pop()
        op = e[0]
        if op == "add":
            signs = [out * _sign(t, flips) for t in e[1]]
            # every term negative: paid, unless a number or a product led by one carries the sign (-0.4 - x)
            count += all(x < 0 for x in signs) and not any(t[0] == "num" or (t[0] == "mul" and not t[2]) for t in e[1])
            for t, sign in zip(e[1], signs):
                atom = _negated_atom(t, sign)
                if atom is not None:
                    atoms.append((atom, False))
                else:
                    stack.append((t, sign * _sign(t, flips), sign < 0))
        elif op == "mul":
            count += e[2] and out * _sign(e, flips) < 0 and not paid
            stack.extend((f, 1, False) for f in e[3] if f[0] not in ("sym", "num"))
        elif op == "other":
            stack.extend((a, 1, False) for a in e[1])
    return count, tuple(atoms)


def _function_weights(rhs: dict, outputs: Sequence[sp.Expr], functions: Sequence[Sequence[int]]) -> dict[tuple, int]:
    """For every output and step, the number of functions whose program contains it (1 without ``functions``)."""
    weight: dict[tuple, int] = {}
    for indices in functions:
        seen: set[sp.Symbol] = set()
        todo = []
        for i in indices:
            weight[("out", i)] = weight.get(("out", i), 0) + 1
            todo.extend(x for x in sp.sympify(outputs[i]).free_symbols if x in rhs)
        while todo:
            x = todo.pop()
            if x not in seen:
                seen.add(x)
                todo.extend(y for y in rhs[x].free_symbols if y in rhs)
        for x in seen:
            weight[("step", x)] = weight.get(("step", x), 0) + 1
    return weight


def _hoisted(uses: int, alone: int) -> int:
    """Negations a negated atom costs: one when it is used twice or more (CSE makes it a temporary) or
    stands alone (an output ``-x``), none when it is subtracted once."""
    return int(uses >= 2 or alone >= 1)


def _live_steps(steps: Sequence[tuple[sp.Symbol, sp.Expr]], outputs: Sequence[sp.Expr]) -> list[tuple[sp.Symbol, sp.Expr]]:
    """The steps ``outputs`` need, in order (candidates that lost, such as the pose's other rows, go)."""
    rhs = dict(steps)
    needed: set[sp.Symbol] = set()
    todo = [x for e in outputs for x in sp.sympify(e).free_symbols if x in rhs]
    while todo:
        x = todo.pop()
        if x not in needed:
            needed.add(x)
            todo.extend(y for y in rhs[x].free_symbols if y in rhs)
    return [(x, e) for x, e in steps if x in needed]


def _normalise_signs(steps: Sequence[tuple[sp.Symbol, sp.Expr]], outputs: Sequence[sp.Expr],
                     groups: Sequence[tuple[sp.Symbol, ...]] = (),
                     functions: Sequence[Sequence[int]] = ()) -> dict[sp.Symbol, sp.Expr]:
    """Signs of the steps that leave the fewest negations: ``{s: -s}`` for each step to store negated.

    Every quantity can be stored with either sign: a sum with a negative term is a subtraction either way,
    and a sign on a factor moves to wherever the product is used. A negation is paid only where a value
    arrives with the wrong sign at an output, or where every term of a sum is negative. Greedy: flip a step
    (its right-hand side negated, its uses given ``-s``) when that lowers the negations of it and its users;
    passes repeat until none does. ``functions``: the outputs (indices) of each emitted function; a negation
    counts once for every function whose program contains it."""
    rhs = dict(steps)
    order = [s for s, _ in steps]
    ids = {s: i for i, s in enumerate(order)}  # every symbol as a number (see _skeleton); the steps first
    # the expressions, numbered: output i is i, step j (ids) is len(outputs) + j; a long sum (acc) pays nothing
    base = len(outputs)
    values = [sp.sympify(e) for e in outputs] + [rhs[s] for s in order]
    kept = [k for k, e in enumerate(values) if not (e.is_Add and len(e.args) > 6)]
    skeletons: list[tuple | None] = [None] * len(values)
    for k in kept:
        skeletons[k] = _skeleton(values[k], ids)
    own = [-1] * base + list(range(len(order)))  # an expression's own step number (-1: an output)
    users: dict[sp.Symbol, list[int]] = {s: [] for s in order}
    for k in kept:
        for x in values[k].free_symbols:
            if x in users:
                users[x].append(k)
    weights = _function_weights(rhs, outputs, functions)
    weight = [weights.get(("out", i), 1) for i in range(base)] + [weights.get(("step", s), 1) for s in order]
    flips: set[int] = set()  # numbers of the flipped steps
    # an expression's profile depends only on which of its own steps are flipped: remembered by that choice
    # (a pass meets most choices again; the Panda's 2829 profiles are 915 distinct ones)
    steps_in: list[tuple[int, ...]] = []  # per expression: the steps whose flip can change its profile
    for k, skeleton in enumerate(skeletons):
        inside = set() if skeleton is None else {i for i in _skeleton_atoms(skeleton) if i < len(order)}
        steps_in.append(tuple(sorted(inside | {own[k]} if own[k] >= 0 else inside)))
    known: dict[tuple, tuple] = {}

    def profile_of(k):
        key = (k, *[i for i in steps_in[k] if i in flips])
        found = known.get(key)
        if found is None:
            found = known[key] = _negations(skeletons[k], flips, -1 if own[k] in flips else 1)
        return found

    def atom_weight(atom):  # a negated atom is hoisted once in each function that has it (inputs: 1)
        return weight[base + atom] if atom < len(order) else 1

    profile: list[tuple | None] = [None] * len(values)
    for k in kept:
        profile[k] = profile_of(k)
    uses: dict[int, list[int]] = {}  # atom (its number) -> [negated uses, negated alone]
    for k in kept:
        for atom, alone in profile[k][1]:
            entry = uses.setdefault(atom, [0, 0])
            entry[0] += 1
            entry[1] += alone
    flippable = {s for s in order if rhs[s].is_Add or rhs[s].is_Mul}  # a sine or cosine stays what the trig block computes
    moves = [(s,) for s in reversed(order) if s in flippable] + [g for g in groups if all(s in flippable for s in g)]
    # per move: the numbers of its steps, and the expressions a flip changes (its steps' own and their users')
    moves = [(tuple(ids[s] for s in move),
              list(dict.fromkeys([base + ids[s] for s in move if skeletons[base + ids[s]] is not None]
                                 + [k for s in move for k in users[s]])))
             for move in moves]
    for _ in range(4):
        changed = False
        for numbers, keys in moves:
            if not any(profile[k][0] or profile[k][1] for k in keys):
                continue
            flips.symmetric_difference_update(numbers)
            new_profile = {k: profile_of(k) for k in keys}
            delta = sum(weight[k] * (new_profile[k][0] - profile[k][0]) for k in keys)
            change: dict[int, list[int]] = {}
            for sign, table in ((-1, profile), (1, new_profile)):
                for k in keys:
                    for atom, alone in table[k][1]:
                        entry = change.setdefault(atom, [0, 0])
                        entry[0] += sign
                        entry[1] += sign * alone
            for atom, (d_uses, d_alone) in change.items():
                old = uses.get(atom, [0, 0])
                delta += atom_weight(atom) * (_hoisted(old[0] + d_uses, old[1] + d_alone) - _hoisted(*old))
            if delta < 0:
                for k, value in new_profile.items():
                    profile[k] = value
                for atom, (d_uses, d_alone) in change.items():
                    entry = uses.setdefault(atom, [0, 0])
                    entry[0] += d_uses
                    entry[1] += d_alone
                changed = True
            else:
                flips.symmetric_difference_update(numbers)
        if not changed:
            break
    return {s: -s for s in order if ids[s] in flips}


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


def _row_tag(dropped: int | None) -> str:
    """The part of a step's label that tells a candidate with frame row ``dropped`` as cofactors from the one
    carrying every row: it ends in ``_``, so that the joint number after it never reads as part of it."""
    return "" if dropped is None else f"c{dropped}_"


def _cofactor_view(step: _Steps, M: Rows, dropped: int | None, label: str, column2: Vector | None = None) -> Rows:
    """The rotation ``M`` with row ``dropped`` written as cofactors of its other two rows (``r_d = r_(d+1) x
    r_(d+2)``, 3 operations an entry): a chain that carries two rows of its frames gets the third's
    entries only where an output uses them. ``M`` itself when ``dropped`` is ``None`` or the row is constant.
    ``column2``: the third column's entry of that row when known already (``G_k = F_s Rz`` keeps ``F_s``'s)."""
    if dropped is None or not any(sp.sympify(x).free_symbols for x in M[dropped]):
        return M
    a, b = (dropped + 1) % 3, (dropped + 2) % 3
    out = [list(r) for r in M]
    for j in range(3):
        if j == 2 and column2 is not None:
            out[dropped][j] = column2[dropped]
            continue
        if _cheap(step, M[dropped][j]):  # near the base a frame is sparse: its entry is one product of sines
            continue
        expr = M[a][(j + 1) % 3] * M[b][(j + 2) % 3] - M[a][(j + 2) % 3] * M[b][(j + 1) % 3]
        known = step._known.get(-expr)  # the same cofactor met before with the other sign (a permuted frame)
        out[dropped][j] = -known if known is not None else step(f"{label}{dropped}{j}", expr)
    return out


def _cheap(step: _Steps, x: sp.Expr) -> bool:
    """True when ``x`` is a constant, an input, a sine or cosine, or one product or sum of those (at most one
    operation, cheaper than a cofactor's three)."""
    x = sp.sympify(x)
    definitions = step.definitions()
    if x.could_extract_minus_sign():
        x = -x
    if not x.is_Symbol:
        return x.is_Number
    rhs = definitions.get(x)
    if rhs is None:
        return True
    if isinstance(rhs, (sp.sin, sp.cos)):
        return True
    return (rhs.is_Mul or rhs.is_Add) and len(rhs.args) == 2 and all(
        a.is_Number or (a.is_Symbol and isinstance(definitions.get(a, sp.sin(a)), (sp.sin, sp.cos))) for a in rhs.args)


def _after_joint(step: _Steps, f: _Frames, k: int, dropped: int | None, axes: list[Vector]) -> Rows:
    """``G_k = F_s Rz(psi_k)``, the rotation after joint ``k``'s motion in base axes (row ``dropped`` as
    cofactors; its third column is the joint's axis)."""
    G = step.mat(f"H{k + 1}_", _times_rz(f.rotation[f.segment[k]], f.trig[k]))
    return _cofactor_view(step, G, dropped, f"Hc{k + 1}_", axes[k])


def _base_offsets(step: _Steps, joints: Sequence[_Canonical], f: _Frames, tool: Transform, axes: list[Vector],
                  dropped: int | None = None) -> tuple[list[Vector], list[Vector]]:
    """``(r, columns)``: ``r_k = p_e - o_k`` in base axes, tip to base, ``r_k = r_(k+1) + G_k t_(k+1)`` plus the
    joint's own advance along ``z_k`` (:func:`_after_joint`; suffix sums of the links in base axes: no rotation
    of a whole vector, only the columns of ``G_k`` a translation uses), and the linear columns
    ``column(z_k, r_k)``, or ``column(z_k, r_(k+1))`` where the link runs along the axis (standard DH with
    ``a = 0``: ``z_k x G_k t = G_k (e_z x t) = 0``), which makes the last column of a wrist exactly zero."""
    n = len(joints)
    r: list[Vector] = [None] * n
    linear: list[Vector] = [None] * n
    below = [sp.S.Zero] * 3
    tag = _row_tag(dropped)
    for k in reversed(range(n)):
        t = list((joints[k + 1].before if k + 1 < n else tool).translation)
        advance = joints[k].motion.advance(f.theta[k])
        G = _after_joint(step, f, k, dropped, axes) if any(x != 0 for x in t) else None
        v = add(below, matvec(G, t)) if G is not None else list(below)
        r[k] = step.vec(f"r{tag}{k + 1}", [v[i] + axes[k][i] * advance for i in range(3)])
        moved = joints[k].motion.follows_tool(E_Z, [t[0], t[1], t[2] + advance])
        along = moved is None or all(x == 0 for x in moved)  # the link runs along the axis: z_k x r_k = z_k x r_(k+1)
        linear[k] = step.vec(f"Jb{tag}_{k + 1}", joints[k].motion.column(axes[k], below if along else r[k])[0])
        below = r[k]
    return r, linear


def _dense_constants(joints: Sequence[_Canonical], f: _Frames) -> bool:
    """True when some segment starts with a constant rotation that is not a signed permutation (URDF angles
    written with few decimals: xArm7's 1.5708): there every way to carry the frames is worth trying."""
    return any(x not in (-1, 0, 1) for k in f.starts[1:] for x in joints[k].before.rotation)


CANDIDATES_UP_TO = 16
"""Chains of at most this many joints try every candidate (summed positions, base-axes columns with a row as
cofactors); longer ones only Horner's rule and the segment columns (and the base-axes columns with every row
where constants are dense, as before): each candidate costs about 20 ms a joint to derive and price."""


@dataclass
class _Columns:
    """One way to write the Jacobian: per joint its linear and angular columns in base axes, the axes ``z_k``
    they use, their rates (:func:`_velocities`) and the tool position their offsets give (``None``: none)."""

    linear: list[Vector]
    angular: list[Vector]
    axes: list[Vector]
    rates: "_Rates"
    tip: Vector | None


def _column_candidates(step: _Steps, joints, f: _Frames, tool: Transform, W: Sequence[Vector], linear, angular, dq, ddq,
                       rows: Sequence[int | None]) -> list[_Columns]:
    """The columns in segment axes (:func:`_columns`, with ``p_e`` by Horner's rule), and in base axes
    (``z_k x r_(k+1)``, :func:`_base_offsets`) with the frames' rows carried whole (``None`` in ``rows``) or
    one row as cofactors of the other two (:func:`_cofactor_view`)."""
    out = [_Columns(linear, angular, f.axes, _velocities(step, joints, f.axes, linear, angular, dq, ddq), None)]
    seen: list[list[Rows]] = []
    for dropped in rows:
        tag = _row_tag(dropped)
        views = [_cofactor_view(step, f.rotation[s], dropped, f"Fc{s + 1}_") for s in range(len(f.rotation))]
        if views in seen:  # that row is constant in every frame (a planar chain): nothing new
            continue
        seen.append(views)
        axes = [[row[2] for row in views[f.segment[k]]] for k in range(len(joints))]
        r, base = _base_offsets(step, joints, f, tool, axes, dropped)
        base = _next_frame_columns(step, joints, f, views, axes, r, W, base, dropped)
        ang = [matvec(views[f.segment[k]], joint.motion.column(E_Z, [0, 0, 0])[1]) for k, joint in enumerate(joints)]
        steps = step.definitions()
        if _price(steps, _flat(base, ang))[0] > 0.98 * _price(steps, _flat(linear, angular))[0]:
            continue  # not 2 % cheaper without their rates (which follow the columns; see _choose): not worth those
        tip = step.vec(f"pb{tag}", add(list(joints[0].before.translation), r[0]))
        out.append(_Columns(base, ang, axes, _velocities(step, joints, axes, base, ang, dq, ddq, f"a{tag}"), tip))
    return out


def _next_frame_columns(step: _Steps, joints, f: _Frames, views: list[Rows], axes: list[Vector], r: list[Vector],
                        W: Sequence[Vector], base: list[Vector], dropped: int | None) -> list[Vector]:
    """The base-axes columns ``base``, each replaced by the same column taken in the axes of the frame that
    starts at the next joint where that needs fewer operations (SYMORO's choice of projection frame):
    ``z_k x (p_e - o_k) = F' ((C^T e_z) x W_(k+1)) + G_k (e_z x t)``, with ``F'`` that frame
    (:func:`_cofactor_view`), ``C`` the constant rotation before it, ``W_(k+1)`` the tool offset in its axes
    (:func:`_tool_offsets`) and ``t`` the translation to the next joint. Near a wrist ``W`` has a zero and the
    column is one column of ``F'`` times one number (3 multiplications instead of a cross product)."""
    steps = step.definitions()
    paid = frozenset(_price(steps, _flat(axes, r))[1])
    out = list(base)
    tag = _row_tag(dropped)
    for k in range(len(joints) - 1):
        if f.segment[k + 1] == f.segment[k]:
            continue
        nxt = joints[k + 1].before
        turned = [nxt.rotation[2, i] for i in range(3)]  # z_k in the next frame's axes
        local = joints[k].motion.column(turned, W[k + 1])[0]
        if sum(x != 0 for x in local) > 1:  # two terms or more: no cheaper than the cross product in base axes
            continue
        column = matvec(views[f.segment[k + 1]], local)
        t = list(nxt.translation)
        moved = joints[k].motion.follows_tool(E_Z, [t[0], t[1], t[2] + joints[k].motion.advance(f.theta[k])])
        if moved is not None and any(x != 0 for x in moved):
            column = add(column, matvec(_after_joint(step, f, k, dropped, axes), moved))
        if _price(steps, column, paid)[0] < _price(steps, base[k], paid)[0]:
            out[k] = step.vec(f"Jn{tag}_{k + 1}", column)
    return out


def _flat(*groups) -> list[sp.Expr]:
    return [e for group in groups for v in group for e in v]


Pose = tuple[Rows, Vector]


def _price(steps: dict, exprs: Sequence[sp.Expr], paid: frozenset = frozenset()) -> tuple[int, set]:
    """Operations (:func:`_nodes`) of ``exprs`` and of the steps they need but ``paid``, and those steps."""
    found: set[sp.Symbol] = set()
    exprs = [sp.sympify(e) for e in exprs]
    todo = [x for e in exprs for x in e.free_symbols if x in steps and x not in paid]
    while todo:
        x = todo.pop()
        if x not in found:
            found.add(x)
            todo.extend(y for y in steps[x].free_symbols if y in steps and y not in paid and y not in found)
    nodes: dict = {}
    for x in found:
        nodes.update(_nodes(steps[x]))
    for e in exprs:
        nodes.update(_nodes(e))
    return sum(nodes.values()), found


def _choose(step: _Steps, poses: list[Pose], columns: list[_Columns]) -> dict[str, tuple[Pose, _Columns]]:
    """Per forward function, the pose and the columns that need the fewest operations (:func:`_price`) for its
    outputs: ``pose`` over every rotation and position, ``jacobian``, ``jacobian_dot``, ``twist`` and
    ``acceleration`` over the columns, ``kinematics`` over both together (a position from the columns'
    offsets only with those columns)."""
    steps = step.definitions()
    alone: dict[tuple[int, int], int] = {}

    def cost(exprs, paid=frozenset()) -> tuple[int, set]:
        return _price(steps, exprs, paid)

    def pose_cost(pose: Pose) -> int:
        key = (id(pose[0]), id(pose[1]))
        if key not in alone:
            alone[key] = cost(T(pose))[0]
        return alone[key]

    def T(pose: Pose) -> list[sp.Expr]:
        return _flat(pose[0], [pose[1]])

    def parts(c: _Columns) -> list[list[sp.Expr]]:
        return [_flat(c.linear, c.angular), _flat(c.rates.d_linear, c.rates.d_angular), list(c.rates.twist), list(c.rates.acc)]

    def pick(candidates: list, price) -> object:
        """The cheapest candidate; one after the first (the segment columns, Horner's rule) only when it saves
        2 % or more: the estimate ignores what the sign choice removes, and a tie is not worth a variant."""
        if len(candidates) == 1:
            return candidates[0]
        prices = [price(x) for x in candidates]
        best_index = min(range(len(candidates)), key=lambda i: prices[i])
        return candidates[best_index] if prices[best_index][0] <= 0.98 * prices[0][0] else candidates[0]

    rotations = list({id(p[0]): p[0] for p in poses}.values())
    with_tips = [(rot, c.tip) for c in columns if c.tip is not None for rot in rotations]
    horner = min((p for p in poses if p[1] is poses[0][1]), key=pose_cost)
    best = {"pose": (pick([horner] + poses + with_tips, lambda p: (pose_cost(p),)), columns[0])}
    for index, name in enumerate(("jacobian", "jacobian_dot", "twist", "acceleration")):
        best[name] = (best["pose"][0], pick(columns, lambda c: (cost(parts(c)[index])[0],)))
    options = []
    for c in columns:
        base, paid = cost([e for part in parts(c) for e in part])
        paid = frozenset(paid)
        for pose in ([horner] if c is columns[0] else []) + poses + ([(rot, c.tip) for rot in rotations] if c.tip is not None else []):
            options.append(((base + cost(T(pose), paid)[0], pose_cost(pose)), pose, c))  # a tie: the pose cheapest alone
    found = pick(options, lambda o: o[0])
    best["kinematics"] = (found[1], found[2])
    return best


def _settle_signs(step: _Steps, groups: dict[str, list[Vector]], functions: Sequence[Sequence[str]],
                  axes: list[Vector]) -> tuple[dict[str, list[Vector]], list[Vector]]:
    """Drop dead steps, choose the signs of the rest (:func:`_normalise_signs`) and return ``groups`` (named
    lists of vectors: the outputs) and ``axes`` written with the flipped steps. ``functions``: the names of
    the groups each function reads (a negation counts once for every function that pays it)."""
    values, where = [], {}
    for name, group in groups.items():
        flat = [e for v in group for e in v]
        where[name] = range(len(values), len(values) + len(flat))
        values.extend(flat)
    step.replace_steps(_live_steps(step.steps, values))
    indices = [[i for name in names for i in where[name]] for names in functions]
    flips = _normalise_signs(step.steps, values, getattr(step, "groups", ()), indices)
    if not flips:
        return groups, axes
    step.replace_steps([(s, (-1 if s in flips else 1) * rhs.xreplace(flips)) for s, rhs in step.steps])
    rewrite = {name: [[sp.sympify(e).xreplace(flips) for e in v] for v in group] for name, group in groups.items()}
    return rewrite, [[sp.sympify(e).xreplace(flips) for e in v] for v in axes]


@functools.lru_cache(maxsize=65536)
def _nodes(e: sp.Expr) -> dict:
    """The composite subtrees of ``e`` with the operations each adds itself, as :mod:`skelarm_sym.ir.count`
    counts them: a sum of k terms k - 1 (one more when every term is negative and none is a number or led by
    one), a product of k factors k - 1
    (a coefficient other than +-1 is a factor, -1 a negation), ``x**k`` k - 1. The union over several
    expressions counts a repeated subtree once, as the CSE of :mod:`skelarm_sym.ir.lower` computes it once.
    Remembered: the candidates of :func:`_choose` share most of their steps."""
    out: dict = {}
    stack = [e]
    while stack:
        x = stack.pop()
        if x.is_Atom or x in out:
            continue
        if x.is_Add:
            own, negative, literal = len(x.args) - 1, 0, False
            for term in x.args:
                coeff, _ = term.as_coeff_Mul()
                literal = literal or abs(coeff) != 1
                if coeff.is_negative:
                    negative += 1
                    term = -term
                stack.append(term)
            out[x] = own + (negative == len(x.args) and not literal)
        elif x.is_Mul:
            coeff, factors = x.as_coeff_mul()
            out[x] = len(factors) - 1 + (abs(coeff) != 1) + (coeff == -1)
            stack.extend(factors)
        elif x.is_Pow and x.exp.is_Integer and x.exp > 0:
            out[x] = int(x.exp) - 1
            stack.append(x.base)
        else:
            out[x] = 1 if x.is_Pow else 0
            stack.extend(x.args)
    return out


def _pose(step: _Steps, joints: Sequence[_Canonical], f: _Frames, tool: Transform,
          W: Sequence[Vector]) -> tuple[list[Pose], int | None]:
    """Candidates for the tool rotation ``R`` (rows) and position ``p_e``, and the row the cheapest rotation
    drops (``None``: all three carried).

    ``R = F_last Rz(psi_n) C_tool``: all rows multiplied out, or two of them and the third as their cross
    product (``r_0 = r_1 x r_2`` cyclically): carrying two rows down the chain instead of three saves six
    operations per dense step. ``p_e = o_1 + F_1 W_1`` (Horner's rule, shared with the Jacobian's offsets)
    or, with the cheapest rotation, summed link by link in base axes (:func:`_summed_tip`). :func:`_choose`
    picks per function.
    """
    full = matmul(step.mat("Ge_", _times_rz(f.rotation[-1], f.trig[-1])), _rows(tool.rotation))
    rows = [[step(f"Re{i}{j}", e) for j, e in enumerate(row)] for i, row in enumerate(full)]
    horner = step.vec("pe", add(list(joints[0].before.translation), matvec(f.rotation[0], W[0])))
    rotations = []
    for d in (None, 0, 1, 2):
        candidate = [list(r) for r in rows]
        if d is not None:
            candidate[d] = step.vec(f"Rx{d}", cross(rows[(d + 1) % 3], rows[(d + 2) % 3]))
        rotations.append(candidate)
    steps = step.definitions()
    prices = [_price(steps, _flat(r))[0] for r in rotations]
    cheapest = prices.index(min(prices))
    dropped = (None, 0, 1, 2)[cheapest]  # the row the cheapest rotation drops
    poses = [(r, horner) for r in rotations]
    if len(joints) <= CANDIDATES_UP_TO:
        poses.append((rotations[cheapest], _summed_tip(step, joints, f, tool, rotations[cheapest], dropped)))
    return poses, dropped


def _summed_tip(step: _Steps, joints: Sequence[_Canonical], f: _Frames, tool: Transform, rotation: Rows,
                dropped: int | None) -> Vector:
    """``p_e = o_1 + sum_k (advance_k z_k + G_k t_(k+1))`` in base axes (``G_k = F_s Rz(psi_k)``, the frame after
    joint ``k``'s motion, ``t_(k+1)`` the translation to the next joint; :func:`_after_joint`), the tool's share
    ``R (C_tool^T t_tool)`` from the pose's rotation. Where the pose drops row ``dropped`` of the rotation,
    that row's entries of the frames are cofactors of the two carried rows (:func:`_cofactor_view`)."""
    n = len(joints)
    views = [_cofactor_view(step, f.rotation[s], dropped, f"Fc{s + 1}_") for s in range(len(f.rotation))]
    axes = [[row[2] for row in views[f.segment[k]]] for k in range(n)]
    terms: list[list[sp.Expr]] = [[x] for x in joints[0].before.translation]  # summed once at the end
    for k in range(n):
        advance = joints[k].motion.advance(f.theta[k])
        if advance != 0:
            for i in range(3):
                terms[i].append(axes[k][i] * advance)
        t = list(joints[k + 1].before.translation) if k + 1 < n else []
        if any(x != 0 for x in t):
            for i, x in enumerate(matvec(_after_joint(step, f, k, dropped, axes), t)):
                terms[i].append(x)
    shift = tool.rotation.T * tool.translation
    for i, x in enumerate(matvec(rotation, [shift[i] for i in range(3)])):
        terms[i].append(x)
    return step.vec(f"ps{'' if dropped is None else dropped}", [sp.Add(*t) for t in terms])


@dataclass
class _Rates:
    """Velocity terms: per joint ``omega`` after it, ``d/dt`` of its column; the tool twist and acceleration."""

    d_linear: list[Vector]
    d_angular: list[Vector]
    twist: Vector
    acc: Vector


def _velocities(step: _Steps, joints, axes, linear, angular, dq, ddq, tag: str = "") -> _Rates:
    """``w_k = w_(k-1) + z_k dtheta_k``, ``u_k = sum_(j>k) Jv_j dtheta_j`` and the columns' derivatives
    (``tag`` tells apart the names of the steps of one set of columns from another's)."""
    count = len(joints)
    rates = [j.multiplier * dq[j.coordinate] for j in joints]
    accels = [j.multiplier * ddq[j.coordinate] for j in joints]
    omega_before, omega = [], [sp.S.Zero] * 3
    for k, joint in enumerate(joints):
        omega_before.append(omega)
        omega = step.vec(f"w{tag}{k + 1}", add(omega, joint.motion.angular_rate(axes[k], rates[k])))
    omega_after = omega_before[1:] + [omega]
    suffix: list[Vector] = [None] * count
    u = [sp.S.Zero] * 3
    for k in reversed(range(count)):
        suffix[k] = u
        u = step.vec(f"u{tag}{k + 1}", [u[i] + linear[k][i] * rates[k] for i in range(3)])
    d_linear, d_angular = [], []
    for k, joint in enumerate(joints):
        dv, dw = joint.motion.column_rate(omega_before[k], omega_after[k], axes[k], linear[k], angular[k], suffix[k])
        d_linear.append(step.vec(f"dJv{tag}{k + 1}", dv))
        d_angular.append(step.vec(f"dJw{tag}{k + 1}", dw))
    acc = [sp.Add(*[part[k][i] * accels[k] + d_part[k][i] * rates[k] for k in range(count)])
           for part, d_part in ((linear, d_linear), (angular, d_angular)) for i in range(3)]
    return _Rates(d_linear, d_angular, u + omega, acc)


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
    the inverse functions of :mod:`skelarm_sym.models.chain.inverse`. Linear in N (the Hessian aside)."""
    n = chain.n
    q = sp.symbols(f"q1:{n + 1}", real=True)
    dq = sp.symbols(f"dq1:{n + 1}", real=True)
    ddq = sp.symbols(f"ddq1:{n + 1}", real=True)
    inputs: dict[str, tuple[sp.Symbol, ...]] = {"q": q, "dq": dq, "ddq": ddq}
    if chain.parameters:
        inputs["params"] = tuple(chain.parameters)
    step = _Steps("ch")
    joints, tool = _named_trig_constants(step, *_axis_turns_into_angles(*canonical_joints(chain)))
    frames = _frames(step, joints, q)
    W = _tool_offsets(step, joints, frames, tool)
    linear, angular = _columns(step, joints, frames, W)
    poses, dropped = _pose(step, joints, frames, tool, W)
    dense = _dense_constants(joints, frames)
    rows = ((None, 0, 1, 2) if dense else (dropped,)) if len(joints) <= CANDIDATES_UP_TO else ((None,) if dense else ())
    chosen = _choose(step, poses, _column_candidates(step, joints, frames, tool, W, linear, angular, dq, ddq, rows))
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
    )
    if not inverse:
        return derivation
    from .inverse import extend  # inverse functions (manipulability, Hessian, inverse velocity, rpy)

    return extend(derivation, step, joints, axes, groups["J"][:count], groups["J"][count:], groups["T"][:3])


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


def _notes(chain: Chain) -> tuple[str, ...]:
    """Header lines: the model, its coordinates and the frames of every output."""
    n = chain.n
    kinds = ", ".join(f"{j.name}: {j.kind}" for j in chain.joints)
    return (
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
