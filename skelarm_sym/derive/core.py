"""What every derivation shares: named steps, function specs, constants and the generic Derivation.

A derivation writes a model's kinematics as a short chain of named intermediate
quantities (*steps*), each a small expression of inputs and earlier steps, plus the
outputs written with those steps. :mod:`skelarm_sym.ir.lower` turns them into a
straight-line program; nothing after this stage knows which model it prints.
"""

from __future__ import annotations

import gc
from dataclasses import dataclass, field
from typing import Iterable, Sequence


def _import_sympy():
    """``import sympy`` with the cyclic garbage collector paused (and restored as it was).

    SymPy's import builds several hundred thousand long-lived objects (classes, caches, tables) and no
    garbage worth collecting; the collections those allocations trigger walk them again and again, about
    0.09 s of the 0.55 s import. This is the package's first import of SymPy (``skelarm_sym`` imports
    :mod:`skelarm_sym.derive` first); once SymPy is loaded this costs nothing."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        import sympy
    finally:
        if collecting:
            gc.enable()
    return sympy


sp = _import_sympy()

Step = tuple[sp.Symbol, sp.Expr]


ARGUMENT_ROLES: dict[str, int] = {
    # 0: the joint (or body) state
    "q": 0, "q0": 0, "q_ref": 0, "dq": 0, "ddq": 0, "pose": 0,
    # 1: the call's other data
    "v": 1, "twist": 1, "target": 1, "weights": 1, "wheels": 1, "rates": 1,
    # 2: the mechanism's parameters
    "l": 2, "params": 2, "track": 2,
    # 3: scalars
    "lambda": 3, "tol": 3, "max_iter": 3, "lock": 3,
}
"""The role of each input name; every emitted function takes its inputs in increasing role,
then its outputs (see :data:`ARGUMENT_RULE`)."""

MATRIX_INPUTS: dict[str, tuple[int, int]] = {"target": (4, 4)}
"""Inputs a caller may give as a matrix: a straight-line function reads ``target`` as its 16 entries, row-major, and
every Python entry takes ``(..., 4, 4)`` for ``(..., 16)``, as the solvers' entries do."""


def matrix_shape(name: str, size: int) -> tuple[int, int] | None:
    """The matrix shape an input ``name`` of ``size`` entries may come in (:data:`MATRIX_INPUTS`), else None."""
    shape = MATRIX_INPUTS.get(name)
    return shape if shape is not None and shape[0] * shape[1] == size else None

ARGUMENT_RULE = (
    "Arguments, in every function: the joint state (q, q0 or q_ref, dq, ddq), the call's other data (v, twist,"
    " target, weights), the mechanism's parameters (l, params), scalars (lambda, tol, max_iter, lock), then the outputs."
)
ROLE_NAMES = ("the state", "the call's other data", "the mechanism's parameters", "scalars")


def argument_rule(names) -> str:
    """:data:`ARGUMENT_RULE` for the input ``names`` a module's functions take (a differential drive's header names
    pose, wheels, rates and track, not an arm's q, twist and lambda)."""
    present = set(names)
    groups = [f"{label} ({', '.join(n for n, role in ARGUMENT_ROLES.items() if role == k and n in present)})"
              for k, label in enumerate(ROLE_NAMES) if any(role == k and n in present for n, role in ARGUMENT_ROLES.items())]
    return "Arguments, in every function: " + ", ".join(groups + ["then the outputs."])


@dataclass(frozen=True)
class FunctionSpec:
    """One emitted function: its name suffix, argument names in order, output names in order.

    ``inputs`` must follow :data:`ARGUMENT_RULE` (checked on construction: every name needs a role in
    :data:`ARGUMENT_ROLES`, and roles may not decrease).
    """

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    summary: str

    def __post_init__(self) -> None:
        unknown = [a for a in self.inputs if a not in ARGUMENT_ROLES]
        if unknown:
            raise ValueError(f"internal error: input {unknown[0]!r} of {self.name} has no argument role")
        roles = [ARGUMENT_ROLES[a] for a in self.inputs]
        if roles != sorted(roles):
            raise ValueError(f"internal error: inputs of {self.name} break the argument order: {self.inputs}")


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
"""The relative rank tolerance of the damped solves; their rules are stated once, in
:func:`skelarm_sym.derive.linalg.damped_solve2` (two rows) and :func:`skelarm_sym.derive.solve6.damped_least_squares`
(more rows). ``jacobian_rpy``'s gimbal test is ``cos(pitch)^2 <= RANK_TOL``."""


@dataclass(frozen=True)
class Table:
    """A named constant array the emitted code defines (joint limits): one number per coordinate.

    ``None`` entries mean "no limit": they print as -/+ ``UNBOUNDED[precision]`` (a huge finite
    number in C, +-inf in Python) according to ``sign``.
    """

    name: str
    values: tuple[float | None, ...]
    doc: str
    sign: int = 1


UNBOUNDED = {"double": 1e300, "float": 1e30}
"""What a missing limit prints as in C (a finite number, so comparisons never trap)."""


