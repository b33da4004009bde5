"""The compile cache's folder and the checks that make it private: kept apart from :mod:`skelarm_sym.build`
(which imports the subprocess and file machinery of compiling) because every ``generate`` command asks for
it, for the compiled templates (:mod:`skelarm_sym.backends.templating`), and most never compile."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from .errors import InputError


def cache_folder() -> Path:
    """Where compiled libraries are kept: ``$SKELARM_SYM_CACHE``, else ``~/.cache/skelarm-sym``."""
    root = os.environ.get("SKELARM_SYM_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "skelarm-sym"


def private_folder(folder: Path) -> Path:
    """``folder``, created with mode 0700 if missing; refused if another user owns it or group or
    others may write to it (they could plant a library that the interpreter would load)."""
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        info = folder.stat()
    except OSError as exc:
        raise InputError(f"cannot create the compile cache folder {str(folder)!r}: {exc.strerror or exc} (set SKELARM_SYM_CACHE)") from None
    if not stat.S_ISDIR(info.st_mode):
        raise InputError(f"compile cache {str(folder)!r} is not a folder (set SKELARM_SYM_CACHE)")
    if hasattr(os, "getuid"):
        if info.st_uid != os.getuid():
            raise InputError(f"compile cache folder {str(folder)!r} belongs to another user (uid {info.st_uid}); set SKELARM_SYM_CACHE to a folder of your own")
        if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            raise InputError(f"compile cache folder {str(folder)!r} is writable by group or others (mode {stat.S_IMODE(info.st_mode):o}); chmod 700 it or set SKELARM_SYM_CACHE")
    return folder
