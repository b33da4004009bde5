"""The planar arm's inverse kinematics solver, described once in the IR and printed by every backend.

``ik_solve(q0, target, [l], [lambda], tol, max_iter, q, error, iterations)``: damped least-squares
steps (the derived ``ik_step``) from ``q0`` toward the endpoint ``target`` with damping
``mu = max(lambda, c |target - p|)``, each step shortened by halving until the endpoint error
decreases; ``c`` starts at ``error_damping``, is multiplied by ``shrink`` after a full step and
doubles per halving (Levenberg-Marquardt). When no shortened step lowers the error (a stationary
point: the stretched arm facing a target behind its base, where the damped step is zero), each
joint is moved by +-``probe`` rad in turn, and a damped step is taken from each probe; the lowest
of these poses is taken if it lowers the error, else the solver stops (STALLED).
"""

from __future__ import annotations

import math

from ...ir.build import Array, Body, select, total
from ...ir.nodes import Argument, Call1, Const, Function, NamedConst, Role, Type, Var, eq

SETTINGS = {
    "double": {"tol": 1e-9, "halvings": 30, "stall": 1e-10, "error_damping": 0.5, "shrink": 1 / 3, "c_min": 1e-4, "c_max": 1e4, "probe": 1e-2},
    "float": {"tol": 1e-4, "halvings": 20, "stall": 1e-6, "error_damping": 0.5, "shrink": 1 / 3, "c_min": 1e-4, "c_max": 1e4, "probe": 1e-2},
}
"""Per precision: ``tol``, the default tolerance for an arm of unit size (scaled by the reach);
``halvings`` tried per iteration; ``stall``, the relative error improvement below which the solver
reports STALLED; the damping schedule (``error_damping``, ``shrink``, ``c_min``, ``c_max``); ``probe``,
the joint offset (rad) tried when no damped step lowers the error."""

STATUSES = (
    ("IK_CONVERGED", 0, "the endpoint error is <= tol"),
    ("IK_STALLED", 1, "no step or probe lowers the error, or it improves by less than a relative stall: an "
                      "unreachable target (q is the closest reach found)"),
    ("IK_MAX_ITER", 2, "max_iter steps taken"),
    ("IK_INVALID", 3, "q0, target or lambda not finite, lambda < 0, tol <= 0 or not finite, or max_iter < 0 "
                      "(q = q0, nothing computed)"),
)


def default_tol(precision: str, reach: float) -> float:
    """The default ``tol``: ``SETTINGS[precision]["tol"]`` times the reach (at least 1), since rounding at
    the endpoint grows with the arm's size (float at a reach of 1500: about 2e-4)."""
    return SETTINGS[precision]["tol"] * max(1.0, float(reach))


def _status(name: str) -> NamedConst:
    return NamedConst(name, Type.INT)


def _error_helper(n: int, symbolic: bool) -> Function:
    """``ik_error(trial, target, [l], error)``: the endpoint error |target - p| at the pose trial."""
    lengths = [Argument("l", Role.PARAMETER, (n,), domain="positive", batched=False)] if symbolic else []
    e = Body()
    trial, target, err_out = Array("trial", n), Array("target", 2), Array("error", 1)
    p = e.array("p", 2)
    e.call("position", trial, *([Array("l", n)] if symbolic else []), p)
    d0 = e.let("d0", target[0] - p[0])
    d1 = e.let("d1", target[1] - p[1])
    e.set(err_out[0], e.norm("distance", [d0, d1]))
    return Function(
        "ik_error", "endpoint error |target - p| at the pose trial",
        (Argument("trial", Role.STATE, (n,)), Argument("target", Role.DATA, (2,)), *lengths,
         Argument("error", Role.OUTPUT, (1,))),
        e.statements, kind="helper",
    )


