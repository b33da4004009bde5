"""Solver rows of ``check``: each model kind's solver checks (``models/<kind>/check.py``), run through the registry."""

from __future__ import annotations

from ..models.registry import kind_of
from .solver_rows import IKCheck


def check_solvers(generated, implementations, cases: int = 100, seed: int = 0, precision: str = "double") -> list[IKCheck]:
    """Solver rows for ``generated`` with its loaded ``implementations`` (``[(label, module)]``); empty when
    the model's kind has no solver or none was emitted."""
    kind = kind_of(generated.derivation.model)
    if kind.solver_checks is None:
        return []
    return kind.solver_checks(generated, implementations, cases, seed, precision)
