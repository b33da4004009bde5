"""Model + options -> emitted files: the one entry point for code emission.

``generate(model, langs=("c", "python"), prefix=None, precision="double", out="generated", ...)`` derives
the model (through its kind in :mod:`skelarm_sym.models.registry`), builds one IR module
(:func:`skelarm_sym.assemble.build_module`), renders every chosen backend, stamps the set and writes
``{out}/{prefix}.h``, ``{prefix}.c``, ``{prefix}.py`` (and ``CMakeLists.txt`` with ``cmake``) atomically:
each file goes to a temporary name first and is renamed into place only after every file rendered. With
``out=None`` it writes nothing and returns the sources.
"""

from __future__ import annotations

import hashlib
import numbers
import os
import re
import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, Sequence

from . import __version__
from .assemble import build_module, function_items, select_functions, wanted_functions
from .backends import BACKENDS
from .backends.templating import render_template
from .backends.text import unescape
from .derive import Derivation
from .errors import InputError
from .files import new_file_mode, write_atomically  # noqa: F401 - re-exported
from .ir.nodes import Function, Module
from .models.planar import PlanarArm
from .models.registry import kind_of
from .names import (C_RESERVED, CMAKE_KEYWORDS, CMAKE_RESERVED, IMPORTED_MODULES, PYTHON_MODULES,  # noqa: F401 - re-exported
                    cmake_reserved, reserved_prefix, standard_header)

PRECISIONS = ("double", "float")
LANGUAGE_ALIASES = {"numpy": "python", "py": "python"}
"""Other names of a language (``--lang numpy`` and ``--lang py`` are ``python``)."""

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,47}")


def validate_prefix(prefix: object) -> str:
    """Return ``prefix`` if it is a safe C identifier and Python module name, else raise InputError."""
    if not isinstance(prefix, str) or not _IDENTIFIER.fullmatch(prefix):
        raise InputError(
            f"prefix must be a C identifier (a letter, then letters, digits or _; at most 48 characters), got {prefix!r}"
        )
    if reserved_prefix(prefix):
        raise InputError(f"prefix {prefix!r} is a reserved word; choose another")
    return prefix


def validate_module_name(prefix: str) -> str:
    """``prefix`` if ``{prefix}.py`` would not shadow a Python standard module or a module the emitted Python imports
    (:data:`~.names.IMPORTED_MODULES`: ``torch.py`` beside ``torch_torch.py``), else InputError."""
    if prefix in PYTHON_MODULES:
        raise InputError(
            f"prefix {prefix!r} is a Python standard module: {prefix}.py would shadow it; choose another"
        )
    if prefix.lower() in IMPORTED_MODULES:
        raise InputError(f"prefix {prefix!r} is a module the emitted Python imports: {prefix}.py would shadow it; "
                         "choose another")
    return prefix


def validate_header_name(prefix: str) -> str:
    """``prefix`` if ``{prefix}.h`` would not be read for a standard C header, else InputError."""
    if standard_header(prefix):
        raise InputError(f"prefix {prefix!r} names a C system header: {prefix}.h would be read for "
                         f"<{prefix.lower()}.h> wherever its folder is on the include path; choose another")
    return prefix


def validate_cmake_target(prefix: str) -> str:
    """``prefix`` if CMake takes it as the name of the library target ``CMakeLists.txt`` defines, else InputError."""
    if not cmake_reserved(prefix):  # the one rule (names.py); the messages below say which part of it
        return prefix
    if prefix.lower() in CMAKE_RESERVED:
        raise InputError(f"prefix {prefix!r} with --cmake: CMake reserves the target name {prefix!r} (or it is the math "
                         "library the target links); choose another --prefix")
    if prefix in CMAKE_KEYWORDS:
        raise InputError(f"prefix {prefix!r} with --cmake: it is a keyword of the CMake commands the target is passed "
                         "to; choose another --prefix")
    raise InputError(f"prefix {prefix!r} with --cmake: its variables ({prefix.upper()}_SHARED) would be CMake's own "
                     "(CMAKE_*); choose another --prefix")


