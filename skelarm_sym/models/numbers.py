"""Numbers a model bakes into emitted code: each must be a normal finite number of the precision."""

from __future__ import annotations

from ..errors import InputError

FLOAT_RANGES = {"double": (2.2250738585072014e-308, 1.7976931348623157e308), "float": (1.1754943508222875e-38, 3.4028234663852886e38)}
"""Smallest normal and largest finite number of each precision."""


def check_number(value: float, name: str, precision: str, power: int = 1, what: str = "") -> None:
    """Raise :class:`InputError` (one line, naming ``name``) unless ``value ** power`` is a normal finite
    number of ``precision`` (``power`` may be negative: a reciprocal, or a fourth power the code forms)."""
    tiny, huge = FLOAT_RANGES[precision]
    magnitude = abs(value)
    try:
        ok = magnitude > 0 and tiny <= magnitude**power <= huge
    except (OverflowError, ZeroDivisionError):
        ok = False
    if not ok:
        low, high = sorted((tiny ** (1 / power), huge ** (1 / power)))
        low, high = max(low, tiny), min(high, huge)
        reason = f" ({what})" if what else ""
        raise InputError(f"{name} = {value!r} is not representable in {precision}: use a magnitude between {low:.3g} and {high:.3g}{reason}")
