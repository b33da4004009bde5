"""What a model's check scenarios are made of: :class:`Scenario`, the tolerances and the judge's SVD
cut-off. A leaf module: the models' ``check.py`` import it, and it imports nothing of the pipeline."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

TOLERANCES = {"double": 1e-12, "float": 3e-5}
EPSILONS = {"double": 2.220446049250313e-16, "float": 1.1920928955078125e-07}
CHAIN_FACTOR = 25
"""Long chains sum n rounded terms: the tolerance is at least CHAIN_FACTOR * n machine epsilons."""


def tolerance(precision: str, n: int = 1) -> float:
    """The check tolerance for a chain of ``n`` links: ``max(TOLERANCES[precision], 25 n eps)``.

    The absolute angles are sums of up to n rounded angles and the endpoint quantities sums
    of n rounded terms, so their rounding grows with n (float at n = 64: about 5e-5).
    """
    return max(TOLERANCES[precision], CHAIN_FACTOR * n * EPSILONS[precision])


@dataclass(frozen=True)
class Scenario:
    """Inputs and expected outputs for one run of every function whose outputs it covers.

    ``values``: input name -> array (``(m, size)`` per configuration, ``(size,)`` or a
    number when shared). ``expected``: output name -> ``(m, *shape)``. ``condition``:
    output name -> ``(m,)`` factors that scale the tolerance of ill-conditioned results
    (a solve's error grows with the condition number of its matrix); 1 when absent.
    """

    label: str
    values: dict[str, object]
    expected: dict[str, np.ndarray]
    condition: dict[str, np.ndarray]
    alternatives: dict[str, np.ndarray | tuple[np.ndarray, ...]] = field(default_factory=dict)
    """Output name -> a second documented answer (``(m, *shape)``), or a tuple of such answers: a case passes
    when it matches any (near a documented switch, such as gimbal lock, where the code and the judge may each be
    right). A tuple is judged on the first answer's size and condition."""
    alternative_condition: dict[str, np.ndarray] = field(default_factory=dict)
    """Output name -> the tolerance factors of its second answer (``(m,)``); absent: the first answer's, and
    its size too."""
    size: int = 1
    """The model's size for the tolerance (its number of joints; see :func:`tolerance`)."""


DAMPINGS = (0.0, 0.1)
"""The check runs the inverse functions undamped (exact and pseudo-inverses) and damped (lambda = 0.1 reach)."""

CUTOFF_FACTOR = 10


def solve_cutoff(precision: str, n: int) -> float:
    """Relative SVD cutoff of the reference solves: ``10 n eps`` of the working precision.

    The emitted code computes ``J`` in that precision; its entries are sums of up to ``n`` rounded terms,
    so singular values below about ``n eps`` times the largest cannot be told from zero. The cutoff is
    relative (scale-free) and owes nothing to the generator's rank rule: where the two disagree (the
    code drops a direction the reference keeps) the reference's condition number, the square of the
    kept singular-value ratio, is at least ``1 / RANK_TOL`` and the tolerance scales with it.
    """
    return CUTOFF_FACTOR * max(n, 2) * EPSILONS[precision]


