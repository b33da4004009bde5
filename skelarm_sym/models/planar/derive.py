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

Those steps are what :mod:`skelarm_sym.ir.lower` turns into code (they are linear
in ``n``). The closed forms users see (``Derivation.J`` and friends) are the same
steps substituted into each other, built on first access.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .model import PlanarArm
from ...derive import linalg
from ...derive.core import RANK_TOL, Derivation, FunctionSpec, StepRecorder, exact_number
from ...derive.solve6 import damped_least_squares, guarded


@dataclass(frozen=True, eq=False)
class PlanarDerivation(Derivation):
    """A planar arm's derivation: the generic one plus the planar views (``p``, ``J``, ``H``, ``det`` ...).

    ``lengths``: the link lengths, symbols ``l1..ln`` or the numbers given.
    """

    lengths: tuple[sp.Expr, ...] = ()

    @property
    def l(self) -> tuple[sp.Expr, ...]:  # noqa: E743 - the seeds' name
        """Link lengths: symbols ``l1..ln`` or the numbers given."""
        return self.lengths

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
        """Manipulability ``sqrt(det(J J^T)) = sqrt(pp rr)``, as emitted (see :func:`skelarm_sym.derive.linalg.gram_schmidt2`)."""
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
        "inverse_velocity", ("q", "v", "l", "lambda"), ("dq",),
        "joint rates dq = J^T (J J^T + lambda^2 I)^+ v for endpoint velocity v (N)",
    ),
    FunctionSpec(
        "inverse_velocity3", ("q", "twist", "l", "lambda"), ("dq3",),
        "joint rates dq3 = J3^T (J3 J3^T + lambda^2 I)^+ twist for twist = (vx, vy, omega) (N)",
    ),
    FunctionSpec(
        "ik_step", ("q", "target", "l", "lambda"), ("q_next",),
        "one damped least-squares step q_next = q + J^T (J J^T + lambda^2 I)^+ (target - p) (N)",
    ),
)
"""Functions of a planar arm; ``inverse_velocity3`` only for n >= 3 (J3 has rank 3 only there)."""


def derive(n: int | PlanarArm, lengths: Sequence[float] | None = None) -> PlanarDerivation:
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
        cos_t.append(step(f"c{k + 1}", _unevaluated(sp.cos, th)))
        sin_t.append(step(f"s{k + 1}", _unevaluated(sp.sin, th)))
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

    inverse = _inverse_kinematics(step, q, jx, jy, l_syms)
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
    return PlanarDerivation(
        model=model,
        inputs=inputs,
        lengths=tuple(l_syms),
        steps=tuple(step.steps),
        compact=compact,
        shapes=shapes,
        functions=functions,
        unavailable={} if n >= 3 else {"inverse_velocity3": f"needs 3 links or more (J3 of {n} links has rank {n})"},
        parameters=("l", "lambda"),
        scalars=("lambda",),
        domains={"q": "finite", "dq": "finite", "ddq": "finite", "l": "positive", "lambda": "nonnegative",
                 "v": "finite", "twist": "finite", "target": "finite"},
        constants=(RANK_TOL,),
        notes=(
            f"Model: {model.describe()}.",
            "Angles: q[i] is the angle of joint i relative to the previous link, in radians",
            "(counter-clockwise); dq, ddq are its first and second time derivatives.",
            f"Layout: row-major. J[i] = j_x(i), J[{n} + i] = j_y(i) for joint i = 0..{n - 1}; H likewise.",
            "p, v, a are (x, y) of the endpoint; H = dJ/dt, so a = J ddq + H dq.",
            "Inverse velocity and IK steps use the damped least-squares solution J^T (J J^T + lambda^2 I)^+,",
            "solved through one Gram-Schmidt step on the rows of J (error follows cond(J), not its square).",
            "lambda is a length. Rank rule, independent of the unit of length: a direction is dropped where",
            "J's smallest singular value is below about RANK_TOL times its largest (RANK_TOL n/5 beyond 5 links;",
            "2 x 2: pp rr <= that^2 * trace^2, without cancellation: rounding of J's sums) and lambda at most",
            "sqrt(RANK_TOL) times its largest.",
            *(("inverse_velocity3 solves with J3's rows x, y divided by the reach l1 + ... + ln, by two Gram-Schmidt",
               "QR stages, the same rule on their residuals and the Frobenius norm.") if n >= 3 else ()),
            "So lambda = 0 at a singular pose gives the minimum-norm least-squares rates (finite"
            + ("; for J3 with x, y errors in reach units)." if n >= 3 else ")."),
            "lambda enters squared (its sign does not matter). The C functions do not check their inputs:",
            "a NaN or infinity in gives one out; ik_solve and the Python wrappers refuse such inputs.",
        ),
    )


