"""Compile emitted C with the system compiler, cache it by content hash, load it, check shapes.

``compile_sources(sources)`` takes the ``{name: text}`` of one generated C
header and source (as :func:`skelarm_sym.generate.generate` returns them) and
gives a :class:`CompiledArm` whose methods have the emitted functions' names and
take NumPy arrays: ``arm.jacobian(q, l)`` with ``q`` of shape ``(..., N)``
returns ``(..., 2, N)``; batches go through the ``_batch`` C functions.

The shared library lives in a cache folder (``$SKELARM_SYM_CACHE``, else
``~/.cache/skelarm-sym``) under the SHA-256 of the sources, compiler and flags,
so a second call with the same inputs reuses it.
"""

from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Sequence


from .errors import InputError
from .wrapper import CompiledArm, IKResult, IK_STATUS_NAMES  # noqa: F401 - re-exported

DEFAULT_FLAGS = ("-O2",)
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")


class CompilerNotFound(InputError):
    """No C compiler could be found."""


def find_compiler(preferred: str | None = None) -> str:
    """The C compiler to use: ``preferred``, ``$CC``, then cc, gcc, clang on PATH."""
    for candidate in (preferred, os.environ.get("CC"), "cc", "gcc", "clang"):
        if candidate and shutil.which(shlex.split(candidate)[0]):
            return candidate
    raise CompilerNotFound(
        "no C compiler found: install gcc or clang (Debian/Ubuntu: apt-get install gcc) or set CC"
    )


def cache_folder() -> Path:
    """Where compiled libraries are kept."""
    root = os.environ.get("SKELARM_SYM_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "skelarm-sym"


def compile_shared(
    sources: dict[str, str],
    flags: Sequence[str] = DEFAULT_FLAGS,
    compiler: str | None = None,
    strict: bool = True,
) -> Path:
    """Compile the ``.c`` file of ``sources`` (with its headers beside it) into a cached shared library."""
    cc = find_compiler(compiler)
    all_flags = [*(STRICT_FLAGS if strict else ("-std=c99",)), *flags, "-fPIC", "-shared"]
    digest = hashlib.sha256()
    for name in sorted(sources):
        digest.update(name.encode() + b"\0" + sources[name].encode() + b"\0")
    digest.update(" ".join([cc, *all_flags]).encode())
    key = digest.hexdigest()[:24]
    c_files = [name for name in sources if name.endswith(".c")]
    if len(c_files) != 1:
        raise InputError("compile needs exactly one generated .c file (generate with lang 'c')")
    stem = c_files[0][:-2]
    suffix = ".dll" if sys.platform == "win32" else ".so"
    target = cache_folder() / key / f"lib{stem}{suffix}"
    if target.exists():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as work:
        for name, text in sources.items():
            if name.endswith((".c", ".h")):
                Path(work, name).write_text(text, encoding="utf-8")
        tmp_lib = Path(work, target.name)
        command = [*shlex.split(cc), *all_flags, "-o", str(tmp_lib), str(Path(work, c_files[0])), "-lm"]
        result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"compiling {c_files[0]} failed:\n{' '.join(command)}\n{result.stderr}")
        os.replace(tmp_lib, target)
    return target


def load_python(source: str, name: str):
    """Execute an emitted Python module's text and return it as a module object."""
    import types

    module = types.ModuleType(name)
    module.__file__ = f"<skelarm-sym {name}>"
    exec(compile(source, module.__file__, "exec"), module.__dict__)
    return module


def compile_arm(generated, flags: Sequence[str] = DEFAULT_FLAGS, compiler: str | None = None) -> CompiledArm:
    """Compile and load the C of a :class:`~skelarm_sym.generate.Generated` result."""
    sources = {k: v for k, v in generated.sources.items() if k.endswith((".c", ".h"))}
    if not sources:
        raise InputError("nothing to compile: generate with lang 'c'")
    library = compile_shared(sources, flags=flags, compiler=compiler)
    prefix = next(k for k in sources if k.endswith(".c"))[:-2]
    precision = "float" if "Precision: float." in sources[prefix + ".c"] else "double"
    derivation = generated.derivation
    return CompiledArm(library, prefix, generated.programs, precision, derivation.parameters, derivation.domains)
