"""Model + options -> emitted files: the one entry point for code emission.

``generate(n, lengths=None, langs=("c", "python"), prefix=None, precision="double", out="generated")``
derives the model, builds one optimised program per function, renders each
backend's templates and writes ``{out}/{prefix}.h``, ``{prefix}.c`` and
``{prefix}.py`` atomically (each file goes to a temporary name first and is
renamed into place only after every file rendered). With ``out=None`` it writes
nothing and returns the sources.
"""

from __future__ import annotations

import keyword
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

from . import __version__
from .backends import BACKENDS
from .derive import Derivation, derive, derive_diffdrive
from .derive.core import ARGUMENT_RULE
from .errors import InputError
from .files import new_file_mode, write_atomically  # noqa: F401 - re-exported
from .models.diffdrive import DiffDrive
from .models.planar import PlanarArm
from .program import Program, build_programs

PRECISIONS = ("double", "float")

C_RESERVED = frozenset(
    """auto break case char const continue default do double else enum extern float for goto if inline int long
    register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while
    _Bool _Complex _Imaginary _Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert _Thread_local
    alignas alignof and bool catch class compl constexpr decltype delete explicit export false friend mutable
    namespace new noexcept not nullptr operator or private protected public template this throw true try typeid
    typename using virtual wchar_t xor asm main errno math sin cos sqrt""".split()
)
"""Words a prefix may not be: C99 and C++ keywords, and names the emitted code itself relies on."""
_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,47}")


def validate_prefix(prefix: object) -> str:
    """Return ``prefix`` if it is a safe C identifier and Python module name, else raise InputError."""
    if not isinstance(prefix, str) or not _IDENTIFIER.fullmatch(prefix):
        raise InputError(
            f"prefix must be a C identifier (a letter, then letters, digits or _; at most 48 characters), got {prefix!r}"
        )
    if prefix in C_RESERVED or keyword.iskeyword(prefix) or prefix.lower() in {"numpy", "np"}:
        raise InputError(f"prefix {prefix!r} is a reserved word; choose another")
    return prefix


def validate_module_name(prefix: str) -> str:
    """``prefix`` if ``{prefix}.py`` would not shadow a Python standard module, else InputError."""
    if prefix in sys.stdlib_module_names:
        raise InputError(
            f"prefix {prefix!r} is a Python standard module: {prefix}.py would shadow it; choose another"
        )
    return prefix


def validate_langs(langs: str | Iterable[str]) -> tuple[str, ...]:
    """Languages as a tuple in canonical order; raise InputError on an unknown one."""
    items = [x.strip() for x in langs.split(",")] if isinstance(langs, str) else [str(x).strip() for x in langs]
    items = [x for x in items if x]
    if not items:
        raise InputError(f"choose at least one language from {', '.join(BACKENDS)}")
    unknown = [x for x in items if x not in BACKENDS]
    if unknown:
        raise InputError(f"unknown language {unknown[0]!r}; choose from {', '.join(BACKENDS)}")
    return tuple(name for name in BACKENDS if name in items)


def validate_precision(precision: object) -> str:
    """``precision`` if it is ``double`` or ``float``, else raise InputError."""
    if precision not in PRECISIONS:
        raise InputError(f"unknown precision {precision!r}; choose double or float")
    return precision


@dataclass(frozen=True)
class Options:
    """Validated generation options; ``header_lines`` open every emitted file."""

    prefix: str
    precision: str
    langs: tuple[str, ...]
    header_lines: tuple[str, ...]


def regenerate_command(model, options_prefix: str, precision: str, langs: Sequence[str]) -> str:
    """The command line that emits the same files again (no output folder: it varies)."""
    parts = ["skelarm-sym generate", *model.command_args()]
    parts += [f"--lang {','.join(langs)}", f"--prefix {options_prefix}", f"--precision {precision}"]
    return " ".join(parts)


def derive_model(model) -> Derivation:
    """The derivation of any supported model (the one place that knows them all)."""
    if isinstance(model, PlanarArm):
        return derive(model)
    if isinstance(model, DiffDrive):
        return derive_diffdrive(model)
    raise InputError(f"unsupported model {model!r}")


