"""Writing emitted files: all of a set or none, durable, with the umask's mode.

``write_atomically`` writes every file of a set to a hidden temporary beside its target
(``.NAME.PID.RANDOM.tmp``), flushes each to disk (``fsync``) and the folder, and only then
renames them into place, so a crash leaves either temporaries (removed by the next run: those of
a process that no longer runs, or older than an hour) or complete new files, never a truncated
one. Between two renames a crash can still leave a new ``.h`` beside an old ``.c``; the emitted
C checks a generation stamp so such a pair fails to compile instead of linking wrong code.
"""

from __future__ import annotations

import os
import re
import tempfile
import time
from pathlib import Path

from .errors import InputError

STALE_SECONDS = 3600
"""A temporary whose writer cannot be identified is removed when older than this."""


def new_file_mode() -> int:
    """The mode a newly created file gets under the current umask (mkstemp's files are 0600)."""
    current = os.umask(0)
    os.umask(current)
    return 0o666 & ~current


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # exists, owned by someone else
    return True


def remove_stale_temporaries(folder: Path, names) -> list[Path]:
    """Remove ``.NAME.PID.*.tmp`` left in ``folder`` by killed runs for the files ``names``.

    A temporary is stale when its process no longer runs, or (no pid in its name, or the pid
    was reused) when it is older than ``STALE_SECONDS``. Returns the paths removed."""
    removed = []
    now = time.time()
    for name in names:
        pattern = re.compile(r"\." + re.escape(name) + r"\.(?:(\d+)\.)?[^/]*\.tmp\Z")
        try:
            entries = list(folder.iterdir())
        except OSError:
            return removed
        for entry in entries:
            match = pattern.match(entry.name)
            if not match:
                continue
            pid = int(match.group(1)) if match.group(1) else None
            try:
                old = now - entry.lstat().st_mtime > STALE_SECONDS
            except OSError:
                continue
            if pid == os.getpid() and not old:
                continue
            if (pid is not None and not _pid_alive(pid)) or old:
                try:
                    entry.unlink()
                    removed.append(entry)
                except OSError:
                    pass
    return removed


def _fsync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # some systems cannot open a folder; the data itself is synced
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_atomically(folder: Path, sources: dict[str, str]) -> tuple[Path, ...]:
    """Write every file to a temporary name in ``folder``, flush all, then rename all into place.

    If anything fails before the renames, the temporary files are removed and no target file is
    touched. Temporaries of earlier, killed runs for the same names are removed first.
    """
    created = [f for f in (folder, *folder.parents) if not os.path.isdir(f)]  # deepest first
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        for made in created:  # leave no half-made folders behind
            try:
                os.rmdir(made)
            except OSError:
                pass
        raise InputError(f"cannot create output folder {str(folder)!r}: {exc.strerror or exc}") from None
    remove_stale_temporaries(folder, sources)
    staged: list[tuple[str, Path]] = []
    try:
        mode = new_file_mode()
        for name, text in sources.items():
            fd, tmp = tempfile.mkstemp(prefix=f".{name}.{os.getpid()}.", suffix=".tmp", dir=folder)
            staged.append((tmp, folder / name))
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as handle:
                handle.write(text)
                handle.flush()
                os.chmod(tmp, mode)
                os.fsync(handle.fileno())
        _fsync_folder(folder)
        for tmp, final in staged:
            os.replace(tmp, final)
        _fsync_folder(folder)
    except OSError as exc:
        for tmp, _ in staged:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        raise InputError(f"cannot write to output folder {str(folder)!r}: {exc.strerror or exc}") from None
    return tuple(final for _, final in staged)
