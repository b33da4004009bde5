"""The joint a 7-joint chain's closed-form IK holds at a run-time value (``--ik-lock JOINT``), kept in the chain's
loader options so that the files' ``regenerate with`` line (and ``check --from``) carries it."""

from __future__ import annotations

import dataclasses

from ...errors import InputError
from .model import Chain

LOCK_OPTION = "--ik-lock"


def ik_lock(model: Chain) -> str | None:
    """The joint ``--ik-lock`` holds (as given: a joint number 1..N or a joint name), or ``None``."""
    return dict(model.load_options).get(LOCK_OPTION)


def named_joint(model: Chain, name: str, error: type[InputError] = InputError) -> int:
    """The 0-based index of the joint (or coordinate: a URDF joint that mimic joints follow) called ``name``;
    ``error`` (one line, naming the joints) where there is none."""
    names = [j.name for j in model.joints]
    if name in names:
        return names.index(name)
    if name in model.coordinates:
        return list(model.coordinates).index(name)
    raise error(f"{model.name}: no joint named {name!r} to lock (joints: {', '.join(names)})")


def lock_index(model: Chain, joint: str | int | None) -> int | None:
    """The 0-based index of the locked joint: ``joint`` is a joint number 1..N (base to tip) or a joint name;
    InputError (one line) for anything else."""
    if joint is None:
        return None
    text = str(joint).strip()
    names = [j.name for j in model.joints]
    numeral = text.isascii() and text.isdigit()  # "³" and "٣" are digits to isdigit, not to int
    if numeral and text in names and 1 <= int(text) <= len(names) and names[int(text) - 1] != text:
        raise InputError(f"{LOCK_OPTION} {text} is ambiguous: joint number {text} is {names[int(text) - 1]!r}, and joint "
                         f"{names.index(text) + 1} is named {text!r}; lock the first by its name ({names[int(text) - 1]}) "
                         f"or the second by its number ({names.index(text) + 1})")
    if numeral and text not in names:
        number = int(text)
        if not 1 <= number <= len(names):
            raise InputError(f"{LOCK_OPTION} {text}: the chain has joints 1..{len(names)} ({', '.join(names)})")
        return number - 1
    return named_joint(model, text)


def with_ik_lock(model: Chain, joint: str | int | None) -> Chain:
    """``model`` with its closed-form IK's locked joint set (``joint``: a number 1..N or a name; ``None``: no
    lock): recorded in the model's loader options, so the files' ``regenerate with`` line carries it."""
    options = tuple(o for o in model.load_options if o[0] != LOCK_OPTION)
    if joint is not None:
        lock_index(model, joint)
        options += ((LOCK_OPTION, str(joint).strip()),)
    return dataclasses.replace(model, load_options=options)
