"""Evaluating IR expressions with NumPy, for the few values Python computes itself: the defaults of a
solver's arguments (``tol`` scales with the arm's reach), given the call's other arguments."""

from __future__ import annotations

import numpy as np

from .nodes import Add, Call1, Call2, Compare, Const, Div, Elem, Logic, Mul, NamedConst, Neg, Not, Select, Var

_CALLS = {"sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "fabs": np.abs, "floor": np.floor, "nearbyint": np.rint,
          "isfinite": np.isfinite,
          "atan2": np.arctan2, "fmin": np.minimum, "fmax": np.maximum}
_COMPARE = {"<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal, "==": np.equal, "!=": np.not_equal}


def evaluate(e, values: dict, constants: dict | None = None):
    """The value of expression ``e``; ``values`` maps variable and array names to numbers and arrays."""
    t = type(e)
    if t is Const:
        return e.value
    if t is Var:
        return values[e.name]
    if t is Elem:
        return np.asarray(values[e.array])[..., int(evaluate(e.index, values, constants))]
    if t is NamedConst:
        return (constants or {})[e.name]
    if t is Add:
        out = evaluate(e.terms[0], values, constants)
        for x in e.terms[1:]:
            out = out + evaluate(x, values, constants)
        return out
    if t is Mul:
        out = evaluate(e.factors[0], values, constants)
        for x in e.factors[1:]:
            out = out * evaluate(x, values, constants)
        return out
    if t is Neg:
        return -evaluate(e.x, values, constants)
    if t is Div:
        return evaluate(e.num, values, constants) / evaluate(e.den, values, constants)
    if t is Call1:
        return _CALLS[e.function](evaluate(e.x, values, constants))
    if t is Call2:
        return _CALLS[e.function](evaluate(e.a, values, constants), evaluate(e.b, values, constants))
    if t is Compare:
        return _COMPARE[e.op](evaluate(e.a, values, constants), evaluate(e.b, values, constants))
    if t is Logic:
        parts = [evaluate(x, values, constants) for x in e.terms]
        out = parts[0]
        for p in parts[1:]:
            out = np.logical_and(out, p) if e.op == "and" else np.logical_or(out, p)
        return out
    if t is Not:
        return np.logical_not(evaluate(e.x, values, constants))
    if t is Select:
        return np.where(evaluate(e.cond, values, constants), evaluate(e.then, values, constants),
                        evaluate(e.otherwise, values, constants))
    raise TypeError(f"internal error: cannot evaluate {t.__name__}")
