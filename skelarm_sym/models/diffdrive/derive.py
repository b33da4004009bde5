"""The differential drive's kinematics, derived from its rolling constraints (seed 002, (9)-(10)).

Seed 002 states, for a robot turning at rate ``omega`` about a point ``O`` at
distance ``R`` from the axle midpoint ``C``, with wheels ``L/2`` either side of ``C``:

    (9)  omega = v_L / (R - L/2) = v_R / (R + L/2)
    (10) v = (v_L + v_R) / 2

Cleared of fractions, (9) is ``v_L = omega R - omega L/2`` and ``v_R = omega R + omega L/2``;
with ``u = omega R`` (the speed of ``C``) both are linear in ``(u, omega)``, and SymPy
solves them: ``u = (v_L + v_R)/2`` (so (10) follows from (9)), ``omega = (v_R - v_L)/L``.
Hence, with ``L`` the distance between the wheels,

    [v, omega]^T = [[1/2, 1/2], [-1/L, 1/L]] [v_L, v_R]^T,
    [v_L, v_R]^T = [[1, -L/2], [1, L/2]] [v, omega]^T.

The matrix printed as (11) in the seed has ``-2/L, 2/L`` (and ``L/4`` in its inverse);
that holds only if its ``L`` is twice the distance between the wheels (a factor 2 off), which
contradicts the ``R -/+ L/2`` of (9). The tests check the result against rigid-body motion.
Writing ``R`` out (as ``u / omega``) is avoided: it is infinite when driving straight.
"""

from __future__ import annotations

import sympy as sp

from ...derive.core import Derivation, FunctionSpec, StepRecorder, exact_number
from .model import DiffDrive

DIFFDRIVE_FUNCTIONS = (
    FunctionSpec("body_rates", ("wheels", "track"), ("rates",), "body rates (v, omega) from wheel speeds (v_L, v_R)"),
    FunctionSpec("wheel_speeds", ("rates", "track"), ("wheels",), "wheel speeds (v_L, v_R) for body rates (v, omega)"),
    FunctionSpec(
        "pose_rate", ("pose", "wheels", "track"), ("dpose",),
        "pose rate (dx, dy, dheading) of pose (x, y, heading) for wheel speeds (v_L, v_R)",
    ),
)


def constraint_equations(v_left, v_right, track, speed, omega) -> list[sp.Eq]:
    """Seed 002's (9) with ``u = omega R`` (fractions cleared), linear in ``(u, omega)``."""
    return [sp.Eq(v_left, speed - omega * track / 2), sp.Eq(v_right, speed + omega * track / 2)]


def wheel_to_body(track: sp.Expr) -> tuple[sp.Matrix, sp.Matrix]:
    """``(M, M^-1)``: ``[v, omega] = M [v_L, v_R]`` and its inverse, solved from the constraints."""
    v_left, v_right, speed, omega = sp.symbols("v_L v_R u omega", real=True)
    solution = sp.solve(constraint_equations(v_left, v_right, track, speed, omega), [speed, omega], dict=True)[0]
    body = sp.Matrix([solution[speed], solution[omega]])
    M = body.jacobian([v_left, v_right])
    v, w = sp.symbols("v omega", real=True)
    wheels = sp.solve([sp.Eq(v, body[0]), sp.Eq(w, body[1])], [v_left, v_right], dict=True)[0]
    M_inv = sp.Matrix([wheels[v_left], wheels[v_right]]).jacobian([v, w])
    return M, M_inv


def derive_diffdrive(model: DiffDrive | float | None = None) -> Derivation:
    """Derive body rates, wheel speeds and the pose rate of a differential drive."""
    model = model if isinstance(model, DiffDrive) else DiffDrive(model)
    wheels = sp.symbols("vl vr", real=True)
    rates = sp.symbols("v w", real=True)
    pose = sp.symbols("x y h", real=True)
    inputs = {"wheels": wheels, "rates": rates, "pose": pose}
    if model.track is None:
        track = sp.Symbol("L", positive=True)
        inputs["track"] = (track,)
    else:
        track = exact_number(model.track)
    M, M_inv = wheel_to_body(track)
    step = StepRecorder("dd")
    body = M * sp.Matrix(wheels)
    speed = step("v", body[0])
    turn = step("omega", body[1])
    compact = {
        "rates": sp.Matrix([speed, turn]),
        "wheels": M_inv * sp.Matrix(rates),
        "dpose": sp.Matrix([speed * sp.cos(pose[2]), speed * sp.sin(pose[2]), turn]),
    }
    return Derivation(
        model=model,
        inputs=inputs,
        steps=tuple(step.steps),
        compact=compact,
        shapes={"rates": (2,), "wheels": (2,), "dpose": (3,)},
        functions=DIFFDRIVE_FUNCTIONS,
        parameters=("track",),
        scalars=("track",),
        domains={"track": "positive", "wheels": "finite", "rates": "finite", "pose": "finite"},
        notes=(
            f"Model: {model.describe()}.",
            "wheels = (v_L, v_R): ground speeds of the left and right wheel; rates = (v, omega): forward",
            "speed of the axle midpoint and turning rate (counter-clockwise); pose = (x, y, heading), radians.",
            "Body frame: x forward, y to the left; the left wheel at y = +track/2, the right one at -track/2.",
            "Rolling without slipping: v_L = v - omega track/2, v_R = v + omega track/2, so omega = (v_R - v_L) / track.",
        ),
    )
