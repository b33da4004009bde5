"""Writing emitted files: all of a set or none, durable, with the umask's mode.

``write_atomically`` writes every file of a set to a hidden temporary beside its target
(``.NAME.PID.RANDOM.tmp``), flushes each to disk (``fsync``) and the folder, keeps a hard link of each
file it replaces (``.NAME.PID.RANDOM.bak``), and only then renames the new files into place. If a rename
fails (a file that refuses to be replaced), the files already renamed get their old text back, so an
error leaves the folder as it was. A crash leaves either temporaries (removed by the next run: those of
a process that no longer runs, or older than an hour) or complete files, never a truncated one. Between
two renames a crash can still leave a new ``.h`` beside an old ``.c``; the emitted C checks a generation
stamp so such a pair fails to compile instead of linking wrong code."""

from __future__ import annotations

import os
import re
import secrets
import shutil
import tempfile
import time
from pathlib import Path

from .errors import InputError

STALE_SECONDS = 3600
"""A temporary whose writer cannot be identified is removed when older than this."""
MARK = "skelarm-"
"""In the name of every temporary and spare this module makes (``.NAME.PID.skelarm-xxxxxxxx.tmp``), so that the
cleanup of a killed run's leftovers can tell them from a user's own backups."""


def new_file_mode() -> int:
    """The mode a newly created file gets under the current umask (mkstemp's files are 0600)."""
    current = os.umask(0)
    os.umask(current)
    return 0o666 & ~current


def _pid_alive(pid: int) -> bool:
    """Whether process ``pid`` runs (True where that cannot be told: another user's)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):  # OverflowError: no pid is that large (a junk file's name)
        return False
    except (PermissionError, OSError):
        return True  # exists, owned by someone else
    return True


def remove_stale_temporaries(folder: Path, names) -> list[Path]:
    """Remove ``.NAME.PID.skelarm-*.tmp`` (and ``.bak``) left in ``folder`` by killed runs for the files ``names``.

    A temporary is stale when its process no longer runs, or (the pid was reused) when it is older than
    ``STALE_SECONDS``. Returns the paths removed."""
    removed = []
    now = time.time()
    for name in names:
        # exactly the names this module makes (a pid, the mark, mkstemp's 8 characters or token_hex(4)'s 8 digits):
        # a user's own ".arm.h.orig.bak", ".arm.h.20240101.bak" or ".arm.h.1.20240101.bak" is not ours to remove
        pattern = re.compile(r"\." + re.escape(name) + r"\.([0-9]{1,10})\." + re.escape(MARK)
                             + r"(?:[a-z0-9_]{8}\.tmp|[0-9a-f]{8}\.bak)\Z")
        try:
            entries = list(folder.iterdir())
        except OSError:
            return removed
        for entry in entries:
            match = pattern.match(entry.name)
            if not match:
                continue
            pid = int(match.group(1))
            try:
                old = now - entry.lstat().st_mtime > STALE_SECONDS
            except OSError:
                continue
            if pid == os.getpid() and not old:
                continue
            if not _pid_alive(pid) or old:
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


def _kept_aside(folder: Path, name: str) -> Path | None:
    """A hard link (or, where the file system has none, a copy) of ``folder/name`` under a hidden name, to
    put back if the set cannot be written whole; ``None`` when there is no such file."""
    final = folder / name
    if not os.path.lexists(final):
        return None
    spare = folder / f".{name}.{os.getpid()}.{MARK}{secrets.token_hex(4)}.bak"
    try:
        os.link(final, spare, follow_symlinks=False)
    except OSError:  # no hard links here (or the file refuses them): a copy serves as well
        shutil.copy2(final, spare, follow_symlinks=False)
    return spare


def _put_back(changed: list[tuple[Path, Path | None]]) -> None:
    """Undo renames and removals, newest first: each target gets its kept-aside file back, or goes when it
    did not exist before. Best effort: the error being reported matters more than one that happens here."""
    for final, spare in reversed(changed):
        try:
            if spare is not None:
                os.replace(spare, final)
            else:
                os.unlink(final)
        except OSError:
            pass


def _refuse_folders(folder: Path, names) -> None:
    for name in names:
        if (folder / name).is_dir() and not (folder / name).is_symlink():
            raise InputError(f"cannot write {str(folder / name)!r}: a folder of that name is in the way; no file was changed")


def write_atomically(folder: Path, sources: dict[str, str], remove: tuple[str, ...] = ()) -> tuple[Path, ...]:
    """Write every file to a temporary name in ``folder``, flush all, then rename all into place.

    All or nothing: if anything fails (a file that cannot be replaced, a folder in the way of a name, a full
    disk), every file is as it was before and no temporary is left; the error names the file that failed.
    ``remove``: names of files in ``folder`` that the new set no longer has (another language's files of an
    older set), removed in the same step. Temporaries of earlier, killed runs for the same names are removed
    first.
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
    remove = tuple(name for name in remove if name not in sources)
    remove_stale_temporaries(folder, [*sources, *remove])
    _refuse_folders(folder, sources)
    staged: list[tuple[str, Path]] = []
    spares: list[Path] = []
    changed: list[tuple[Path, Path | None]] = []
    current = folder
    try:
        mode = new_file_mode()
        for name, text in sources.items():
            current = folder / name
            fd, tmp = tempfile.mkstemp(prefix=f".{name}.{os.getpid()}.{MARK}", suffix=".tmp", dir=folder)
            staged.append((tmp, folder / name))
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as handle:
                handle.write(text)
                handle.flush()
                os.chmod(tmp, mode)
                os.fsync(handle.fileno())
        _fsync_folder(folder)
        for tmp, final in staged:
            current = final
            spare = _kept_aside(folder, final.name)
            if spare is not None:
                spares.append(spare)
            os.replace(tmp, final)
            changed.append((final, spare))
        for name in remove:
            current = folder / name
            spare = _kept_aside(folder, name)
            if spare is None:
                continue
            spares.append(spare)
            os.unlink(current)
            changed.append((current, spare))
        for spare in spares:  # the new set is whole: the old files go
            try:
                os.unlink(spare)
            except OSError:
                pass
        _fsync_folder(folder)
    except OSError as exc:
        _put_back(changed)
        for leftover in [Path(tmp) for tmp, _ in staged] + spares:
            try:
                os.unlink(leftover)
            except OSError:
                pass
        for made in created:  # the folders this call made, deepest first (empty again)
            try:
                os.rmdir(made)
            except OSError:
                pass
        raise InputError(f"cannot write {str(current)!r}: {exc.strerror or exc}; no file was changed") from None
    return tuple(final for _, final in staged)