class _PlanarIK:
    """Writes the planar solver into a :class:`Body`, part by part (see the module docstring)."""

    def __init__(self, n: int, symbolic: bool, damped: bool, precision: str) -> None:
        self.n, self.symbolic, self.damped, self.s = n, symbolic, damped, SETTINGS[precision]
        b = self.b = Body()
        self.q0, self.q = Array("q0", n), Array("q", n)
        self.err_a, self.iters = Array("error", 1), Array("iterations", 1, Type.INT)
        self.target = Array("target", 2)
        self.lam, self.tol, self.max_iter = Var("lambda"), Var("tol"), Var("max_iter", Type.INT)
        self.length_args = [Array("l", n)] if symbolic else []
        self.q_next, self.trial, self.probe, self.e1 = b.array("q_next", n), b.array("trial", n), b.array("probe", n), b.array("e1", 1)
        for name in ("err", "err_trial", "alpha", "mu", "improvement"):
            setattr(self, name, b.var(name))
        self.c = b.var("c", self.s["error_damping"])
        self.halving = b.var("halving", 0, Type.INT)
        self.found = b.var("found", 0, Type.INT)

    def step_args(self, start: Array) -> list:
        return [start, self.target, *self.length_args, *([self.mu] if self.damped else []), self.q_next]

    def error_at(self, pose: Array) -> None:
        self.b.call("ik_error", pose, self.target, *self.length_args, self.e1)

    def start(self) -> None:
        """Checks (INVALID) and the first error."""
        b, n = self.b, self.n
        with b.for_("k", 0, n) as k:
            b.set(self.q[k], self.q0[k])
        b.set(self.iters[0], 0)
        b.set(self.err_a[0], Const(math.inf))
        bad = ~Call1("isfinite", self.tol) | (self.tol <= 0.0) | (self.max_iter < 0)
        if self.damped:
            bad = bad | ~Call1("isfinite", self.lam) | (self.lam < 0.0)
        with b.if_(bad):
            b.return_(_status("IK_INVALID"))
        for name, size in (("q0", n), ("target", 2)) + ((("l", n),) if self.symbolic else ()):
            with b.for_("k", 0, size) as k:
                with b.if_(~Call1("isfinite", Array(name, size)[k])):
                    b.return_(_status("IK_INVALID"))
        self.error_at(self.q)
        b.set(self.err, self.e1[0])
        b.set(self.err_a[0], self.err)

    def halve(self) -> None:
        """The damped step, shortened by halving until the error decreases (``found``)."""
        b, s = self.b, self.s
        b.set(self.mu, self.c * self.err)
        if self.damped:
            with b.if_(self.mu < self.lam):
                b.set(self.mu, self.lam)
        b.call("ik_step", *self.step_args(self.q))
        b.set(self.alpha, 1.0)
        b.set(self.halving, 0)
        b.set(self.found, 0)
        with b.while_(self.halving <= s["halvings"]):
            with b.for_("k", 0, self.n) as k:
                b.set(self.trial[k], self.q[k] + self.alpha * (self.q_next[k] - self.q[k]))
            self.error_at(self.trial)
            b.set(self.err_trial, self.e1[0])
            with b.if_(self.err_trial < self.err):
                b.set(self.found, 1)
                b.break_()
            b.set(self.alpha, self.alpha * 0.5)
            b.set(self.halving, self.halving + 1)

    def probe_or_adapt(self) -> None:
        """No step helped: probe each joint (STALLED when no probe helps either); else adapt the damping."""
        b, s, n = self.b, self.s, self.n
        with b.if_(eq(self.found, 0)):
            b.comment("no damped step lowers the error: q is a stationary point of it; probe each joint by "
                      f"+-{s['probe']} rad, and a damped step from each probe")
            b.set(self.err_trial, self.err)
            with b.for_("j", 0, n) as j:
                for sign in (1.0, -1.0):
                    with b.for_("k", 0, n) as k:
                        b.set(self.probe[k], self.q[k])
                    b.set(self.probe[j], self.probe[j] + sign * s["probe"])
                    for start in (self.probe, self.q_next):
                        if start is self.q_next:
                            b.call("ik_step", *self.step_args(self.probe))
                        self.error_at(start)
                        with b.if_(self.e1[0] < self.err_trial):
                            b.set(self.err_trial, self.e1[0])
                            b.set(self.found, 1)
                            with b.for_("k", 0, n) as k:
                                b.set(self.trial[k], start[k])
            with b.if_(eq(self.found, 0)):
                b.return_(_status("IK_STALLED"))
        with b.else_():
            b.comment("Levenberg-Marquardt: a full step lowers the damping, each halving doubles it")
            with b.if_(eq(self.halving, 0)):
                b.set(self.c, select(self.c * s["shrink"] < s["c_min"], s["c_min"], self.c * s["shrink"]))
            with b.else_():
                with b.for_("k", 0, self.halving):
                    b.set(self.c, select(self.c * 2.0 > s["c_max"], s["c_max"], self.c * 2.0))

    def take(self, it: Var) -> None:
        """Move to the trial pose; CONVERGED or STALLED (too little improvement) end the solve."""
        b = self.b
        with b.for_("k", 0, self.n) as k:
            b.set(self.q[k], self.trial[k])
        b.set(self.iters[0], it + Const(1, Type.INT))
        b.set(self.improvement, self.err - self.err_trial)
        b.set(self.err, self.err_trial)
        b.set(self.err_a[0], self.err)
        with b.if_(self.err <= self.tol):
            b.return_(_status("IK_CONVERGED"))
        with b.if_(self.improvement <= self.s["stall"] * self.err):
            b.return_(_status("IK_STALLED"))

    def body(self):
        b = self.b
        self.start()
        with b.for_("it", 0, self.max_iter) as it:
            with b.if_(self.err <= self.tol):
                b.return_(_status("IK_CONVERGED"))
            self.halve()
            self.probe_or_adapt()
            self.take(it)
        b.return_(select(self.err <= self.tol, _status("IK_CONVERGED"), _status("IK_MAX_ITER")))
        return b.statements


