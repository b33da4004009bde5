"""``show`` for the differential drive: its wheel-to-body matrix and inverse."""

from __future__ import annotations

import sympy as sp

from ...errors import InputError
from ...show import render

DIFFDRIVE_WHAT = ("matrix", "inverse", "all")


def show_diffdrive(model, what: str = "all", fmt: str = "pretty") -> str:
    """The differential drive's wheel-to-body matrix and its inverse, with seed 002's (11) beside them."""
    from .derive import wheel_to_body

    if what not in DIFFDRIVE_WHAT:
        raise InputError(f"unknown --what {what!r} for a diffdrive; choose from {', '.join(DIFFDRIVE_WHAT)}")
    track = sp.Symbol("L", positive=True) if model.track is None else sp.nsimplify(model.track)
    M, M_inv = wheel_to_body(track)
    blocks = []
    if what in ("matrix", "all"):
        blocks.append(f"[v, omega] = M [v_L, v_R], M =\n{render(M, fmt)}")
    if what in ("inverse", "all"):
        blocks.append(f"[v_L, v_R] = M^-1 [v, omega], M^-1 =\n{render(M_inv, fmt)}")
    if what == "all":
        blocks.append(
            "From rolling without slipping, the wheels at y = +-L/2 in the body frame (x forward, y to the left),\n"
            "L the distance between them. A matrix printed with -2/L, 2/L (inverse: L/4) holds only with L twice that distance."
        )
    return "\n\n".join(blocks) + "\n"
