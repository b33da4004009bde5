"""Writing emitted files: all of a set or none, with the umask's mode."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from .errors import InputError


def new_file_mode() -> int:
    """The mode a newly created file gets under the current umask (mkstemp's files are 0600)."""
    current = os.umask(0)
    os.umask(current)
    return 0o666 & ~current


def write_atomically(folder: Path, sources: dict[str, str]) -> tuple[Path, ...]:
    """Write every file to a temporary name in ``folder``, then rename all into place.

    If anything fails, the temporary files are removed and no target file is touched.
    """
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder {str(folder)!r}: {exc.strerror or exc}") from None
    staged: list[tuple[str, Path]] = []
    try:
        for name, text in sources.items():
            fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=".tmp", dir=folder)
            staged.append((tmp, folder / name))
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as handle:
                handle.write(text)
        mode = new_file_mode()
        for tmp, _ in staged:
            os.chmod(tmp, mode)
        for tmp, final in staged:
            os.replace(tmp, final)
    except OSError as exc:
        for tmp, _ in staged:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        raise InputError(f"cannot write to output folder {str(folder)!r}: {exc.strerror or exc}") from None
    return tuple(final for _, final in staged)
