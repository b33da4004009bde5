"""The differential-drive robot (seed 002, example 2): two driven wheels on one axle.

Conventions: ``track`` is the distance between the two wheel contact points
(the usual meaning of ``L``); ``v_L``, ``v_R`` are the wheels' ground speeds
(wheel radius times wheel rate); ``v`` is the forward speed of the axle's
midpoint ``C`` and ``omega`` the turning rate (counter-clockwise positive); the
pose is ``(x, y, heading)`` of ``C`` in the world frame, heading in radians.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from ...errors import InputError
from ..numbers import check_number


def validate_track(track: object) -> float | None:
    """Return ``track`` as a float (``None`` stays symbolic) or raise :class:`InputError`."""
    if track is None:
        return None
    if isinstance(track, bool) or not isinstance(track, numbers.Real):
        raise InputError(f"track width must be a number, got {track!r}")
    value = float(track)
    if not math.isfinite(value) or value <= 0.0:
        raise InputError(f"track width must be finite and positive, got {value!r}")
    return value


@dataclass(frozen=True)
class DiffDrive:
    """A differential-drive base; ``track`` ``None`` makes it a run-time argument."""

    track: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "track", validate_track(self.track))

    @property
    def default_prefix(self) -> str:
        """File name and C prefix when none is given."""
        return "diffdrive"

    def command_args(self, folder: str | None = None) -> list[str]:
        """The ``skelarm-sym generate`` options (words) that describe this model."""
        return ["--model", "diffdrive"] + ([] if self.track is None else ["--track", repr(self.track)])

    def for_precision(self, precision: str) -> "DiffDrive":
        """The model as ``precision`` holds it: itself, once :meth:`check_representable` passes (its lengths are
        checked, not rounded)."""
        self.check_representable(precision)
        return self

    def check_representable(self, precision: str) -> None:
        """Raise :class:`InputError` unless a fixed track suits ``precision``: a normal number whose
        reciprocal (``omega = (v_R - v_L) / track``) is one too."""
        if self.track is None:
            return
        check_number(self.track, "track width", precision)
        check_number(self.track, "track width", precision, -1, "the code divides by it")

    def summary(self) -> list[str]:
        """What ``generate`` prints about the model."""
        return [self.describe()]

    def describe(self) -> str:
        """One line for file headers."""
        width = "passed at run time" if self.track is None else f"fixed at {self.track!r}"
        return f"differential-drive robot, track width (distance between the wheels) {width}"
