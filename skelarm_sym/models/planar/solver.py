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

from ...ir.build import Array, Body, select, sqrt, total
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


def planar_solvers(derivation, names, precision: str) -> list[Function]:
    """``ik_solve`` (and its helper ``ik_error``) when ``names`` holds it; needs ``position`` and ``ik_step``."""
    if "ik_solve" not in names:
        return []
    n = derivation.n
    symbolic = "l" in derivation.inputs
    damped = "lambda" in derivation.function("ik_step").inputs
    s = SETTINGS[precision]
    lengths = [Argument("l", Role.PARAMETER, (n,), domain="positive", batched=False)] if symbolic else []

    # |target - p(trial)|
    e = Body()
    trial, target, err_out = Array("trial", n), Array("target", 2), Array("error", 1)
    p = e.array("p", 2)
    e.call("position", trial, *([Array("l", n)] if symbolic else []), p)
    d0 = e.let("d0", target[0] - p[0])
    d1 = e.let("d1", target[1] - p[1])
    e.set(err_out[0], sqrt(d0 * d0 + d1 * d1))
    helper = Function(
        "ik_error", "endpoint error |target - p| at the pose trial",
        (Argument("trial", Role.STATE, (n,)), Argument("target", Role.DATA, (2,)), *lengths,
         Argument("error", Role.OUTPUT, (1,))),
        e.statements, kind="helper",
    )

    b = Body()
    q0, q, err_a, iters = Array("q0", n), Array("q", n), Array("error", 1), Array("iterations", 1, Type.INT)
    lam, tol, max_iter = Var("lambda"), Var("tol"), Var("max_iter", Type.INT)
    length_args = [Array("l", n)] if symbolic else []
    q_next, trial, probe, e1 = b.array("q_next", n), b.array("trial", n), b.array("probe", n), b.array("e1", 1)
    err = b.var("err")
    err_trial = b.var("err_trial")
    alpha = b.var("alpha")
    mu = b.var("mu")
    improvement = b.var("improvement")
    c = b.var("c", s["error_damping"])
    halving = b.var("halving", 0, Type.INT)
    found = b.var("found", 0, Type.INT)
    with b.for_("k", 0, n) as k:
        b.set(q[k], q0[k])
    b.set(iters[0], 0)
    b.set(err_a[0], Const(math.inf))
    bad = ~Call1("isfinite", tol) | (tol <= 0.0) | (max_iter < 0)
    if damped:
        bad = bad | ~Call1("isfinite", lam) | (lam < 0.0)
    with b.if_(bad):
        b.return_(_status("IK_INVALID"))
    for name, size in (("q0", n), ("target", 2)) + ((("l", n),) if symbolic else ()):
        with b.for_("k", 0, size) as k:
            with b.if_(~Call1("isfinite", Array(name, size)[k])):
                b.return_(_status("IK_INVALID"))
    b.call("ik_error", q, Array("target", 2), *length_args, e1)
    b.set(err, e1[0])
    b.set(err_a[0], err)
    step_args = lambda start: [start, Array("target", 2), *length_args, *([mu] if damped else []), q_next]  # noqa: E731
    with b.for_("it", 0, max_iter) as it:
        with b.if_(err <= tol):
            b.return_(_status("IK_CONVERGED"))
        b.set(mu, c * err)
        if damped:
            with b.if_(mu < lam):
                b.set(mu, lam)
        b.call("ik_step", *step_args(q))
        b.set(alpha, 1.0)
        b.set(halving, 0)
        b.set(found, 0)
        with b.while_(halving <= s["halvings"]):
            with b.for_("k", 0, n) as k:
                b.set(trial[k], q[k] + alpha * (q_next[k] - q[k]))
            b.call("ik_error", trial, Array("target", 2), *length_args, e1)
            b.set(err_trial, e1[0])
            with b.if_(err_trial < err):
                b.set(found, 1)
                b.break_()
            b.set(alpha, alpha * 0.5)
            b.set(halving, halving + 1)
        with b.if_(eq(found, 0)):
            b.comment("no damped step lowers the error: q is a stationary point of it; probe each joint by "
                      f"+-{s['probe']} rad, and a damped step from each probe")
            b.set(err_trial, err)
            with b.for_("j", 0, n) as j:
                for sign in (1.0, -1.0):
                    with b.for_("k", 0, n) as k:
                        b.set(probe[k], q[k])
                    b.set(probe[j], probe[j] + sign * s["probe"])
                    for start in (probe, q_next):
                        if start is q_next:
                            b.call("ik_step", *step_args(probe))
                        b.call("ik_error", start, Array("target", 2), *length_args, e1)
                        with b.if_(e1[0] < err_trial):
                            b.set(err_trial, e1[0])
                            b.set(found, 1)
                            with b.for_("k", 0, n) as k:
                                b.set(trial[k], start[k])
            with b.if_(eq(found, 0)):
                b.return_(_status("IK_STALLED"))
        with b.else_():
            b.comment("Levenberg-Marquardt: a full step lowers the damping, each halving doubles it")
            with b.if_(eq(halving, 0)):
                b.set(c, select(c * s["shrink"] < s["c_min"], s["c_min"], c * s["shrink"]))
            with b.else_():
                with b.for_("k", 0, halving):
                    b.set(c, select(c * 2.0 > s["c_max"], s["c_max"], c * 2.0))
        with b.for_("k", 0, n) as k:
            b.set(q[k], trial[k])
        b.set(iters[0], it + Const(1, Type.INT))
        b.set(improvement, err - err_trial)
        b.set(err, err_trial)
        b.set(err_a[0], err)
        with b.if_(err <= tol):
            b.return_(_status("IK_CONVERGED"))
        with b.if_(improvement <= s["stall"] * err):
            b.return_(_status("IK_STALLED"))
    b.return_(select(err <= tol, _status("IK_CONVERGED"), _status("IK_MAX_ITER")))

    reach = total([Array("l", n)[k] for k in range(n)]) if symbolic else Const(float(sum(derivation.model.lengths)))
    tol_default = Const(s["tol"]) * select(reach > 1.0, reach, 1.0)
    arguments = (
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
    doc = (
        "Inverse kinematics: damped least-squares steps (ik_step) from q0 toward target with damping",
        "mu = max(lambda, c |target - p|), each step shortened by halving until the endpoint error decreases;",
        f"c starts at {s['error_damping']:g}, shrinks after a full step and doubles per halving (Levenberg-Marquardt).",
        "When no shortened step lowers the error (a stationary point: a singular pose such as the stretched arm",
        f"facing a target behind its base), each joint is moved by +-{s['probe']:g} rad in turn, and a damped step is",
        "taken from each probe; the lowest of these poses is taken if it lowers the error, else STALLED.",
        f"A tol of {s['tol']:g} times the reach is reachable in this precision. q may be q0 itself.",
    )
    solver = Function("ik_solve", "inverse kinematics of the endpoint by damped least squares", arguments, b.statements,
                      kind="procedure", returns=Type.INT, statuses=STATUSES, doc=doc,
                      result="IKResult")
    return [helper, solver]