def validate_langs(langs: str | Iterable[str]) -> tuple[str, ...]:
    """Languages as a tuple in canonical order; raise InputError on an unknown one."""
    names = langs.split(",") if isinstance(langs, str) else list(langs) if isinstance(langs, Iterable) else None
    if names is None or not all(isinstance(x, str) for x in names):
        raise InputError(f"langs must be a comma-separated string or a sequence of language names, got {langs!r}")
    items = [x.strip() for x in names]
    items = [LANGUAGE_ALIASES.get(x, x) for x in items if x]
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


def _shell_word(word: str) -> str:
    """``shlex.quote(word)`` with ``??``, ``*/`` and ``/*`` split by an empty quote pair (``'tip?''?'``): the same
    word to a shell, and nothing a C comment must escape (a trigraph, a comment's end or start), so that the
    command in a header runs as printed. (A backslash or a character outside printable ASCII is still written
    escaped there, ``\\\\`` or ``\\uXXXX``: no shell word spells those without a backslash.)"""
    quoted = shlex.quote(word)
    if quoted.startswith("'"):
        quoted = re.sub(r"\?(?=\?)", "?''", quoted).replace("*/", "*''/").replace("/*", "/''*")
    return quoted


def regenerate_command(model, prefix: str, precision: str, langs: Sequence[str], functions: Sequence[str] | None = None,
                       folder: str | os.PathLike | None = None, cmake: bool = False) -> str:
    """The command line that emits the same files again when run in ``folder`` (where they are written):
    every option that shapes them (``--cmake`` too: the set's stamp covers ``CMakeLists.txt``), the robot
    file relative to that folder, ``--out .``."""
    words = ["skelarm-sym", "generate", *model.command_args(None if folder is None else str(folder))]
    words += ["--lang", ",".join(langs), "--prefix", prefix, "--precision", precision]
    if functions is not None:
        words += ["--functions", ",".join(functions)]
    if cmake:
        words += ["--cmake"]
    if folder is not None:
        words += ["--out", "."]
    return " ".join(_shell_word(w) for w in _joined_values(words))


_SWITCHES = frozenset({"--cmake"})
"""The recorded options that take no value."""


def _joined_values(words: Sequence[str]) -> list[str]:
    """``words`` with each option whose value starts with ``-`` written ``--option=value``: a link named ``--base``
    or a robot file ``--cmake.toml`` would otherwise be read back as an option (``expected one argument``)."""
    out: list[str] = []
    i = 0
    while i < len(words):
        word = words[i]
        if word.startswith("--") and word not in _SWITCHES and i + 1 < len(words) and words[i + 1].startswith("-"):
            out.append(f"{word}={words[i + 1]}")
            i += 2
        else:
            out.append(word)
            i += 1
    return out


_RECORDED = re.compile(r"regenerate with \(in this folder\): (.*?)\s*$", re.M)


def recorded_command(text: str) -> str | None:
    """The command recorded in the header of an emitted file (unescaped), or ``None``."""
    match = _RECORDED.search(text[:6000])
    if match is None:
        return None
    return unescape(match.group(1).strip())


def _words(command: str) -> list[str] | str:
    """A recorded command as the words a shell reads (two quotings of one word compare equal), else as it is."""
    try:
        return shlex.split(command)
    except ValueError:
        return command


def _head(path: Path) -> str | None:
    """The first 6000 characters of the file ``path``, or None when there is no such file (or it cannot be read)."""
    try:
        if not path.is_file():
            return None
        return path.read_text(encoding="utf-8", errors="replace")[:6000]
    except OSError:
        return None


def _recorded_in(path: Path) -> str | None:
    """The command recorded in the file ``path``, or None (no such file, or not one skelarm-sym wrote)."""
    head = _head(path)
    return None if head is None else recorded_command(head)


