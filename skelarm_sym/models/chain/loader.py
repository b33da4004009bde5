"""One entry point for robot description files: URDF (``.urdf``) or a TOML DH table (``.toml``).

The default prefix (the emitted files' names and the C prefix when ``--prefix`` is not given):

* URDF: the file name's stem made an identifier, else the ``<robot name>`` made one, else ``robot``;
* TOML: the ``name`` key made an identifier (``long`` gives ``long_robot``), else the file name's stem made
  an identifier, else ``robot``.

"Made an identifier" (:func:`~skelarm_sym.names.identifier_from`): case kept as written, every run of
characters other than ASCII letters and digits becomes one ``_`` (none at either end), ``robot_``
before a leading digit, at most 48 characters, ``_robot`` after a name some output cannot take
(:func:`~skelarm_sym.names.unusable_default`: a reserved word, a Python standard module, ``torch``, a C system
header's name, a CMake target name): ``xarm7.urdf`` gives ``xarm7``, ``ur5 (copy).urdf`` ``ur5_copy``, ``2dof.urdf``
``robot_2dof``. :data:`PREFIX_RULE` says it in one sentence for ``--help``.

Robot-file text (names, descriptions, the ``base`` and ``tip`` link names) must be printable: a control,
format (bidi, zero-width) or line-separator character is refused with one line naming the file, the
element or key and the code point (:func:`~skelarm_sym.names.check_printable`). Every error is an
:class:`~skelarm_sym.errors.InputError` of one line that starts with the file's path.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from ...errors import InputError
from ...names import quoted
from .model import Chain
from .dh_file import MAX_TOML_BYTES, load_robot_file
from .urdf import MAX_URDF_BYTES, MAX_URDF_ELEMENTS, UrdfLink, load_urdf, urdf_links, urdf_tree

SUFFIXES = (".urdf", ".toml")
PREFIX_RULE = (
    "default prefix: for a URDF the file name without .urdf (xarm7.urdf: xarm7) made an identifier: each run of "
    "characters other than ASCII letters and digits becomes one _ (none at either end), a leading digit gets robot_ "
    "before it, a name with no letter or digit gives the robot's name, else robot; for a TOML file its name key "
    "(a C identifier); either gets _robot after a name some output cannot take: a C or Python reserved word, a "
    "Python standard module, a module the emitted Python imports, a C system header's name, a CMake target name "
    "(long: long_robot, stddef: stddef_robot, torch: torch_robot, install: install_robot)"
)
"""The default-prefix rule in one sentence (for ``generate --help``)."""

__all__ = [
    "MAX_TOML_BYTES", "MAX_URDF_BYTES", "MAX_URDF_ELEMENTS", "PREFIX_RULE", "SUFFIXES", "UrdfLink",
    "load_robot", "urdf_links", "urdf_tree",
]


def load_robot(path: str | os.PathLike, base: str | None = None, tip: str | None = None,
               ik_lock: str | int | None = None) -> Chain:
    """The chain described by ``path``: a URDF file (from link ``base`` to link ``tip``) or a TOML robot file.

    ``base`` and ``tip`` pick a path in a URDF tree; a TOML file is one chain already, so they are refused there.
    ``ik_lock`` (the command line's ``--ik-lock``): a 7-joint arm's joint (number 1..N, base to tip, or name) that
    its closed-form IK holds at a value given at run time. The chain's ``default_prefix`` follows the rule in the
    module docstring. InputError (a ValueError) names the problem with any of them.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"load_robot takes the path of a robot file (.urdf or .toml), got {type(path).__name__} {path!r:.60}")
    for what, value in (("base", base), ("tip", tip)):
        if value is not None and not isinstance(value, str):
            raise InputError(f"{what} must be a link's name (str), got {type(value).__name__} {value!r:.60}")
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if not text:  # Path("") is the current folder: "a folder, not a robot file" named none
        raise InputError("load_robot: the robot file's path is empty")
    if "\0" in text:  # open() said only "embedded null byte"
        raise InputError(f"load_robot: the robot file's path {quoted(text)} holds a NUL character")
    chain = _load(Path(text), base, tip)
    if ik_lock is None:
        return chain
    from .lock import with_ik_lock

    return with_ik_lock(chain, ik_lock)


def _load(path: Path, base: str | None, tip: str | None) -> Chain:
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        chain = load_urdf(path, base=base, tip=tip)
        options = tuple((flag, value) for flag, value in (("--base", base), ("--tip", tip)) if value is not None)
        return dataclasses.replace(chain, load_options=options) if options else chain
    if suffix == ".toml":
        given = [k for k, v in (("base", base), ("tip", tip)) if v is not None]
        if given:
            links = " and ".join(given)
            options = ", ".join(f"{k}= / --{k}" for k in given)
            verb = "are" if len(given) > 1 else "is"
            raise InputError(f"{path}: a {links} link ({options}) {verb} chosen in URDF files only "
                             "(a TOML robot file is one chain)")
        return load_robot_file(path)
    if path.is_dir():
        raise InputError(f"{path}: a folder, not a robot file: name a {' or '.join(SUFFIXES)} file in it")
    raise InputError(f"{path}: unknown kind of robot file {path.suffix!r}: expected {' or '.join(SUFFIXES)}")
