"""The step recorder of the chain derivation."""

from __future__ import annotations

from typing import Sequence

import sympy as sp

from .algebra import Rows, Vector
from ...derive.core import StepRecorder


class _Steps(StepRecorder):
    """A StepRecorder that leaves a negated atom unnamed (``-x`` costs nothing where it is used), keeps
    groups of steps that belong together (for :func:`_normalise_signs`) and names vectors and matrices."""

    def __call__(self, label: str, expr: sp.Expr) -> sp.Expr:
        expr = sp.sympify(expr)
        if expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom:
            return expr
        return super().__call__(label, expr)

    groups: list[tuple[sp.Symbol, ...]]
    """Steps that belong together (a vector; a row or a column of a matrix): candidates for one sign flip."""

    def _group(self, entries: Sequence[sp.Expr]) -> None:
        symbols = tuple(e for e in entries if isinstance(e, sp.Symbol) and e.name.startswith(f"_{self._tag}_"))
        if len(symbols) > 1:
            self.__dict__.setdefault("groups", []).append(symbols)

    def vec(self, label: str, v: Sequence[sp.Expr]) -> Vector:
        out = [self(f"{label}{'xyz'[i]}", sp.sympify(v[i])) for i in range(3)]
        self._group(out)
        return out

    def mat(self, label: str, m: Sequence[Sequence[sp.Expr]]) -> Rows:
        out = [[self(f"{label}{i}{j}", sp.sympify(m[i][j])) for j in range(3)] for i in range(3)]
        for i in range(3):
            self._group(out[i])
            self._group([row[i] for row in out])
        return out