class StepRecorder:
    """Collects named intermediate quantities.

    Trivial ones (atoms) are not given a name, and an expression recorded before
    returns its first name (two derivations of the same quantity share one step). A label
    that names a second, different expression is an internal error: SymPy makes equal
    symbols of equal names, so the lowering would keep one definition for both.
    """

    def __init__(self, tag: str) -> None:
        self._tag = tag
        self.steps: list[Step] = []
        self._known: dict[sp.Expr, sp.Symbol] = {}
        self._definitions: dict[sp.Symbol, sp.Expr] = {}

    def symbol(self, label: str) -> sp.Symbol:
        """The symbol of the step called ``label`` (real)."""
        return sp.Symbol(f"_{self._tag}_{label}", real=True)

    def __call__(self, label: str, expr: sp.Expr) -> sp.Expr:
        if expr.is_Atom:
            return expr
        known = self._known.get(expr)
        if known is not None:
            return known
        symbol = self.symbol(label)
        if symbol in self._definitions:
            raise ValueError(f"internal error: step {symbol} defined twice")
        self.steps.append((symbol, expr))
        self._known[expr] = symbol
        self._definitions[symbol] = expr
        return symbol

    def definitions(self) -> dict[sp.Symbol, sp.Expr]:
        """Each recorded step's right-hand side by its symbol (read only)."""
        return self._definitions

    def recorded(self, expr: sp.Expr) -> sp.Symbol | None:
        """The symbol of the step recorded for ``expr``, or ``None``."""
        return self._known.get(expr)

    def replace_steps(self, steps: Sequence[Step]) -> None:
        """Take ``steps`` (symbol, right-hand side) as the recorded steps, in order (a pass that drops dead steps
        or rewrites their signs); an expression recorded twice keeps its first symbol."""
        self.steps = list(steps)
        self._definitions = dict(self.steps)
        self._known = {}
        for symbol, rhs in self.steps:
            self._known.setdefault(rhs, symbol)


def expand_steps(steps: Sequence[Step], exprs: Iterable[sp.Expr]) -> list[sp.Expr]:
    """Substitute the steps into ``exprs`` (in order), giving closed forms in the inputs only."""
    exprs = [sp.sympify(e) for e in exprs]
    needed: set[sp.Symbol] = set().union(*(e.free_symbols for e in exprs)) if exprs else set()
    for symbol, expr in reversed(steps):  # only the steps these expressions use (the solves' are costly to expand)
        if symbol in needed:
            needed |= expr.free_symbols
    closed: dict[sp.Symbol, sp.Expr] = {}
    for symbol, expr in steps:
        if symbol in needed:
            closed[symbol] = expr.xreplace(closed)
    return [e.xreplace(closed) for e in exprs]


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
        tables: named constant arrays (joint limits) the emitted code defines (see :class:`Table`).
        variants: function name -> {output name -> key of ``compact``}: where one function computes an
            output another way than the others (the same values, fewer operations for what it needs
            alone: the chain's ``pose`` sums its position where ``kinematics`` reuses its Jacobian's
            offsets); every other function, and :meth:`closed_form`, reads ``compact[name]``.
    """

    model: object
    inputs: dict[str, tuple[sp.Symbol, ...]]
    steps: tuple[Step, ...]
    compact: dict[str, sp.Matrix]
    shapes: dict[str, tuple[int, ...]]
    functions: tuple[FunctionSpec, ...]
    parameters: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    scalars: tuple[str, ...] = ()
    domains: dict[str, str] = field(default_factory=dict)
    constants: tuple[Constant, ...] = ()
    tables: tuple[Table, ...] = ()
    variants: dict[str, dict[str, str]] = field(default_factory=dict)
    unavailable: dict[str, str] = field(default_factory=dict)
    """Functions of the kind this model has not, each with why (``inverse_velocity3``: needs n >= 3)."""
    _cache: dict = field(default_factory=dict, repr=False)

    # -- symbols --------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of joints of a chain; ``AttributeError`` for other models."""
        return self.model.n

    def output_key(self, function: str, output: str) -> str:
        """The key of ``compact`` that function ``function`` reads for its output ``output``."""
        return self.variants.get(function, {}).get(output, output)

    def function(self, name: str) -> FunctionSpec:
        """The function spec called ``name``; ``KeyError`` if this derivation has none."""
        for spec in self.functions:
            if spec.name == name:
                return spec
        raise KeyError(name)

    @property
    def q(self) -> tuple[sp.Symbol, ...]:
        """Joint positions ``q1..qn`` (radians for revolute joints, metres for prismatic ones)."""
        return self.inputs["q"]

    @property
    def dq(self) -> tuple[sp.Symbol, ...]:
        """Joint rates ``dq1..dqn``."""
        return self.inputs["dq"]

    @property
    def ddq(self) -> tuple[sp.Symbol, ...]:
        """Joint accelerations ``ddq1..ddqn``."""
        return self.inputs["ddq"]

    # -- closed forms ---------------------------------------------------------
    def closed_form(self, name: str) -> sp.Matrix:
        """Output ``name`` as a matrix of closed-form expressions in the inputs only."""
        if name not in self._cache:
            matrix = self.compact[name]
            values = expand_steps(self.steps, list(matrix))
            self._cache[name] = sp.Matrix(matrix.rows, matrix.cols, values)
        return self._cache[name]


def exact_number(x: float) -> sp.Expr:
    """A fixed parameter as a SymPy number: an Integer when it is whole, else a Float."""
    return sp.Integer(int(x)) if float(x).is_integer() else sp.Float(x)
