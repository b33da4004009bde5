"""The intermediate representation between the derivation and every printer.

A :class:`Module` holds what one emitted file set says: prefix, precision, header notes (text, escaped
by each printer), named constants, constant tables and functions. A :class:`Function` has typed
arguments with a role (joint state, call data, parameter, scalar, output), a shape, a domain and a
batching rule, and a body of statements over a small expression vocabulary. Nothing here knows SymPy
or a model: :mod:`skelarm_sym.ir.lower` turns SymPy steps into these nodes once, and
:mod:`skelarm_sym.ir.build` writes procedural bodies (the iterative solvers) directly.

Expressions (all immutable and hashable):

* :class:`Const` (a number of the function's real type, an ``int`` or a ``bool``), :class:`NamedConst`
  (a module constant), :class:`Var` (a scalar local or argument), :class:`Elem` (an array element);
* :class:`Add` and :class:`Mul` (n-ary), :class:`Neg`, :class:`Div` (``guarded``: the printer writes
  ``den != 0 ? den : 1`` so that the branch of a select that is not taken never divides by zero),
  :class:`Call1` (``sqrt``, ``sin``, ``cos``, ``fabs``, ``floor``, ``nearbyint``, ``isfinite``),
  :class:`Call2` (``atan2``, ``fmin``, ``fmax``);
* :class:`Compare` (``<``, ``<=``, ``>``, ``>=``, ``==``, ``!=``), :class:`Logic` (``and``, ``or``),
  :class:`Not`, :class:`Select` (``cond ? a : b``).

Statements: :class:`Let` (a constant local), :class:`Declare` / :class:`DeclareArray` (mutable locals),
:class:`Assign`, :class:`TrigBlock` (cosines and sines of several angles at once: the vectorisable
block), :class:`Store` (an output element), :class:`If`, :class:`For`, :class:`While`, :class:`Break`,
:class:`Return`, :class:`CallFunction` (another function of the module), :class:`Comment`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from enum import Enum
from typing import Union


LONG_SUM = 8
"""Sums of more terms are lowered as balanced trees of :class:`Add` (``lower._sum``); no pass writes a longer one."""


class Type(str, Enum):
    """Scalar types: the module's real type (``double`` or ``float``), ``int`` and ``bool``."""

    REAL = "real"
    INT = "int"
    BOOL = "bool"
    UINT64 = "uint64"


class Role(int, Enum):
    """Argument roles, in the order every function takes them (then its outputs)."""

    STATE = 0
    DATA = 1
    PARAMETER = 2
    SCALAR = 3
    OUTPUT = 4


# -- expressions -------------------------------------------------------------------------------------

def _wrap(x: object) -> "Expr":
    """A Python number as a :class:`Const`; expressions pass."""
    if isinstance(x, bool):
        return Const(x, Type.BOOL)
    if isinstance(x, int):
        return Const(x, Type.INT)
    if isinstance(x, float):
        return Const(x)
    return x  # type: ignore[return-value]


def _composite(cls):
    """A composite expression node: a frozen, slotted dataclass that remembers its structural hash in a ``_hash``
    slot (no part of its value: not in ``__init__``, ``==`` or ``repr``) and answers ``==`` from the hashes
    first. The printers' memos, the common-subexpression tables and the operation counts look up deep trees,
    and a frozen dataclass's own hash walks the whole tree on every lookup (quadratic in depth). Equal nodes
    keep equal hashes (the same function of the same fields)."""
    cls.__annotations__["_hash"] = "int | None"
    cls._hash = field(default=None, init=False, repr=False, compare=False)
    cls = dataclass(frozen=True, slots=True)(cls)
    structural_hash, structural_eq = cls.__hash__, cls.__eq__

    def __hash__(self):
        h = self._hash
        if h is None:
            h = structural_hash(self)
            object.__setattr__(self, "_hash", h)
        return h

    def __eq__(self, other):
        if self is other:
            return True
        if type(other) is not type(self):
            return NotImplemented
        if __hash__(self) != __hash__(other):
            return False
        return structural_eq(self, other)

    cls.__hash__, cls.__eq__ = __hash__, __eq__
    return cls


