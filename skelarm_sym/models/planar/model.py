"""The planar serial chain: ``n`` revolute joints in a plane, one link after another.

Conventions: ``q[i]`` is the angle of joint ``i`` relative to the previous link
(radians, counter-clockwise); ``theta_i = q_1 + ... + q_i`` is the absolute
angle of link ``i``; ``l[i]`` is the length of link ``i``. Joint 1 sits at the
origin; the endpoint is the far end of link ``n``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Iterable

from ...errors import InputError

from ..numbers import check_number  # noqa: F401 - re-exported

MAX_LINKS = 1000
"""Largest number of links accepted: beyond it generation is no longer useful."""


def validate_links(n: object) -> int:
    """Return ``n`` as an ``int`` or raise :class:`InputError` (1 <= n <= MAX_LINKS)."""
    if isinstance(n, bool) or not isinstance(n, numbers.Integral):
        if isinstance(n, float) and n.is_integer():
            n = int(n)
        else:
            raise InputError(f"number of links must be a whole number, got {n!r}")
    n = int(n)
    if n < 1:
        raise InputError(f"number of links must be at least 1, got {n}")
    if n > MAX_LINKS:
        raise InputError(f"number of links must be at most {MAX_LINKS}, got {n}")
    return n


def validate_lengths(lengths: Iterable[object] | None, n: int) -> tuple[float, ...] | None:
    """Return the link lengths as a tuple of floats (or ``None`` for symbolic lengths).

    Each length must be a finite positive real number, and there must be exactly ``n``.
    """
    if lengths is None:
        return None
    if isinstance(lengths, (str, bytes)):
        raise InputError("link lengths must be a sequence of numbers, not a string")
    try:
        values = list(lengths)
    except TypeError:
        raise InputError(f"link lengths must be a sequence of numbers, got {lengths!r}") from None
    if len(values) != n:
        raise InputError(f"expected {n} link length{'s' if n != 1 else ''}, got {len(values)}")
    result = []
    for i, value in enumerate(values, start=1):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise InputError(f"link length l{i} must be a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value) or value <= 0.0:
            raise InputError(f"link length l{i} must be finite and positive, got {value!r}")
        result.append(value)
    return tuple(result)


@dataclass(frozen=True)
class PlanarArm:
    """A planar serial chain of ``n`` revolute joints.

    ``lengths`` is ``None`` for symbolic lengths ``l1..ln`` (the generated code
    then takes an ``l`` argument) or a tuple of ``n`` finite positive floats
    (baked into the generated code as constants).
    """

    n: int
    lengths: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        n = validate_links(self.n)
        object.__setattr__(self, "n", n)
        object.__setattr__(self, "lengths", validate_lengths(self.lengths, n))

    @property
    def symbolic_lengths(self) -> bool:
        """True when the lengths are symbols (and an input of the generated code)."""
        return self.lengths is None

    @property
    def default_prefix(self) -> str:
        """File name and C prefix when none is given."""
        return f"arm{self.n}"

    def command_args(self, folder: str | None = None) -> list[str]:
        """The ``skelarm-sym generate`` options (words) that describe this model."""
        args = ["--links", str(self.n)]
        if self.lengths is not None:
            args += ["--lengths", ",".join(repr(x) for x in self.lengths)]
        return args

    def for_precision(self, precision: str) -> "PlanarArm":
        """The model as ``precision`` holds it: itself, once :meth:`check_representable` passes (its lengths are
        checked, not rounded)."""
        self.check_representable(precision)
        return self

    def check_representable(self, precision: str) -> None:
        """Raise :class:`InputError` unless the fixed lengths suit ``precision``: each a normal number, and the
        reach (their sum) such that its reciprocal and its fourth power (the damped solves form
        ``det(J J^T + lambda^2 I)``, a product of four lengths) are normal finite numbers too."""
        if self.lengths is None:
            return
        for i, value in enumerate(self.lengths, start=1):
            check_number(value, f"link length l{i}", precision)
        try:
            reach = math.fsum(self.lengths)
        except OverflowError:  # lengths of 1e308 each: a sum beyond every precision
            reach = math.inf
        check_number(reach, "the sum of the link lengths", precision, 4, "the inverse functions use its fourth power")
        check_number(reach, "the sum of the link lengths", precision, -1)

    def summary(self) -> list[str]:
        """What ``generate`` prints about the model."""
        return [self.describe()]

    def describe(self) -> str:
        """One line for file headers: number of links and lengths."""
        if self.lengths is None:
            return f"planar serial chain, {self.n} revolute joint(s), lengths l[0..{self.n - 1}] passed at run time"
        shown = ", ".join(repr(x) for x in self.lengths)
        return f"planar serial chain, {self.n} revolute joint(s), lengths fixed at ({shown})"
