"""One entry point for robot description files: URDF (``.urdf``) or a TOML DH table (``.toml``)."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from ...errors import InputError
from .model import Chain
from .dh_file import load_robot_file
from .urdf import load_urdf

SUFFIXES = (".urdf", ".toml")


def load_robot(path: str | os.PathLike, base: str | None = None, tip: str | None = None) -> Chain:
    """The chain described by ``path``: a URDF file (from link ``base`` to link ``tip``) or a TOML robot file.

    ``base`` and ``tip`` pick a path in a URDF tree; a TOML file is one chain already, so they are refused there.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        chain = load_urdf(path, base=base, tip=tip)
        options = tuple((flag, value) for flag, value in (("--base", base), ("--tip", tip)) if value is not None)
        return dataclasses.replace(chain, load_options=options) if options else chain
    if suffix == ".toml":
        given = [k for k, v in (("base", base), ("tip", tip)) if v is not None]
        if given:
            raise InputError(f"{path}: {' and '.join(given)} apply to URDF files only (a TOML robot file is one chain)")
        return load_robot_file(path)
    raise InputError(f"{path}: unknown kind of robot file {path.suffix!r}: expected {' or '.join(SUFFIXES)}")
