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
from .derive import Derivation
from .derive.core import ARGUMENT_RULE
from .errors import InputError
from .files import new_file_mode, write_atomically  # noqa: F401 - re-exported
from .models.chain import Chain
from .models.diffdrive import DiffDrive
from .models.planar import PlanarArm
from .names import C_RESERVED  # noqa: F401 - re-exported
from .program import Program, build_programs

PRECISIONS = ("double", "float")

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


def regenerate_command(
    model, options_prefix: str, precision: str, langs: Sequence[str], functions: Sequence[str] | None = None
) -> str:
    """The command line that emits the same files again (no output folder: it varies; no --cmake: it
    adds a file without changing the others)."""
    parts = ["skelarm-sym generate", *model.command_args()]
    parts += [f"--lang {','.join(langs)}", f"--prefix {options_prefix}", f"--precision {precision}"]
    if functions is not None:
        parts.append(f"--functions {','.join(functions)}")
    return " ".join(parts)


IK_SOLVE_NEEDS = ("position", "ik_step")
"""``ik_solve`` is emitted whenever these two are (it calls them)."""


def select_functions(derivation: Derivation, functions: str | Iterable[str] | None) -> tuple[str, ...] | None:
    """The derivation's function names to emit, in declaration order, for a ``--functions`` list
    (``None``: all). ``ik_solve`` brings ``position`` and ``ik_step``. InputError names the valid ones."""
    if functions is None:
        return None
    items = [x.strip() for x in functions.split(",")] if isinstance(functions, str) else [str(x).strip() for x in functions]
    items = [x for x in items if x]
    names = [f.name for f in derivation.functions]
    valid = names + (["ik_solve"] if all(n in names for n in IK_SOLVE_NEEDS) else [])
    unknown = [x for x in items if x not in valid]
    if unknown or not items:
        what = f"unknown function {unknown[0]!r}" if unknown else "no function named"
        raise InputError(f"{what}; choose from {', '.join(valid)}")
    wanted = set(items) | (set(IK_SOLVE_NEEDS) if "ik_solve" in items else set())
    return tuple(n for n in names if n in wanted)


def cmake_lists(prefix: str, command: str) -> str:
    """``CMakeLists.txt`` for the emitted C: a library target ``prefix`` (static unless
    ``{PREFIX}_SHARED`` or ``BUILD_SHARED_LIBS``), C99, linking the math library, exporting its folder."""
    upper = prefix.upper()
    return f"""# {prefix}: CMake target generated by skelarm-sym {__version__}. Do not edit;
# regenerate with: {command} --cmake
#
# add_subdirectory({prefix})  then  target_link_libraries(app PRIVATE {prefix})
cmake_minimum_required(VERSION 3.10)
project({prefix} LANGUAGES C)

option({upper}_SHARED "build {prefix} as a shared library (default: static)" ${{BUILD_SHARED_LIBS}})
if({upper}_SHARED)
  add_library({prefix} SHARED {prefix}.c {prefix}.h)
else()
  add_library({prefix} STATIC {prefix}.c {prefix}.h)
endif()
set_target_properties({prefix} PROPERTIES C_STANDARD 99 C_STANDARD_REQUIRED ON POSITION_INDEPENDENT_CODE ON)
target_include_directories({prefix} PUBLIC ${{CMAKE_CURRENT_SOURCE_DIR}})
find_library({upper}_MATH_LIBRARY m)
if({upper}_MATH_LIBRARY)
  target_link_libraries({prefix} PUBLIC ${{{upper}_MATH_LIBRARY}})  # sin, cos, sqrt (glibc's vector math too)
endif()
"""


_RECORDED = re.compile(r"regenerate with: (.*?)(?: --cmake)?\s*$", re.M)


def refuse_other_options(target: Path, sources: dict[str, str]) -> None:
    """InputError when a file about to be replaced was generated with other options (or not by skelarm-sym)."""
    for name, text in sources.items():
        path = target / name
        try:
            if not path.is_file():
                continue
            old = path.read_text(encoding="utf-8", errors="replace")[:4000]
        except OSError:
            continue
        before, after = _RECORDED.search(old), _RECORDED.search(text)
        if before is None:
            raise InputError(f"{path} exists and was not generated by skelarm-sym; pass --force (force=True) to replace it")
        if after is not None and before.group(1).strip() != after.group(1).strip():
            raise InputError(
                f"{path} was generated with other options ({before.group(1).strip()}); "
                "choose another --prefix or --out, or pass --force (force=True) to replace it"
            )


def derive_model(model, functions: str | Iterable[str] | None = None) -> Derivation:
    """The derivation of any supported model, through the model registry. ``functions`` (a
    ``--functions`` list or ``None``): the kind may leave out what none of them needs."""
    from .models.registry import derive

    wanted = None if functions is None else (
        [x.strip() for x in functions.split(",")] if isinstance(functions, str) else [str(x).strip() for x in functions]
    )
    return derive(model, wanted)


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
    functions: str | Iterable[str] | None = None,
    cmake: bool = False,
    force: bool = False,
) -> Generated:
    """Emit specialised code for an arm of ``n`` links.

    Args:
        n: number of links, or a model (:class:`PlanarArm`, :class:`DiffDrive`).
        lengths: ``None`` (lengths are a run-time argument ``l``) or ``n`` numbers baked in as constants.
        langs: ``"c"``, ``"python"`` or both (a comma-separated string or a sequence).
        prefix: name of the files and prefix of C functions; default ``arm{n}`` (``diffdrive``).
        precision: ``"double"`` or ``"float"``.
        out: folder to write to (created if missing), or ``None`` to only return the sources.
        functions: names of the functions to emit (a comma-separated string or a sequence; default all);
            ``ik_solve`` brings ``position`` and ``ik_step``, and comes whenever both are emitted.
        cmake: also write ``CMakeLists.txt`` (a library target named ``prefix``; needs lang ``c``).
        force: replace files that were generated with other options (by default that is refused).

    Raises :class:`~skelarm_sym.errors.InputError` (a ``ValueError``) on bad input;
    on any error no file is left behind.
    """
    model = n if isinstance(n, (PlanarArm, DiffDrive, Chain)) else PlanarArm(n, None if lengths is None else _lengths_tuple(lengths))
    prefix = validate_prefix(model.default_prefix if prefix is None else prefix)
    precision = validate_precision(precision)
    getattr(model, "check_representable", lambda precision: None)(precision)  # parameters the precision cannot hold
    langs = validate_langs(langs)
    if "python" in langs:
        validate_module_name(prefix)
    target = _check_output_folder(out) if out is not None else None

    if cmake and "c" not in langs:
        raise InputError("--cmake builds the C: generate with lang 'c'")

    derivation = derive_model(model, functions)
    selected = select_functions(derivation, functions)
    programs = tuple(build_programs(derivation, selected))
    command = regenerate_command(model, prefix, precision, langs, selected)
    header = (
        f"{prefix}: differential kinematics generated by skelarm-sym {__version__}. Do not edit;",
        f"regenerate with: {command}",
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
    if cmake:
        sources["CMakeLists.txt"] = cmake_lists(prefix, command)
    paths: tuple[Path, ...] = ()
    if target is not None:
        if not force:
            refuse_other_options(target, sources)
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
