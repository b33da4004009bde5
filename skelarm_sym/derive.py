"""Closed-form differential kinematics derived from the chain's structure.

The derivation never differentiates one large expression. It writes the
kinematics as a short chain of named intermediate quantities (*steps*), each a
small expression of inputs and earlier steps:

* absolute angles as prefix sums ``theta_k = theta_{k-1} + q_k`` and their sines and cosines;
* link vectors ``X_k = l_k cos theta_k``, ``Y_k = l_k sin theta_k``;
* Jacobian columns as suffix sums ``j_yk = X_k + j_y(k+1)``, ``j_xk = j_x(k+1) - Y_k``;
  the endpoint is ``p = (j_y1, -j_x1)``;
* absolute angular rates ``w_k = w_{k-1} + dq_k`` and the columns of ``H = dJ/dt`` as
  suffix sums ``h_xk = h_x(k+1) - X_k w_k``, ``h_yk = h_y(k+1) - Y_k w_k``;
  the endpoint velocity is ``v = J dq = (h_y1, -h_x1)``;
* ``a = J ddq + H dq``.

Those steps are what :mod:`skelarm_sym.program` turns into code (they are linear
in ``n``). The closed forms users see (``Derivation.J`` and friends) are the same
steps substituted into each other, built on first access.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Sequence

import sympy as sp

from . import linalg
from .models.planar import PlanarArm

Step = tuple[sp.Symbol, sp.Expr]


@dataclass(frozen=True)
class FunctionSpec:
    """One emitted function: its name suffix, argument names in order, output names in order."""

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    summary: str


@dataclass(frozen=True, eq=False)
class Constant:
    """A named constant the emitted code defines once, with a value per precision."""

    symbol: sp.Symbol
    values: dict[str, float]
    doc: str

    @property
    def name(self) -> str:
        """Upper-case name; backends prefix it (``ARM3_RANK_TOL`` in C)."""
        return self.symbol.name


RANK_TOL = Constant(
    sp.Symbol("RANK_TOL", positive=True),
    {"double": 100 * 2.220446049250313e-16, "float": 100 * 1.1920928955078125e-07},
    "relative rank tolerance of the closed-form solves: 100 machine epsilons",
)
"""A symmetric 2 x 2 ``A`` counts as singular when ``det A <= RANK_TOL * tr(A)**2``; see
:mod:`skelarm_sym.linalg` for 3 x 3 (both: smallest eigenvalue below about RANK_TOL times the largest)."""


class StepRecorder:
    """Collects named intermediate quantities.

    Trivial ones (atoms) are not given a name, and an expression recorded before
    returns its first name (two derivations of the same quantity share one step).
    """

    def __init__(self, tag: str) -> None:
        self._tag = tag
        self.steps: list[Step] = []
        self._known: dict[sp.Expr, sp.Symbol] = {}

    def __call__(self, label: str, expr: sp.Expr) -> sp.Expr:
        if expr.is_Atom:
            return expr
        known = self._known.get(expr)
        if known is not None:
            return known
        symbol = sp.Symbol(f"_{self._tag}_{label}", real=True)
        self.steps.append((symbol, expr))
        self._known[expr] = symbol
        return symbol


def expand_steps(steps: Sequence[Step], exprs: Iterable[sp.Expr]) -> list[sp.Expr]:
    """Substitute the steps into ``exprs`` (in order), giving closed forms in the inputs only."""
    closed: dict[sp.Symbol, sp.Expr] = {}
    for symbol, expr in steps:
        closed[symbol] = expr.xreplace(closed)
    return [sp.sympify(e).xreplace(closed) for e in exprs]


@dataclass(frozen=True, eq=False)
class Derivation:
    """The differential kinematics of one model, as steps plus compact outputs.

    Attributes:
        model: the arm model derived from.
        inputs: ordered mapping of input array name to its symbols (``q``, ``dq``,
            ``ddq``, and ``l`` when lengths are symbolic).
        steps: ordered ``(symbol, expr)`` definitions; each uses inputs and earlier steps.
        compact: output name -> SymPy matrix written with step symbols.
        shapes: output name -> array shape in emitted code (``(2,)`` for a vector, ``(2, n)`` ...).
        functions: the functions a backend emits, in order.
        parameters: inputs that describe the mechanism rather than its state; batch
            functions share them across configurations.
        notes: lines for the headers of emitted files (model, conventions, layout).
        scalars: inputs passed as one number (by value in C) rather than an array;
            they must be parameters.
        domains: input name -> ``"finite"``, ``"nonnegative"`` (finite and >= 0) or ``"positive"``:
            the Python wrappers reject other values with a ``ValueError``.
        constants: named constants the emitted code defines (see :class:`Constant`).
    """

    model: object
    inputs: dict[str, tuple[sp.Symbol, ...]]
    lengths: tuple[sp.Expr, ...]
    steps: tuple[Step, ...]
    compact: dict[str, sp.Matrix]
    shapes: dict[str, tuple[int, ...]]
    functions: tuple[FunctionSpec, ...]
    parameters: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    scalars: tuple[str, ...] = ()
    domains: dict[str, str] = field(default_factory=dict)
    constants: tuple[Constant, ...] = ()
    _cache: dict = field(default_factory=dict, repr=False)

    # -- symbols --------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of links (and joints) of a chain; ``AttributeError`` for other models."""
        return self.model.n

    def function(self, name: str) -> FunctionSpec:
        """The function spec called ``name``; ``KeyError`` if this derivation has none."""
        for spec in self.functions:
            if spec.name == name:
                return spec
        raise KeyError(name)

    @property
    def q(self) -> tuple[sp.Symbol, ...]:
        """Relative joint angles ``q1..qn`` (radians)."""
        return self.inputs["q"]

    @property
    def dq(self) -> tuple[sp.Symbol, ...]:
        """Joint rates ``dq1..dqn``."""
        return self.inputs["dq"]

    @property
    def ddq(self) -> tuple[sp.Symbol, ...]:
        """Joint accelerations ``ddq1..ddqn``."""
        return self.inputs["ddq"]

    @property
    def l(self) -> tuple[sp.Expr, ...]:  # noqa: E743 - the seeds' name
        """Link lengths: symbols ``l1..ln`` or the numbers given."""
        return self.lengths

    # -- closed forms ---------------------------------------------------------
    def closed_form(self, name: str) -> sp.Matrix:
        """Output ``name`` as a matrix of closed-form expressions in the inputs only."""
        if name not in self._cache:
            matrix = self.compact[name]
            values = expand_steps(self.steps, list(matrix))
            self._cache[name] = sp.Matrix(matrix.rows, matrix.cols, values)
        return self._cache[name]

    @property
    def p(self) -> sp.Matrix:
        """Endpoint position, 2 x 1."""
        return self.closed_form("p")

    @property
    def phi(self) -> sp.Expr:
        """Endpoint orientation ``q1 + ... + qn``."""
        return self.closed_form("phi")[0]

    @property
    def J(self) -> sp.Matrix:
        """Endpoint Jacobian ``dp/dq``, 2 x n (row 0: ``j_x``, row 1: ``j_y``)."""
        return self.closed_form("J")

    @property
    def J3(self) -> sp.Matrix:
        """Planar Jacobian with the orientation row ``dphi/dq`` (all ones), 3 x n."""
        return self.closed_form("J3")

    @property
    def H(self) -> sp.Matrix:
        """``H = dJ/dt``, 2 x n, the centripetal/Coriolis basis."""
        return self.closed_form("H")

    @property
    def v(self) -> sp.Matrix:
        """Endpoint velocity ``J dq``, 2 x 1."""
        return self.closed_form("v")

    @property
    def a(self) -> sp.Matrix:
        """Endpoint acceleration ``J ddq + H dq``, 2 x 1."""
        return self.closed_form("a")

    @property
    def det(self) -> sp.Expr | None:
        """``det J`` where the Jacobian is square, in closed form: J for n = 2 and J3 for
        n = 3 (both ``l1*l2*sin(q2)``); ``None`` otherwise. See :mod:`skelarm_sym.singular`."""
        from .singular import determinant

        return determinant(self)

    @property
    def manipulability(self) -> sp.Expr:
        """``sqrt(det(J J^T))`` as a readable closed form (square root of the sum of squared 2 x 2
        minors); :attr:`w` is the same quantity as the emitted code computes it."""
        from .singular import manipulability

        return manipulability(self) if self.n > 1 else sp.S.Zero

    @property
    def w(self) -> sp.Expr:
        """Manipulability ``sqrt(det(J J^T))``, as emitted (see :func:`skelarm_sym.linalg.gram_root`)."""
        return self.closed_form("w")[0]


