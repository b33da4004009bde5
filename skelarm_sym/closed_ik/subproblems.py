"""Geometric subproblems (Paden-Kahan 1-3, IK-Geo's 4) as straight-line SymPy steps.

Notation: ``R(k, theta)`` is the rotation by ``theta`` about the unit vector ``k`` (right hand);
vectors are lists of three SymPy expressions (any frame, the same for all arguments of a call).

* SP1 ``R(k, theta) p = q``: ``theta = atan2(k . (u x w), u . w)`` with ``u = k x p``, ``w = k x q`` (the
  perpendicular parts turned by 90 degrees; ``u . w = p . q - (k . p)(k . q)`` without its cancellation) -- exact when ``p``, ``q``
  have equal components along ``k`` and equal lengths, else the least-squares angle. Singular (any angle)
  when ``p`` or ``q`` lies on the axis: ``atan2(0, 0) = 0`` is the representative.
* SP4 ``h . R(k, theta) p = d``: with ``A = h . p_perp``, ``B = h . (k x p)``, ``C = d - (h . k)(k . p)`` the
  equation is ``A cos + B sin = C``; ``disc = A^2 + B^2 - C^2``; ``s = sqrt(max(disc, 0))``;
  ``(cos, sin) ~ (A C -+ B s, B C +- A s)`` -- two branches, one double root at ``disc = 0``, the
  least-squares angle (``s = 0``) when ``disc < 0``.
* SP3 ``|R(k, theta) p1 - p2|^2 = d2``: SP4 with ``h = p2``, ``p = p1``, ``d = (|p1|^2 + |p2|^2 - d2) / 2``
  (least squares in ``|.|^2 - d2``).
* SP2 ``R(k1, theta1) p1 = R(k2, theta2) p2`` (``k1`` not parallel to ``k2``): the common image
  ``c = alpha k1 + beta k2 +- gamma (k1 x k2)`` from ``k1 . c = k1 . p1``, ``k2 . c = k2 . p2`` and ``c`` on the
  smaller of the two circles (``gamma^2 |k1 x k2|^2 = |k2 x p2|^2 - alpha^2 |k1 x k2|^2`` or the same with 1);
  then SP1 twice. ``gamma^2 < 0`` is clamped to 0 (least squares).
* SPL (prismatic) ``|x0 + t h - o|^2 = d2`` for ``t``: ``t = -b +- sqrt(max(b^2 - c, 0))``, ``b = h . (x0 - o)``,
  ``c = |x0 - o|^2 - d2``.

Every solved angle comes with ``cos`` and ``sin`` computed algebraically (``x / rho``, ``y / rho`` with
``rho = sqrt(x^2 + y^2)``; angle 0 and ``(1, 0)`` when ``rho = 0``, by a select, so no backend's ``atan2(0, 0)``
matters), and
two 0/1 flags: ``ls`` (least squares: a clamped discriminant below ``-LS_TOL`` times its scale) and
``singular`` (a continuum -- ``rho`` at most ``SING_TOL`` times its scale -- or a double root,
``|disc| <= LS_TOL`` times its scale). Special cases are ``Piecewise`` selects; there are no loops, no
simplification and no numeric iteration. Operations emitted: Add, Mul, Pow (integer exponents, 1/2),
atan2, Max, Piecewise, ``<``/``<=``/``>``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from ..derive.core import StepRecorder
from .classify import add, cross, dot, scale, sub

LS_TOL = 1e-10
"""A discriminant below ``-LS_TOL`` times its scale marks a least-squares answer; within ``+-LS_TOL`` a double root."""
SING_TOL = 1e-9
"""An SP1/SP4 whose ``rho`` (or ``sqrt(A^2 + B^2)``) is at most this times its scale is a continuum (singular)."""
LS_TOL_FLOAT, SING_TOL_FLOAT = 1e-6, 1e-5
"""The same in code emitted in float, whose rounding of a discriminant is about 1e-8 of its scale (a double root of
the UR's elbow near stretched came back least squares with the double tolerance) and of a sine about 1e-7."""
ROOT_TOL, ROOT_TOL_FLOAT = 2e-15, 1e-7
"""A double root's discriminant computed with cancellation (``r2 - C^2``) that rounding alone keeps from 0 gives the
double root itself (its square root taken as 0, both branches the middle angle); rounding left ``sqrt(eps)``, 4e-8
rad: an iiwa (joint 3 locked) stretched straight up had its elbow bent that much, which moved the wrist off the
shoulder's axis where joint 2 cannot bring it back (rows 1e-8 m off, and an aligned wrist missed by its 1e-11 test;
its discriminants there reach 1e-14 of ``r2``). Taken as 0 where ``|disc| <= 10 ROOT_TOL r2`` (SP4) and, for SP3's
distance ``D`` between points at ``|p1|``, ``|p2|``, where that moves ``D`` by at most ``ROOT_TOL (|p1| + |p2|)``:
``disc^2 <= 8 ROOT_TOL^2 r2 D^2 (|p1|^2 + |p2|^2)``. The second bound keeps a folded arm exact (``D`` small: a
relative bound of 1e-13 put a review's arm with equal links, 3e-7 rad from folded, 7e-11 off its target)."""
LS_SYMBOL = sp.Symbol("IK_LS_TOL", positive=True)
SING_SYMBOL = sp.Symbol("IK_SING_TOL", positive=True)
ROOT_SYMBOL = sp.Symbol("IK_ROOT_TOL", positive=True)
"""The tolerances in the steps: module constants of the emitted code (double or float values); the NumPy spec
evaluates the steps with the double ones."""
DOUBLE_VALUES = {LS_SYMBOL: LS_TOL, SING_SYMBOL: SING_TOL, ROOT_SYMBOL: ROOT_TOL}
"""The symbols at their double values."""


def _irrational_inside(expr: sp.Basic) -> bool:
    """Whether ``expr`` has a number symbol (``pi``) or a power of a number (``sqrt(2)``) anywhere in it: what
    ``expr.atoms(NumberSymbol)`` and ``expr.atoms(Pow)`` would find, in one walk that stops at the first."""
    stack = [expr]
    while stack:
        e = stack.pop()
        if e.is_Atom:
            if isinstance(e, sp.NumberSymbol):
                return True
        elif e.is_Pow and e.base.is_number:
            return True
        else:
            stack.extend(e.args)
    return False


def _floaty(expr: sp.Expr) -> sp.Expr:
    """Irrational number subexpressions (``sqrt(2)``, ``pi``) as Floats: the emitted code has only literals."""
    expr = sp.sympify(expr)
    if expr.is_number and not expr.is_Rational and not expr.is_Float:
        return sp.Float(expr.evalf(30), 17) if expr.is_real is not False else expr
    if expr.is_Atom:
        return expr
    # an irrational number below has a number symbol (pi) or a numeric power (sqrt(2)) in it (no step here takes
    # a function of a number);
    # without one, skip replace(), which rebuilds the whole tree (a third of the derivation's time)
    if not _irrational_inside(expr):
        return expr
    return expr.replace(
        lambda e: e.is_number and not e.is_Atom and not e.is_Rational and not e.is_Float and e.is_real is not False
        and not isinstance(e, sp.logic.boolalg.Boolean),
        lambda e: sp.Float(e.evalf(30), 17),
    )


class Steps(StepRecorder):
    """A :class:`StepRecorder` that turns irrational constants into Floats, names vectors, and names its steps
    with symbols that carry no assumptions.

    Why no ``real=True``: SymPy evaluates every relational, ``Piecewise``, ``Max`` and ``Abs`` it builds (here and
    again in the lowering's CSE, which rebuilds every node) by asking the assumptions system about its operands;
    for a real symbol that is a deduction over its facts, 3.4 ms per relational against 0.07 ms without (measured
    on the 2-core machine), and the candidates have about a thousand of them. Nothing here needs the assumption:
    no step is simplified, and every value is real by construction.

    It also records which steps are angles in ``[-pi, pi]`` (:meth:`principal`, :meth:`is_principal`): the
    post-processing skips a 2 pi shift that cannot move such a column (``models/chain/solver_closed.py``)."""

    def __init__(self, tag: str, atan2: str | None = None) -> None:
        super().__init__(tag)
        self._principal: set = set()
        self.atan2 = ATAN2 if atan2 is None else atan2
        """How this recording writes its angles (:data:`ATAN2`'s values; ``"libm"`` keeps ``atan2`` a call, as
        ``show`` prints it)."""

    def symbol(self, label: str) -> sp.Symbol:
        """The symbol of the step called ``label``, without assumptions (see above)."""
        return sp.Symbol(f"_{self._tag}_{label}")

    def __call__(self, label: str, expr: sp.Expr) -> sp.Expr:
        expr = _floaty(sp.sympify(expr))
        if expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom:
            return expr  # -x costs nothing where it is used
        return super().__call__(label, expr)

    def vec(self, label: str, v: Sequence) -> list:
        """Name each component of a 3-vector."""
        return [self(f"{label}{'xyz'[i]}", v[i]) for i in range(3)]

    def principal(self, label: str, expr: sp.Expr) -> sp.Expr:
        """``self(label, expr)`` for an angle known to lie in ``[-pi, pi]`` (``pi`` the double 3.141592653589793,
        the emitted code's), recorded so that :meth:`is_principal` knows it."""
        out = self(label, expr)
        if out.is_Symbol:
            self._principal.add(out)
        return out

    def is_principal(self, expr: sp.Expr) -> bool:
        """Whether ``expr`` is known to lie in ``[-pi, pi]``: a number there, a step recorded by :meth:`principal`,
        a negation or a select (any depth) of such, or a step that names one of these."""
        expr = sp.sympify(expr)
        if expr.is_Number:
            return abs(float(expr)) <= math.pi
        if expr.is_Symbol:
            if expr in self._principal:
                return True
            definition = self.definitions().get(expr)
            return definition is not None and self.is_principal(definition)
        if expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1:
            return self.is_principal(expr.args[1])
        if isinstance(expr, sp.Piecewise):
            return all(self.is_principal(value) for value, _ in expr.args)
        return False


def any_of(*flags: sp.Expr) -> sp.Expr:
    """1 when any of the 0/1 flags is set, else 0: ``1 - (1 - f1)(1 - f2)...`` over the distinct non-zero ones
    (exact for 0/1 in floating point). Not a ``Max``: SymPy evaluates a ``Max`` of symbols by comparing every
    pair through the assumptions system (56 ms for six flags), and the lowering's CSE rebuilds every node it
    passes, so an unevaluated ``Max`` here cost about 1.3 s of each arm's generation."""
    args = []
    for f in flags:
        f = sp.sympify(f)
        if f != 0 and f not in args:
            args.append(f)
    if not args:
        return sp.S.Zero
    if any(a == 1 for a in args):
        return sp.S.One
    return args[0] if len(args) == 1 else 1 - sp.Mul(*[1 - a for a in args])


def _select(*pieces) -> sp.Expr:
    """``Piecewise(*pieces)`` unevaluated: its evaluation (collapsing conditions, a millisecond each) decides
    nothing here; the lowering builds each one again anyway."""
    return sp.Piecewise(*pieces, evaluate=False)


def positive(x: sp.Expr) -> sp.Expr:
    """``max(x, 0)`` as a select, not ``Max``: C's ``fmax`` is a call into the math library (it must treat NaN
    specially), and each call makes the compiler store every live value around it (all SSE registers are the
    caller's): 13 of them doubled the instructions of UR5's candidates."""
    return _select((x, x > 0), (sp.S.Zero, True))


def indicator(cond) -> sp.Expr:
    """1 where ``cond`` holds, else 0 (a select). A test of numbers and the tolerances alone (a fixed axis against
    another) is decided here, with the double tolerances, as it was before they became module constants: printed,
    it would be a comparison of constants, which the array backends cannot select on."""
    free = getattr(cond, "free_symbols", None)
    if free and free <= DOUBLE_VALUES.keys():
        cond = cond.xreplace(DOUBLE_VALUES)
    return _select((sp.S.One, cond), (sp.S.Zero, True))


@dataclass(frozen=True)
class Angle:
    """A solved joint variable: ``theta`` (rad, or m for a prismatic one), ``c``/``s`` its cosine and sine
    (``None`` for a prismatic one), and 0/1 flags ``ls`` and ``singular``."""

    theta: sp.Expr
    c: sp.Expr | None
    s: sp.Expr | None
    ls: sp.Expr = sp.S.Zero
    singular: sp.Expr = sp.S.Zero

    def negated(self) -> "Angle":
        """``-theta`` (cos unchanged, sin negated)."""
        return Angle(-self.theta, self.c, None if self.s is None else -self.s, self.ls, self.singular)


ATAN2 = "arithmetic"
"""How the angles are written: ``"arithmetic"`` (:func:`atan2_steps`: a rational approximation, additions,
multiplications, two divisions and selects, within 2 ulp; no call) or ``"libm"`` (``atan2``, a call to the math
library: about 30 ns each on the 2-core machine, half the time of a whole ``ik_all`` with 34 of them)."""
ATAN_P = (-8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
          -1.228866684490136173410e2, -6.485021904942025371773e1)
ATAN_Q = (2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
          4.853903996359136964868e2, 1.945506571482613964425e2)
"""Cephes' ``atan`` (S. L. Moshier): ``atan(u) = u + u z P(z) / Q(z)``, ``z = u^2``, ``|u| <= 0.66``, ``Q`` monic
of degree 5; peak relative error 1.8e-16 (Cephes' tests)."""
PI = (math.pi / 4, math.pi / 2, math.pi)


def _horner(z: sp.Expr, coefficients, monic: bool = False) -> sp.Expr:
    out = sp.S.One if monic else sp.Float(coefficients[0], 17)
    for c in (coefficients if monic else coefficients[1:]):
        out = out * z + sp.Float(c, 17)
    return out


def atan2_steps(steps: Steps, label: str, y: sp.Expr, x: sp.Expr) -> sp.Expr:
    """``atan2(y, x)`` for ``(x, y) != (0, 0)`` in arithmetic: ``a = |y|``, ``b = |x|``; ``u = min/max`` or, above
    ``0.66``, ``(min - max)/(min + max)`` (the angle less ``pi/4``), one division; Cephes' rational ``atan(u)``
    (:data:`ATAN_P`, :data:`ATAN_Q`, a second division); then ``+ pi/4``, ``pi/2 -`` (when ``a > b``), ``pi -`` (when
    ``x < 0``) and the sign of ``y``. Against ``numpy.arctan2`` on random points of every size: within 2 ulp (a
    test). ``atan2(+-0, x < 0)`` is ``+pi`` (libm: ``+-pi``). Ten steps: the lowering rebuilds every SymPy node
    (milliseconds each for a select), so the form is kept short."""
    a, b = steps(f"{label}_ay", sp.Abs(y)), steps(f"{label}_ax", sp.Abs(x))
    swap = a > b
    lo = steps(f"{label}_lo", _select((b, swap), (a, True)))
    hi = steps(f"{label}_hi", _select((a, swap), (b, True)))
    reduced = lo > 0.66 * hi
    den = steps(f"{label}_ud", _select((lo + hi, reduced), (hi, True)))  # named: one division (SymPy would
    u = steps(f"{label}_u", _select((lo - hi, reduced), (lo, True)) / den)  # put 1/den inside both branches)
    z = steps(f"{label}_z", u * u)
    q = steps(f"{label}_Q", _horner(z, ATAN_Q, True))
    r = steps(f"{label}_t", _select((sp.Float(PI[0], 17), reduced), (sp.S.Zero, True)) + (u + u * z * _horner(z, ATAN_P) / q))
    r = steps(f"{label}_t2", _select((sp.Float(PI[1], 17) - r, swap), (r, True)))
    r = steps(f"{label}_t1", _select((sp.Float(PI[2], 17) - r, x < 0), (r, True)))
    return _select((-r, y < 0), (r, True))


def angle_from(steps: Steps, label: str, x: sp.Expr, y: sp.Expr, scale2: sp.Expr) -> Angle:
    """``theta = atan2(y, x)`` with ``cos = x / rho``, ``sin = y / rho`` (``(1, 0)`` when ``rho = 0``); singular
    when ``rho^2 <= SING_TOL^2 scale2``.

    ``theta`` lies in ``[-pi, pi]`` (``pi`` the double 3.141592653589793) and is recorded so
    (:meth:`Steps.principal`): :func:`atan2_steps`' magnitude before its last two selects is in ``[0, pi/2]`` (an
    ``atan`` of ``u`` in ``[0, 0.66]``, or ``pi/4`` plus one of ``u`` in ``(-0.21, 0]``, or ``pi/2`` less one of these),
    ``pi - r`` of an ``r >= 0`` rounds to at most that double, and libm's and NumPy's ``atan2`` return at most it.

    Where ``y`` (or ``x``) is the negation of a step, the ``Abs``, ``rho`` and the rational ``atan`` are those of
    the angle at ``(x, -y)`` (or ``(-x, y)``) if that was solved before: the steps are recorded once, so a mirrored
    branch (SP4 with ``B = 0``: the 2R arm's elbow) costs a select, not a second ``atan2``."""
    x, y = steps(f"{label}_x", x), steps(f"{label}_y", y)
    rho2 = steps(f"{label}_r2", x * x + y * y)
    rho = steps(f"{label}_r", sp.sqrt(rho2))
    angle = atan2_steps(steps, label, y, x) if steps.atan2 == "arithmetic" else sp.atan2(y, x)
    # rho2 > 0 (the same test as rho > 0): an angle whose cosine and sine nothing uses (the last joints) needs no sqrt
    theta = steps.principal(f"{label}", _select((angle, rho2 > 0), (sp.S.Zero, True)))  # atan2(0, 0): 0 everywhere
    c = steps(f"{label}_c", _select((x / rho, rho2 > 0), (sp.S.One, True)))
    s = steps(f"{label}_s", _select((y / rho, rho2 > 0), (sp.S.Zero, True)))
    singular = steps(f"{label}_rsg", indicator(rho2 <= SING_SYMBOL**2 * scale2))
    return Angle(theta, c, s, sp.S.Zero, singular)


@dataclass(frozen=True)
class Parts:
    """An angle before its ``atan2``: ``theta = atan2(y, x)``, and its 0/1 flags. :func:`choose_parts` selects
    between two of them, so that one ``atan2`` (and one ``sqrt``) serves two alternatives."""

    x: sp.Expr
    y: sp.Expr
    ls: sp.Expr = sp.S.Zero
    singular: sp.Expr = sp.S.Zero

    def angle(self, steps: Steps, label: str, scale2: sp.Expr = sp.S.Zero) -> Angle:
        """The angle (see :func:`angle_from`), with these flags."""
        a = angle_from(steps, label, self.x, self.y, scale2)
        return Angle(a.theta, a.c, a.s, self.ls, self.singular)


def choose_parts(steps: Steps, label: str, pick: sp.Expr, first: Parts, second: Parts, ls: sp.Expr = sp.S.Zero,
                 singular: sp.Expr = sp.S.Zero) -> Parts:
    """``first`` where ``pick`` holds, else ``second``, with the flags ``ls`` and ``singular``: the inputs of the
    ``atan2`` selected, not its outputs. The angle, its cosine and its sine are, bit for bit, those of the chosen
    parts (the same operations on the same numbers)."""
    def sel(name, a, b):
        return a if a == b else steps(f"{label}_{name}", _select((a, pick), (b, True)))

    return Parts(sel("x", first.x, second.x), sel("y", first.y, second.y), ls, singular)


def sp1_parts(steps: Steps, label: str, k: Sequence, p: Sequence, q: Sequence) -> Parts:
    """:func:`sp1` before its ``atan2``."""
    # perpendicular parts as k x p, k x q: p . q - (k . p)(k . q) cancels when p and q lie near the axis
    # (a circle of radius 1e-7 m at 0.4 m from its centre: 3e-3 rad error in theta), k x p does not
    u = steps.vec(f"{label}_u", cross(k, p))
    w = steps.vec(f"{label}_w", cross(k, q))
    x = dot(u, w)
    y = dot(k, cross(u, w))
    # comparisons of named quantities: SymPy evaluates a relational through the assumptions system, which
    # costs milliseconds on a large expression (and the lowering's CSE builds every relational again)
    uu, pp = steps(f"{label}_uu", dot(u, u)), steps(f"{label}_pp", dot(p, p))
    ww, qq = steps(f"{label}_ww", dot(w, w)), steps(f"{label}_qq", dot(q, q))
    flat = sp.Or(uu <= SING_SYMBOL**2 * pp, ww <= SING_SYMBOL**2 * qq)
    return Parts(steps(f"{label}_x", x), steps(f"{label}_y", y), sp.S.Zero, steps(f"{label}_sg", indicator(flat)))


def sp1(steps: Steps, label: str, k: Sequence, p: Sequence, q: Sequence) -> Angle:
    """SP1: ``theta`` with ``R(k, theta) p = q`` (least squares when inconsistent); ``k`` unit. Singular (a
    continuum) when ``p`` or ``q`` is within ``SING_TOL`` (sine of the angle) of the axis."""
    return sp1_parts(steps, label, k, p, q).angle(steps, label)


def sp4_parts(steps: Steps, label: str, h: Sequence, p: Sequence, k: Sequence, d: sp.Expr,
              disc: sp.Expr | None = None, snap_scale: sp.Expr | None = None) -> tuple[tuple[Parts, Parts], sp.Expr]:
    """:func:`sp4` before its ``atan2`` s: both branches' parts and the scale of their singular test (``r2^2``).

    Where ``B`` is 0 (or ``A``), the second branch's ``y`` (or ``x``) is written as the negation of the first's,
    which :func:`angle_from` turns into a select on the first branch's ``atan2``."""
    hk, kp = steps(f"{label}_hk", dot(h, k)), steps(f"{label}_kp", dot(k, p))
    A = steps(f"{label}_A", dot(cross(k, h), cross(k, p)))  # h . p - (h . k)(k . p), without its cancellation
    B = steps(f"{label}_B", dot(h, cross(k, p)))
    C = steps(f"{label}_C", d - hk * kp)
    r2 = steps(f"{label}_r2", A * A + B * B)
    if disc is None:  # r2 - C^2 cancels at a double root: its rounding, not the geometry, makes a small root
        disc = steps(f"{label}_disc", r2 - C * C)
        exact_double = sp.And(disc <= 10 * ROOT_SYMBOL * r2, disc >= -10 * ROOT_SYMBOL * r2)
        if snap_scale is not None:  # SP3: and the distance moves by at most ROOT_TOL (|p1| + |p2|) (see ROOT_TOL)
            exact_double = sp.And(exact_double, disc * disc <= 8 * ROOT_SYMBOL**2 * r2 * snap_scale)
        root = steps(f"{label}_sq", _select((sp.S.Zero, exact_double), (sp.sqrt(positive(disc)), True)))
    else:  # written without cancellation (unit_disc): a small discriminant is a small root
        disc = steps(f"{label}_disc", disc)
        root = steps(f"{label}_sq", sp.sqrt(positive(disc)))
    ls = steps(f"{label}_ls", indicator(disc < -LS_SYMBOL * r2))
    scale2 = steps(f"{label}_n2", dot(h, h) * dot(p, p))
    double = steps(f"{label}_dbl", indicator(sp.And(disc <= LS_SYMBOL * r2, disc >= -LS_SYMBOL * r2)))
    flat = steps(f"{label}_flat", indicator(r2 <= SING_SYMBOL**2 * scale2))
    singular = steps(f"{label}_sg", any_of(double, flat))
    xs = [A * C - sign * B * root for sign in (1, -1)]
    ys = [B * C + sign * A * root for sign in (1, -1)]
    out = []
    for b in range(2):
        mirror_x = b == 1 and not out[0].x.is_Number and xs[0] + xs[1] == 0  # A = 0: the mirror image in y
        mirror_y = b == 1 and not out[0].y.is_Number and ys[0] + ys[1] == 0  # B = 0: the mirror image in x
        x = -out[0].x if mirror_x else steps(f"{label}{b}_x", xs[b])
        y = -out[0].y if mirror_y else steps(f"{label}{b}_y", ys[b])
        out.append(Parts(x, y, ls, singular))
    return (out[0], out[1]), r2 * r2


def sp4(steps: Steps, label: str, h: Sequence, p: Sequence, k: Sequence, d: sp.Expr,
        disc: sp.Expr | None = None) -> tuple[Angle, Angle]:
    """SP4: both ``theta`` with ``h . R(k, theta) p = d`` (``k`` unit; ``h`` any length). Branch 0 takes ``+s``.

    ``disc``: the discriminant ``A^2 + B^2 - C^2`` written without cancellation, when the caller has such a
    form (see :func:`unit_disc`); by default it is computed as written, which loses digits near a double root.
    """
    parts, scale2 = sp4_parts(steps, label, h, p, k, d, disc)
    return parts[0].angle(steps, f"{label}0", scale2), parts[1].angle(steps, f"{label}1", scale2)


ROUNDING_ZERO = 1e-14
"""A constant of a wrist's geometry (a unit-vector expression) at most this in magnitude is taken as exactly 0: the
rounding of axes read from a file (``0.8660254037844386`` for ``sqrt(3)/2``)."""


def _zero_to_rounding(x: sp.Expr) -> sp.Expr:
    """``x``, or exactly 0 where it is a constant within :data:`ROUNDING_ZERO` of 0. (Not ``nsimplify``: it replaced
    such constants by a nearby closed form it recognised, a wrong one for a random arm with a prismatic third joint,
    whose rows then missed their targets by up to 0.17 m.)"""
    if x.free_symbols:
        return x
    return sp.S.Zero if abs(float(sp.N(x, 30))) <= ROUNDING_ZERO else x


def unit_disc(h: Sequence, p: Sequence, k: Sequence, g: Sequence) -> sp.Expr:
    """SP4's discriminant for ``h . R(k, theta) p = h . g`` with unit ``h``, ``p``, ``k`` and a unit target direction
    ``g``, written to keep its digits at a double root (the wrist singularity).

    It is ``A^2 + B^2 - C^2 = a^2 - C^2`` with ``a = sqrt((1 - hk^2)(1 - pk^2))`` and ``C = d - hk pk``
    (``hk = h . k``, ``pk = p . k``, ``d = h . g``). Where ``h`` and ``p`` are perpendicular to ``k`` (every wrist with
    right-angle twists: exact zeros) it is ``|h x g|^2``, a sum of squares, where ``1 - (h . g)^2`` loses digits
    (measured: q5 = 1.7e-4 rad gave a 1.3e-12 rad error in q5 before, 1e-16 after). Otherwise (a wrist whose
    middle axis is skewed) it is ``(a - C)(a + C)`` with ``a - C = (hk pk + a - 1) + (1 - d)`` and
    ``a + C = (1 + d) - (1 + hk pk - a)``: the constants exact, ``1 - d`` as ``|h x g|^2 / (1 + d)`` where ``d > 0``
    and ``1 + d`` as ``|h x g|^2 / (1 - d)`` where ``d < 0``, so neither factor cancels where it vanishes (the
    written form ``|h x g|^2 - (hk^2 + pk^2 - 2 d hk pk)`` left the aligned wrist's roots 1e-8 apart: rows 2e-8
    off in rotation, a new user's arm with axis 5 at 60 degrees to axes 4 and 6)."""
    hk, pk, d = dot(h, k), dot(p, k), dot(h, g)
    hg = cross(h, g)
    sine2 = dot(hg, hg)
    if hk == 0 and pk == 0:
        return sine2
    hk_x, pk_x = (sp.nsimplify(x, rational=True) if isinstance(x, sp.Float) else x for x in (hk, pk))
    a = sp.sqrt((1 - hk_x**2) * (1 - pk_x**2))
    top, bottom = _zero_to_rounding(hk_x * pk_x + a - 1), _zero_to_rounding(1 + hk_x * pk_x - a)  # exact 0 where aligned
    one_minus = _select((sine2 / (1 + d), d > 0), (1 - d, True))
    one_plus = _select((sine2 / (1 - d), d < 0), (1 + d, True))
    return (top + one_minus) * (one_plus - bottom)


def sp3_parts(steps: Steps, label: str, k: Sequence, p1: Sequence, p2: Sequence, d2: sp.Expr) -> tuple[tuple[Parts, Parts], sp.Expr]:
    """:func:`sp3` before its ``atan2`` s (see :func:`sp4_parts`)."""
    d = (dot(p1, p1) + dot(p2, p2) - d2) / 2
    return sp4_parts(steps, label, p2, p1, k, d, snap_scale=d2 * (dot(p1, p1) + dot(p2, p2)))


def sp3(steps: Steps, label: str, k: Sequence, p1: Sequence, p2: Sequence, d2: sp.Expr) -> tuple[Angle, Angle]:
    """SP3: both ``theta`` with ``|R(k, theta) p1 - p2|^2 = d2`` (``d2`` a squared distance)."""
    parts, scale2 = sp3_parts(steps, label, k, p1, p2, d2)
    return parts[0].angle(steps, f"{label}0", scale2), parts[1].angle(steps, f"{label}1", scale2)


def sp2(steps: Steps, label: str, k1: Sequence, p1: Sequence, k2: Sequence, p2: Sequence) -> tuple[tuple[Angle, Angle], tuple[Angle, Angle]]:
    """SP2: both ``(theta1, theta2)`` with ``R(k1, theta1) p1 = R(k2, theta2) p2`` (unit, non-parallel ``k1``, ``k2``)."""
    k12 = steps(f"{label}_k12", dot(k1, k2))
    a1, a2 = steps(f"{label}_a1", dot(k1, p1)), steps(f"{label}_a2", dot(k2, p2))
    nn = steps(f"{label}_nn", 1 - k12 * k12)
    inv = steps(f"{label}_inv", 1 / nn)
    alpha = steps(f"{label}_al", (a1 - k12 * a2) * inv)
    beta = steps(f"{label}_be", (a2 - k12 * a1) * inv)
    norm2 = steps(f"{label}_m2", (dot(p1, p1) + dot(p2, p2)) / 2)
    # gamma^2 |k1 x k2|^2 = r2^2 - alpha^2 nn = r1^2 - beta^2 nn (r_i: the circles' radii, |k_i x p_i|): the form
    # with the smaller circle cancels least (a circle of radius 1e-11 m next to a 0.4 m one: |c|^2 - |proj c|^2
    # left gamma 3e-9 m wrong, and the SP1 on that small circle turned that into the pose).
    c1, c2 = cross(k1, p1), cross(k2, p2)
    r1 = steps(f"{label}_r1", dot(c1, c1))
    r2 = steps(f"{label}_r2", dot(c2, c2))
    disc = steps(f"{label}_disc", _select((r2 - alpha * alpha * nn, r2 <= r1), (r1 - beta * beta * nn, True)))
    gamma = steps(f"{label}_g", sp.sqrt(positive(disc) * inv))
    ls = steps(f"{label}_ls", indicator(disc < -LS_SYMBOL * norm2))
    double = steps(f"{label}_dbl", indicator(sp.And(disc <= LS_SYMBOL * norm2, disc >= -LS_SYMBOL * norm2)))
    n = cross(k1, k2)
    out = []
    for b, sign in enumerate((1, -1)):
        c = steps.vec(f"{label}{b}_c", add(add(scale(alpha, k1), scale(beta, k2)), scale(sign * gamma, n)))
        t1 = sp1(steps, f"{label}{b}_t1", k1, p1, c)
        t2 = sp1(steps, f"{label}{b}_t2", k2, p2, c)
        sg = steps(f"{label}{b}_sg", any_of(double, t1.singular, t2.singular))
        out.append((Angle(t1.theta, t1.c, t1.s, ls, sg), Angle(t2.theta, t2.c, t2.s, ls, sg)))
    return out[0], out[1]


def sp_line(steps: Steps, label: str, h: Sequence, x0: Sequence, o: Sequence, d2: sp.Expr) -> tuple[Angle, Angle]:
    """Prismatic SP3: both ``t`` with ``|x0 + t h - o|^2 = d2`` (unit ``h``): a quadratic. Branch 0 is the larger root."""
    r = sub(x0, o)
    b = steps(f"{label}_b", dot(h, r))
    c = steps(f"{label}_c", dot(r, r) - d2)
    disc = steps(f"{label}_disc", b * b - c)
    root = steps(f"{label}_sq", sp.sqrt(positive(disc)))
    scale2 = steps(f"{label}_n2", dot(r, r) + sp.Abs(d2))
    ls = steps(f"{label}_ls", indicator(disc < -LS_SYMBOL * scale2))
    singular = steps(f"{label}_sg", indicator(sp.And(disc <= LS_SYMBOL * scale2, disc >= -LS_SYMBOL * scale2)))
    return (Angle(steps(f"{label}0", -b + root), None, None, ls, singular),
            Angle(steps(f"{label}1", -b - root), None, None, ls, singular))
