"""From derivation to an optimised straight-line program: one CSE pass, ordered, counted.

A :class:`Program` is everything a backend needs to print one function and
nothing model-specific:

* ``inputs``/``outputs``: named arrays (row-major, flattened) with their symbols/expressions;
* ``pre``: assignments that compute the trigonometric arguments (``angles``);
* the trigonometric block: ``cos`` and ``sin`` of every angle, which a backend
  may evaluate as one vectorisable loop over arrays;
* ``post``: the remaining assignments, then the outputs.

Every temporary is assigned once. ``ops`` counts the arithmetic of the whole
program, as printed (see :func:`count_ops`).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Iterable, Sequence

import sympy as sp

from .derive.core import Derivation, FunctionSpec

try:  # the core of sympy.cse without its search for common sub-sums (see _cse)
    from sympy.simplify.cse_main import tree_cse as _tree_cse
except ImportError:  # pragma: no cover
    _tree_cse = None

Assignment = tuple[sp.Symbol, sp.Expr]


@dataclass(frozen=True)
class ArrayArg:
    """A function argument: name, shape, and its elements flattened row-major."""

    name: str
    shape: tuple[int, ...]
    elements: tuple[sp.Expr, ...]

    @property
    def size(self) -> int:
        """Number of elements."""
        return len(self.elements)

    @property
    def is_scalar(self) -> bool:
        """True for a single number passed by value (shape ``()``)."""
        return self.shape == ()


_COUNTED = ("add", "mul", "neg", "div", "sqrt", "cmp", "select")


@dataclass(frozen=True)
class OpCount:
    """Operation counts of a program: arithmetic by kind plus transcendental calls."""

    add: int = 0
    mul: int = 0
    neg: int = 0
    div: int = 0
    sqrt: int = 0
    cmp: int = 0
    select: int = 0
    sin: int = 0
    cos: int = 0

    @property
    def arithmetic(self) -> int:
        """Additions, subtractions, multiplications and negations."""
        return self.add + self.mul + self.neg

    def as_dict(self) -> dict[str, int]:
        """All counts by name, plus ``arithmetic``."""
        out = {k: getattr(self, k) for k in _COUNTED + ("sin", "cos")}
        out["arithmetic"] = self.arithmetic
        return out


@dataclass(frozen=True)
class Program:
    """A straight-line program for one function. See the module docstring."""

    name: str
    summary: str
    inputs: tuple[ArrayArg, ...]
    outputs: tuple[ArrayArg, ...]
    pre: tuple[Assignment, ...]
    angles: tuple[sp.Symbol, ...]
    cos: tuple[sp.Symbol, ...]
    sin: tuple[sp.Symbol, ...]
    post: tuple[Assignment, ...]
    ops: OpCount
    numbers: dict[sp.Symbol, int]
    """Position of each temporary in the derivation-wide program: the same temporary gets the
    same number (and so the same printed name) in every function."""
    constants: tuple = ()
    """The :class:`~skelarm_sym.derive.Constant` objects the program uses."""

    @property
    def temporaries(self) -> tuple[sp.Symbol, ...]:
        """Scalar temporaries (not angles), in order of first assignment."""
        angles = set(self.angles)
        seen: dict[sp.Symbol, None] = {}
        for symbol, _ in self.pre + self.post:
            if symbol not in angles:
                seen.setdefault(symbol)
        return tuple(seen)


def count_ops(expr: sp.Expr) -> Counter:
    """Count the operations of ``expr`` as a C or NumPy printer writes it.

    An ``Add`` of k terms is k-1 additions/subtractions (a negative term is a
    subtraction; one negation more when every term is negative). A ``Mul`` of k
    factors is k-1 multiplications; a coefficient -1 is a negation when it
    stands alone. ``x**2`` is one multiplication, ``x**-1`` a division,
    ``x**(1/2)`` a square root. A comparison is one ``cmp``; a ``Piecewise``
    of k pieces is k-1 ``select``.
    """
    counts: Counter = Counter()
    stack = [(sp.sympify(expr), False)]  # (expression, negation already paid for)
    while stack:
        e, negation_paid = stack.pop()
        if e.is_Atom:
            continue
        if e.is_Add:
            terms = e.args
            negative = [t.could_extract_minus_sign() for t in terms]
            counts["add"] += len(terms) - 1
            if all(negative):
                counts["neg"] += 1
            stack.extend((t, neg) for t, neg in zip(terms, negative))
        elif e.is_Mul:
            coeff, factors = e.as_coeff_mul()
            if coeff == -1:
                if not negation_paid:
                    counts["neg"] += 1
                coeff = sp.S.One
            elif coeff.is_negative and negation_paid:
                coeff = -coeff
            k = len(factors) + (0 if coeff == 1 else 1)
            counts["mul"] += max(k - 1, 0)
            stack.extend((f, False) for f in factors)
        elif e.is_Pow:
            base, exp = e.args
            if exp == 2:
                counts["mul"] += 1
            elif exp == -1:
                counts["div"] += 1
            elif exp == -2:
                counts["div"] += 1
                counts["mul"] += 1
            elif exp == sp.Rational(1, 2):
                counts["sqrt"] += 1
            elif exp == sp.Rational(-1, 2):
                counts["sqrt"] += 1
                counts["div"] += 1
            elif exp.is_Integer and exp > 2:
                counts["mul"] += int(exp) - 1
            else:
                counts["pow"] += 1
            stack.append((base, False))
        elif isinstance(e, sp.Piecewise):
            counts["select"] += len(e.args) - 1
            for value, condition in e.args:
                stack.append((value, False))
                if condition is not sp.true:
                    stack.append((condition, False))
        elif e.is_Relational:
            counts["cmp"] += 1
            stack.extend((a, False) for a in e.args)
        elif isinstance(e, (sp.sin, sp.cos)):
            counts[type(e).__name__] += 1
            stack.append((e.args[0], False))
        else:
            counts[type(e).__name__.lower()] += 1
            stack.extend((a, False) for a in e.args)
    return counts


def _needed_steps(steps: Sequence[Assignment], roots: Iterable[sp.Expr]) -> list[Assignment]:
    """The steps that ``roots`` depend on, in their original order (dead code dropped)."""
    index = {symbol: i for i, (symbol, _) in enumerate(steps)}
    keep: set[int] = set()
    todo = [s for e in roots for s in sp.sympify(e).free_symbols if s in index]
    while todo:
        i = index[todo.pop()]
        if i in keep:
            continue
        keep.add(i)
        todo.extend(s for s in steps[i][1].free_symbols if s in index)
    return [steps[i] for i in sorted(keep)]


def _cse(assignments: Sequence[Assignment], outputs: Sequence[sp.Expr], tag: str) -> tuple[list[Assignment], list[sp.Expr]]:
    """One CSE pass over all right-hand sides and outputs together; returns ordered assignments.

    The steps arrive already factored (prefix and suffix sums), so only repeated
    subtrees are worth finding: this calls ``tree_cse``, the core of ``sympy.cse``,
    without the ``opt_cse`` pre-pass that searches sums and products for common
    argument subsets. That pre-pass took two thirds of the generation time at
    n = 128 and saved one operation in two functions there. Falls back to
    ``sympy.cse`` if a SymPy version lacks ``tree_cse``.
    """
    exprs = [rhs for _, rhs in assignments] + list(outputs)
    symbols = sp.numbered_symbols(f"_cse_{tag}_", real=True)
    if _tree_cse is not None:
        replacements, reduced = _tree_cse(exprs, symbols, opt_subs={}, order="none")
    else:  # pragma: no cover - a SymPy without cse_main.tree_cse
        replacements, reduced = sp.cse(exprs, symbols=symbols, order="none")
    rep_index = {symbol: i for i, (symbol, _) in enumerate(replacements)}
    emitted: set[int] = set()
    ordered: list[Assignment] = []

    def emit_needed(expr: sp.Expr) -> None:
        todo = [s for s in expr.free_symbols if s in rep_index and rep_index[s] not in emitted]
        needed: set[int] = set()
        while todo:
            i = rep_index[todo.pop()]
            if i in needed or i in emitted:
                continue
            needed.add(i)
            todo.extend(s for s in replacements[i][1].free_symbols if s in rep_index)
        for i in sorted(needed):
            ordered.append(replacements[i])
            emitted.add(i)

    for (symbol, _), rhs in zip(assignments, reduced):
        emit_needed(rhs)
        ordered.append((symbol, rhs))
    out_exprs = reduced[len(assignments):]
    for expr in out_exprs:
        emit_needed(expr)
    return ordered, out_exprs


def _closure(assignments: Sequence[Assignment], roots: Iterable[sp.Symbol]) -> set[sp.Symbol]:
    defs = dict(assignments)
    seen: set[sp.Symbol] = set()
    todo = [r for r in roots if r in defs]
    while todo:
        s = todo.pop()
        if s in seen:
            continue
        seen.add(s)
        todo.extend(t for t in defs[s].free_symbols if t in defs)
    return seen


@dataclass(frozen=True)
class Optimised:
    """All outputs of a derivation after the one CSE pass: ordered assignments and reduced outputs.

    ``trig`` maps each cos/sin symbol to ``(kind, angle symbol)``; ``angles`` lists
    the angle symbols in order of first use.
    """

    assignments: tuple[Assignment, ...]
    outputs: dict[str, tuple[sp.Expr, ...]]
    shapes: dict[str, tuple[int, ...]]
    angles: tuple[sp.Symbol, ...]
    cos: tuple[sp.Symbol, ...]
    sin: tuple[sp.Symbol, ...]


def optimise(derivation: Derivation, outputs: Iterable[str] | None = None) -> Optimised:
    """One ``sympy.cse`` over every output of ``derivation`` (or those named in ``outputs``) together
    (deterministic names and order).

    Sines and cosines are lifted out first: each distinct argument becomes an
    angle slot, so that backends can evaluate all of them in one loop.
    """
    wanted = None if outputs is None else set(outputs)
    names = [name for name in derivation.compact if wanted is None or name in wanted]
    matrices = [derivation.compact[name] for name in names]
    out_exprs = [e for m in matrices for e in m]
    steps, out_exprs = _name_trig(_needed_steps(derivation.steps, out_exprs), out_exprs)

    angle_of: dict[sp.Expr, int] = {}
    angle_args: list[sp.Expr] = []
    trig_alias: dict[sp.Symbol, tuple[str, int]] = {}
    plain: list[Assignment] = []
    for symbol, rhs in steps:
        if isinstance(rhs, (sp.sin, sp.cos)):
            arg = rhs.args[0]
            if arg not in angle_of:
                angle_of[arg] = len(angle_args)
                angle_args.append(arg)
            trig_alias[symbol] = (type(rhs).__name__, angle_of[arg])
        else:
            plain.append((symbol, rhs))
    count = len(angle_args)
    defined = {s for s, _ in plain}
    # An argument that is already a named step becomes the angle slot itself; others get one.
    angles = tuple(arg if arg in defined else sp.Symbol(f"_angle_{k}", real=True) for k, arg in enumerate(angle_args))
    cos_syms = tuple(sp.Symbol(f"_cos_{k}", real=True) for k in range(count))
    sin_syms = tuple(sp.Symbol(f"_sin_{k}", real=True) for k in range(count))
    rename = {s: (cos_syms if kind == "cos" else sin_syms)[k] for s, (kind, k) in trig_alias.items()}
    plain = [(s, rhs.xreplace(rename)) for s, rhs in plain]
    plain += [(angles[k], arg) for k, arg in enumerate(angle_args) if angles[k] is not arg]
    out_exprs = [e.xreplace(rename) for e in out_exprs]

    ordered, reduced = _cse(_dependency_order(plain), out_exprs, "x")
    outputs: dict[str, tuple[sp.Expr, ...]] = {}
    shapes: dict[str, tuple[int, ...]] = {}
    offset = 0
    for name, matrix in zip(names, matrices):
        size = matrix.rows * matrix.cols
        shapes[name] = derivation.shapes[name]
        outputs[name] = tuple(reduced[offset:offset + size])
        offset += size
    return Optimised(tuple(ordered), outputs, shapes, angles, cos_syms, sin_syms)


def _name_trig(steps: list[Assignment], outputs: list[sp.Expr]) -> tuple[list[Assignment], list[sp.Expr]]:
    """Give every sin/cos inside a larger expression a step of its own, so all reach the trig block."""
    named = {rhs: symbol for symbol, rhs in steps if isinstance(rhs, (sp.sin, sp.cos))}
    inner = set()
    for expr in [rhs for _, rhs in steps] + outputs:
        inner |= {t for t in expr.atoms(sp.sin, sp.cos) if t not in named and t is not expr}
    if not inner:
        return steps, outputs
    extra = {t: sp.Symbol(f"_trig_{k}", real=True) for k, t in enumerate(sorted(inner, key=sp.default_sort_key))}
    swap = {t: s for t, s in extra.items()}
    new_steps = [(s, t) for t, s in extra.items()] + [(sym, rhs if rhs in named else rhs.xreplace(swap)) for sym, rhs in steps]
    return new_steps, [e.xreplace(swap) for e in outputs]


def build_program(derivation: Derivation, spec: FunctionSpec, optimised: Optimised | None = None) -> Program:
    """The straight-line program of function ``spec``: what its outputs need, in order, counted."""
    opt = optimised if optimised is not None else optimise(derivation)
    inputs = tuple(
        ArrayArg(name, () if name in derivation.scalars else (len(derivation.inputs[name]),), tuple(derivation.inputs[name]))
        for name in spec.inputs
        if name in derivation.inputs
    )
    outputs = tuple(ArrayArg(name, opt.shapes[name], opt.outputs[name]) for name in spec.outputs)
    out_exprs = [e for arg in outputs for e in arg.elements]
    needed = _closure(opt.assignments, {s for e in out_exprs for s in e.free_symbols})
    used = [a for a in opt.assignments if a[0] in needed]
    referenced = {s for _, rhs in used for s in rhs.free_symbols} | {s for e in out_exprs for s in e.free_symbols}
    slots = [k for k in range(len(opt.angles)) if opt.cos[k] in referenced or opt.sin[k] in referenced]
    angles = tuple(opt.angles[k] for k in slots)
    angle_deps = _closure(opt.assignments, angles)
    needed |= angle_deps
    used = [a for a in opt.assignments if a[0] in needed]

    pre = [a for a in used if a[0] in angle_deps]
    rest = [a for a in used if a[0] not in angle_deps]
    after = _closure(used, {s for _, rhs in rest for s in rhs.free_symbols} | {s for e in out_exprs for s in e.free_symbols})
    angle_set = set(angles)
    post = [a for a in pre if a[0] in after and a[0] not in angle_set] + rest

    total: Counter = Counter()
    for _, rhs in pre + post:
        total.update(count_ops(rhs))
    for e in out_exprs:
        total.update(count_ops(e))
    known = {k: total.pop(k, 0) for k in _COUNTED}
    if total:
        raise ValueError(f"internal error: unsupported operations {dict(total)} in {spec.name}")
    ops = OpCount(**known, sin=len(slots), cos=len(slots))
    return Program(
        spec.name, spec.summary, inputs, outputs, tuple(pre), angles,
        tuple(opt.cos[k] for k in slots), tuple(opt.sin[k] for k in slots), tuple(post), ops,
        {symbol: i for i, (symbol, _) in enumerate(opt.assignments)},
        tuple(c for c in derivation.constants if c.symbol in referenced_all(pre + post, out_exprs)),
    )


def referenced_all(assignments: Sequence[Assignment], exprs: Sequence[sp.Expr]) -> set[sp.Symbol]:
    """Every symbol the right-hand sides of ``assignments`` and ``exprs`` mention."""
    return {s for _, rhs in assignments for s in rhs.free_symbols} | {s for e in exprs for s in e.free_symbols}


def _dependency_order(assignments: Sequence[Assignment]) -> list[Assignment]:
    """Stable topological order: each assignment after the ones it uses."""
    defs = {s: i for i, (s, _) in enumerate(assignments)}
    placed: set[int] = set()
    order: list[Assignment] = []
    for start in range(len(assignments)):
        stack = [(start, False)]
        while stack:
            i, expanded = stack.pop()
            if i in placed:
                continue
            if expanded:
                placed.add(i)
                order.append(assignments[i])
                continue
            stack.append((i, True))
            deps = sorted(defs[s] for s in assignments[i][1].free_symbols if s in defs and defs[s] not in placed)
            stack.extend((d, False) for d in reversed(deps))
    return order


def build_programs(derivation: Derivation, names: Sequence[str] | None = None) -> list[Program]:
    """Programs for the derivation's functions (all, or those in ``names``), in declaration order."""
    specs = [f for f in derivation.functions if names is None or f.name in names]
    opt = optimise(derivation, None if names is None else {o for spec in specs for o in spec.outputs})
    return [build_program(derivation, spec, opt) for spec in specs]
