"""The sign search: which steps to store negated so that the printed code pays the fewest negations
(:func:`_normalise_signs`), and its use on the chain's outputs (:func:`_settle_signs`)."""

from __future__ import annotations

from typing import Sequence

import sympy as sp

from .algebra import Vector
from .steps import _Steps


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
        coeff, factors = e.as_coeff_mul(rational=False)  # a Float coefficient carries a sign too (-0.4 x)
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
    if flips:
        step.replace_steps([(s, (-1 if s in flips else 1) * rhs.xreplace(flips)) for s, rhs in step.steps])
        groups = {name: [[sp.sympify(e).xreplace(flips) for e in v] for v in group] for name, group in groups.items()}
        axes = [[sp.sympify(e).xreplace(flips) for e in v] for v in axes]
    return _hoist_negated_factors(step, groups, axes)


def _hoist_negated_factors(step: _Steps, groups: dict[str, list[Vector]],
                           axes: list[Vector]) -> tuple[dict[str, list[Vector]], list[Vector]]:
    """Negated products that pay their negation (a step or an output ``-x y``, no sum to subtract them in) and
    share a factor ``x``: ``-x`` becomes a step of its own and each product ``(-x) y``, one negation for all of
    them (``-dq1 c1``, ``-dq1 s1``: Stanford's ``dJ``). A function with one such product pays one negation
    either way; the sign search (:func:`_normalise_signs`) has left what flips can remove."""
    outputs = [sp.sympify(e) for group in groups.values() for v in group for e in v]
    negated = [e for e in outputs + [rhs for _, rhs in step.steps]
               if e.is_Mul and e.as_coeff_Mul()[0] == -1 and len(e.args) > 2]
    negated = list(dict.fromkeys(negated))
    chosen: dict[sp.Expr, sp.Symbol] = {}
    while True:
        counts: dict[sp.Symbol, int] = {}
        for e in negated:
            if e not in chosen:
                for x in e.args[1:]:
                    if x.is_Symbol:
                        counts[x] = counts.get(x, 0) + 1
        if not counts or max(counts.values()) < 2:
            break
        atom = max(counts, key=lambda x: (counts[x], x.name))  # the most products; a tie by name (deterministic)
        for e in negated:
            if e not in chosen and atom in e.args[1:]:
                chosen[e] = atom
    if not chosen:
        return groups, axes
    names = {atom: step.symbol(f"neg_{atom.name.lstrip('_')}") for atom in dict.fromkeys(chosen.values())}
    rewrite = {e: names[atom] * sp.Mul(*[x for x in e.args[1:] if x != atom]) for e, atom in chosen.items()}
    steps = [(name, -atom) for atom, name in names.items() if atom not in step.definitions()]  # inputs first
    for symbol, rhs in step.steps:
        steps.append((symbol, rhs.xreplace(rewrite)))
        if symbol in names:  # a step's negation right after its definition
            steps.append((names[symbol], -symbol))
    step.replace_steps(steps)
    groups = {name: [[sp.sympify(e).xreplace(rewrite) for e in v] for v in group] for name, group in groups.items()}
    return groups, [[sp.sympify(e).xreplace(rewrite) for e in v] for v in axes]
