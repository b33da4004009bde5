"""Check scenarios for the differential drive: rigid-body motion judges."""

from __future__ import annotations

import numpy as np

from ... import reference
from ...check.scenario import Scenario

def diffdrive_scenarios(derivation, cases: int, seed: int, precision: str) -> list[Scenario]:
    """Scenarios for a differential drive: rigid-body reference of :mod:`skelarm_sym.reference`."""
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731
    rng = np.random.default_rng(seed)
    track = derivation.model.track if derivation.model.track is not None else float(rounded(rng.uniform(0.1, 2.0)))
    wheels = rounded(np.concatenate([rng.uniform(-2, 2, (cases, 2)), [[1.0, 1.0], [-1.0, 1.0], [0.0, 0.0]]]))
    rates = rounded(np.concatenate([rng.uniform(-2, 2, (cases, 2)), [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]]))
    pose = rounded(np.concatenate([rng.uniform(-np.pi, np.pi, (cases, 3)), np.zeros((3, 3))]))
    expected = {
        "rates": reference.diffdrive_body_rates(wheels, track),
        "wheels": reference.diffdrive_wheel_speeds(rates, track),
        "dpose": reference.diffdrive_pose_rate(pose, wheels, track),
    }
    values = {"wheels": wheels, "rates": rates, "pose": pose, "track": track}
    return [Scenario("", values, expected, {})]