class ExprOps:
    """Operators that build expressions (``a + b``, ``a * 2.0``, ``-a``, ``a < b``); ``==`` stays
    structural equality: use :func:`eq` and :func:`ne` for comparisons."""

    __slots__ = ()

    def __add__(self, other): return Add((self, _wrap(other)))
    def __radd__(self, other): return Add((_wrap(other), self))
    def __sub__(self, other): return Add((self, Neg(_wrap(other))))
    def __rsub__(self, other): return Add((_wrap(other), Neg(self)))
    def __mul__(self, other): return Mul((self, _wrap(other)))
    def __rmul__(self, other): return Mul((_wrap(other), self))
    def __truediv__(self, other): return Div(self, _wrap(other))
    def __rtruediv__(self, other): return Div(_wrap(other), self)
    def __neg__(self): return Neg(self)
    def __lt__(self, other): return Compare("<", self, _wrap(other))
    def __le__(self, other): return Compare("<=", self, _wrap(other))
    def __gt__(self, other): return Compare(">", self, _wrap(other))
    def __ge__(self, other): return Compare(">=", self, _wrap(other))
    def __and__(self, other): return _logic("and", self, _wrap(other))
    def __or__(self, other): return _logic("or", self, _wrap(other))
    def __invert__(self): return Not(self)


def _logic(op: str, a, b) -> "Logic":
    """``a op b``, flattened: ``(a or b) or c`` is one ``or`` of three terms."""
    terms = []
    for x in (a, b):
        terms.extend(x.terms if type(x) is Logic and x.op == op else (x,))
    return Logic(op, tuple(terms))


def eq(a: object, b: object) -> "Compare":
    """``a == b``."""
    return Compare("==", _wrap(a), _wrap(b))


def ne(a: object, b: object) -> "Compare":
    """``a != b``."""
    return Compare("!=", _wrap(a), _wrap(b))


@dataclass(frozen=True, slots=True)
class Const(ExprOps):
    """A literal: ``value`` of ``type`` (a real prints in the module's precision)."""

    value: float | int | bool
    type: Type = Type.REAL


@dataclass(frozen=True, slots=True)
class NamedConst(ExprOps):
    """A constant of the module (``Module.constants``), referred to by name."""

    name: str
    type: Type = Type.REAL


@dataclass(frozen=True, slots=True)
class Var(ExprOps):
    """A scalar: a local, a loop counter or a scalar argument."""

    name: str
    type: Type = Type.REAL


@_composite
class Elem(ExprOps):
    """Element ``index`` of array ``array`` (an argument, a local array or a table), row-major."""

    array: str
    index: "Expr"
    type: Type = Type.REAL


@_composite
class Add(ExprOps):
    """``terms[0] + terms[1] + ...``; a :class:`Neg` term prints as a subtraction."""

    terms: tuple["Expr", ...]


@_composite
class Mul(ExprOps):
    """``factors[0] * factors[1] * ...``."""

    factors: tuple["Expr", ...]


@_composite
class Neg(ExprOps):
    """``-x``."""

    x: "Expr"


@_composite
class Div(ExprOps):
    """``num / den``; with ``guarded``, ``num / (den != 0 ? den : 1)``."""

    num: "Expr"
    den: "Expr"
    guarded: bool = False


UNARY = ("sqrt", "sin", "cos", "fabs", "floor", "nearbyint", "isfinite")
BINARY = ("atan2", "fmin", "fmax")


@_composite
class Call1(ExprOps):
    """A math function of one real: one of :data:`UNARY` (``isfinite`` is a ``bool`` that -ffast-math
    cannot remove in C; ``nearbyint`` rounds to the nearest whole number, halves to even: C99's
    ``nearbyint`` in the default rounding mode, NumPy's ``rint``)."""

    function: str
    x: "Expr"


@_composite
class Call2(ExprOps):
    """A math function of two reals: one of :data:`BINARY`."""

    function: str
    a: "Expr"
    b: "Expr"


COMPARISONS = ("<", "<=", ">", ">=", "==", "!=")


@_composite
class Compare(ExprOps):
    """``a op b`` for ``op`` in :data:`COMPARISONS`; a ``bool``."""

    op: str
    a: "Expr"
    b: "Expr"