def _recorded_before(path: Path) -> str | None:
    """The command recorded in the file ``path`` (None when there is no such file); InputError when the file
    exists and was not generated by skelarm-sym."""
    head = _head(path)
    if head is None:
        return None
    before = recorded_command(head)
    if before is None:
        raise InputError(f"{path} exists and was not generated by skelarm-sym; pass --force (force=True) to replace it")
    return before


def written_by_skelarm_sym(path: Path) -> bool:
    """Whether the file ``path`` exists and its header records the command that made it."""
    head = _head(path)
    return head is not None and recorded_command(head) is not None


def refuse_foreign_files(target: Path, names: Sequence[str]) -> None:
    """InputError for the first file of ``names`` in ``target`` that skelarm-sym did not write (``--force`` aside,
    generate replaces only its own files)."""
    for name in names:
        _recorded_before(target / name)


def _other_options(path: Path, before: str, command: str | None = None) -> InputError:
    owner = recorded_prefix(before)
    if command is not None and path.name == "CMakeLists.txt" and owner is not None and owner != recorded_prefix(command):
        return InputError(f"{path} belongs to prefix {owner!r} ({before}): a folder holds one CMakeLists.txt; "
                          "generate into another --out, or pass --force (force=True) to replace it")
    return InputError(f"{path} was generated with other options ({before}); "
                      "choose another --prefix or --out, or pass --force (force=True) to replace it")


def refuse_other_options(target: Path, sources: dict[str, str]) -> None:
    """InputError when a file about to be replaced was generated with other options (or not by skelarm-sym)."""
    for name, text in sources.items():
        path = target / name
        before, after = _recorded_before(path), recorded_command(text)
        if before is not None and after is not None and _words(before) != _words(after):
            raise _other_options(path, before, after)


def _without_functions(words: list[str] | str) -> list[str] | str:
    """A recorded command's words without the ``--functions`` value (its presence kept)."""
    if isinstance(words, str) or "--functions" not in words:
        return words
    i = words.index("--functions")
    return words[: i + 1] + words[i + 2:]


def _flag_value(words: list[str] | str, flag: str) -> str | None:
    """The word after ``flag`` in a recorded command's words, or ``None`` when it has none."""
    if isinstance(words, str) or flag not in words:
        return None
    i = words.index(flag) + 1
    return words[i] if i < len(words) else None


def _recorded_functions(words: list[str] | str) -> frozenset[str] | None:
    """The function names of a recorded command's ``--functions`` value, or ``None`` when it has none."""
    value = _flag_value(words, "--functions")
    return None if value is None else frozenset(value.split(","))


def refuse_before_deriving(target: Path, names: Sequence[str], command: str, wanted: frozenset[str] | None = None) -> None:
    """The refusals of :func:`refuse_other_options` that need no derivation, made before it (a large chain's
    derivation takes seconds): a file of the set that skelarm-sym did not write, or one recorded with other
    options. ``command``: the command to record, with any function list as a placeholder (the derivation settles
    the list, which :func:`refuse_other_options` compares afterwards); a file recorded with a function list where
    the new one has none, or the reverse, differs already. ``wanted``: the functions the new list asks for with the
    ones its solvers need; fewer than a file records differ already (names the file does not record wait for the
    derivation, which says whether they exist)."""
    new = _without_functions(_words(command))
    for name in names:
        path = target / name
        before = _recorded_before(path)
        if before is None:
            continue
        recorded = _recorded_functions(_words(before))
        if _without_functions(_words(before)) != new or (wanted is not None and recorded is not None and wanted < recorded):
            raise _other_options(path, before, command)


def recorded_prefix(command: str) -> str | None:
    """The ``--prefix`` value of a recorded command, or ``None``."""
    return _flag_value(_words(command), "--prefix")


