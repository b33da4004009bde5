"""Operation estimates that follow the IR's counting rules (:func:`_price`, :func:`_nodes`), and the choice of
candidates per forward function (:func:`_choose`)."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Sequence

import sympy as sp

from .algebra import Rows, Vector
from .steps import _Steps

if TYPE_CHECKING:
    from .candidates import _Columns


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


def _choose(step: _Steps, poses: list[Pose], columns: list[_Columns],
            pose_alone: Sequence[Pose] = ()) -> dict[str, tuple[Pose, _Columns]]:
    """Per forward function, the pose and the columns that need the fewest operations (:func:`_price`) for its
    outputs: ``pose`` over every rotation and position (``pose_alone``: candidates for it only), ``jacobian``,
    ``jacobian_dot``, ``twist`` and ``acceleration`` over the columns, ``kinematics`` over both together (a
    position from the columns' offsets only with those columns)."""
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
    best = {"pose": (pick([horner] + poses + with_tips + list(pose_alone), lambda p: (pose_cost(p),)), columns[0])}
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