PLANAR_FUNCTIONS = (
    FunctionSpec("position", ("q", "l"), ("p",), "endpoint position p (2)"),
    FunctionSpec("jacobian", ("q", "l"), ("J",), "Jacobian J (2 x N, row-major)"),
    FunctionSpec("coriolis", ("q", "dq", "l"), ("H",), "H = dJ/dt (2 x N, row-major)"),
    FunctionSpec("velocity", ("q", "dq", "l"), ("v",), "endpoint velocity v = J dq (2)"),
    FunctionSpec("acceleration", ("q", "dq", "ddq", "l"), ("a",), "endpoint acceleration a = J ddq + H dq (2)"),
    FunctionSpec("kinematics", ("q", "dq", "ddq", "l"), ("p", "J", "H", "v", "a"), "p, J, H, v and a at once"),
    FunctionSpec("manipulability", ("q", "l"), ("w",), "manipulability w = sqrt(det(J J^T)) (1)"),
    FunctionSpec(
        "inverse_velocity", ("q", "l", "v", "lambda"), ("dq",),
        "joint rates dq = J^T (J J^T + lambda^2 I)^+ v for endpoint velocity v (N)",
    ),
    FunctionSpec(
        "inverse_velocity3", ("q", "l", "twist", "lambda"), ("dq3",),
        "joint rates dq3 = J3^T (J3 J3^T + lambda^2 I)^+ twist for twist = (vx, vy, omega) (N)",
    ),
    FunctionSpec(
        "ik_step", ("q", "l", "target", "lambda"), ("q_next",),
        "one damped least-squares step q_next = q + J^T (J J^T + lambda^2 I)^+ (target - p) (N)",
    ),
)
"""Functions of a planar arm; ``inverse_velocity3`` only for n >= 3 (J3 has rank 3 only there)."""


