"""The closed-form IK's SymPy steps evaluated in NumPy (:func:`~.numpy_source.numpy_function`: printed directly,
``sympy.lambdify`` as the fallback for a node it has no rule for), independent of the IR and its backends.

:func:`lambdify_ik` turns a :class:`~.derive.ClosedIK` into ``f(target, lock=None) -> (Q, flags)`` with
``target`` of shape ``(..., 16)`` (or ``(..., 4, 4)``), ``Q`` ``(..., S, N)`` and ``flags`` ``(..., S)`` (ints):
the raw candidates, before post-processing. The steps are printed in order (straight-line code).
:class:`ClosedFormIK` adds the post-processing: ``all(target)`` and ``nearest(q_ref, target)``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import sympy as sp
from sympy.printing.numpy import NumPyPrinter

from .derive import STEP_TOLERANCES, ClosedIK, derive_ik_all
from .numpy_source import Unsupported, numpy_function
from .postprocess import LOCK_MAX, STATUS, IKAll, nearest, postprocess


def _steps_function(args: list, steps: list, outs: list, precision: str = "double") -> Callable[..., list]:
    """``f(*args) -> outs`` through the steps: :func:`~.numpy_source.numpy_function`, or ``sympy.lambdify`` where
    the steps hold a node that has no rule there. The module constants in the steps take their values for
    ``precision`` (:data:`~.derive.STEP_TOLERANCES`; the arithmetic is double either way)."""
    values = {c.symbol: c.values[precision] for c in STEP_TOLERANCES}
    steps = [(s, e.xreplace(values) if e.has(*values) else e) for s, e in steps]
    try:
        return numpy_function(args, steps, outs)
    except Unsupported:
        printer = NumPyPrinter({"fully_qualified_modules": False, "inline": True, "allow_unknown_functions": True,
                                "user_functions": {}, "order": "none"})  # "none": no term sorting (3x faster printing)
        return sp.lambdify(args, outs, modules="numpy", cse=lambda exprs: (steps, exprs), printer=printer)


def _needed_steps(steps, outs: list) -> list:
    """The steps ``outs`` read, directly or through other steps, in their order."""
    index = {symbol: i for i, (symbol, _) in enumerate(steps)}
    keep: set[int] = set()
    todo = [s for e in outs for s in e.free_symbols if s in index]
    while todo:
        i = index[todo.pop()]
        if i not in keep:
            keep.add(i)
            todo.extend(s for s in steps[i][1].free_symbols if s in index)
    return [steps[i] for i in sorted(keep)]


def lambdify_ik(ik: ClosedIK) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """``f(target, lock=None) -> (Q (..., S, N), flags (..., S))`` for ``ik`` (see the module docstring)."""
    args = list(ik.inputs["target"]) + list(ik.inputs.get("lock", ()))
    outs = list(ik.Q) + list(ik.flags)
    fn = _steps_function(args, _needed_steps(list(ik.steps), outs), outs)
    S, N = ik.Q.shape

    def evaluate(target, lock=None):
        t = np.asarray(target, dtype=float)
        t = t.reshape(t.shape[:-2] + (16,)) if t.shape[-2:] == (4, 4) else t
        if t.shape[-1] != 16:
            raise ValueError(f"target must have shape (..., 16) or (..., 4, 4), got {np.shape(target)}")
        batch = t.shape[:-1]
        extra = []
        if "lock" in ik.inputs:
            if lock is None:
                raise ValueError("this IK has a locked joint: give lock=VALUE")
            extra = [np.broadcast_to(np.asarray(lock, dtype=float), batch)]
        with np.errstate(divide="ignore", invalid="ignore"):
            values = fn(*[t[..., i] for i in range(16)], *extra)
        values = [np.broadcast_to(np.asarray(v, dtype=float), batch) for v in values]
        Q = np.stack(values[: S * N], axis=-1).reshape(batch + (S, N))
        flags = np.stack(values[S * N:], axis=-1).astype(int)
        return Q, flags

    return evaluate


def lambdify_members(ik: ClosedIK) -> Callable[..., tuple[np.ndarray, np.ndarray]] | None:
    """``f(q_ref (N), target (16), lock=None) -> (M (R, N), flags (R))`` for :attr:`~.derive.ClosedIK.members`, or
    None where the IK has none."""
    if ik.members is None:
        return None
    batched = _members_evaluator(ik.inputs, ik.steps, ik.members, ik.member_flags)

    def evaluate(q_ref, target, lock=None):
        M, flags = batched(q_ref, target, lock)
        return M[0], flags[0].astype(int)

    return evaluate


class ClosedFormIK:
    """A chain's closed-form IK in NumPy: raw candidates (``candidates``), ``all`` and ``nearest``.

    ``chain``: a :class:`~skelarm_sym.models.chain.Chain`; ``lock``: see :func:`~.derive.derive_ik_all`.
    """

    def __init__(self, chain, lock=None, ik: ClosedIK | None = None) -> None:
        self.ik = ik if ik is not None else derive_ik_all(chain, lock)
        self.candidates = lambdify_ik(self.ik)
        self.members = lambdify_members(self.ik)
        self.lower = np.array([-np.inf if v is None else v for v in self.ik.lower])
        self.upper = np.array([np.inf if v is None else v for v in self.ik.upper])
        self.revolute = np.array(self.ik.revolute)

    def all(self, target, lock=None, **kwargs) -> IKAll:
        """Every solution of one target (4 x 4 or 16), post-processed (see :func:`~.postprocess.postprocess`)."""
        return self._all(target, lock, **kwargs)[0]

    def _all(self, target, lock=None, **kwargs) -> tuple[IKAll, np.ndarray | None]:
        """:meth:`all` and the raw candidates' flags (None for an invalid input)."""
        target = np.asarray(target, dtype=float).reshape(16)
        if not np.all(np.isfinite(target)) or (lock is not None and not (np.isfinite(lock) and abs(lock) <= LOCK_MAX)):
            return postprocess(None, None, self.lower, self.upper, self.revolute, target=target), None
        Q, flags = self.candidates(target, lock)
        return postprocess(Q, flags, self.lower, self.upper, self.revolute, target=target,
                           continuum=self.ik.continuum, **kwargs), flags

    def nearest(self, q_ref, target, lock=None, weights=None) -> tuple[np.ndarray | None, int]:
        """The solution nearest ``q_ref`` (see :func:`~.postprocess.nearest`); a UR's continuum members where a raw
        candidate is exact and flagged singular (a representative)."""
        result, flags = self._all(target, lock)
        members = None
        if self.members is not None and result.status != STATUS["invalid"] and np.any(flags == 2):
            members = self.members(q_ref, target, lock)
        return nearest(result, q_ref, self.lower, self.upper, self.revolute, weights, continuum=self.ik.continuum,
                       members=members)