@_composite
class Logic(ExprOps):
    """``terms[0] and terms[1] ...`` (``op == "and"``) or ``or``; a ``bool``."""

    op: str
    terms: tuple["Expr", ...]


@_composite
class Not(ExprOps):
    """``not x``."""

    x: "Expr"


@_composite
class Select(ExprOps):
    """``cond ? then : otherwise`` (both sides are evaluated in vectorised backends)."""

    cond: "Expr"
    then: "Expr"
    otherwise: "Expr"


@_composite
class Bits(ExprOps):
    """Integer operations: ``^ << >> *`` on ``uint64`` (the random-number generator; ``*`` and ``<<`` wrap
    modulo 2**64) and ``%`` on non-negative ``int``."""

    op: str
    a: "Expr"
    b: "Expr"


@_composite
class Cast(ExprOps):
    """``x`` converted to ``type`` (``uint64`` -> ``real``: the top 53 bits as a number in [0, 1))."""

    type: Type
    x: "Expr"


Expr = Union[Const, NamedConst, Var, Elem, Add, Mul, Neg, Div, Call1, Call2, Compare, Logic, Not, Select, Bits, Cast]


def take_sign(plus: list, minus: list) -> None:
    """Where every term of a sum is subtracted (``plus`` empty, ``minus`` a :class:`Neg` each), let the first
    literal, or product led by one, take the sign itself: ``-x - 0.3`` is ``-0.3 - x``, no negation to pay.
    Moves that term from ``minus`` to ``plus``; nothing otherwise."""
    if plus:
        return
    for i, m in enumerate(minus):
        x = m.x
        if type(x) is Const:
            plus.append(Const(-x.value, x.type))
        elif type(x) is Mul and type(x.factors[0]) is Const:
            plus.append(Mul((Const(-x.factors[0].value, x.factors[0].type), *x.factors[1:])))
        else:
            continue
        del minus[i]
        return


def signed_sum(terms) -> Expr:
    """The sum of ``terms`` as the lowering writes one (``lower._add``): added terms first, then the subtracted
    ones (a :class:`Neg` each), the sign taken by a literal where all are subtracted (:func:`take_sign`). One
    term is that term."""
    plus = [t for t in terms if type(t) is not Neg]
    minus = [t for t in terms if type(t) is Neg]
    take_sign(plus, minus)
    ordered = plus + minus
    return ordered[0] if len(ordered) == 1 else Add(tuple(ordered))


# -- statements --------------------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Let:
    """``const type var = value``: assigned once, never changed."""

    var: Var
    value: Expr


@dataclass(frozen=True, slots=True)
class Declare:
    """A mutable scalar local, with an initial value or none."""

    var: Var
    value: Expr | None = None


@dataclass(frozen=True, slots=True)
class DeclareArray:
    """A local array of ``size`` elements of ``type``; ``values`` (constants) initialise it, else it is uninitialised."""

    name: str
    size: int
    type: Type = Type.REAL
    values: tuple[Expr, ...] | None = None
    const: bool = False


@dataclass(frozen=True, slots=True)
class Assign:
    """``target = value`` for a declared local, an array element or an output element."""

    target: Var | Elem
    value: Expr


@dataclass(frozen=True, slots=True)
class TrigBlock:
    """``cos[k] = cos(angles[k])``, ``sin[k] = sin(angles[k])`` for every k, as one block.

    Backends may evaluate it as one vectorised loop (C: glibc's vector math; NumPy: one call each).
    ``cos`` and ``sin`` are the variables later statements read."""

    angles: tuple[Expr, ...]
    cos: tuple[Var, ...]
    sin: tuple[Var, ...]


@dataclass(frozen=True, slots=True)
class Store:
    """Output element: ``output[index] = value``."""

    output: str
    index: int
    value: Expr


@dataclass(frozen=True, slots=True)
class If:
    """``if cond: then else: otherwise``."""

    cond: Expr
    then: tuple["Stmt", ...]
    otherwise: tuple["Stmt", ...] = ()