@dataclass(frozen=True)
class Generated:
    """Result of :func:`generate`: file name -> text, the programs, and where files went (if written)."""

    sources: dict[str, str]
    programs: tuple[Program, ...]
    derivation: Derivation
    paths: tuple[Path, ...] = ()


def generate(
    n: int | PlanarArm | DiffDrive,
    lengths: Sequence[float] | None = None,
    langs: str | Iterable[str] = ("c", "python"),
    prefix: str | None = None,
    precision: str = "double",
    out: str | os.PathLike | None = "generated",
) -> Generated:
    """Emit specialised code for an arm of ``n`` links.

    Args:
        n: number of links, or a model (:class:`PlanarArm`, :class:`DiffDrive`).
        lengths: ``None`` (lengths are a run-time argument ``l``) or ``n`` numbers baked in as constants.
        langs: ``"c"``, ``"python"`` or both (a comma-separated string or a sequence).
        prefix: name of the files and prefix of C functions; default ``arm{n}`` (``diffdrive``).
        precision: ``"double"`` or ``"float"``.
        out: folder to write to (created if missing), or ``None`` to only return the sources.

    Raises :class:`~skelarm_sym.errors.InputError` (a ``ValueError``) on bad input;
    on any error no file is left behind.
    """
    model = n if isinstance(n, (PlanarArm, DiffDrive)) else PlanarArm(n, None if lengths is None else _lengths_tuple(lengths))
    prefix = validate_prefix(model.default_prefix if prefix is None else prefix)
    precision = validate_precision(precision)
    getattr(model, "check_representable", lambda precision: None)(precision)  # parameters the precision cannot hold
    langs = validate_langs(langs)
    if "python" in langs:
        validate_module_name(prefix)
    target = _check_output_folder(out) if out is not None else None

    derivation = derive_model(model)
    programs = tuple(build_programs(derivation))
    header = (
        f"{prefix}: differential kinematics generated by skelarm-sym {__version__}. Do not edit;",
        f"regenerate with: {regenerate_command(model, prefix, precision, langs)}",
        "",
        *derivation.notes,
        *wrap_line(ARGUMENT_RULE),
        f"Precision: {precision}.",
    )
    options = Options(prefix, precision, langs, header)
    sources: dict[str, str] = {}
    for lang in langs:
        for suffix, text in BACKENDS[lang].render(derivation, list(programs), options).items():
            sources[prefix + suffix] = text
    paths: tuple[Path, ...] = ()
    if target is not None:
        paths = write_atomically(target, sources)
    return Generated(sources, programs, derivation, paths)


def wrap_line(text: str, width: int = 100) -> list[str]:
    """``text`` broken at spaces into lines of at most ``width`` characters (for file headers)."""
    import textwrap

    return textwrap.wrap(text, width) or [""]


def _lengths_tuple(lengths: object) -> object:
    if isinstance(lengths, str):
        return parse_lengths(lengths)
    try:
        return tuple(lengths)  # type: ignore[arg-type]
    except TypeError:
        raise InputError(f"link lengths must be a sequence of numbers, got {lengths!r}") from None


def parse_numbers(text: str, what: str) -> tuple[float, ...]:
    """``"1.0,0.8,0.5"`` -> ``(1.0, 0.8, 0.5)``; raise InputError (naming ``what``) on anything else."""
    values = []
    for item in text.split(","):
        try:
            values.append(float(item))
        except ValueError:
            raise InputError(f"{what} must be comma-separated numbers, got {item.strip()!r}") from None
    return tuple(values)


def parse_lengths(text: str) -> tuple[float, ...]:
    """``"1.0,0.8,0.5"`` -> ``(1.0, 0.8, 0.5)``; raise InputError on anything else."""
    return parse_numbers(text, "link lengths")


def _check_output_folder(out: str | os.PathLike) -> Path:
    target = Path(out)
    try:
        exists, is_folder = target.exists(), target.is_dir()
    except OSError as exc:  # ENAMETOOLONG, EACCES on a parent, ...
        raise InputError(f"cannot use output folder {str(target)!r}: {exc.strerror or exc}") from None
    if exists and not is_folder:
        raise InputError(f"output folder {str(target)!r} exists and is not a folder")
    return target