def rank_spread(n: int) -> sp.Expr:
    """The factor of a planar arm's rank tolerance over RANK_TOL: ``n / 5`` (n links, more than 5)."""
    return sp.Rational(n, 5)


def _unevaluated(func, angle: sp.Symbol) -> sp.Expr:
    """``func(angle)`` (``sp.cos`` or ``sp.sin``) of a real symbol (an input or a named step) that is neither
    known to be 0 nor of a known sign: SymPy's evaluation finds nothing to rewrite in it (no number, no
    multiple of pi, no sign to extract), so it is built unevaluated, the same expression at a third of the
    cost; anything else is evaluated."""
    plain = angle.is_Symbol and angle.is_real and angle.is_zero is None and angle.is_positive is None
    return func(angle, evaluate=not plain)


@dataclass(frozen=True)
class _Inverse:
    inputs: dict[str, tuple[sp.Symbol, ...]]
    outputs: dict[str, sp.Matrix]


def _inverse_kinematics(step: StepRecorder, q, jx, jy, lengths) -> _Inverse:
    """Manipulability, damped inverse velocity (2 and 3 rows) and the damped IK step, as steps.

    ``J J^T`` is three sums over the columns (linear in n); the two-row solves are
    :func:`skelarm_sym.derive.linalg.damped_solve2`, the three-row one (``J3``, rows x, y in reach units)
    :func:`skelarm_sym.derive.solve6.damped_least_squares`.
    """
    n = len(q)
    lam = sp.Symbol("lambda", real=True)
    v_in = sp.symbols("v_x v_y", real=True)
    twist = sp.symbols("t_x t_y t_w", real=True)
    target = sp.symbols("target_x target_y", real=True)
    # J's entries are sums of up to n rounded terms, so its singular values below about n eps of the largest are
    # rounding: the rank rule's tolerance grows with n beyond 5 links (the check's SVD cuts at 10 n eps; at 64
    # links RANK_TOL alone kept a rounding direction of a stretched arm: |dq| 1.6e13)
    tol = RANK_TOL.symbol * rank_spread(n) if n > 5 else RANK_TOL.symbol

    G = linalg.gram(step, [jx, jy], "G")
    gs = linalg.gram_schmidt2(step, [jx, jy], G, "w")
    w = sp.sqrt(gs.pp * gs.rr)
    lam2, kappa = linalg.damping_scale(step, lam)  # kappa (J J^T) + lam2 I: finite for every finite lambda

    dq = linalg.damped_solve2(step, gs, G, lam2, v_in, tol, "iv", kappa)
    err = [step("ex", target[0] - jy[0]), step("ey", target[1] + jx[0])]
    dq_ik = linalg.damped_solve2(step, gs, G, lam2, err, tol, "ik", kappa)
    q_next = [q[i] + dq_ik[i] for i in range(n)]

    inputs = {"v": v_in, "target": target, "lambda": (lam,)}
    outputs = {"w": sp.Matrix([w]), "dq": sp.Matrix(dq), "q_next": sp.Matrix(q_next)}
    if n >= 3:  # with the orientation row (all ones): J3^T (J3 J3^T + lambda^2 I)^+ twist
        # Rows x, y are lengths and the orientation row is a number: the rank rule compares the rows scaled by
        # 1/reach (reach = l1 + ... + ln), dimensionless, as a 3-D chain's does (solve6.damped_least_squares:
        # its error follows cond(J3), and a direction is dropped only where the damping is negligible too)
        reach = sp.Add(*lengths)
        ireach = step("ireach", 1 / linalg.nonzero(reach)) if not reach.is_number else sp.S.One / reach
        size = step("lamabs", sp.Abs(lam))  # lambda enters squared: its sign does not matter
        mu = step("mu3", 1 / guarded(size, sp.StrictGreaterThan(size, 1)))  # 1 / max(1, |lambda|)
        inputs["twist"] = twist
        # the damping in the scaled rows' units is lambda / reach on the position rows and lambda on the orientation
        # row: negligible where the larger of them is
        larger = step("iv3ls", guarded(ireach, sp.StrictGreaterThan(ireach, 1)))  # max(1 / reach, 1)
        dq3 = damped_least_squares(step, [jx, jy, [sp.S.One] * n], [ireach, ireach, sp.S.One], twist, size, mu, tol, "iv3",
                                   scaled_when_dropping=True, lam_scale=larger, rounding_share=sp.S.One)
        outputs["dq3"] = sp.Matrix(dq3)
    return _Inverse(inputs, outputs)