@dataclass(frozen=True, slots=True)
class For:
    """``for var in range(start, stop)`` (``var`` an ``int``)."""

    var: Var
    start: Expr
    stop: Expr
    body: tuple["Stmt", ...]


@dataclass(frozen=True, slots=True)
class While:
    """``while cond: body`` (``Const(True, BOOL)`` for a loop left only by :class:`Break` or :class:`Return`)."""

    cond: Expr
    body: tuple["Stmt", ...]


@dataclass(frozen=True, slots=True)
class Break:
    """Leave the innermost loop."""


@dataclass(frozen=True, slots=True)
class Return:
    """Leave the function, with ``value`` (its status) when it returns one."""

    value: Expr | None = None


@dataclass(frozen=True, slots=True)
class ArrayArg:
    """An array passed to a called function: ``name`` from element ``offset``."""

    name: str
    offset: "int | Expr" = 0


@dataclass(frozen=True, slots=True)
class CallFunction:
    """Call ``function`` (a function of this module) with ``args`` (expressions or :class:`ArrayArg`);
    its status goes to ``result`` when given."""

    function: str
    args: tuple[Expr | ArrayArg, ...]
    result: Var | None = None


@dataclass(frozen=True, slots=True)
class Comment:
    """A comment line (text of the project, not of a robot file)."""

    text: str


Stmt = Union[Let, Declare, DeclareArray, Assign, TrigBlock, Store, If, For, While, Break, Return, CallFunction, Comment]


# -- functions and modules ---------------------------------------------------------------------------

DOMAINS = ("", "finite", "nonnegative", "positive")


@dataclass(frozen=True)
class Argument:
    """One argument: ``shape`` ``()`` for a number passed by value; arrays are row-major.

    ``batched``: each configuration of a batch call has its own (joint state, data, outputs);
    otherwise the batch shares it (parameters, scalars). ``domain`` (inputs): ``finite``,
    ``nonnegative`` (finite and >= 0) or ``positive``; wrappers refuse other values.
    ``optional``: an output the caller may omit (C: may be NULL). ``default`` (scalars of procedures):
    the value a Python caller gets when it passes none, an expression of the other inputs.
    ``fields``: names for the elements of a small output that Python returns as separate numbers."""

    name: str
    role: Role
    shape: tuple[int, ...]
    type: Type = Type.REAL
    domain: str = ""
    batched: bool = True
    doc: str = ""
    optional: bool = False
    default: "Expr | None" = None
    fields: tuple[str, ...] = ()

    @property
    def size(self) -> int:
        """Number of elements (1 for a scalar)."""
        out = 1
        for d in self.shape:
            out *= d
        return out

    @property
    def is_scalar(self) -> bool:
        return self.shape == ()

    @property
    def is_output(self) -> bool:
        return self.role is Role.OUTPUT


@dataclass(frozen=True)
class OpCount:
    """Operations of a function as printed: arithmetic by kind plus transcendental calls."""

    add: int = 0
    mul: int = 0
    neg: int = 0
    div: int = 0
    sqrt: int = 0
    cmp: int = 0
    select: int = 0
    sin: int = 0
    cos: int = 0
    atan2: int = 0

    @property
    def arithmetic(self) -> int:
        """Additions, subtractions, multiplications and negations."""
        return self.add + self.mul + self.neg

    def as_dict(self) -> dict[str, int]:
        out = {k: getattr(self, k) for k in ("add", "mul", "neg", "div", "sqrt", "cmp", "select", "sin", "cos", "atan2")}
        out["arithmetic"] = self.arithmetic
        return out


