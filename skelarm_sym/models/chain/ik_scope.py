"""What rules a chain out of closed-form IK before any of its geometry is computed: named parameters,
mimic joints, and a number of joints other than six (seven with a locked joint). One-line reasons.

:mod:`skelarm_sym.closed_ik.classify` raises its :class:`~skelarm_sym.closed_ik.classify.ClosedFormError`
with these reasons; the chain's model kind asks here first, so that a chain no family can hold (a 7-joint
arm without a lock, a 3-joint one) is generated without importing the closed-form IK (and NumPy with it).
This module imports neither.
"""

from __future__ import annotations

import sympy as sp

from .model import Chain


def unsupported(chain: Chain) -> str | None:
    """Why closed-form IK does not take ``chain`` at all (named parameters, mimic joints), else ``None``."""
    if chain.parameters:
        return (f"{chain.name}: named parameters ({', '.join(map(str, chain.parameters))}) are not supported by closed-form IK:"
                " give numbers")
    if len(chain.joints) != chain.n or any(sp.sympify(j.multiplier) != 1 for j in chain.joints):
        return f"{chain.name}: mimic joints (a coordinate moving several joints) are not supported by closed-form IK"
    return None


def joint_count(name: str, n: int, lock: int | None) -> str | None:
    """Why ``n`` moving joints (``lock``: the 0-based locked joint, or ``None``) cannot be solved, else ``None``."""
    if lock is not None:
        if n != 7:
            return f"{name}: a locked joint reduces a 7-joint chain to 6; this chain has {n} joints"
        return None
    if n != 6:
        hint = " (a 7-joint arm: lock one joint, --ik-lock JOINT; load_robot(path, ik_lock=JOINT) from Python)" if n == 7 else ""
        return f"{name}: closed-form families here need 6 moving joints, this chain has {n}{hint}"
    return None


def refusal(chain: Chain, lock: int | None) -> str | None:
    """The first reason above that rules ``chain`` out (with ``lock`` held), else ``None``: then only its
    geometry decides (:func:`skelarm_sym.closed_ik.classify.classify`)."""
    return unsupported(chain) or joint_count(chain.name, len(chain.joints), lock)
