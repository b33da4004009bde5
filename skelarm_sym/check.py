"""Emitted C and Python against the recursive reference, per output, with tolerances.

Tolerance: for each configuration and output array, the error is
``max |emitted - reference| / max(1, max |reference|)`` over that array's
elements; it must stay below 1e-12 for double and 1e-5 for float. Inputs are
rounded to the working precision first; the reference always runs in double.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from . import reference
from .build import compile_arm, load_python
from .generate import Generated, generate

TOLERANCES = {"double": 1e-12, "float": 1e-5}


@dataclass(frozen=True)
class OutputError:
    """Worst errors of one output of one implementation over all cases."""

    implementation: str
    output: str
    max_abs: float
    max_rel: float
    tolerance: float

    @property
    def ok(self) -> bool:
        """True when the scaled error is within tolerance (and finite)."""
        return bool(np.isfinite(self.max_rel) and self.max_rel <= self.tolerance)


def check_cases(n: int, cases: int, seed: int = 0, lengths: Sequence[float] | None = None):
    """Random configurations plus singular (stretched, folded) and zero-velocity ones.

    Returns ``(q, dq, ddq, l)`` with ``q`` etc. of shape ``(m, n)``, ``l`` ``(n,)``.
    """
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (cases, n))
    dq = rng.uniform(-np.pi, np.pi, (cases, n))
    ddq = rng.uniform(-np.pi, np.pi, (cases, n))
    folded = np.zeros(n)
    folded[1:] = np.pi
    special_q = np.stack([np.zeros(n), folded, q[0] if cases else np.zeros(n)])
    special_dq = np.stack([dq[0] if cases else np.ones(n), np.zeros(n), np.zeros(n)])
    special_ddq = np.stack([np.zeros(n), ddq[0] if cases else np.ones(n), np.zeros(n)])
    l = np.asarray(lengths, dtype=float) if lengths is not None else rng.uniform(0.2, 2.0, n)
    return (np.concatenate([q, special_q]), np.concatenate([dq, special_dq]), np.concatenate([ddq, special_ddq]), l)


def _reference_outputs(q, dq, ddq, l) -> dict[str, np.ndarray]:
    k = reference.kinematics(q, dq, ddq, l)
    return {"p": k.p, "J": k.J, "H": k.H, "v": k.v, "a": k.a}


def compare(generated: Generated, cases: int = 100, seed: int = 0, precision: str = "double") -> list[OutputError]:
    """Run every emitted function of ``generated`` (C if present, Python if present) against the reference."""
    derivation = generated.derivation
    n = derivation.n
    fixed = derivation.model.lengths
    q, dq, ddq, l = check_cases(n, cases, seed, fixed)
    dtype = np.float64 if precision == "double" else np.float32
    q, dq, ddq, l = (np.asarray(x, dtype=dtype).astype(np.float64) for x in (q, dq, ddq, l))
    expected = _reference_outputs(q, dq, ddq, l)
    values = {"q": q, "dq": dq, "ddq": ddq, "l": l}
    implementations = []
    c_files = [k for k in generated.sources if k.endswith(".c")]
    py_files = [k for k in generated.sources if k.endswith(".py")]
    if c_files:
        implementations.append(("C", compile_arm(generated)))
    if py_files:
        implementations.append(("Python", load_python(generated.sources[py_files[0]], py_files[0][:-3])))
    tolerance = TOLERANCES[precision]
    results = []
    for label, impl in implementations:
        for program in generated.programs:
            args = [values[a.name] for a in program.inputs]
            outs = getattr(impl, program.name)(*args)
            outs = outs if isinstance(outs, tuple) else (outs,)
            for arg, got in zip(program.outputs, outs):
                want = expected[arg.name]
                axes = tuple(range(1, want.ndim))
                diff = np.abs(np.asarray(got, dtype=np.float64) - want)
                diff = np.where(np.isnan(diff), np.inf, diff)
                abs_err = diff.max(axis=axes)
                scale = np.maximum(1.0, np.abs(want).max(axis=axes))
                results.append(OutputError(f"{label} {program.name}", arg.name, float(abs_err.max()), float((abs_err / scale).max()), tolerance))
    return results


def run_check(n: int, lengths: Sequence[float] | None = None, precision: str = "double", cases: int = 100, seed: int = 0, langs=("c", "python")) -> list[OutputError]:
    """Generate (in memory), compile, and compare; see :func:`compare`."""
    generated = generate(n, lengths=lengths, langs=langs, precision=precision, out=None)
    return compare(generated, cases=cases, seed=seed, precision=precision)