def exact_number(x: float) -> sp.Expr:
    """A fixed parameter as a SymPy number: an Integer when it is whole, else a Float."""
    return sp.Integer(int(x)) if float(x).is_integer() else sp.Float(x)


def derive(n: int | PlanarArm, lengths: Sequence[float] | None = None) -> Derivation:
    """Derive the planar chain's ``p, phi, J, J3, H, v, a`` for ``n`` links.

    ``lengths``: ``None`` for symbolic lengths ``l1..ln``, or ``n`` finite positive numbers.
    Raises :class:`~skelarm_sym.errors.InputError` (a ``ValueError``) on bad input.
    Cost is linear in ``n``; closed forms are built on first access.
    """
    model = n if isinstance(n, PlanarArm) else PlanarArm(n, None if lengths is None else tuple(lengths) if not isinstance(lengths, (str, bytes)) else lengths)
    n = model.n
    q = sp.symbols(f"q1:{n + 1}", real=True)
    dq = sp.symbols(f"dq1:{n + 1}", real=True)
    ddq = sp.symbols(f"ddq1:{n + 1}", real=True)
    if model.lengths is None:
        l_syms = sp.symbols(f"l1:{n + 1}", positive=True)
        inputs = {"q": q, "dq": dq, "ddq": ddq, "l": l_syms}
    else:
        l_syms = tuple(exact_number(x) for x in model.lengths)
        inputs = {"q": q, "dq": dq, "ddq": ddq}
    step = StepRecorder("planar")

    theta, cos_t, sin_t = [], [], []
    for k in range(n):
        th = q[k] if k == 0 else step(f"theta{k + 1}", theta[-1] + q[k])
        theta.append(th)
        cos_t.append(step(f"c{k + 1}", sp.cos(th)))
        sin_t.append(step(f"s{k + 1}", sp.sin(th)))
    X = [step(f"X{k + 1}", l_syms[k] * cos_t[k]) for k in range(n)]
    Y = [step(f"Y{k + 1}", l_syms[k] * sin_t[k]) for k in range(n)]

    jx, jy = [None] * n, [None] * n
    for k in reversed(range(n)):
        if k == n - 1:
            jx[k] = step(f"jx{k + 1}", -Y[k])
            jy[k] = X[k]
        else:
            jx[k] = step(f"jx{k + 1}", jx[k + 1] - Y[k])
            jy[k] = step(f"jy{k + 1}", jy[k + 1] + X[k])

    w = []
    for k in range(n):
        w.append(dq[0] if k == 0 else step(f"w{k + 1}", w[-1] + dq[k]))
    XW = [step(f"XW{k + 1}", X[k] * w[k]) for k in range(n)]
    YW = [step(f"YW{k + 1}", Y[k] * w[k]) for k in range(n)]
    hx, hy = [None] * n, [None] * n
    for k in reversed(range(n)):
        if k == n - 1:
            hx[k] = step(f"hx{k + 1}", -XW[k])
            hy[k] = step(f"hy{k + 1}", -YW[k])
        else:
            hx[k] = step(f"hx{k + 1}", hx[k + 1] - XW[k])
            hy[k] = step(f"hy{k + 1}", hy[k + 1] - YW[k])

    inverse = _inverse_kinematics(step, q, jx, jy)
    a_x = sp.Add(*[jx[k] * ddq[k] for k in range(n)], *[hx[k] * dq[k] for k in range(n)])
    a_y = sp.Add(*[jy[k] * ddq[k] for k in range(n)], *[hy[k] * dq[k] for k in range(n)])
    J = sp.Matrix([jx, jy])
    compact = {
        "p": sp.Matrix([jy[0], -jx[0]]),
        "phi": sp.Matrix([theta[-1]]),
        "J": J,
        "J3": J.col_join(sp.ones(1, n)),
        "H": sp.Matrix([hx, hy]),
        "v": sp.Matrix([hy[0], -hx[0]]),
        "a": sp.Matrix([a_x, a_y]),
        **inverse.outputs,
    }
    inputs.update(inverse.inputs)
    shapes = {"p": (2,), "phi": (1,), "J": (2, n), "J3": (3, n), "H": (2, n), "v": (2,), "a": (2,)}
    shapes.update({name: (len(m),) for name, m in inverse.outputs.items()})
    functions = tuple(f for f in PLANAR_FUNCTIONS if f.name != "inverse_velocity3" or n >= 3)
    return Derivation(
        model=model,
        inputs=inputs,
        lengths=tuple(l_syms),
        steps=tuple(step.steps),
        compact=compact,
        shapes=shapes,
        functions=functions,
        parameters=("l", "lambda"),
        scalars=("lambda",),
        domains={"lambda": "nonnegative", "v": "finite", "twist": "finite", "target": "finite"},
        constants=(RANK_TOL,),
        notes=(
            f"Model: {model.describe()}.",
            "Angles: q[i] is the angle of joint i relative to the previous link, in radians",
            "(counter-clockwise); dq, ddq are its first and second time derivatives.",
            f"Layout: row-major. J[i] = j_x(i), J[{n} + i] = j_y(i) for joint i = 0..{n - 1}; H likewise.",
            "p, v, a are (x, y) of the endpoint; H = dJ/dt, so a = J ddq + H dq.",
            "Inverse velocity and IK steps use the damped least-squares solution J^T (J J^T + lambda^2 I)^+;",
            "the matrix counts as singular when its smallest eigenvalue is below about RANK_TOL times its largest",
            "(2 x 2: det <= RANK_TOL * trace^2), and then its pseudo-inverse is used in closed form,",
            "so lambda = 0 at a singular pose gives the minimum-norm least-squares rates (finite).",
            "lambda enters squared (its sign does not matter). The C functions do not check their inputs:",
            "a NaN or infinity in gives one out; ik_solve and the Python wrappers refuse such inputs.",
        ),
    )


