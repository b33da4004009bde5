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

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from . import reference
from .build import compile_arm, load_python
from .generate import Generated, generate

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


def planar_scenarios(derivation, cases: int, seed: int, precision: str) -> list[Scenario]:
    """Scenarios for a planar arm: forward outputs from the recursion, solves from NumPy linear algebra."""

    n = derivation.n
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731 - inputs as the code sees them
    q, dq, ddq, l = (rounded(x) for x in check_cases(n, cases, seed, derivation.model.lengths))
    m = len(q)
    rng = np.random.default_rng(seed + 1)
    reach = float(l.sum())
    # commanded velocities of the arm's own size (lengths per second), so errors in dq are relative to O(1)
    v = rounded(rng.uniform(-1, 1, (m, 2)) * reach)
    twist = rounded(rng.uniform(-1, 1, (m, 3)) * [reach, reach, 1.0])
    k = reference.kinematics(q, dq, ddq, l)
    reachable = reference.kinematics(rng.uniform(-np.pi, np.pi, (m, n)), None, None, l).p
    target = rounded(np.where(rng.uniform(size=(m, 1)) < 0.5, reachable, rng.uniform(-1.2 * reach, 1.2 * reach, (m, 2))))
    values = {"q": q, "dq": dq, "ddq": ddq, "l": l, "v": v, "twist": twist, "target": target}
    forward = {"p": k.p, "J": k.J, "H": k.H, "v": k.v, "a": k.a, "w": reference.manipulability(k.J)[:, None]}
    # Rounding in a sum scales with the sum of its terms' sizes, not with the result, which can cancel:
    # compare each output with the natural size of its terms.
    rates = np.abs(np.cumsum(dq, axis=-1))
    accels = np.abs(np.cumsum(ddq, axis=-1))
    sizes = {
        "p": np.full(m, reach),
        "J": np.full(m, reach),
        "H": (l * rates).sum(axis=-1),
        "v": (l * rates).sum(axis=-1),
        "a": (l * (rates**2 + accels)).sum(axis=-1),
        "w": np.sum(k.J**2, axis=(-2, -1)),  # a product of two lengths of J's rows
    }
    condition = {
        name: np.maximum(1.0, size / np.maximum(1.0, np.abs(forward[name]).reshape(m, -1).max(axis=-1)))
        for name, size in sizes.items()
    }
    scenarios = [Scenario("", values, forward, condition)]
    rcond = solve_cutoff(precision, n)
    D3 = np.array([1.0 / reach, 1.0 / reach, 1.0])  # the orientation row against lengths measured in reaches
    for lam in DAMPINGS:
        lam_run = float(rounded(lam * reach))  # lambda is a length: damp in proportion to the arm
        solves = {
            "dq": reference.damped_least_squares(k.J, v, lam_run, rcond),
            "q_next": reference.damped_least_squares(k.J, target - k.p, lam_run, rcond),
        }
        if "twist" in derivation.inputs:
            solves["dq3"] = reference.damped_least_squares(k.J3, twist, lam_run, rcond, D3)
        expected = {name: s.x for name, s in solves.items()}
        expected["q_next"] = q + expected["q_next"]
        condition = {name: s.condition for name, s in solves.items()}
        scenarios.append(Scenario(f"lambda={lam:g}*reach", {**values, "lambda": lam_run}, expected, condition))
    return scenarios


def load_implementations(generated: Generated) -> list[tuple[str, object]]:
    """``[("C", CompiledArm), ("Python", module)]`` for the ``.c`` and ``.py`` files of ``generated`` present."""
    implementations: list[tuple[str, object]] = []
    c_files = [k for k in generated.sources if k.endswith(".c")]
    py_files = [k for k in generated.sources if k.endswith(".py")]
    if c_files:
        implementations.append(("C", compile_arm(generated)))
    if py_files:
        try:
            module = load_python(generated.sources[py_files[0]], py_files[0][:-3])
        except SyntaxError as exc:  # a file edited by hand (check --from)
            from .errors import InputError

            raise InputError(f"{py_files[0]} does not load: {exc.msg} (line {exc.lineno})") from None
        implementations.append(("Python", module))
    return implementations


