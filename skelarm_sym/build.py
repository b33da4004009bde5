"""Compile emitted C with the system compiler, cache it by content hash, load it, check shapes.

``compile_sources(sources)`` takes the ``{name: text}`` of one generated C
header and source (as :func:`skelarm_sym.generate.generate` returns them) and
gives a :class:`CompiledArm` whose methods have the emitted functions' names and
take NumPy arrays: ``arm.jacobian(q, l)`` with ``q`` of shape ``(..., N)``
returns ``(..., 2, N)``; batches go through the ``_batch`` C functions.

The shared library lives in a cache folder (``$SKELARM_SYM_CACHE``, else
``~/.cache/skelarm-sym``) under the SHA-256 of the sources, compiler and flags,
so a second call with the same inputs reuses it. Compiles are at ``-O2`` unless ``flags`` say otherwise
or ``$SKELARM_SYM_OPT`` names another level (:func:`default_flags`; the test suite uses ``0``). The cache is private (created
with mode 0700; the cache folder and the key folder are refused when another
user owns them or group or others may write to them, before a cached library is
used as well as before a build) and is trusted only as far as it can be checked:
beside each library a sidecar ``.sha256`` records the cache key and the SHA-256
of the library as built, both flushed to disk before their renames. A library
whose sidecar is missing or does not match its key or its content (truncated by
a power cut, copied from another arm, planted) is rebuilt, never loaded. Build
folders of killed compiles (``.build-PID-*``) are removed by later compiles, and so are libraries that
no call has built or loaded for :data:`UNUSED_LIBRARY_DAYS` days (the cache would otherwise only grow).

A compiler that refuses the sources raises :class:`CompileError`: its first line
names the file and the compiler's first error, the next lines give the command
and the first ``COMPILER_LINES`` lines of the compiler's output.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from .errors import InputError
from .compile_cache import cache_folder, private_folder  # noqa: F401 - part of this module's interface
from .files import _pid_alive

if TYPE_CHECKING:
    from .wrapper import CompiledArm


def __getattr__(name: str):
    """``CompiledArm`` (re-exported from :mod:`skelarm_sym.wrapper`, imported on first use: it needs NumPy,
    which the cache folder and the compiler do not)."""
    if name == "CompiledArm":
        from .wrapper import CompiledArm

        return CompiledArm
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

EXTENSION_SUFFIX = ".ext.c"
"""The file of a generation's CPython extension (:mod:`skelarm_sym.backends.cpython`), which includes its C."""


def extension_module(prefix: str) -> str:
    """The name of the CPython extension module of ``prefix`` (its init function is ``PyInit_{name}``; the
    backend's ``module_name``)."""
    return f"{prefix}_ext"

DEFAULT_FLAGS = ("-O2",)
OPT_LEVEL_VARIABLE = "SKELARM_SYM_OPT"
"""An environment variable naming the optimisation level of compiles that pass no ``flags``: ``0``, ``1``, ``2``,
``3``, ``s`` or ``g`` (``-O0`` ... ``-Og``); unset or empty: :data:`DEFAULT_FLAGS`. The test suite sets ``0``
where the speed of the library is not what a test checks (``-O0`` compiles several times faster). The strict
warning flags (:data:`STRICT_FLAGS`) are used at every level."""
OPT_LEVELS = ("0", "1", "2", "3", "s", "g")
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")
STALE_BUILD_SECONDS = 3600
"""A build folder whose process cannot be identified is removed when older than this."""
UNUSED_LIBRARY_DAYS = 30
"""A compile removes the cached libraries that no call has built or loaded for this many days (a library's
sidecar's modification time is renewed each time it is reused)."""
_KEY_FOLDER = re.compile(r"[0-9a-f]{24}")


class CompilerNotFound(InputError):
    """No C compiler could be found."""