def _arguments(derivation, n: int, symbolic: bool, damped: bool, s: dict) -> tuple[Argument, ...]:
    lengths = [Argument("l", Role.PARAMETER, (n,), domain="positive", batched=False)] if symbolic else []
    reach = total([Array("l", n)[k] for k in range(n)]) if symbolic else Const(float(sum(derivation.model.lengths)))
    tol_default = Const(s["tol"]) * select(reach > 1.0, reach, 1.0)
    return (
        Argument("q0", Role.STATE, (n,), domain="finite", batched=False, doc="start pose (rad)"),
        Argument("target", Role.DATA, (2,), domain="finite", batched=False, doc="endpoint target"),
        *lengths,
        *([Argument("lambda", Role.SCALAR, (), domain="nonnegative", batched=False, default=Const(0.0),
                    doc="damping floor (>= 0)")] if damped else []),
        Argument("tol", Role.SCALAR, (), domain="positive", batched=False, default=tol_default,
                 doc=f"stop when |target - p| <= tol (default {s['tol']:g} times the reach, at least 1)"),
        Argument("max_iter", Role.SCALAR, (), Type.INT, batched=False, default=Const(200, Type.INT),
                 doc="at most this many steps"),
        Argument("q", Role.OUTPUT, (n,), doc="final pose"),
        Argument("error", Role.OUTPUT, (1,), optional=True, fields=("error",), doc="endpoint error |target - p| at q"),
        Argument("iterations", Role.OUTPUT, (1,), Type.INT, optional=True, fields=("iterations",), doc="steps taken"),
    )


def _doc(s: dict) -> tuple[str, ...]:
    return (
        "Inverse kinematics: damped least-squares steps (ik_step) from q0 toward target with damping",
        "mu = max(lambda, c |target - p|), each step shortened by halving until the endpoint error decreases;",
        f"c starts at {s['error_damping']:g}, shrinks after a full step and doubles per halving (Levenberg-Marquardt).",
        "When no shortened step lowers the error (a stationary point: a singular pose such as the stretched arm",
        f"facing a target behind its base), each joint is moved by +-{s['probe']:g} rad in turn, and a damped step is",
        "taken from each probe; the lowest of these poses is taken if it lowers the error, else STALLED.",
        f"A tol of {s['tol']:g} times the reach is reachable in this precision. q may be q0 itself.",
    )


def planar_solvers(derivation, names, precision: str) -> list[Function]:
    """``ik_solve`` (and its helper ``ik_error``) when ``names`` holds it; needs ``position`` and ``ik_step``."""
    if "ik_solve" not in names:
        return []
    n = derivation.n
    symbolic = "l" in derivation.inputs
    damped = "lambda" in derivation.function("ik_step").inputs
    s = SETTINGS[precision]
    body = _PlanarIK(n, symbolic, damped, precision).body()
    solver = Function("ik_solve", "inverse kinematics of the endpoint by damped least squares",
                      _arguments(derivation, n, symbolic, damped, s), body, kind="procedure", returns=Type.INT,
                      statuses=STATUSES, doc=_doc(s), result="IKResult")
    return [_error_helper(n, symbolic), solver]