def compare(generated: Generated, cases: int = 100, seed: int = 0, precision: str = "double",
            implementations: Sequence[tuple[str, object]] | None = None) -> list[OutputError]:
    """Run every emitted function of ``generated`` (C if present, Python if present; or the loaded
    ``implementations``, ``[(label, module)]``) against the reference."""
    derivation = generated.derivation
    scenarios = scenarios_for(derivation)(derivation, cases, seed, precision)
    if implementations is None:
        implementations = load_implementations(generated)
    allowed = tolerance(precision, getattr(derivation.model, "n", 1))
    results = []
    for label, impl in implementations:
        for program in generated.programs:
            for scenario in scenarios:
                if not all(o.name in scenario.expected for o in program.outputs):
                    continue
                args = [scenario.values[a.name] for a in program.inputs]
                outs = getattr(impl, program.name)(*args)
                outs = outs if isinstance(outs, tuple) else (outs,)
                name = f"{label} {program.name}" + (f" [{scenario.label}]" if scenario.label else "")
                for arg, got in zip(program.outputs, outs):
                    want = scenario.expected[arg.name]
                    axes = tuple(range(1, want.ndim))
                    diff = np.abs(np.asarray(got, dtype=np.float64) - want)
                    diff = np.where(np.isnan(diff), np.inf, diff)
                    abs_err = diff.max(axis=axes) if axes else diff
                    size = np.maximum(1.0, np.abs(want).max(axis=axes) if axes else np.abs(want))
                    condition = np.broadcast_to(np.asarray(scenario.condition.get(arg.name, 1.0), dtype=float), size.shape)
                    rel = abs_err / (size * condition)
                    worst = int(np.argmax(np.where(np.isnan(rel), np.inf, rel)))
                    results.append(OutputError(
                        name, arg.name, float(abs_err.max()), float(rel.max()), allowed,
                        float(abs_err[worst]), float(size[worst]), float(condition[worst]),
                    ))
    return results


def diffdrive_scenarios(derivation, cases: int, seed: int, precision: str) -> list[Scenario]:
    """Scenarios for a differential drive: rigid-body reference of :mod:`skelarm_sym.reference`."""
    dtype = np.float64 if precision == "double" else np.float32
    rounded = lambda x: np.asarray(x, dtype=dtype).astype(np.float64)  # noqa: E731
    rng = np.random.default_rng(seed)
    track = derivation.model.track if derivation.model.track is not None else float(rounded(rng.uniform(0.1, 2.0)))
    wheels = rounded(np.concatenate([rng.uniform(-2, 2, (cases, 2)), [[1.0, 1.0], [-1.0, 1.0], [0.0, 0.0]]]))
    rates = rounded(np.concatenate([rng.uniform(-2, 2, (cases, 2)), [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]]))
    pose = rounded(np.concatenate([rng.uniform(-np.pi, np.pi, (cases, 3)), np.zeros((3, 3))]))
    expected = {
        "rates": reference.diffdrive_body_rates(wheels, track),
        "wheels": reference.diffdrive_wheel_speeds(rates, track),
        "dpose": reference.diffdrive_pose_rate(pose, wheels, track),
    }
    values = {"wheels": wheels, "rates": rates, "pose": pose, "track": track}
    return [Scenario("", values, expected, {})]


def scenarios_for(derivation):
    """The scenario builder of ``derivation``'s model."""
    from .models.diffdrive import DiffDrive
    from .models.planar import PlanarArm

    if isinstance(derivation.model, PlanarArm):
        return planar_scenarios
    if isinstance(derivation.model, DiffDrive):
        return diffdrive_scenarios
    from .models.chain import Chain

    if isinstance(derivation.model, Chain):
        from .check_chain import chain_scenarios

        return chain_scenarios
    raise TypeError(f"no reference for model {derivation.model!r}")


def run_check(n, lengths: Sequence[float] | None = None, precision: str = "double", cases: int = 100, seed: int = 0, langs=("c", "python")) -> list[OutputError]:
    """Generate (in memory), compile, and compare; see :func:`compare`."""
    generated = generate(n, lengths=lengths, langs=langs, precision=precision, out=None)
    return compare(generated, cases=cases, seed=seed, precision=precision)


