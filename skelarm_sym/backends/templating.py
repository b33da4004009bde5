"""The Jinja environment of every backend's templates (``templates/<lang>/`` in the source tree,
``skelarm_sym.templates`` in the wheel). Templates lay text out; they hold no algorithm and print
text that is data only through the escapes of :mod:`skelarm_sym.backends.text`."""

from __future__ import annotations

import hashlib
import os
from functools import lru_cache
from importlib import resources
from pathlib import Path

import jinja2

from .text import c_comment, line_comment, py_string


class CompiledTemplates(jinja2.BytecodeCache):
    """Templates as Jinja compiles them (Python code objects), kept in the compile cache's private folder
    (``$SKELARM_SYM_CACHE/templates``, see :func:`skelarm_sym.compile_cache.private_folder`): compiling the
    templates took a fifth of a ``generate`` command. Each file holds the SHA-256 of what follows it;
    one that does not match (truncated, damaged) is ignored and written again, and Jinja itself drops
    code compiled from another text of the template or by another Jinja or Python. A file that cannot
    be read or written only costs the compile."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def _path(self, bucket: jinja2.bccache.Bucket) -> Path:
        return self.folder / f"{bucket.key}.jinja"

    def load_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        try:
            data = self._path(bucket).read_bytes()
        except OSError:
            return
        digest, _, payload = data.partition(b"\n")
        if digest == hashlib.sha256(payload).hexdigest().encode("ascii"):
            bucket.bytecode_from_string(payload)

    def dump_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        payload = bucket.bytecode_to_string()
        path = self._path(bucket)
        temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:
            temporary.write_bytes(hashlib.sha256(payload).hexdigest().encode("ascii") + b"\n" + payload)
            # rename, not replace: the same atomic step on POSIX, and not one of the replaces by which
            # generate() and build.py publish their files (their tests follow os.replace)
            os.rename(temporary, path)
        except OSError:
            temporary.unlink(missing_ok=True)


def compiled_templates() -> CompiledTemplates | None:
    """The cache of compiled templates, or ``None`` when the private cache folder is not usable here."""
    from ..compile_cache import cache_folder, private_folder
    from ..errors import InputError

    try:
        return CompiledTemplates(private_folder(private_folder(cache_folder()) / "templates"))
    except (InputError, OSError):
        return None


def template_folder(module: Path | None = None) -> Path:
    """The templates of this copy of the package: ``templates/`` beside it in a source checkout, else the wheel's
    ``skelarm_sym.templates``. The checkout's own folder comes first because an editable install maps
    ``skelarm_sym.templates`` to its checkout's folder whichever copy of the package is imported: a benchmark
    that runs another checkout's code (``PYTHONPATH=/other/checkout``, the ``--before`` of ``benchmarks/``)
    would otherwise print that code through this checkout's templates. ``module``: where this file lies (tests)."""
    checkout = Path(module or __file__).resolve().parents[2]
    if (checkout / "pyproject.toml").is_file() and (checkout / "templates" / "c").is_dir():
        return checkout / "templates"
    return Path(str(resources.files("skelarm_sym.templates")))


@lru_cache(maxsize=1)
def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(template_folder())),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
        bytecode_cache=compiled_templates(),
    )
    env.filters.update(c_comment=c_comment, py_string=py_string, line_comment=line_comment)
    return env


def render_template(name: str, **context) -> str:
    """Render template ``name`` (a path under ``templates/``) with ``context``."""
    return environment().get_template(name).render(**context)