class CompileError(RuntimeError):
    """The compiler refused the sources. The message's first line says which file and the first error
    the compiler reported (``compiling ur10.c failed: ur10.c:123:5: error: 'M_PI_2' undeclared ...``);
    the next lines give the command and up to ``COMPILER_LINES`` lines of the compiler's output.
    ``command`` and ``output`` hold them whole."""

    def __init__(self, message: str, command: Sequence[str] = (), output: str = "") -> None:
        super().__init__(message)
        self.command = list(command)
        self.output = output


COMPILER_LINES = 20
"""Lines of the compiler's output a :class:`CompileError` message shows after the command."""
_ERROR_LINE = re.compile(r"(?:^|:\s*)(?:fatal )?error\b|undefined reference|\bld returned", re.IGNORECASE)
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


def compile_failure(c_file: str, command: Sequence[str], returncode: int, output: str, work: str | None = None) -> CompileError:
    """The :class:`CompileError` for a compile of ``c_file`` that exited with ``returncode`` and printed
    ``output``: its first line is ``compiling {c_file} failed: {the first error line}`` (paths inside the
    build folder ``work`` shortened to the file's name, colour codes removed, at most 300 characters);
    then ``command: ...`` and up to ``COMPILER_LINES`` lines of the output."""
    text = _ANSI.sub("", output)
    if work:
        text = text.replace(str(work).rstrip(os.sep) + os.sep, "")
    lines = [line.rstrip() for line in text.splitlines() if line.strip()]
    first = next((line for line in lines if _ERROR_LINE.search(line)), lines[0] if lines else "")
    if not first:
        first = f"the compiler exited with status {returncode} and printed nothing"
    first = "".join(ch if ch.isprintable() else " " for ch in first.strip())
    if len(first) > 300:
        first = first[:297] + "..."
    shown = lines[:COMPILER_LINES]
    if len(lines) > COMPILER_LINES:
        shown.append(f"... ({len(lines) - COMPILER_LINES} more lines)")
    message = "\n".join([f"compiling {c_file} failed: {first}", f"command: {shlex.join(command)}", *shown])
    return CompileError(message, command, output)


def default_flags() -> tuple[str, ...]:
    """The flags of a compile that passes none: ``-O{level}`` when ``$SKELARM_SYM_OPT`` names a level, else
    :data:`DEFAULT_FLAGS`."""
    level = os.environ.get(OPT_LEVEL_VARIABLE, "").strip()
    if not level:
        return DEFAULT_FLAGS
    if level.startswith("-O"):
        level = level[2:]
    if level not in OPT_LEVELS:
        raise InputError(f"{OPT_LEVEL_VARIABLE}={os.environ[OPT_LEVEL_VARIABLE]!r} is not an optimisation level: "
                         f"one of {', '.join(OPT_LEVELS)}")
    return (f"-O{level}",)


def _split_command(text: str, origin: str) -> list[str]:
    try:
        words = shlex.split(text)
    except ValueError as exc:
        raise InputError(f"{origin} {text!r} is not a valid command line: {exc}") from None
    if not words:
        raise InputError(f"{origin} is empty")
    return words


def find_compiler(preferred: str | None = None) -> str:
    """The C compiler to use: ``preferred``, else ``$CC``, else cc, gcc, clang on PATH.

    A compiler named by ``preferred`` or ``$CC`` must exist: it is an error naming it, not a
    silent fall-back to another compiler."""
    for origin, named in (("compiler", preferred), ("CC", os.environ.get("CC"))):
        if named is None or (origin == "CC" and not named.strip()):
            continue
        program = _split_command(named, origin)[0]
        if not shutil.which(program):
            raise CompilerNotFound(f"{origin} {named!r}: {program!r} is not an executable on PATH")
        return named
    for candidate in ("cc", "gcc", "clang"):
        if shutil.which(candidate):
            return candidate
    raise CompilerNotFound(
        "no C compiler found: install gcc or clang (Debian/Ubuntu: apt-get install gcc) or set CC"
    )


