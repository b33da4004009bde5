"""Check scenarios for 3-D chains: the NumPy twist-propagation reference is the judge.

Configurations: random joint values (revolute in [-pi, pi], prismatic in [-0.5, 0.5] m), rates
and accelerations in [-2, 2], plus the zero configuration at rest and a configuration with rates
but no accelerations. Named parameters get random values in [0.2, 1.2]. Expected outputs come
from :func:`skelarm_sym.models.chain.reference.chain_kinematics` (seed 001's forward recursion and seed
003's columns), never from the derivation.

Tolerance scaling (``condition``): rounding in a sum scales with its terms, not with the result;
a Jacobian entry sums lever arms up to the chain's reach ``L`` (the sum of its constant
translations and prismatic travel), a rate term ``L |dq|_1``, an acceleration ``L (|dq|_1^2 + |ddq|_1)``.
"""

from __future__ import annotations

import numpy as np

from . import reference
from .check import Scenario


def chain_scenarios(derivation, cases: int, seed: int, precision: str) -> list[Scenario]:
    """Scenarios for a :class:`~skelarm_sym.models.chain.Chain` derivation (see the module docstring)."""
    chain = derivation.model
    n = chain.n
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731 - inputs as the code sees them
    rng = np.random.default_rng(seed)
    prismatic = np.zeros(n, dtype=bool)
    for joint in chain.joints:
        prismatic[joint.coordinate] |= joint.kind == "prismatic"
    span = np.where(prismatic, 0.5, np.pi)
    q = rng.uniform(-1, 1, (cases, n)) * span
    dq = rng.uniform(-2, 2, (cases, n))
    ddq = rng.uniform(-2, 2, (cases, n))
    q = rounded(np.concatenate([q, np.zeros((1, n)), q[:1] if cases else np.zeros((1, n))]))
    dq = rounded(np.concatenate([dq, np.zeros((1, n)), dq[:1] if cases else np.ones((1, n))]))
    ddq = rounded(np.concatenate([ddq, np.zeros((1, n)), np.zeros((1, n))]))
    params = rounded(rng.uniform(0.2, 1.2, len(chain.parameters)))
    numeric = chain.numeric(params if chain.parameters else None)
    k = reference.chain_kinematics(numeric, q, dq, ddq)
    expected = {"T": k.T, "J": k.J, "J_tool": k.J_tool, "dJ": k.dJ, "twist": k.twist, "acc": k.acc}
    transforms = [numeric.base, numeric.tool] + [m for j in numeric.joints for m in (j.before, j.after)]
    reach = sum(float(np.linalg.norm(m[:3, 3])) for m in transforms) + np.sum(np.abs(q) * prismatic, axis=-1) + 1.0
    rate = np.sum(np.abs(dq), axis=-1)
    accel = np.sum(np.abs(ddq), axis=-1)
    sizes = {
        "T": reach, "J": reach, "J_tool": reach, "dJ": reach * (rate + 1), "twist": reach * (rate + 1),
        "acc": reach * (rate**2 + accel + 1),
    }
    condition = {
        name: np.maximum(1.0, size / np.maximum(1.0, np.abs(expected[name]).reshape(len(q), -1).max(axis=-1)))
        for name, size in sizes.items()
    }
    values = {"q": q, "dq": dq, "ddq": ddq}
    if chain.parameters:
        values["params"] = params
    from .models.chain.inverse import characteristic_length  # inverse functions: hook of chain_inverse
    from .derive.core import RANK_TOL
    from .models.chain.reference_inverse import check_expectations

    forward, forward_condition, solves = check_expectations(
        numeric, q, k, float(characteristic_length(chain).xreplace(dict(zip(chain.parameters, params))) if chain.parameters else characteristic_length(chain)),
        RANK_TOL.values[precision], np.random.default_rng(seed + 1), rounded,
    )
    expected.update(forward)
    condition.update(forward_condition)
    return [Scenario("", values, expected, condition)] + [
        Scenario(label, {**values, **extra}, want, cond) for label, extra, want, cond in solves
    ]