def set_leftovers(target: Path, prefix: str, names: Sequence[str]) -> list[tuple[Path, str]]:
    """Files in ``target`` of an earlier set of ``prefix`` that the new set (its file ``names``) does not write:
    another language's files (``{prefix}.py`` beside a new C-only set), or a ``CMakeLists.txt`` the new set has
    no more; each with the command it records. Only files skelarm-sym wrote for this prefix count (their header
    records ``--prefix {prefix}``): a file named alike by hand, or another prefix's file whose name happens to
    end the same way, is left alone. Left in place, such a file would make a mixed set (``check --from``
    refuses one, and its stamp names another generation)."""
    candidates = sorted({prefix + suffix for backend in BACKENDS.values() for suffix in backend.FILE_SUFFIXES}
                        | {"CMakeLists.txt"})
    found = []
    for name in candidates:
        if name in names:
            continue
        path = target / name
        before = _recorded_in(path)
        if before is not None and recorded_prefix(before) == prefix:
            found.append((path, before))
    return found


def refuse_case_twins(target: Path, prefix: str) -> None:
    """InputError when ``target`` holds a file skelarm-sym generated for a prefix that differs from ``prefix`` in case
    only (``Arm`` beside ``arm``): a case-insensitive file system (macOS, Windows) takes their files for one, and C
    headers of both would take one include guard and one set of macros (``ARM_H``, ``ARM_Q_MAX``), so a program
    including both silently loses the second. (``--force`` does not lift it: the files are another set's.)"""
    if not target.is_dir():
        return
    suffixes = sorted({suffix for backend in BACKENDS.values() for suffix in backend.FILE_SUFFIXES}, key=len, reverse=True)
    try:
        entries = sorted(target.iterdir())
    except OSError:
        return
    for path in entries:
        suffix = next((x for x in suffixes if path.name.endswith(x)), None)
        other = path.name[: -len(suffix)] if suffix else ""
        if not other or other == prefix or other.lower() != prefix.lower():
            continue
        recorded = _recorded_in(path)
        if recorded is not None and recorded_prefix(recorded) == other:
            raise InputError(f"{path} is of prefix {other!r}, which differs from {prefix!r} in case only: a "
                             "case-insensitive file system takes their files for one, and their C headers would share "
                             f"the guard and macros {prefix.upper()}_...; choose another --prefix or --out")


def refuse_leftovers(leftovers: Sequence[tuple[Path, str]], prefix: str) -> None:
    """InputError naming the first file of an earlier set that the new one would leave beside it."""
    if leftovers:
        path, before = leftovers[0]
        raise InputError(f"{path} is from an earlier set of {prefix!r} generated with other options ({before}); the new "
                         "set has no such file: choose another --prefix or --out, or pass --force (force=True) to replace "
                         "the set (that file is removed)")


@dataclass(frozen=True)
class Generated:
    """Result of :func:`generate`: file name -> text, the IR module, the derivation, and where files went."""

    sources: dict[str, str]
    module: Module
    derivation: Derivation
    paths: tuple[Path, ...] = ()

    @property
    def model(self):
        return self.derivation.model

    @property
    def programs(self) -> tuple[Function, ...]:
        """The straight-line functions (each also has a batch variant)."""
        return tuple(f for f in self.module.functions if f.kind == "straight")

    @property
    def functions(self) -> tuple[Function, ...]:
        """Every public function: straight-line ones and solvers."""
        return self.module.public

    @property
    def stamp(self) -> str:
        """The generation stamp every file of the set carries."""
        return file_stamp(next(iter(self.sources.values()))) or ""

    def extension_source(self) -> str:
        """The text of ``{prefix}.ext.c`` (the CPython extension of :mod:`skelarm_sym.backends.cpython`) for
        this set's C, carrying its stamp: :func:`skelarm_sym.build.compile_arm` builds it when the set has
        no such file."""
        from .backends.cpython import render_extension

        return render_extension(self.module, self.stamp + "UL")


STAMP_PLACEHOLDER = "@SKELARM_STAMP@"
_STAMP = re.compile(r"STAMP(?: != | = | )(0x[0-9a-f]{8})")


def file_stamp(text: str) -> str | None:
    """The generation stamp written in an emitted file (C: ``X_STAMP 0x...UL``, Python: ``STAMP = 0x...``), or ``None``."""
    match = _STAMP.search(text)
    return match.group(1) if match else None