GENERATED_SUFFIXES = (".h", ".c", ".py")
_MARK = "generated by skelarm-sym"


@dataclass(frozen=True)
class LoadedFiles:
    """Files written earlier (``check --from``): ``generated`` holds the FILES' text with the programs
    and derivation regenerated from their recorded command; ``precision``, ``command`` (the recorded
    ``skelarm-sym generate ...``) and ``edited``, the files whose text differs from what this version
    generates (edited by hand, or generated by another version)."""

    generated: Generated
    precision: str
    command: str
    edited: tuple[str, ...]


def _read_head(path) -> str:
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            return handle.read(4000)
    except OSError:
        return ""


def load_generated(folder, prefix: str | None = None) -> LoadedFiles:
    """Read ``folder/prefix.{h,c,py}`` (those present), rebuild the model and options from the
    ``regenerate with:`` line of their header, regenerate in memory for the derivation and programs,
    and return the files' own text to be compiled and compared. ``prefix`` defaults to the only one in
    ``folder``. Raises InputError (one line) for a missing folder, no generated files, several prefixes
    and none chosen, or a header without the regenerate line."""
    import shlex
    from pathlib import Path

    from .errors import InputError
    from .generate import _RECORDED

    root = Path(folder)
    if not root.is_dir():
        raise InputError(f"--from {str(root)!r}: no such folder")
    found: dict[str, list[str]] = {}
    for path in sorted(root.iterdir()):
        if path.suffix in GENERATED_SUFFIXES and path.is_file() and _MARK in _read_head(path):
            found.setdefault(path.stem, []).append(path.name)
    if prefix is None:
        if not found:
            raise InputError(f"--from {str(root)!r}: no files generated by skelarm-sym (.h, .c or .py) in it")
        if len(found) > 1:
            raise InputError(f"--from {str(root)!r} holds files of several prefixes ({', '.join(sorted(found))}); choose one with --prefix")
        prefix = next(iter(found))
    elif prefix not in found:
        others = f" (it has {', '.join(sorted(found))})" if found else ""
        raise InputError(f"--from {str(root)!r}: no files generated by skelarm-sym with prefix {prefix!r}{others}")
    names = [prefix + s for s in GENERATED_SUFFIXES if prefix + s in found[prefix]]
    sources = {name: (root / name).read_text(encoding="utf-8") for name in names}
    command = None
    for name in names:
        match = _RECORDED.search(sources[name][:4000])
        if match is not None:
            command = match.group(1).strip()
            break
    if command is None or not command.startswith("skelarm-sym generate"):
        raise InputError(f"{root / names[0]}: no 'regenerate with: skelarm-sym generate ...' line in its header")
    if prefix + ".c" in sources and prefix + ".h" not in sources:
        raise InputError(f"{root / (prefix + '.c')} needs {prefix}.h beside it to compile")

    from .cli import build_parser, model_from_args
    from .generate import generate

    try:
        words = shlex.split(command)
    except ValueError:
        words = command.split()
    try:
        args = build_parser().parse_args(words[1:])
    except InputError as exc:
        raise InputError(f"{root / names[0]}: cannot read its recorded command ({command}): {exc}") from None
    if args.robot is not None and not Path(args.robot).exists() and (root / args.robot).exists():
        args.robot = str(root / args.robot)  # a robot file recorded relative to the folder of the files
    model = model_from_args(args)
    langs = tuple(lang for lang, suffix in (("c", ".c"), ("python", ".py")) if prefix + suffix in sources)
    if not langs:
        raise InputError(f"--from {str(root)!r}: only {names[0]} for prefix {prefix!r}; check needs its .c or .py")
    if args.prefix != prefix:
        raise InputError(f"{root / names[0]} records --prefix {args.prefix}, not {prefix}; was it renamed?")
    fresh = generate(model, langs=langs, prefix=args.prefix, precision=args.precision, out=None, functions=args.functions)
    edited = tuple(name for name in names if fresh.sources.get(name) != sources[name])
    return LoadedFiles(Generated(sources, fresh.programs, fresh.derivation), args.precision, command, edited)
