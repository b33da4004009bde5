"""Context of ``templates/c_chain_ik.c.j2``: the chain pose/position IK solver in C.

``context(derivation, programs, precision, prefix)`` is ``None`` unless the programs include
``ik_terms`` (tool pose T and Jacobian J at once) of a 3-D chain. The algorithm and its constants are
those of :mod:`skelarm_sym.ik` (the NumPy side), so both end with the same status on the same input.
"""

from __future__ import annotations

import math

from .. import ik
from .common import IK_STATUS as STATUS

SETTINGS = {
    "double": {"tol": ik.DEFAULT_TOL["double"], "pivot": ik.PIVOT, "stall": ik.STALL},
    "float": {"tol": ik.DEFAULT_TOL["float"], "pivot": 1e-6, "stall": 1e-6},
}
"""Per precision: default tolerance (documented; callers pass tol), LDL^T pivot cut-off, relative stall."""


def context(derivation, programs, precision, prefix: str) -> dict | None:
    """What the template needs (see the module docstring)."""
    by_name = {p.name: p for p in programs}
    chain = getattr(derivation, "model", None)
    if "ik_terms" not in by_name or chain is None or not hasattr(chain, "limits"):
        return None
    terms = by_name["ik_terms"]
    n = next(a.size for a in terms.inputs if a.name == "q")
    params = next((a for a in terms.inputs if a.name == "params"), None)
    ctype = precision.ctype
    lit = precision.literal
    options = ik.chain_options(chain)
    limits = options["limits"]
    big = 1e300 if ctype == "double" else 1e30
    lower = [-big if x is None else float(x) for x in limits["lower"]]
    upper = [big if x is None else float(x) for x in limits["upper"]]
    draw_low = [-math.pi if x is None else float(x) for x in limits["lower"]]
    draw_span = [(math.pi if u is None else float(u)) - d for u, d in zip(limits["upper"], draw_low)]
    periodic = [k for k, p in enumerate(options["periodic"]) if p and upper[k] - lower[k] >= 2 * math.pi]
    # even restarts: ik.SHRINK times the range around its centre (periodic joints: the whole range)
    near_low = [d if k in periodic else d + s * ((1.0 - ik.SHRINK) / 2.0) for k, (d, s) in enumerate(zip(draw_low, draw_span))]
    near_span = [s if k in periodic else s * ik.SHRINK for k, s in enumerate(draw_span)]
    settings = SETTINGS[ctype]
    f = "" if ctype == "double" else "f"
    itemsize = 8 if ctype == "double" else 4
    return {
        "n": n,
        "params": f"const {ctype} params[{params.size}]" if params else None,
        "param_size": params.size if params else 0,
        "lower": [lit(x) for x in lower],
        "upper": [lit(x) for x in upper],
        "draw_low": [lit(x) for x in draw_low],
        "draw_span": [lit(x) for x in draw_span],
        "near_low": [lit(x) for x in near_low],
        "near_span": [lit(x) for x in near_span],
        "periodic": periodic,
        "status": [{"macro": f"{prefix.upper()}_IK_{s}", "value": i} for i, s in enumerate(STATUS)],
        "c": {
            "start": lit(ik.C_START), "min": lit(ik.C_MIN), "max": lit(ik.C_MAX), "up": lit(ik.C_UP),
            "down": lit(ik.C_DOWN), "step_max": lit(ik.STEP_MAX), "progress": lit(ik.PROGRESS),
            "pivot": lit(settings["pivot"]), "stall": lit(settings["stall"]), "two_pi": lit(2 * math.pi),
            "pi": lit(math.pi), "zero": lit(0.0), "one": lit(1.0), "half": lit(0.5), "twelfth": lit(1 / 12),
            "small_angle": lit(1e-4), "near_pi": lit(1e-3), "stationary": lit(ik.STATIONARY),
            "stationary2": lit(ik.STATIONARY * ik.STATIONARY),
        },
        "candidates": ik.CANDIDATES,
        "attempt": ik.ATTEMPT,
        "window": ik.WINDOW,
        "seed": f"{ik.SEED:#x}ULL",
        "tol": repr(settings["tol"]),
        "fn": {"sqrt": "sqrt" + f, "atan2": "atan2" + f, "fabs": "fabs" + f},
        "stack": f"about {itemsize * (16 + 6 * n * 3 + 36 + 10 * n + 48)} bytes plus {prefix}_ik_terms'",
    }
