"""Emitted C and Python against the recursive reference, per output, with tolerances.

Tolerance: for each configuration and output array, the error is
``max |emitted - reference| / (max(1, max |reference|) * condition)`` over that
array's elements; it must stay below 1e-12 for double and 3e-5 for float (about 250 float
epsilons), or 25 n machine epsilons for a longer chain (see :func:`tolerance`).
``condition`` is, for forward kinematics, the natural size of the terms summed
over the size of the result (at least 1: sums that cancel keep the rounding of
their terms), and for the damped least-squares solves the condition number of the
matrix solved (rounding in it is amplified that much by any method). Inputs are rounded to the working precision first; the
reference always runs in double.

Each :class:`OutputError` also records, at the case that decided it (the largest scaled error),
the absolute error there, its ``size`` (``max(1, max |reference|)``), its ``condition`` and the
absolute error allowed there, ``allowed_abs = tolerance * size * condition``: the row is ok exactly
when ``abs_error <= allowed_abs`` (up to rounding of the product), which the ``check`` table shows.

:func:`load_generated` reads files written earlier by ``skelarm-sym generate`` (``check --from``).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import InputError
from ..generate import Generated, generate
from ..models.registry import kind_of
from .scenario import CHAIN_FACTOR, CUTOFF_FACTOR, DAMPINGS, EPSILONS, TOLERANCES, Scenario, solve_cutoff, tolerance  # noqa: F401

@dataclass(frozen=True)
class OutputError:
    """Worst errors of one output of one implementation over all cases."""

    implementation: str
    output: str
    max_abs: float
    """Largest ``|emitted - reference|`` over all cases (it may come from a case with a larger allowance)."""
    max_rel: float
    """Largest scaled error ``|emitted - reference| / (size * condition)``: the row is ok when it is <= tolerance."""
    tolerance: float
    abs_error: float = float("nan")
    """``max |emitted - reference|`` at the case of ``max_rel`` (the case that decides the row)."""
    size: float = 1.0
    """``max(1, max |reference|)`` at that case."""
    condition: float = 1.0
    """The condition factor at that case (1 for well-conditioned outputs; see the module docstring)."""

    @property
    def allowed_abs(self) -> float:
        """The largest ``|emitted - reference|`` allowed at the deciding case: ``tolerance * size * condition``."""
        return self.tolerance * self.size * self.condition

    @property
    def ok(self) -> bool:
        """True when the scaled error is within tolerance (and finite)."""
        return bool(np.isfinite(self.max_rel) and self.max_rel <= self.tolerance)


TABLE_NOTE = (
    "abs error: max |emitted - reference| at the case that decides the row (largest scaled error); "
    "allowed abs = tolerance x size x condition at that case, size = max(1, max |reference|), condition = 1 "
    "unless rounding is amplified (sums that cancel, ill-conditioned solves); rel error = abs error / "
    "(size x condition), ok when <= tolerance, i.e. abs error <= allowed abs."
)
"""The line under the ``check`` table explaining its columns."""


def table(results: Sequence[OutputError]) -> list[str]:
    """The ``check`` table: one self-explaining row per output (see :data:`TABLE_NOTE`)."""
    width = max([len("function"), *(len(r.implementation) for r in results)])
    out = max([len("output"), *(len(r.output) for r in results)])
    lines = [
        f"{'function':<{width}}  {'output':<{out}}  {'abs error':>10}  {'allowed abs':>11}  {'rel error':>10}  "
        f"{'tolerance':>9}  {'size':>8}  {'condition':>9}  result"
    ]
    for r in results:
        lines.append(
            f"{r.implementation:<{width}}  {r.output:<{out}}  {r.abs_error:10.2e}  {r.allowed_abs:11.2e}  {r.max_rel:10.2e}  "
            f"{r.tolerance:9.0e}  {r.size:8.3g}  {r.condition:9.3g}  {'ok' if r.ok else 'FAIL'}"
        )
    return lines


def load_implementations(generated: Generated) -> list[tuple[str, object]]:
    """``[(label, implementation)]`` for every registered backend whose files ``generated`` holds, in the
    registry's order (``[("C", CompiledArm), ("Python", module)]`` for the default languages)."""
    from ..backends import BACKENDS

    prefix = generated.module.prefix
    return [(backend.LABEL, backend.load(generated)) for backend in BACKENDS.values()
            if all(prefix + suffix in generated.sources for suffix in backend.FILE_SUFFIXES)]


MAX_CASES = 100_000
"""Most random configurations a check takes (a seven-joint arm's Jacobians of 100,000 cases hold 34 MB an array;
10^8 asked for terabytes)."""