@dataclass(frozen=True)
class _Inverse:
    inputs: dict[str, tuple[sp.Symbol, ...]]
    outputs: dict[str, sp.Matrix]


def _inverse_kinematics(step: StepRecorder, q, jx, jy) -> _Inverse:
    """Manipulability, damped inverse velocity (2 and 3 rows) and the damped IK step, as steps.

    ``J J^T`` is three sums over the columns (linear in n); every solve is the
    closed form of :func:`skelarm_sym.linalg.sym_solve`.
    """
    n = len(q)
    lam = sp.Symbol("lambda", real=True)
    v_in = sp.symbols("v_x v_y", real=True)
    twist = sp.symbols("t_x t_y t_w", real=True)
    target = sp.symbols("target_x target_y", real=True)
    tol = RANK_TOL.symbol

    G = linalg.gram(step, [jx, jy], "G")
    w = linalg.gram_root(step, [jx, jy], G, "w")
    lam2 = step("lam2", lam**2)
    A = linalg.add_diagonal(step, G, lam2, "A")

    def back(u):  # J^T u
        return [jx[i] * u[0] + jy[i] * u[1] for i in range(n)]

    dq = back(linalg.sym_solve(step, A, v_in, tol, "iv"))
    err = [step("ex", target[0] - jy[0]), step("ey", target[1] + jx[0])]
    dq_ik = back(linalg.sym_solve(step, A, err, tol, "ik"))
    q_next = [q[i] + dq_ik[i] for i in range(n)]

    inputs = {"v": v_in, "target": target, "lambda": (lam,)}
    outputs = {"w": sp.Matrix([w]), "dq": sp.Matrix(dq), "q_next": sp.Matrix(q_next)}
    if n >= 3:  # with the orientation row (all ones): J3 J3^T + lambda^2 I, 3 x 3
        sx = step("Gsx", sp.Add(*jx))
        sy = step("Gsy", sp.Add(*jy))
        G3 = [[G[0][0], G[0][1], sx], [G[0][1], G[1][1], sy], [sx, sy, sp.Integer(n)]]
        u3 = linalg.sym_solve(step, linalg.add_diagonal(step, G3, lam2, "A3_"), twist, tol, "iv3")
        inputs["twist"] = twist
        outputs["dq3"] = sp.Matrix([jx[i] * u3[0] + jy[i] * u3[1] + u3[2] for i in range(n)])
    return _Inverse(inputs, outputs)