@dataclass(frozen=True)
class Function:
    """One emitted function.

    ``kind``: ``"straight"`` (a straight-line program of its inputs: backends also emit a batch
    variant and vectorise it), ``"procedure"`` (loops and branches on data: the solvers; one problem
    per call, and a batch variant that solves one problem after another, or all at once in masked form
    in the array backends) or ``"helper"`` (a procedure used by other functions, not public).
    ``returns``: ``Type.INT`` for a status, else ``None``. ``statuses``: the named return values.
    ``doc``: lines for the header beside the prototype."""

    name: str
    summary: str
    arguments: tuple[Argument, ...]
    body: tuple[Stmt, ...]
    kind: str = "straight"
    returns: Type | None = None
    statuses: tuple[tuple[str, int, str], ...] = ()
    """Procedures' return codes: (name, value, meaning)."""
    doc: tuple[str, ...] = ()
    ops: OpCount = field(default_factory=OpCount)
    result: str = ""
    """Procedures: the name of the record a Python caller gets (its first output, the status name, then
    the other outputs, small ones split into their ``fields``)."""
    refused: str = ""
    """Procedures: why the status ending in ``INVALID`` comes back once every argument has passed its Python
    checks (domain, shape, integer range), which raise first and name the argument: the ``ValueError`` a Python
    caller gets for that status. Empty: the status's meaning."""

    @property
    def invalid_status(self) -> tuple[str, int, str] | None:
        """``(name, value, message)`` of the status ending in ``INVALID``, the message as Python callers raise
        it (:attr:`refused`, else the status's meaning); None without one."""
        for name, value, meaning in self.statuses:
            if name.endswith("INVALID"):
                return name, value, self.refused or meaning
        return None

    @property
    def result_fields(self) -> tuple[str, ...]:
        outs = self.outputs
        if not outs:
            return ()
        rest = [x for o in outs[1:] for x in (o.fields or (o.name,))]
        return (outs[0].name, "status", *rest)

    @cached_property
    def inputs(self) -> tuple[Argument, ...]:
        return tuple(a for a in self.arguments if not a.is_output)

    @cached_property
    def outputs(self) -> tuple[Argument, ...]:
        return tuple(a for a in self.arguments if a.is_output)

    def argument(self, name: str) -> Argument:
        for a in self.arguments:
            if a.name == name:
                return a
        raise KeyError(name)


@dataclass(frozen=True)
class ConstantDef:
    """A named constant of the module: value in the module's precision, and what it means. A Python ``int``
    value is an integer constant (printed without a decimal point: an array size, a count, a bit)."""

    name: str
    value: float | int
    doc: str


@dataclass(frozen=True)
class TableDef:
    """A named constant array (joint limits): ``values`` in the module's precision (``None``: unbounded,
    printed as ``sign`` times a huge finite number in C and an infinity in Python)."""

    name: str
    values: tuple[float | None, ...]
    doc: str
    sign: int = 1


@dataclass(frozen=True)
class Module:
    """Everything one set of emitted files holds. ``notes``: header lines (plain text; every printer
    escapes them for its comment syntax). ``command``: the command line that regenerates the set."""

    prefix: str
    precision: str
    notes: tuple[str, ...]
    constants: tuple[ConstantDef, ...]
    tables: tuple[TableDef, ...]
    functions: tuple[Function, ...]
    command: str = ""

    def function(self, name: str) -> Function:
        for f in self.functions:
            if f.name == name:
                return f
        raise KeyError(name)

    @property
    def public(self) -> tuple[Function, ...]:
        """Functions a user calls (not helpers)."""
        return tuple(f for f in self.functions if f.kind != "helper")


def module_statuses(functions) -> list[tuple[str, int, str]]:
    """The named return values of a module's procedures, once each, in order of first use: ``(name, value,
    meaning)``. Where public functions give one name different meanings (``IK_INVALID``: ``ik_solve`` leaves ``q =
    q0``, ``ik_all`` returns count 0), the meaning names each: ``"ik_solve: ...; ik_all, ik_nearest: ..."``; helpers
    count only for names no public function uses."""
    order: dict[str, int] = {}
    meanings: dict[str, dict[str, list[str]]] = {}
    for public in (True, False):
        for f in functions:
            if (f.kind == "helper") == public:
                continue
            for name, value, meaning in f.statuses:
                if not public and name in meanings:
                    continue
                order.setdefault(name, value)
                meanings.setdefault(name, {}).setdefault(meaning, []).append(f.name)
    first = [name for f in functions for name, _, _ in f.statuses]
    out = []
    for name in dict.fromkeys(first):
        by_meaning = meanings[name]
        text = next(iter(by_meaning)) if len(by_meaning) == 1 else "; ".join(
            f"{', '.join(names)}: {meaning}" for meaning, names in by_meaning.items())
        out.append((name, order[name], text))
    return out
