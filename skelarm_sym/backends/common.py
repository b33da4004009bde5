"""What every backend shares: storage names for a program's symbols, printer behaviour, templates."""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Callable

import jinja2
import sympy as sp

from ..program import Program

ANGLES, COSINES, SINES = "ang", "cs", "sn"
"""Array names of the trigonometric block inside emitted functions."""

def default_ik_tol(precision: str, reach: float) -> float:
    """The planar IK's default tolerance: ``IK_SETTINGS[precision]["tol"]`` times the reach (at least 1),
    since rounding at the endpoint grows with the arm's size (float at a reach of 1500: about 2e-4)."""
    return IK_SETTINGS[precision]["tol"] * max(1.0, float(reach))


IK_STATUS = ("CONVERGED", "STALLED", "MAX_ITER", "INVALID")
"""Outcomes of the emitted IK solvers, in order from 0 (C return codes; lower case in Python)."""
IK_SETTINGS = {
    "double": {"tol": 1e-9, "halvings": 30, "stall": 1e-10, "error_damping": 0.5, "shrink": 1 / 3, "c_min": 1e-4, "c_max": 1e4, "probe": 1e-2},
    "float": {"tol": 1e-4, "halvings": 20, "stall": 1e-6, "error_damping": 0.5, "shrink": 1 / 3, "c_min": 1e-4, "c_max": 1e4, "probe": 1e-2},
}
"""Per precision: step halvings tried per iteration; the relative error improvement below
which the solver reports STALLED; and the damping schedule ``mu = max(lambda, c |e|)``:
damping that shrinks with the error (bounded steps near singular poses, fast convergence at
reachable targets, progress to the closest reach of unreachable ones), with ``c`` starting at
``error_damping``, multiplied by ``shrink`` after a full step and doubled per halving, kept
in ``[c_min, c_max]`` (Levenberg-Marquardt); ``tol``, the default tolerance (one float reaches);
``probe``, the joint offset (radians) tried one joint at a time, both signs, when no damped
step lowers the error (a stationary point such as the stretched pose facing a target behind
it): the best probe is taken if it lowers the error, else the solver reports STALLED."""


def storage_names(
    program: Program,
    element: str = "{name}[{index}]",
    temporary: str = "t{index}",
    identifier: Callable[[str], str] = str,
    constant: str = "{name}",
) -> dict[sp.Symbol, str]:
    """Map each symbol of ``program`` to the text that names it in emitted code.

    Inputs become array elements (``q[2]``) or, for scalars, the argument itself;
    angles and their cosines/sines elements of the trigonometric arrays; constants
    ``constant`` formatted with their name; every other temporary a numbered local.
    ``identifier`` turns an input name into a legal argument name of the language.
    """
    names: dict[sp.Symbol, str] = {}
    for arg in program.inputs:
        if arg.is_scalar:
            names[arg.elements[0]] = identifier(arg.name)
            continue
        for i, symbol in enumerate(arg.elements):
            names[symbol] = element.format(name=identifier(arg.name), index=i)
    for const in program.constants:
        names[const.symbol] = constant.format(name=const.name)
    for array, symbols in ((ANGLES, program.angles), (COSINES, program.cos), (SINES, program.sin)):
        for k, symbol in enumerate(symbols):
            names[symbol] = element.format(name=array, index=k)
    for symbol in program.temporaries:
        names[symbol] = temporary.format(index=program.numbers[symbol])
    return names


class MemoPrinter:
    """Prints expressions through ``printer``, once per distinct (expression, names of its symbols).

    Functions of one derivation share most statements; printing each once keeps
    generation time linear in n rather than in n times the number of functions.
    Use one instance per rendered file: every printer it sees then has the same
    language and precision, so those need not be part of the key.
    """

    def __init__(self) -> None:
        self._cache: dict = {}

    def __call__(self, printer, names: dict[sp.Symbol, str], expr: sp.Expr) -> str:
        key = (expr, tuple(sorted((s.name, names[s]) for s in expr.free_symbols)))
        text = self._cache.get(key)
        if text is None:
            text = self._cache[key] = printer._print(expr)
        return text


class ArrayPrinterMixin:
    """Printer behaviour shared by the backends; subclasses set ``literal`` and the ``pow_forms`` table.

    * symbols print as their storage (``q[2]``, ``t7``) from the ``names`` table;
    * numbers print as literals of the target precision;
    * sums print positive terms first (``z - x*y``, not ``-x*y + z``);
    * powers with small exponents print by table (``x*x``, ``1/x``, ``sqrt(x)``);
    * ``Piecewise`` prints by ``select_form`` (a C conditional, ``np.where``).
    """

    pow_forms: dict[sp.Expr, str] = {
        sp.Integer(2): "{base}*{base}",
        sp.Integer(-1): "{one}/{base}",
        sp.Integer(-2): "{one}/({base}*{base})",
        sp.Rational(1, 2): "{sqrt}({base})",
        sp.Rational(-1, 2): "{one}/{sqrt}({base})",
    }
    sqrt_name = "sqrt"
    select_form = "({cond} ? {then} : {otherwise})"

    def __init__(self, names: dict[sp.Symbol, str], **settings) -> None:
        super().__init__(settings)
        self._names = names

    def literal(self, value: float) -> str:  # pragma: no cover - overridden
        raise NotImplementedError

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        try:
            return self._names[expr]
        except KeyError:
            raise ValueError(f"internal error: symbol {expr} has no storage") from None

    def _print_Integer(self, expr: sp.Integer) -> str:
        return self.literal(float(expr))

    _print_Float = _print_Rational = _print_Integer
    _print_One = _print_Zero = _print_NegativeOne = _print_Half = _print_Integer

    def parenthesize(self, item, level, strict=False):
        if isinstance(item, sp.Number) and not item.is_negative:  # a literal never needs parentheses
            return self._print(item)
        return super().parenthesize(item, level, strict)

    def _as_ordered_terms(self, expr, order=None):
        terms = list(expr.args)
        terms.sort(key=lambda t: (t.could_extract_minus_sign(), sp.default_sort_key(t)))
        return terms

    def _print_Piecewise(self, expr: sp.Piecewise) -> str:
        *pieces, (last, last_cond) = expr.args
        if last_cond is not sp.true:
            raise ValueError("internal error: Piecewise needs a final True branch")
        text = self._print(last)
        for value, cond in reversed(pieces):
            text = self.select_form.format(cond=self._print(cond), then=self._print(value), otherwise=text)
        return text

    def _print_Pow(self, expr: sp.Pow, rational: bool = False) -> str:
        base, exp = expr.args
        form = self.pow_forms.get(exp)
        if form is None:
            raise ValueError(f"internal error: no form for power {exp}")
        base_text = self.parenthesize(base, sp.printing.precedence.PRECEDENCE["Mul"], strict=True)
        return form.format(base=base_text, one=self.literal(1.0), sqrt=self.sqrt_name)


@lru_cache(maxsize=1)
def _environment() -> jinja2.Environment:
    try:
        folder = Path(str(resources.files("skelarm_sym.templates")))
    except ModuleNotFoundError:  # running from a source checkout: templates/ beside the package
        folder = Path(__file__).resolve().parents[2] / "templates"
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(folder)),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )


def render_template(name: str, **context) -> str:
    """Render template ``name`` from ``templates/`` with ``context``."""
    return _environment().get_template(name).render(**context)


def pad(count: int, lanes: int) -> int:
    """``count`` rounded up to a multiple of ``lanes`` (at least ``lanes``)."""
    return max(lanes, -(-count // lanes) * lanes)