def cmake_version(version: str) -> str:
    """The numeric ``major.minor.patch`` CMake's ``project(VERSION)`` accepts, from a Python package version
    (``0.4.0``, ``0.5.0.dev3+g1234``, ``1.0rc1`` -> ``0.4.0``, ``0.5.0``, ``1.0.0``)."""
    leading = re.match(r"\d+(?:\.\d+){0,2}", version)
    parts = leading.group(0).split(".") if leading else ["0"]
    return ".".join(parts + ["0"] * (3 - len(parts)))


def render_all(module: Module, langs: Sequence[str], cmake: bool) -> dict[str, str]:
    """Every file of the set, stamped: the stamp is a hash of all their texts, so each file names the
    set it belongs to (C refuses to compile a mismatched pair; ``check --from`` refuses a mixed set;
    the CMake target checks the header)."""
    texts: dict[str, str] = {}
    for lang in langs:
        unsupported = [f for f in module.functions if f.kind in ("straight", "procedure") and f.kind not in BACKENDS[lang].SUPPORTS]
        if unsupported:  # never dropped silently
            kinds = " and ".join(sorted({f.kind for f in unsupported}))
            raise InputError(f"--lang {lang} does not print {kinds} functions ({', '.join(f.name for f in unsupported)}): "
                             "leave them out with --functions, or choose another language")
        for suffix, text in BACKENDS[lang].render(module, STAMP_PLACEHOLDER).items():
            texts[module.prefix + suffix] = text
    if cmake:
        version = cmake_version(__version__)
        texts["CMakeLists.txt"] = render_template("cmake/CMakeLists.txt.j2", prefix=module.prefix, P=module.prefix.upper(),
                                                  command=module.command, stamp=STAMP_PLACEHOLDER, version=version,
                                                  version_mm=".".join(version.split(".")[:2]))
    digest = hashlib.sha256()
    for name in sorted(texts):
        digest.update(name.encode() + b"\0" + texts[name].encode() + b"\0")
    stamp = "0x" + digest.hexdigest()[:8]
    out = {}
    for name, text in texts.items():
        suffix_c = name.endswith((".h", ".c"))
        out[name] = text.replace(STAMP_PLACEHOLDER, stamp + ("UL" if suffix_c else ""))
    return out


