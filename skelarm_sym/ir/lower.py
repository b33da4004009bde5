"""SymPy -> IR, once: trigonometric lifting, one CSE pass, ordering, then IR expressions.

:func:`lower` takes a :class:`~skelarm_sym.derive.core.Derivation` (named steps and compact outputs,
written with SymPy) and the names of the functions to emit, and returns one straight-line IR
:class:`~skelarm_sym.ir.nodes.Function` per function. Every temporary is assigned once and named
after its position in the derivation-wide program (``t17``; the angle of trigonometric slot k is
``a{k}``), so the same quantity has the same name in every function. Sines and cosines are lifted into
:class:`~skelarm_sym.ir.nodes.TrigBlock` statements: each distinct argument becomes an angle slot;
angles that depend on the result of an earlier block (closed-form solutions) go to a later block.

Printing rules live in the printers; here SymPy's numbers become :class:`Const` (``pi`` too, as a
double: no ``M_PI`` reaches any output), ``x**2`` a product, ``x**-1`` a guarded division unless
its denominator is a positive number or an input (a division by an input the header requires
positive, the track of the differential drive), ``Piecewise`` a nest of :class:`Select`.

Speed (the whole ``generate`` command is meant to take about a second): the CSE is SymPy's
``tree_cse`` decision (a subtree seen twice is computed once) without its rebuild of every
expression. The repeated subtrees are found in one walk, numbered in a second, and the conversion to
IR reads the original SymPy trees, returning a temporary's variable where it meets a repeated
subtree. Sums and products keep SymPy's canonical argument order (positive terms first), which is
deterministic and needs no sort. Dependencies are integer graphs computed once for all functions,
and one memoised converter serves every function of the derivation.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Iterable, Sequence

import sympy as sp
from sympy.utilities.iterables import iterable as _sympy_iterable

from ..derive.core import ARGUMENT_ROLES, Derivation, FunctionSpec
from .constants import fold_constants
from .count import count_ops
from .factors import factor_sums
from .products import reuse_products
from .signs import settle_signs
from .unread import drop_unread
from .nodes import (
    LONG_SUM, Add, Argument, Call1, Call2, Compare, Const, Div, Elem, Expr, Function, Let, Logic, Mul, NamedConst, Neg, Not,
    Role, Select, Store, TrigBlock, Type, Var, take_sign,
)

Assignment = tuple[sp.Symbol, sp.Expr]


# -- the SymPy side: one program for all functions ----------------------------------------------------

def _symbols(e: sp.Basic) -> set[sp.Symbol]:
    """The free symbols of ``e`` (a plain walk: faster than SymPy's unions, and than memoising them)."""
    found: set[sp.Symbol] = set()
    stack = [e]
    while stack:
        x = stack.pop()
        if x.is_Symbol:
            found.add(x)
        else:
            stack.extend(x.args)
    return found


def _needed_steps(steps: Sequence[Assignment], roots: Iterable[sp.Expr], symbols=_symbols) -> list[Assignment]:
    """The steps that ``roots`` depend on, in their original order (dead code dropped)."""
    index = {symbol: i for i, (symbol, _) in enumerate(steps)}
    keep: set[int] = set()
    todo = [s for e in roots for s in symbols(sp.sympify(e)) if s in index]
    while todo:
        i = index[todo.pop()]
        if i in keep:
            continue
        keep.add(i)
        todo.extend(s for s in symbols(steps[i][1]) if s in index)
    return [steps[i] for i in sorted(keep)]


def _dependency_order(assignments: Sequence[Assignment], symbols=_symbols) -> list[Assignment]:
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
            deps = sorted(defs[s] for s in symbols(assignments[i][1]) if s in defs and defs[s] not in placed)
            stack.extend((d, False) for d in reversed(deps))
    return order


def _trig_atoms(expr: sp.Basic) -> set[sp.Basic]:
    """``expr.atoms(sp.sin, sp.cos)``, walked without SymPy's generator."""
    found: set[sp.Basic] = set()
    stack = [expr]
    while stack:
        e = stack.pop()
        args = e.args
        if args:
            if isinstance(e, (sp.sin, sp.cos)):
                found.add(e)
            stack.extend(args)
    return found


def _name_trig(steps: list[Assignment], outputs: list[sp.Expr]) -> tuple[list[Assignment], list[sp.Expr]]:
    """Give every sin/cos inside a larger expression a step of its own, so all reach a trig block."""
    named = {rhs: symbol for symbol, rhs in steps if isinstance(rhs, (sp.sin, sp.cos))}
    inner = set()
    for expr in [rhs for _, rhs in steps] + outputs:
        inner |= {t for t in _trig_atoms(expr) if t not in named and t is not expr}
    if not inner:
        return steps, outputs
    extra = {t: sp.Symbol(f"_trig_{k}", real=True) for k, t in enumerate(sorted(inner, key=sp.default_sort_key))}
    new_steps = [(s, t) for t, s in extra.items()] + [(sym, rhs if rhs in named else rhs.xreplace(extra)) for sym, rhs in steps]
    return new_steps, [e.xreplace(extra) for e in outputs]


_ITERABLE: dict[type, bool] = {}


def _is_container(e: sp.Basic) -> bool:
    """Whether ``tree_cse`` walks ``e`` as a container (a ``Tuple``, a Piecewise's ``ExprCondPair``)
    rather than as a subexpression it may eliminate."""
    t = type(e)
    known = _ITERABLE.get(t)
    if known is None:
        known = _ITERABLE[t] = bool(_sympy_iterable(e))
    return known


def _repeated(exprs: Sequence[sp.Basic]) -> set[sp.Basic]:
    """The subexpressions ``sympy.cse``'s ``tree_cse`` eliminates: compound nodes met a second time
    in a walk that does not descend into a node it has met before."""
    seen: set[sp.Basic] = set()
    repeated: set[sp.Basic] = set()
    stack = list(reversed(exprs))
    while stack:
        e = stack.pop()
        if not isinstance(e, sp.Basic) or e.is_Atom:
            continue
        if not _is_container(e):
            if e in seen:
                repeated.add(e)
                continue
            seen.add(e)
        stack.extend(reversed(e.args))
    return repeated


@dataclass
class Entry:
    """One assignment of the derivation-wide program: a step (``symbol = expr``) or a temporary of the
    CSE (``expr`` a repeated subtree). ``deps``: the entries its value reads; ``slots``: the trigonometric
    slots whose sine or cosine it reads."""

    expr: sp.Basic
    temp: bool
    symbol: sp.Symbol | None = None
    deps: tuple[int, ...] = ()
    slots: tuple[int, ...] = ()
    boolean: bool = False


@dataclass
class Program:
    """Every wanted output of a derivation after the one CSE pass, as integer graphs.

    ``entries``: the assignments in program order; ``outputs``: name -> per element ``(expr, deps,
    slots)``; ``angles``: the entry computing each trig slot's angle; ``cos``/``sin``: the symbols
    standing for each slot's cosine and sine; ``temps``: repeated subtree -> entry."""

    entries: list[Entry]
    outputs: dict[str, tuple[tuple[sp.Basic, tuple[int, ...], tuple[int, ...]], ...]]
    angles: tuple[int, ...]
    cos: tuple[sp.Symbol, ...]
    sin: tuple[sp.Symbol, ...]
    temps: dict[sp.Basic, int]
    _levels: dict[int, int] | None = None
    _depth: dict[int, int] | None = None

    def level(self, slot: int) -> int:
        """The trig block of ``slot``: 0 when its angle needs no sine or cosine, else one more than the
        latest block it needs."""
        if self._levels is None:
            self._levels, self._depth = {}, {}
        levels = self._levels
        if slot in levels:
            return levels[slot]
        depth = self._depth  # entry -> the latest block below it (-1: none), kept for the next slots
        # iterative depth-first: entry -> max level of the slots below it (-1: none)
        stack: list[tuple[str, int, bool]] = [("slot", slot, False)]
        while stack:
            kind, i, expanded = stack.pop()
            if kind == "slot":
                if i in levels:
                    continue
                a = self.angles[i]
                if expanded:
                    levels[i] = depth[a] + 1
                    continue
                if a in depth:
                    levels[i] = depth[a] + 1
                    continue
                stack.append(("slot", i, True))
                stack.append(("entry", a, False))
                continue
            if i in depth and not expanded:
                continue
            e = self.entries[i]
            if expanded:
                best = -1
                for d in e.deps:
                    best = max(best, depth[d])
                for k in e.slots:
                    best = max(best, levels[k])
                depth[i] = best
                continue
            depth[i] = -1  # a guard against cycles, as the recursion it replaces had
            stack.append(("entry", i, True))
            stack.extend(("entry", d, False) for d in e.deps if d not in depth)
            stack.extend(("slot", k, False) for k in e.slots if k not in levels)
        return levels[slot]


def optimise(derivation: Derivation, outputs: Iterable[str] | None = None) -> Program:
    """One CSE over the outputs of ``derivation`` (all, or those named), sines and cosines lifted first."""
    wanted = None if outputs is None else set(outputs)
    names = [name for name in derivation.compact if wanted is None or name in wanted]
    matrices = [derivation.compact[name] for name in names]
    out_exprs = [sp.sympify(e) for m in matrices for e in m]
    steps, out_exprs = _name_trig(_needed_steps(derivation.steps, out_exprs), out_exprs)
    plain, out_exprs, angle_syms, cos_t, sin_t = _trig_slots(steps, out_exprs)

    # the CSE: which subtrees repeat, then (walking as tree_cse's rebuild does) their numbering and every
    # expression's direct dependencies
    cse = _CseWalk(_repeated([rhs for _, rhs in plain] + out_exprs))
    step_refs = [cse.walk(rhs) for _, rhs in plain]
    out_refs = [cse.walk(e) for e in out_exprs]
    order = _program_order(step_refs, out_refs, cse.temp_refs)

    position_of_temp = {k: p for p, (is_temp, k) in enumerate(order) if is_temp}
    position_of_symbol = {plain[i][0]: p for p, (is_temp, i) in enumerate(order) if not is_temp}
    slot_of = {s: k for k, s in enumerate(cos_t)} | {s: k for k, s in enumerate(sin_t)}

    def resolve(refs: tuple[set, set]) -> tuple[tuple[int, ...], tuple[int, ...]]:
        temps, syms = refs
        deps = {position_of_temp[k] for k in temps}
        slots = set()
        for s in syms:
            p = position_of_symbol.get(s)
            if p is not None:
                deps.add(p)
            else:
                k = slot_of.get(s)
                if k is not None:
                    slots.add(k)
        return tuple(sorted(deps)), tuple(sorted(slots))

    entries: list[Entry] = []
    for is_temp, i in order:
        if is_temp:
            expr = cse.temp_nodes[i]
            deps, slots = resolve(cse.temp_refs[i])
            entries.append(Entry(expr, True, None, deps, slots, _is_boolean(expr)))
        else:
            symbol, rhs = plain[i]
            deps, slots = resolve(step_refs[i])
            boolean = _is_boolean(rhs) and not (rhs in cse.repeated and not _is_container(rhs))
            entries.append(Entry(rhs, False, symbol, deps, slots, boolean))
    result: dict[str, tuple] = {}
    offset = 0
    for name, matrix in zip(names, matrices):
        size = matrix.rows * matrix.cols
        result[name] = tuple((out_exprs[j], *resolve(out_refs[j])) for j in range(offset, offset + size))
        offset += size
    angles = tuple(position_of_symbol[s] for s in angle_syms)
    temps = {node: position_of_temp[k] for node, k in cse.temp_index.items()}
    return Program(entries, result, angles, cos_t, sin_t, temps)


def _trig_slots(steps: list[Assignment], out_exprs: list[sp.Expr]):
    """The trig slots: one per distinct argument; the first step naming its cosine (sine) stands for it,
    and later steps naming the same value are renamed to that one.

    Returns ``(plain, out_exprs, angle_syms, cos_t, sin_t)``: the other steps (plus one per angle that no
    step names) in dependency order, the outputs renamed, and per slot its angle, cosine and sine symbols."""
    angle_of: dict[sp.Expr, int] = {}
    angle_args: list[sp.Expr] = []
    cos_syms: list[sp.Symbol | None] = []
    sin_syms: list[sp.Symbol | None] = []
    rename: dict[sp.Symbol, sp.Symbol] = {}
    plain: list[Assignment] = []
    for symbol, rhs in steps:
        if isinstance(rhs, (sp.sin, sp.cos)):
            arg = rhs.args[0]
            k = angle_of.get(arg)
            if k is None:
                k = angle_of[arg] = len(angle_args)
                angle_args.append(arg)
                cos_syms.append(None)
                sin_syms.append(None)
            slots = cos_syms if isinstance(rhs, sp.cos) else sin_syms
            if slots[k] is None:
                slots[k] = symbol
            else:
                rename[symbol] = slots[k]
        else:
            plain.append((symbol, rhs))
    cos_t = tuple(c if c is not None else sp.Symbol(f"_cos_{k}", real=True) for k, c in enumerate(cos_syms))
    sin_t = tuple(s if s is not None else sp.Symbol(f"_sin_{k}", real=True) for k, s in enumerate(sin_syms))
    defined = {s for s, _ in plain}
    angle_syms = tuple(arg if arg in defined else sp.Symbol(f"_angle_{k}", real=True) for k, arg in enumerate(angle_args))
    if rename:
        plain = [(s, rhs.xreplace(rename)) for s, rhs in plain]
        out_exprs = [e.xreplace(rename) for e in out_exprs]
    plain += [(angle_syms[k], arg.xreplace(rename) if rename else arg)
              for k, arg in enumerate(angle_args) if angle_syms[k] is not arg]
    return _dependency_order(plain), out_exprs, angle_syms, cos_t, sin_t


class _CseWalk:
    """Numbers the repeated subtrees (the temporaries) in the order tree_cse's rebuild meets them and
    records, per walked expression and per temporary, the temporaries and symbols it reads directly."""

    def __init__(self, repeated) -> None:
        self.repeated = repeated
        self.temp_index: dict[sp.Basic, int] = {}
        self.temp_nodes: list[sp.Basic] = []
        self.temp_refs: list[tuple[set, set]] = []

    def walk(self, root: sp.Basic) -> tuple[set, set]:
        """``(temporaries, symbols)`` that ``root`` reads directly."""
        temps: set[int] = set()
        syms: set[sp.Symbol] = set()
        stack = [root]
        while stack:
            e = stack.pop()
            if not isinstance(e, sp.Basic):
                continue
            if e.is_Symbol:
                syms.add(e)
                continue
            if not e.args:
                continue
            if e in self.repeated and not _is_container(e):
                k = self.temp_index.get(e)
                if k is None:
                    refs = self._walk_args(e)
                    k = self.temp_index[e] = len(self.temp_nodes)
                    self.temp_nodes.append(e)
                    self.temp_refs.append(refs)
                temps.add(k)
                continue
            stack.extend(reversed(e.args))
        return temps, syms

    def _walk_args(self, e: sp.Basic) -> tuple[set, set]:
        temps: set[int] = set()
        syms: set[sp.Symbol] = set()
        for a in e.args:
            t, s = self.walk(a)
            temps |= t
            syms |= s
        return temps, syms


def _program_order(step_refs, out_refs, temp_refs) -> list[tuple[bool, int]]:
    """Program order (as sympy.cse's): ``(is a temporary, index)``, each step after the temporaries it
    needs that are not yet placed, then those the outputs need."""
    order: list[tuple[bool, int]] = []
    placed: set[int] = set()

    def place_temps(temps: set[int]) -> None:
        needed: set[int] = set()
        todo = [k for k in temps if k not in placed]
        while todo:
            k = todo.pop()
            if k in needed or k in placed:
                continue
            needed.add(k)
            todo.extend(temp_refs[k][0])
        for k in sorted(needed):
            order.append((True, k))
            placed.add(k)

    for i, (temps, _) in enumerate(step_refs):
        place_temps(temps)
        order.append((False, i))
    for temps, _ in out_refs:
        place_temps(temps)
    return order


def _is_boolean(e: sp.Basic) -> bool:
    return bool(e.is_Relational) or isinstance(e, (sp.And, sp.Or, sp.Not))


# -- SymPy expressions -> IR expressions --------------------------------------------------------------

class Converter:
    """SymPy -> IR: ``names`` maps each free symbol to its IR expression, ``temps`` each repeated subtree
    (the CSE's temporaries) to its variable. Results are memoised per SymPy node, so one converter
    serves every function of a derivation.

    Conversion reads the original trees; where SymPy's ``cse`` would have rebuilt an expression with
    its temporaries as symbols before converting it (and the converter builds a new SymPy expression
    from its parts: a quotient's numerator and denominator), the parts are rebuilt first so that the
    result is the same.

    ``plain_denominators``: symbols a division by which needs no guard (inputs the header requires
    positive)."""

    def __init__(self, names: dict[sp.Symbol, Expr], plain_denominators: frozenset = frozenset(),
                 temps: dict[sp.Basic, Var] | None = None) -> None:
        self.names = names
        self.plain = plain_denominators
        self.temps = temps or {}
        self._memo: dict[sp.Basic, Expr] = {}
        self._placeholders: dict[sp.Basic, sp.Symbol] = {}
        self._rebuilt: dict[sp.Basic, sp.Basic] = {}
        self._built: Converter | None = None

    def _fresh(self, expr: sp.Basic) -> Expr:
        """An expression built here from rebuilt parts (temporaries as symbols), converted as ``cse``'s
        output was: node by node, with no temporary found anywhere but at those symbols."""
        if not self.temps:
            return self(expr)
        if self._built is None:
            self._built = Converter(self.names, self.plain)
        return self._built(expr)

    def __call__(self, expr: sp.Basic) -> Expr:
        """``expr`` as IR: its temporary's variable when it is one, else its structure."""
        temp = self.temps.get(expr)
        if temp is not None:
            return temp
        return self.structure(expr)

    def structure(self, expr: sp.Basic) -> Expr:
        """``expr`` itself as IR (its children may be temporaries)."""
        memo = self._memo.get(expr)
        if memo is None:
            memo = self._memo[expr] = self._convert(expr)
        return memo

    def _rebuild(self, e: sp.Basic) -> sp.Basic:
        """``e`` with every repeated subtree replaced by a symbol standing for its temporary (what
        ``tree_cse`` hands on), evaluated as SymPy evaluates it."""
        temp = self.temps.get(e)
        if temp is not None:
            symbol = self._placeholders.get(e)
            if symbol is None:
                symbol = self._placeholders[e] = sp.Dummy(temp.name, real=True)
                self.names[symbol] = temp
            return symbol
        if not e.args:
            return e
        out = self._rebuilt.get(e)
        if out is None:
            args = [self._rebuild(a) for a in e.args]
            out = e if all(a is b for a, b in zip(args, e.args)) else e.func(*args)
            self._rebuilt[e] = out
        return out

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
        """Positive terms, then negated ones (a subtraction each), in SymPy's argument order."""
        plus: list[Expr] = []
        minus: list[Expr] = []
        temps = self.temps
        for t in e.args:
            if t in temps:
                plus.append(temps[t])
            elif t.is_Number and _negative(t):
                minus.append(Neg(Const(float(-t))))
            elif t.is_Mul and t.args[0].is_Number and _negative(t.args[0]):
                minus.append(Neg(self._negated(t.args[0], t.args[1:])))
            elif t.is_Number or t.is_Mul:
                plus.append(self(t))
            elif t.could_extract_minus_sign():  # no other kind of term extracts one today
                minus.append(Neg(self._fresh(-self._rebuild(t))))
            else:
                plus.append(self(t))
        take_sign(plus, minus)  # every term negative: a number, or a product led by one, takes the sign itself
        return _sum(plus, minus)

    def _negated(self, coeff: sp.Number, factors: Sequence[sp.Basic]) -> Expr:
        """``-(coeff * factors[0] * ...)`` for a product whose leading number ``coeff`` is negative, as
        this converter converts that SymPy product, without building it."""
        c = -coeff
        if not c.is_Rational:  # a float leads the factors (Mul.as_coeff_mul)
            return self._mul_parts(sp.S.One, (c, *factors))
        if c == 1:
            return self(factors[0]) if len(factors) == 1 else self._mul_parts(sp.S.One, factors)
        return self._mul_parts(c, factors)

    def _mul(self, e: sp.Mul) -> Expr:
        """A product led by its number (``Mul.as_coeff_Mul``): a rational, or a float."""
        args = e.args
        first = args[0]
        if first.is_Number and (first.is_Rational or _negative(first)):
            return self._mul_parts(first, args[1:])  # a negative literal leads: -0.4*x, its sign free
        return self._mul_parts(sp.S.One, args)

    def _mul_parts(self, coeff: sp.Number, factors: Sequence[sp.Basic]) -> Expr:
        if coeff == -1:
            return Neg(self(factors[0]) if len(factors) == 1 else self._mul_parts(sp.S.One, factors))
        temps = self.temps
        den = [f for f in factors if f not in temps and f.is_Pow and f.exp.is_Rational and _negative(f.exp)]
        if den:
            num = [self._rebuild(f) for f in factors if f not in den]
            numerator = self._fresh(sp.Mul(coeff, *num)) if (num or coeff != 1) else Const(float(coeff))
            denominator = sp.Mul(*[sp.Pow(self._rebuild(f.base), -f.exp) for f in den])
            return Div(numerator, self._fresh(denominator), self._guarded(denominator))
        parts = ([Const(float(coeff))] if coeff != 1 else []) + [self(f) for f in factors]
        return parts[0] if len(parts) == 1 else Mul(tuple(parts))

    def _pow(self, e: sp.Pow) -> Expr:
        base, exp = e.args
        if exp.is_Rational and _negative(exp):
            positive = sp.Pow(self._rebuild(base), -exp)
            return Div(Const(1.0), self._fresh(positive), self._guarded(positive))
        if exp == sp.Rational(1, 2):
            return Call1("sqrt", self(base))
        if exp.is_Integer and exp >= 2:
            b = self(base)
            return Mul((b,) * int(exp))
        raise ValueError(f"internal error: no IR for the power {e}")

    def _guarded(self, den: sp.Expr) -> bool:
        return not ((den.is_Number and float(den) > 0) or den in self.plain)


def _sum(plus: list[Expr], minus: list[Neg]) -> Expr:
    """``plus[0] + ... - minus...``: a sum of at most ``LONG_SUM`` terms as one :class:`Add` (evaluated left
    to right), a longer one as the positive terms summed pairwise minus the negated ones summed pairwise:
    the same additions and negations, in a dependency chain of log2(terms) instead of terms (planar
    kinematics at n = 48 has two sums of 96 products), and a rounding error that grows as log(terms)."""
    if len(plus) + len(minus) <= LONG_SUM:
        return Add(tuple(plus + minus))
    if not minus:
        return _tree(plus)
    negated = _tree([m.x for m in minus])
    return Neg(negated) if not plus else Add((_tree(plus), Neg(negated)))


def _tree(terms: list[Expr]) -> Expr:
    if len(terms) == 1:
        return terms[0]
    middle = len(terms) // 2
    return Add((_tree(terms[:middle]), _tree(terms[middle:])))


def _negative(number: sp.Number) -> bool:
    """``number.is_extended_negative`` without SymPy's assumption system (which deduces every fact of a
    number the first time one is asked: most of the conversion's time)."""
    return float(number) < 0


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


class Lowering:
    """The IR of every function of one derivation: one :class:`Program`, one :class:`Converter`, each
    assignment converted once (a :class:`Let` shared by every function that needs it)."""

    def __init__(self, derivation: Derivation, program: Program) -> None:
        self.derivation = derivation
        self.program = program
        angle_slot = {a: k for k, a in enumerate(program.angles)}
        self.vars = [
            Var(f"a{angle_slot[i]}") if i in angle_slot else Var(f"t{i}", Type.BOOL if e.boolean else Type.REAL)
            for i, e in enumerate(program.entries)
        ]
        names: dict[sp.Symbol, Expr] = {}
        plain: set[sp.Symbol] = set()
        for name, symbols in derivation.inputs.items():
            if name in derivation.scalars:
                names[symbols[0]] = Var(name)
            else:
                for i, s in enumerate(symbols):
                    names[s] = Elem(name, Const(i, Type.INT))
            if derivation.domains.get(name) == "positive":
                plain |= set(symbols)
        for c in derivation.constants:
            names[c.symbol] = NamedConst(c.name)
        for k in range(len(program.angles)):
            names[program.cos[k]] = Var(f"c{k}")
            names[program.sin[k]] = Var(f"s{k}")
        for i, e in enumerate(program.entries):
            if e.symbol is not None:
                names[e.symbol] = self.vars[i]
        self.convert = Converter(names, frozenset(plain), {node: self.vars[i] for node, i in program.temps.items()})
        self._lets: dict[int, Let] = {}

    def let(self, i: int) -> Let:
        let = self._lets.get(i)
        if let is None:
            e = self.program.entries[i]
            value = self.convert.structure(e.expr) if e.temp else self.convert(e.expr)
            let = self._lets[i] = Let(self.vars[i], value)
        return let

    def function(self, spec: FunctionSpec) -> Function:
        """The straight-line IR function of ``spec``: what its outputs need, in order, counted."""
        program = self.program
        entries = program.entries
        args = arguments(self.derivation, spec)
        outs = [(name, i, item) for name in spec.outputs
                for i, item in enumerate(program.outputs[self.derivation.output_key(spec.name, name)])]
        # what the outputs need, and the angle slots used; an angle may need sines and cosines of other
        # angles in turn (closed-form solutions), so repeat until nothing new is found
        needed: set[int] = set()
        slots: set[int] = set()
        frontier = {d for _, _, (_, deps, _) in outs for d in deps}
        new_slots = {k for _, _, (_, _, ks) in outs for k in ks}
        while frontier or new_slots:
            todo = [i for i in frontier if i not in needed]
            found: list[int] = []
            while todo:
                i = todo.pop()
                if i in needed:
                    continue
                needed.add(i)
                found.append(i)
                todo.extend(d for d in entries[i].deps if d not in needed)
            for i in found:
                new_slots.update(entries[i].slots)
            new_slots -= slots
            slots |= new_slots
            frontier = {program.angles[k] for k in new_slots}
            new_slots = set()
        ordered_slots = sorted(slots)
        level = {k: program.level(k) for k in ordered_slots}
        blocks = sorted(set(level.values()))
        # each assignment goes to the earliest trig block whose angles need it
        block_of: dict[int, int] = {}
        for b in blocks:
            todo = [program.angles[k] for k in ordered_slots if level[k] == b]
            while todo:
                i = todo.pop()
                if i in block_of:
                    continue
                block_of[i] = b
                todo.extend(d for d in entries[i].deps if d not in block_of)
        assigned = sorted(needed)
        body: list = []
        for b in blocks:
            body.extend(self.let(i) for i in assigned if block_of.get(i) == b)
            ks = [k for k in ordered_slots if level[k] == b]
            body.append(TrigBlock(tuple(self.vars[program.angles[k]] for k in ks), tuple(Var(f"c{k}") for k in ks),
                                  tuple(Var(f"s{k}") for k in ks)))
        body.extend(self.let(i) for i in assigned if i not in block_of)
        body.extend(Store(name, i, self.convert(expr)) for name, i, (expr, _, _) in outs)
        body_t = _per_function_passes(tuple(body))
        return Function(spec.name, spec.summary, args, body_t, kind="straight", ops=count_ops(body_t))


@lru_cache(maxsize=512)
def _per_function_passes(body: tuple) -> tuple:
    """A function's statements after :func:`~.products.reuse_products`, :func:`~.signs.settle_signs`,
    :func:`~.constants.fold_constants`, :func:`~.factors.factor_sums` and :func:`~.unread.drop_unread`;
    remembered, as the same derivation is lowered again for each generation of it (a test session's many)."""
    return drop_unread(factor_sums(fold_constants(settle_signs(reuse_products(body)))))


def lower_function(derivation: Derivation, spec: FunctionSpec, program: Program) -> Function:
    """The straight-line IR function of ``spec`` from the derivation's :class:`Program`."""
    return Lowering(derivation, program).function(spec)


def lower(derivation: Derivation, names: Sequence[str] | None = None) -> list[Function]:
    """IR functions for the derivation's functions (all, or those in ``names``), in declaration order."""
    specs = [f for f in derivation.functions if names is None or f.name in names]
    program = optimise(derivation, None if names is None else {derivation.output_key(spec.name, o) for spec in specs for o in spec.outputs})
    lowering = Lowering(derivation, program)
    return [lowering.function(spec) for spec in specs]