def _check_whole(value: object, name: str, least: int | None, most: int | None = None) -> None:
    """InputError unless ``value`` is a whole number (an int, NumPy's too; not a bool), at least ``least`` and at
    most ``most``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InputError(f"{name} must be a whole number, got {value!r:.60}")
    if least is not None and value < least:
        raise InputError(f"{name} must be at least {least}, got {value}")
    if most is not None and value > most:
        raise InputError(f"{name} must be at most {most}, got {value}")


def compare(generated: Generated, cases: int = 100, seed: int = 0, precision: str = "double",
            implementations: Sequence[tuple[str, object]] | None = None) -> list[OutputError]:
    """Run every emitted function of ``generated`` (C if present, Python if present; or the loaded
    ``implementations``, ``[(label, module)]``) against the reference. ``cases``: random configurations, a whole
    number of at least 1 (the judged poses add to them); ``seed``: a whole number, at least 0. InputError (a ValueError) for
    others."""
    _check_whole(cases, "cases", 1, MAX_CASES)
    _check_whole(seed, "seed", 0)
    derivation = generated.derivation
    scenarios = kind_of(derivation.model).scenarios(derivation, cases, seed, precision)
    if implementations is None:
        implementations = load_implementations(generated)
    results = []
    for label, impl in implementations:
        for program in generated.programs:
            covering = [s for s in scenarios if all(o.name in s.expected for o in program.outputs)]
            if not covering:
                raise InputError(f"internal error: no check scenario covers {program.name} (its expected value belongs in "
                                 "the model's check.py: docs/architecture.md, 'Adding an output function')")
            for scenario in covering:
                allowed = tolerance(precision, scenario.size)
                args = [scenario.values[a.name] for a in program.inputs]
                outs = getattr(impl, program.name)(*args)
                outs = outs if isinstance(outs, tuple) else (outs,)
                name = f"{label} {program.name}" + (f" [{scenario.label}]" if scenario.label else "")
                for arg, got in zip(program.outputs, outs):
                    want = scenario.expected[arg.name]
                    axes = tuple(range(1, want.ndim))
                    got = np.asarray(got, dtype=np.float64)
                    abs_err = _worst(got, want, axes)
                    size = np.maximum(1.0, np.abs(want).max(axis=axes) if axes else np.abs(want))
                    condition = np.broadcast_to(np.asarray(scenario.condition.get(arg.name, 1.0), dtype=float), size.shape)
                    if isinstance(scenario.alternatives.get(arg.name), tuple):  # several answers, one scale
                        for other in scenario.alternatives[arg.name]:
                            abs_err = np.minimum(abs_err, _worst(got, other, axes))
                    elif arg.name in scenario.alternatives:
                        second = scenario.alternatives[arg.name]
                        second_err = _worst(got, second, axes)
                        if arg.name in scenario.alternative_condition:  # judged on its own scale
                            second_size = np.maximum(1.0, np.abs(second).max(axis=axes) if axes else np.abs(second))
                            second_condition = np.broadcast_to(np.asarray(scenario.alternative_condition[arg.name], dtype=float), size.shape)
                            closer = second_err / (second_size * second_condition) < abs_err / (size * condition)
                            size = np.where(closer, second_size, size)
                            condition = np.where(closer, second_condition, condition)
                            abs_err = np.where(closer, second_err, abs_err)
                        else:
                            abs_err = np.minimum(abs_err, second_err)
                    rel = abs_err / (size * condition)
                    worst = int(np.argmax(np.where(np.isnan(rel), np.inf, rel)))
                    results.append(OutputError(
                        name, arg.name, float(abs_err.max()), float(rel.max()), allowed,
                        float(abs_err[worst]), float(size[worst]), float(condition[worst]),
                    ))
    return results


def _worst(got: np.ndarray, want: np.ndarray, axes: tuple[int, ...]) -> np.ndarray:
    """Per case: the largest ``|got - want|`` (NaN counts as infinite)."""
    diff = np.abs(got - want)
    diff = np.where(np.isnan(diff), np.inf, diff)
    return diff.max(axis=axes) if axes else diff


def run_check(n, lengths: Sequence[float] | None = None, precision: str = "double", cases: int = 100, seed: int = 0, langs=("c", "python")) -> list[OutputError]:
    """Generate (in memory), compile, and compare; see :func:`compare` (its arguments checked before the work)."""
    _check_whole(cases, "cases", 1, MAX_CASES)
    _check_whole(seed, "seed", 0)
    generated = generate(n, lengths=lengths, langs=langs, precision=precision, out=None)
    return compare(generated, cases=cases, seed=seed, precision=precision)