def generate(
    n: int | object,
    lengths: Sequence[float] | None = None,
    langs: str | Iterable[str] = ("c", "python"),
    prefix: str | None = None,
    precision: str = "double",
    out: str | os.PathLike | None = "generated",
    functions: str | Iterable[str] | None = None,
    cmake: bool = False,
    force: bool = False,
    recorded_folder: str | os.PathLike | None = None,
    before_writing: Callable[[Generated], object] | None = None,
) -> Generated:
    """Emit specialised code for a model.

    Args:
        n: a model (:class:`PlanarArm`, :class:`DiffDrive`, a chain from :func:`skelarm_sym.load_robot`) or a
            number of planar links.
        lengths: planar links only: ``None`` (lengths are a run-time argument ``l``) or ``n`` numbers baked in.
        langs: languages of :data:`skelarm_sym.backends.BACKENDS` (``"c"``, ``"python"``): a comma-separated
            string or a sequence.
        prefix: name of the files and prefix of C functions; default the model's (``arm{n}``, ``diffdrive``,
            the robot's name).
        precision: ``"double"`` or ``"float"``.
        out: folder to write to (created if missing), or ``None`` to only return the sources.
        functions: names of the functions to emit (a comma-separated string or a sequence; default all); a
            solver (``ik_solve``) brings the functions it calls.
        cmake: also write ``CMakeLists.txt`` (a library target named ``prefix``; needs lang ``c``).
        force: replace files that were generated with other options (by default that is refused), and remove
            the files of an earlier set of the same prefix that the new set does not have (another language's).
        recorded_folder: the folder the header's ``regenerate with`` line is written for (its robot path is
            relative to it); default ``out`` (files staged elsewhere before they move to their place).
        before_writing: called with the result before any file is written (``generate --compile`` compiles
            there): when it raises, nothing is written.

    Raises :class:`~skelarm_sym.errors.InputError` (a ``ValueError``) on bad input; on any error no file
    is left behind.
    """
    for name, value in (("cmake", cmake), ("force", force)):
        if not isinstance(value, bool):  # force="no" is true: it replaced a user's file
            raise InputError(f"{name} must be True or False, got {value!r:.60}")
    if before_writing is not None and not callable(before_writing):
        raise InputError(f"before_writing must be a function of the result or None, got {before_writing!r:.60}")
    model = n
    if isinstance(n, numbers.Real) and not isinstance(n, bool):  # NumPy's integers too (q.shape[-1])
        model = PlanarArm(n, None if lengths is None else _lengths_tuple(lengths))
    elif lengths is not None:
        raise InputError("lengths describe a planar arm given by its number of links; the model has its own")
    kind = kind_of(model)
    prefix = validate_prefix(model.default_prefix if prefix is None else prefix)
    precision = validate_precision(precision)
    model = model.for_precision(precision)  # constants as the precision holds them; what it cannot hold is refused
    langs = validate_langs(langs)
    if "python" in langs:
        validate_module_name(prefix)
    if any(".h" in BACKENDS[lang].FILE_SUFFIXES for lang in langs):
        validate_header_name(prefix)
    target = _check_output_folder(out) if out is not None else None
    if cmake and not {"c", "cpython"} & set(langs):  # cpython writes the C it includes
        raise InputError("--cmake builds the C: generate with lang 'c' (or 'cpython', which writes it too)")
    if cmake:
        validate_cmake_target(prefix)

    recorded_in = recorded_folder if recorded_folder is not None else target
    leftovers: list[tuple[Path, str]] = []
    if target is not None:
        names = [prefix + suffix for lang in langs for suffix in BACKENDS[lang].FILE_SUFFIXES] + (["CMakeLists.txt"] if cmake else [])
        leftovers = set_leftovers(target, prefix, names)
        refuse_case_twins(target, prefix)
        if not force:
            refuse_before_deriving(target, names, regenerate_command(model, prefix, precision, langs, None if functions is None else ["?"],
                                                                     recorded_in, cmake),
                                   None if functions is None else wanted_functions(kind, functions))
            refuse_leftovers(leftovers, prefix)
    items = None if functions is None else frozenset(function_items(functions))
    # no name at all: everything is derived, so that the error lists every function there is (not the few an empty
    # selection derives)
    derivation = kind.derive(model, items or None)
    derived, solvers = select_functions(kind, derivation, functions)
    chosen = None if functions is None else derived + solvers
    command = regenerate_command(model, prefix, precision, langs, chosen, recorded_in, cmake)
    module = build_module(kind, derivation, derived, solvers, prefix, precision, command)
    sources = render_all(module, langs, cmake)
    paths: tuple[Path, ...] = ()
    if target is not None and not force:
        refuse_other_options(target, sources)
    if before_writing is not None:
        before_writing(Generated(sources, module, derivation))
    if target is not None:
        paths = write_atomically(target, sources, remove=tuple(path.name for path, _ in leftovers))
    return Generated(sources, module, derivation, paths)


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
    if not isinstance(out, (str, os.PathLike)):
        raise InputError(f"out must be a folder's path (str or os.PathLike) or None, got {type(out).__name__} {out!r:.60}")
    if not os.fspath(out):  # Path("") is the current folder: an empty --out is a mistake, not a choice
        raise InputError("output folder is empty text: name a folder (--out DIR, or out='.' for the current one)")
    target = Path(out)
    try:
        exists, is_folder = target.exists(), target.is_dir()
    except OSError as exc:  # ENAMETOOLONG, EACCES on a parent, ...
        raise InputError(f"cannot use output folder {str(target)!r}: {exc.strerror or exc}") from None
    if exists and not is_folder:
        raise InputError(f"output folder {str(target)!r} exists and is not a folder")
    return target