def lambdify_candidates(derivation, precision: str = "double") -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """``f(target (m, 16), lock=None) -> (Q (m, S, N), flags (m, S))`` from a derivation that has the function
    ``ik_candidates`` (:func:`~.derive.with_candidates`): its SymPy steps evaluated in double (:func:`_steps_function`)
    with the tolerances of ``precision``, the check's expectation for the emitted ``ik_candidates`` (the emission
    against SymPy's own evaluation; whether the candidates solve the IK is judged by the reference in the
    ``ik_all`` rows)."""
    Q, flags = derivation.compact["Q"], derivation.compact["flags"]
    S, N = Q.shape
    outs = list(Q) + list(flags)
    steps = _needed_steps(list(derivation.steps), outs)
    args = list(derivation.inputs["target"]) + list(derivation.inputs.get("lock", ()))
    fn = _steps_function(args, steps, outs, precision)
    locked = "lock" in derivation.inputs

    def evaluate(target, lock=None, dtype=np.float64):
        """``dtype`` ``np.float32``: the target's entries go in as float32, and the steps keep float32 wherever
        NumPy's promotion does (constants are float64 arrays in places): decisions near a tolerance as float
        arithmetic may take them."""
        t = np.asarray(target, dtype=dtype).reshape(-1, 16)
        extra = [np.full(len(t), float(lock), dtype=dtype)] if locked else []
        with np.errstate(all="ignore"):
            values = fn(*[t[:, i] for i in range(16)], *extra)
        values = [np.broadcast_to(np.asarray(v, dtype=float), (len(t),)) for v in values]
        return (np.stack(values[: S * N], axis=-1).reshape(len(t), S, N),
                np.stack(values[S * N:], axis=-1).reshape(len(t), S))

    return evaluate


def lambdify_members_of(derivation) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """``f(q_ref (m, N), target (m, 16), lock=None) -> (M (m, R, N), mflags (m, R))`` from a derivation that has
    ``ik_continuum_members`` (:func:`~.derive.with_candidates`): its SymPy steps in double, the check's expectation
    for the emitted function."""
    return _members_evaluator(derivation.inputs, derivation.steps, derivation.compact["M"], derivation.compact["mflags"])


def _members_evaluator(inputs: dict, steps, M: sp.Matrix, mflags: sp.Matrix) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """The continuum members' steps in double, for a batch: ``f(q_ref (m, N), target (m, 16), lock=None)``."""
    R, N = M.shape
    outs = list(M) + list(mflags)
    args = list(inputs["q_ref"]) + list(inputs["target"]) + list(inputs.get("lock", ()))
    fn = _steps_function(args, _needed_steps(list(steps), outs), outs)

    def evaluate(q_ref, target, lock=None):
        q_ref, t = np.asarray(q_ref, dtype=float).reshape(-1, N), np.asarray(target, dtype=float).reshape(-1, 16)
        extra = [np.full(len(t), float(lock))] if "lock" in inputs else []
        with np.errstate(all="ignore"):
            values = fn(*[q_ref[:, j] for j in range(N)], *[t[:, i] for i in range(16)], *extra)
        values = [np.broadcast_to(np.asarray(v, dtype=float), (len(t),)) for v in values]
        return (np.stack(values[: R * N], axis=-1).reshape(len(t), R, N),
                np.stack(values[R * N:], axis=-1).reshape(len(t), R))

    return evaluate
