"""SymPy -> IR, once: trigonometric lifting, one CSE pass, ordering, then IR expressions.

:func:`lower` takes a :class:`~skelarm_sym.derive.core.Derivation` (named steps and compact outputs,
written with SymPy) and the names of the functions to emit, and returns one straight-line IR
:class:`~skelarm_sym.ir.nodes.Function` per function. Every temporary is assigned once and named
after its position in the derivation-wide program (``t17``), so the same quantity has the same
name in every function. Sines and cosines are lifted into :class:`~skelarm_sym.ir.nodes.TrigBlock`
statements: each distinct argument becomes an angle slot; angles that depend on the result of an
earlier block (closed-form solutions) go to a later block.

Printing rules live in the printers; here SymPy's numbers become :class:`Const` (``pi`` too, as a
double: no ``M_PI`` reaches any output), ``x**2`` a product, ``x**-1`` a guarded division unless
its denominator is a positive number or an input (a division by an input the header requires
positive, the track of the differential drive), ``Piecewise`` a nest of :class:`Select`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

import sympy as sp

from ..derive.core import ARGUMENT_ROLES, Derivation, FunctionSpec
from .count import count_ops
from .nodes import (
    Add, Argument, Call1, Call2, Compare, Const, Div, Elem, Expr, Function, Let, Logic, Mul, NamedConst, Neg, Not,
    Role, Select, Store, TrigBlock, Type, Var,
)

try:  # the core of sympy.cse without its search for common sub-sums
    from sympy.simplify.cse_main import tree_cse as _tree_cse
except ImportError:  # pragma: no cover
    _tree_cse = None

Assignment = tuple[sp.Symbol, sp.Expr]


# -- the SymPy side: one optimised program for all functions -----------------------------------------

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


def _cse(assignments: Sequence[Assignment], outputs: Sequence[sp.Expr]) -> tuple[list[Assignment], list[sp.Expr]]:
    """One CSE pass over all right-hand sides and outputs together; returns ordered assignments.

    The steps arrive already factored (prefix and suffix sums), so only repeated subtrees are worth
    finding: ``tree_cse`` (the core of ``sympy.cse``) without the ``opt_cse`` pre-pass that searches
    sums and products for common argument subsets (two thirds of the generation time at n = 128 for
    one operation saved in two functions)."""
    exprs = [rhs for _, rhs in assignments] + list(outputs)
    symbols = sp.numbered_symbols("_cse_x_", real=True)
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


def _name_trig(steps: list[Assignment], outputs: list[sp.Expr]) -> tuple[list[Assignment], list[sp.Expr]]:
    """Give every sin/cos inside a larger expression a step of its own, so all reach a trig block."""
    named = {rhs: symbol for symbol, rhs in steps if isinstance(rhs, (sp.sin, sp.cos))}
    inner = set()
    for expr in [rhs for _, rhs in steps] + outputs:
        inner |= {t for t in expr.atoms(sp.sin, sp.cos) if t not in named and t is not expr}
    if not inner:
        return steps, outputs
    extra = {t: sp.Symbol(f"_trig_{k}", real=True) for k, t in enumerate(sorted(inner, key=sp.default_sort_key))}
    new_steps = [(s, t) for t, s in extra.items()] + [(sym, rhs if rhs in named else rhs.xreplace(extra)) for sym, rhs in steps]
    return new_steps, [e.xreplace(extra) for e in outputs]


@dataclass(frozen=True)
class Optimised:
    """Every wanted output of a derivation after the one CSE pass.

    ``assignments``: ordered ``(symbol, rhs)``; ``outputs``: name -> reduced elements; ``angles``,
    ``cos``, ``sin``: the trig slots (angle symbol, its cosine and sine symbols)."""

    assignments: tuple[Assignment, ...]
    outputs: dict[str, tuple[sp.Expr, ...]]
    angles: tuple[sp.Symbol, ...]
    cos: tuple[sp.Symbol, ...]
    sin: tuple[sp.Symbol, ...]

    @property
    def numbers(self) -> dict[sp.Symbol, int]:
        return {symbol: i for i, (symbol, _) in enumerate(self.assignments)}


def optimise(derivation: Derivation, outputs: Iterable[str] | None = None) -> Optimised:
    """One CSE over the outputs of ``derivation`` (all, or those named), sines and cosines lifted first."""
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
    angles = tuple(arg if arg in defined else sp.Symbol(f"_angle_{k}", real=True) for k, arg in enumerate(angle_args))
    cos_syms = tuple(sp.Symbol(f"_cos_{k}", real=True) for k in range(count))
    sin_syms = tuple(sp.Symbol(f"_sin_{k}", real=True) for k in range(count))
    rename = {s: (cos_syms if kind == "cos" else sin_syms)[k] for s, (kind, k) in trig_alias.items()}
    plain = [(s, rhs.xreplace(rename)) for s, rhs in plain]
    plain += [(angles[k], arg.xreplace(rename)) for k, arg in enumerate(angle_args) if angles[k] is not arg]
    out_exprs = [e.xreplace(rename) for e in out_exprs]

    ordered, reduced = _cse(_dependency_order(plain), out_exprs)
    result: dict[str, tuple[sp.Expr, ...]] = {}
    offset = 0
    for name, matrix in zip(names, matrices):
        size = matrix.rows * matrix.cols
        result[name] = tuple(reduced[offset:offset + size])
        offset += size
    return Optimised(tuple(ordered), result, angles, cos_syms, sin_syms)


# -- SymPy expressions -> IR expressions --------------------------------------------------------------

class Converter:
    """SymPy -> IR for one function: ``names`` maps each free symbol to its IR expression. Results are
    memoised per SymPy node (functions of one derivation share most subtrees).

    ``plain_denominators``: symbols a division by which needs no guard (inputs the header requires
    positive)."""

    def __init__(self, names: dict[sp.Symbol, Expr], plain_denominators: frozenset = frozenset()) -> None:
        self.names = names
        self.plain = plain_denominators
        self._memo: dict[sp.Basic, Expr] = {}

    def __call__(self, expr: sp.Basic) -> Expr:
        memo = self._memo.get(expr)
        if memo is None:
            memo = self._memo[expr] = self._convert(expr)
        return memo

    # Each SymPy kind ------------------------------------------------------------------------------
    def _convert(self, e: sp.Basic) -> Expr:
        if e.is_Symbol:
            try:
                return self.names[e]
            except KeyError:
                raise ValueError(f"internal error: symbol {e} has no storage") from None
        if e.is_Number or isinstance(e, sp.NumberSymbol):
            return Const(float(e))
        if e is sp.true or e is sp.false:
            return Const(bool(e), Type.BOOL)
        if e.is_Add:
            return self._add(e)
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(e)
        if isinstance(e, sp.Piecewise):
            *pieces, (last, last_cond) = e.args
            if last_cond is not sp.true:
                raise ValueError("internal error: Piecewise needs a final True branch")
            out = self(last)
            for value, cond in reversed(pieces):
                out = Select(self(cond), self(value), out)
            return out
        if e.is_Relational:
            op = {sp.StrictLessThan: "<", sp.LessThan: "<=", sp.StrictGreaterThan: ">", sp.GreaterThan: ">=",
                  sp.Equality: "==", sp.Unequality: "!="}[type(e)]
            return Compare(op, self(e.lhs), self(e.rhs))
        if isinstance(e, sp.And):
            return Logic("and", tuple(self(a) for a in sorted(e.args, key=sp.default_sort_key)))
        if isinstance(e, sp.Or):
            return Logic("or", tuple(self(a) for a in sorted(e.args, key=sp.default_sort_key)))
        if isinstance(e, sp.Not):
            return Not(self(e.args[0]))
        if isinstance(e, (sp.sin, sp.cos)):
            return Call1(type(e).__name__, self(e.args[0]))
        if isinstance(e, sp.Abs):
            return Call1("fabs", self(e.args[0]))
        if isinstance(e, sp.floor):
            return Call1("floor", self(e.args[0]))
        if isinstance(e, sp.atan2):
            return Call2("atan2", self(e.args[0]), self(e.args[1]))
        if isinstance(e, (sp.Min, sp.Max)):
            name = "fmin" if isinstance(e, sp.Min) else "fmax"
            args = [self(a) for a in sorted(e.args, key=sp.default_sort_key)]
            out = args[0]
            for a in args[1:]:
                out = Call2(name, out, a)
            return out
        raise ValueError(f"internal error: no IR for {type(e).__name__} ({e})")

    def _add(self, e: sp.Add) -> Expr:
        terms = sorted(e.args, key=lambda t: (t.could_extract_minus_sign(), sp.default_sort_key(t)))
        out = []
        for t in terms:
            out.append(Neg(self(-t)) if t.could_extract_minus_sign() else self(t))
        return Add(tuple(out))

    def _mul(self, e: sp.Mul) -> Expr:
        coeff, factors = e.as_coeff_mul()
        if coeff == -1:
            return Neg(self(sp.Mul(*factors)))
        factors = list(factors)
        den = [f for f in factors if f.is_Pow and f.exp.is_Rational and f.exp.is_negative]
        num = [f for f in factors if f not in den]
        if den:
            numerator = self(sp.Mul(coeff, *num)) if (num or coeff != 1) else Const(float(coeff))
            denominator = sp.Mul(*[sp.Pow(f.base, -f.exp) for f in den])
            return Div(numerator, self(denominator), self._guarded(denominator))
        parts = ([Const(float(coeff))] if coeff != 1 else []) + [self(f) for f in _ordered_factors(factors)]
        return parts[0] if len(parts) == 1 else Mul(tuple(parts))

    def _pow(self, e: sp.Pow) -> Expr:
        base, exp = e.args
        if exp.is_Rational and exp.is_negative:
            return Div(Const(1.0), self(sp.Pow(base, -exp)), self._guarded(sp.Pow(base, -exp)))
        if exp == sp.Rational(1, 2):
            return Call1("sqrt", self(base))
        if exp.is_Integer and exp >= 2:
            b = self(base)
            return Mul((b,) * int(exp))
        raise ValueError(f"internal error: no IR for the power {e}")

    def _guarded(self, den: sp.Expr) -> bool:
        return not ((den.is_Number and den.is_positive) or den in self.plain)


def _ordered_factors(factors: Sequence[sp.Expr]) -> list[sp.Expr]:
    return sorted(factors, key=sp.default_sort_key)


# -- functions --------------------------------------------------------------------------------------

ROLES = {0: Role.STATE, 1: Role.DATA, 2: Role.PARAMETER, 3: Role.SCALAR}


def arguments(derivation: Derivation, spec: FunctionSpec) -> tuple[Argument, ...]:
    """The IR arguments of ``spec``: its inputs (role, shape, domain, batching) then its outputs."""
    args = []
    for name in spec.inputs:
        if name not in derivation.inputs:
            continue
        scalar = name in derivation.scalars
        args.append(Argument(
            name, ROLES[ARGUMENT_ROLES[name]], () if scalar else (len(derivation.inputs[name]),),
            domain=derivation.domains.get(name, ""), batched=name not in derivation.parameters,
        ))
    for name in spec.outputs:
        args.append(Argument(name, Role.OUTPUT, tuple(derivation.shapes[name])))
    return tuple(args)


def _levels(opt: Optimised, slots: Sequence[int]) -> dict[int, int]:
    """The trig block of each angle slot: 0 when its angle needs no sine or cosine, else one more
    than the latest block it needs."""
    defs = dict(opt.assignments)
    trig_slot = {s: k for k, s in enumerate(opt.cos)} | {s: k for k, s in enumerate(opt.sin)}
    level: dict[int, int] = {}
    memo: dict[sp.Symbol, int] = {}

    def depth(symbol: sp.Symbol) -> int:  # -1: no trig below
        if symbol in memo:
            return memo[symbol]
        memo[symbol] = -1
        if symbol in trig_slot:
            memo[symbol] = slot_level(trig_slot[symbol])
            return memo[symbol]
        rhs = defs.get(symbol)
        best = -1
        if rhs is not None:
            for s in rhs.free_symbols:
                best = max(best, depth(s))
        memo[symbol] = best
        return best

    def slot_level(k: int) -> int:
        if k not in level:
            level[k] = depth(opt.angles[k]) + 1
        return level[k]

    for k in slots:
        slot_level(k)
    return level


def lower_function(derivation: Derivation, spec: FunctionSpec, opt: Optimised) -> Function:
    """The straight-line IR function of ``spec``: what its outputs need, in order, counted."""
    args = arguments(derivation, spec)
    out_exprs = [(name, i, e) for name in spec.outputs for i, e in enumerate(opt.outputs[name])]
    roots = {s for _, _, e in out_exprs for s in e.free_symbols}
    trig_of = {s: k for k, s in enumerate(opt.cos)} | {s: k for k, s in enumerate(opt.sin)}
    defs = dict(opt.assignments)
    # what the outputs need, and the angle slots used; an angle may need sines and cosines of
    # other angles in turn (closed-form solutions), so repeat until nothing new is found
    needed: set[sp.Symbol] = set()
    slots: set[int] = set()
    frontier = set(roots)
    while frontier:
        new = _closure(opt.assignments, frontier) - needed
        needed |= new
        refs = {t for s in new for t in defs[s].free_symbols} | frontier
        frontier = set()
        for t in refs:
            if t in trig_of and trig_of[t] not in slots:
                slots.add(trig_of[t])
                frontier.add(opt.angles[trig_of[t]])
    ordered_slots = sorted(slots)
    level = _levels(opt, ordered_slots)

    names: dict[sp.Symbol, Expr] = {}
    plain: set[sp.Symbol] = set()
    for name in spec.inputs:
        if name not in derivation.inputs:
            continue
        symbols = derivation.inputs[name]
        if name in derivation.scalars:
            names[symbols[0]] = Var(name)
        else:
            for i, s in enumerate(symbols):
                names[s] = Elem(name, Const(i, Type.INT))
        if derivation.domains.get(name) == "positive":
            plain |= set(symbols)
    for c in derivation.constants:
        names[c.symbol] = NamedConst(c.name)
    numbers = opt.numbers
    angle_vars = {opt.angles[k]: Var(f"a{k}") for k in ordered_slots}
    for k in ordered_slots:
        names[opt.cos[k]] = Var(f"c{k}")
        names[opt.sin[k]] = Var(f"s{k}")
    for symbol in needed:
        names[symbol] = angle_vars.get(symbol) or Var(f"t{numbers[symbol]}", Type.BOOL if defs[symbol].is_Relational or isinstance(defs[symbol], (sp.And, sp.Or, sp.Not)) else Type.REAL)
    convert = Converter(names, frozenset(plain))

    # statements in program order; each trig block right after the last assignment its angles need
    body: list = []
    blocks = sorted(set(level.values()))
    block_of_symbol: dict[sp.Symbol, int] = {}
    for k in ordered_slots:
        for s in _closure(opt.assignments, [opt.angles[k]]) | ({opt.angles[k]} & set(defs)):
            block_of_symbol[s] = min(block_of_symbol.get(s, 99), level[k])
    assigned = [(s, rhs) for s, rhs in opt.assignments if s in needed]
    for b in blocks:
        for s, rhs in assigned:
            if block_of_symbol.get(s) == b:
                body.append(Let(names[s], convert(rhs)))
        ks = [k for k in ordered_slots if level[k] == b]
        for k in ks:
            if opt.angles[k] not in defs:  # an angle that is an input itself
                raise ValueError("internal error: angle without assignment")
        body.append(TrigBlock(tuple(angle_vars[opt.angles[k]] for k in ks), tuple(Var(f"c{k}") for k in ks),
                              tuple(Var(f"s{k}") for k in ks)))
    for s, rhs in assigned:
        if s not in block_of_symbol:
            body.append(Let(names[s], convert(rhs)))
    for name, i, e in out_exprs:
        body.append(Store(name, i, convert(e)))
    body_t = tuple(body)
    return Function(spec.name, spec.summary, args, body_t, kind="straight", ops=count_ops(body_t))


def lower(derivation: Derivation, names: Sequence[str] | None = None) -> list[Function]:
    """IR functions for the derivation's functions (all, or those in ``names``), in declaration order."""
    specs = [f for f in derivation.functions if names is None or f.name in names]
    opt = optimise(derivation, None if names is None else {o for spec in specs for o in spec.outputs})
    return [lower_function(derivation, spec, opt) for spec in specs]