def file_sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _sidecar(library: Path) -> Path:
    return library.with_name(library.name + ".sha256")


def verified(library: Path, key: str) -> bool:
    """Whether ``library`` is the one built for ``key``, unchanged since (its sidecar says so)."""
    try:
        recorded = _sidecar(library).read_text(encoding="ascii").split()
        return len(recorded) == 2 and recorded[0] == key and recorded[1] == file_sha256(library)
    except (OSError, UnicodeDecodeError):
        return False


def _durable_replace(source: Path, target: Path) -> None:
    with open(source, "rb") as handle:
        os.fsync(handle.fileno())
    os.replace(source, target)
    try:
        fd = os.open(target.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError:
        pass


def remove_stale_builds(root: Path) -> list[Path]:
    """Remove ``root/*/.build-PID-*`` folders of compiles whose process is gone or that are old."""
    removed = []
    now = time.time()
    for work in root.glob("*/.build-*"):
        parts = work.name.split("-")
        pid = int(parts[1]) if len(parts) > 2 and parts[1].isascii() and parts[1].isdigit() else None
        try:
            old = now - work.lstat().st_mtime > STALE_BUILD_SECONDS
        except OSError:
            continue
        if pid == os.getpid() and not old:
            continue
        if old or (pid is not None and not _pid_alive(pid)):
            shutil.rmtree(work, ignore_errors=True)
            removed.append(work)
    return removed


def remove_unused_libraries(root: Path, days: float = UNUSED_LIBRARY_DAYS) -> list[Path]:
    """Remove the key folders of ``root`` (24 hexadecimal digits, as :func:`compile_shared` names them) whose
    libraries were all last built or reused more than ``days`` days ago; other folders are left alone."""
    removed = []
    now = time.time()
    for folder in root.iterdir():
        parts = folder.name.split("-", 2)
        if parts[0] == ".unused" and len(parts) == 3 and parts[1].isascii() and parts[1].isdigit() and not _pid_alive(int(parts[1])):
            shutil.rmtree(folder, ignore_errors=True)  # left by a process killed while it removed it
            continue
        if not _KEY_FOLDER.fullmatch(folder.name) or folder.is_symlink() or not folder.is_dir():
            continue
        try:
            if any(folder.glob(".build-*")):  # a compile is writing here now
                continue
            libraries = [path.lstat().st_mtime for path in folder.glob("lib*")]  # the libraries and their sidecars
        except OSError:
            continue
        if not libraries or now - max(libraries) <= days * 86400:
            continue
        # renamed first (atomic): a process that reuses the library from now on rebuilds it rather than losing it
        # half-way; one that verified it just before keeps its mapping of the file it loaded
        doomed = folder.with_name(f".unused-{os.getpid()}-{folder.name}")
        try:
            os.rename(folder, doomed)
        except OSError:
            continue
        shutil.rmtree(doomed, ignore_errors=True)
        removed.append(folder)
    return removed


def reusable(target: Path, key: str) -> bool:
    """Whether the cached library ``target`` is the one built for ``key`` (:func:`verified`); if so it is marked
    used now (its sidecar's time: the library itself stays as built), which keeps :func:`remove_unused_libraries`
    from it."""
    if not (target.exists() and verified(target, key)):
        return False
    with contextlib.suppress(OSError):
        os.utime(_sidecar(target))
    return True


def compile_shared(
    sources: dict[str, str],
    flags: Sequence[str] | None = None,
    compiler: str | None = None,
    strict: bool = True,
) -> Path:
    """Compile the ``.c`` file of ``sources`` (with its headers beside it) into a cached shared library.

    Returns the library's path in the cache. The cache folder and the key folder are checked
    (:func:`private_folder`) before a cached library is returned, and a library is returned only when
    its sidecar vouches for it (:func:`verified`). A compiler that refuses the sources raises
    :class:`CompileError` (a ``RuntimeError``) whose first line names the file and the first error;
    nothing is left behind. ``flags``: ``None`` for :func:`default_flags` (``-O2``, or the level of
    ``$SKELARM_SYM_OPT``)."""
    if flags is None:
        flags = default_flags()
    if isinstance(flags, str) or not all(isinstance(flag, str) for flag in flags):
        raise InputError(f"flags must be a sequence of strings (['-O2']), got {flags!r:.60}")
    if compiler is not None and not isinstance(compiler, str):
        raise InputError(f"compiler must be a command (str) or None, got {compiler!r:.60}")
    cc = find_compiler(compiler)
    cc_words = _split_command(cc, "compiler")
    all_flags = [*(STRICT_FLAGS if strict else ("-std=c99",)), *flags, "-fPIC", "-shared"]
    digest = hashlib.sha256()
    for name in sorted(sources):
        digest.update(name.encode() + b"\0" + sources[name].encode() + b"\0")
    digest.update(" ".join([cc, *all_flags]).encode())
    full_key = digest.hexdigest()
    key = full_key[:24]
    c_files = [name for name in sources if name.endswith(".c")]
    units = [name for name in c_files if name.endswith(EXTENSION_SUFFIX)]
    if len(units) == 1 and len(c_files) == 2 and units[0][: -len(EXTENSION_SUFFIX)] + ".c" in c_files:
        c_files = units  # the extension includes the C: one translation unit
        stem = units[0][: -len(EXTENSION_SUFFIX)]
    elif len(c_files) != 1:
        raise InputError("compile needs exactly one generated .c file (generate with lang 'c')")
    else:
        stem = c_files[0][:-2]
    suffix = ".dll" if sys.platform == "win32" else ".so"
    root = private_folder(cache_folder())
    target = root / key / f"lib{stem}{suffix}"
    # the key folder is checked before anything in it is trusted: made group-writable after the
    # build, the library beside the sidecar could have been swapped between the check and the load
    private_folder(target.parent)
    if reusable(target, full_key):
        return target
    remove_stale_builds(root)
    remove_unused_libraries(root)
    work = Path(tempfile.mkdtemp(prefix=f".build-{os.getpid()}-", dir=target.parent))
    try:
        for name, text in sources.items():
            if name.endswith((".c", ".h")):
                Path(work, name).write_text(text, encoding="utf-8")
        tmp_lib = Path(work, target.name)
        command = [*cc_words, *all_flags, "-o", str(tmp_lib), str(Path(work, c_files[0])), "-lm"]
        try:
            result = subprocess.run(command, capture_output=True, text=True)
        except OSError as exc:
            raise CompilerNotFound(f"cannot run the C compiler {cc!r}: {exc.strerror or exc}") from None
        if result.returncode != 0:
            raise compile_failure(c_files[0], command, result.returncode, result.stderr + result.stdout, str(work))
        if not tmp_lib.is_file():  # CC=true: nothing to load, and "No such file" named no culprit
            raise CompileError(f"compiling {c_files[0]} failed: the compiler {cc!r} exited 0 but wrote no library",
                               command, result.stderr + result.stdout)
        tmp_sidecar = Path(work, "sidecar")
        tmp_sidecar.write_text(f"{full_key} {file_sha256(tmp_lib)}\n", encoding="ascii")
        # the library first, then the sidecar that vouches for it: a crash between leaves a
        # library without a matching sidecar, which is rebuilt
        _durable_replace(tmp_lib, target)
        _durable_replace(tmp_sidecar, _sidecar(target))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return target


def load_python(source: str, name: str):
    """Execute an emitted Python module's text and return it as a module object."""
    import types

    module = types.ModuleType(name)
    module.__file__ = f"<skelarm-sym {name}>"
    exec(compile(source, module.__file__, "exec"), module.__dict__)
    return module


def python_headers() -> tuple[str, ...] | None:
    """The include flags that build a CPython extension for this interpreter (Python's headers, and NumPy's
    as system headers), or ``None`` where this module does not build one: no ``Python.h`` (Debian:
    ``apt-get install python3-dev``), or not Linux (elsewhere an extension links differently)."""
    if not sys.platform.startswith("linux"):
        return None
    import sysconfig

    import numpy

    paths = sysconfig.get_paths()
    folders = [paths.get("include"), paths.get("platinclude")]
    if not folders[0] or not Path(folders[0], "Python.h").is_file():
        return None
    # NumPy's headers as system headers: they are not -pedantic clean (function pointers from data pointers).
    # The extension is tied to the NumPy whose headers built it; the (unused) define puts NumPy's version in
    # the compile cache's key, so that another NumPy builds its own.
    return (*dict.fromkeys(f"-I{folder}" for folder in folders if folder), "-isystem", numpy.get_include(),
            f"-DSKELARM_SYM_BUILT_WITH_NUMPY={numpy.__version__}")


def compile_arm(generated, flags: Sequence[str] | None = None, compiler: str | None = None,
                extension: bool | None = None) -> CompiledArm:
    """Compile and load the C of a :class:`~skelarm_sym.generate.Generated` result.

    ``extension``: also build the CPython extension (``{prefix}.ext.c``, see
    :mod:`skelarm_sym.backends.cpython`; rendered from the generation's module when its files do not
    include it) into the same library, so that calls on one configuration skip ctypes (about 1 µs instead
    of tens). ``None`` (the default): when the generation has that file (languages ``c,cpython``) and this
    interpreter's headers are installed (:func:`python_headers`); ``True``: always (an :class:`InputError`
    where it cannot be built); ``False``: never, the ctypes library alone. Batches go through ctypes
    either way (single solver problems take the extension too). ``flags``: as :func:`compile_shared`'s (``None``: :func:`default_flags`)."""
    from .wrapper import CompiledArm

    # what generate() returns (not imported: generate imports this module's backends)
    if not (isinstance(getattr(generated, "sources", None), dict) and hasattr(generated, "module")):
        raise InputError(f"compile_arm takes what generate() returns, got {type(generated).__name__} {generated!r:.60}")
    if flags is not None and (isinstance(flags, str) or not all(isinstance(flag, str) for flag in flags)):
        raise InputError(f"flags must be a sequence of strings (['-O2']), got {flags!r:.60}")
    if extension not in (None, True, False):  # "yes" (and "no") was taken as true
        raise InputError(f"extension must be True, False or None, got {extension!r:.60}")
    if flags is None:
        flags = default_flags()
    EXT = EXTENSION_SUFFIX
    sources = {k: v for k, v in generated.sources.items() if k.endswith((".c", ".h")) and not k.endswith(EXT)}
    if not sources:
        raise InputError("nothing to compile: generate with lang 'c'")
    if extension is None and generated.module.prefix + EXT not in generated.sources:
        extension = False
    include = python_headers() if extension is not False else None
    if extension and include is None:
        raise InputError("the CPython extension needs this Python's headers (Python.h; Debian: apt-get install "
                         "python3-dev) on Linux; compile_arm(..., extension=False) builds the ctypes library alone")
    if include is None:
        return CompiledArm(compile_shared(sources, flags=flags, compiler=compiler), generated.module)
    prefix = generated.module.prefix
    name = prefix + EXT
    sources[name] = generated.sources.get(name) or generated.extension_source()
    try:
        library = compile_shared(sources, flags=[*flags, *include], compiler=compiler)
    except CompileError:
        plain = {k: v for k, v in sources.items() if k != name}
        fallback = compile_shared(plain, flags=flags, compiler=compiler)  # the C's own error, if it has one
        if extension:
            raise
        import warnings

        warnings.warn(f"the CPython extension of {prefix} did not compile; single calls go through ctypes",
                      RuntimeWarning, stacklevel=2)
        return CompiledArm(fallback, generated.module)
    return CompiledArm(library, generated.module, extension=extension_module(prefix))
