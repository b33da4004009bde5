"""Command-line options shared by the ``skelarm-sym`` commands and by ``check --from`` (which reads a
recorded ``generate`` command back): the model options each kind registers, and the generation options.

:func:`model_from_args` is the one place that turns parsed options into a model: it asks each registered
kind in turn (:data:`skelarm_sym.models.registry.ModelKind.from_args`) and refuses options that belong to
another kind.
"""

from __future__ import annotations

import argparse
import difflib

from .errors import InputError
from .names import path_option
from .models.registry import kinds


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one-line :class:`InputError` (status 2, no usage dump)."""

    def error(self, message: str) -> None:
        if message.startswith("unrecognized arguments:"):
            message += _nearest_options(self, message.split(":", 1)[1].split())
        raise InputError(message)


def _option_owners(parser: argparse.ArgumentParser, name: str = "") -> dict[str, set[str]]:
    """Every ``--option`` of ``parser`` and of its subcommands, with the (sub)commands that take it."""
    out: dict[str, set[str]] = {o: {name} for o in parser._option_string_actions if o.startswith("--")}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                for option, owners in _option_owners(sub, sub_name).items():
                    out.setdefault(option, set()).update(owners)
    return out


def _nearest_options(parser: argparse.ArgumentParser, given: list[str]) -> str:
    """A hint for the unknown options in ``given``: the known one they are near (``--language``: ``--lang``), or
    the commands that take an option this command does not; ``""`` when there is none."""
    owners = _option_owners(parser)
    known = sorted(owners)
    hints = []
    for word in given:
        flag = word.split("=", 1)[0]
        if not flag.startswith("--"):
            continue
        if flag in owners:
            hints.append(f"{flag} is an option of {' and '.join(sorted(o for o in owners[flag] if o))}")
            continue
        near = [o for o in known if flag.startswith(o) or o.startswith(flag)] or difflib.get_close_matches(flag, known, n=1)
        if near:
            hints.append(f"{flag}: did you mean {near[0]}?")
    return f" ({'; '.join(hints)})" if hints else ""


class Default(str):
    """An option's default value (a ``str``): tells an option left out from one given with the same text
    (``generate --from`` refuses every option its files record)."""


def add_model_options(parser: argparse.ArgumentParser) -> None:
    """``--model`` and every kind's own options."""
    named = [k.name for k in kinds() if k.model_option]
    parser.add_argument("--model", choices=named, help=f"the kind of model when no --robot is given: {' or '.join(named)} "
                        f"(default {named[-1]})")
    for kind in kinds():
        if kind.add_options is not None:
            kind.add_options(parser)


def model_given(args) -> list[str]:
    """The model options given on the command line (flags)."""
    flags = [flag for kind in kinds() for flag, dest in kind.options if getattr(args, dest, None) is not None]
    return flags + (["--model"] if getattr(args, "model", None) is not None else [])


def model_from_args(args, folder=None):
    """The model an invocation describes (files named relative to ``folder`` when given: a recorded
    command); InputError when its options do not fit it."""
    for kind in kinds():
        model = kind.from_args(args, folder) if kind.from_args is not None else None
        if model is None:
            continue
        others = [flag for other in kinds() if other is not kind for flag, dest in other.options
                  if getattr(args, dest, None) is not None]
        if others:
            raise InputError(f"{', '.join(others)} {'does' if len(others) == 1 else 'do'} not apply to {kind.title}; "
                             f"{kind.title} takes {', '.join(flag for flag, _ in kind.options) or 'no options'}")
        return model
    raise InputError("the following arguments are required: --links/-n (a planar arm), --model diffdrive or --robot FILE")


def add_generate_options(parser: argparse.ArgumentParser) -> None:
    """The options of ``generate`` besides the model's."""
    from .backends import BACKENDS

    parser.add_argument("--lang", default=Default("c,python"), help=f"comma-separated languages: {', '.join(BACKENDS)} (default c,python; numpy or py: python)")
    rules = "; ".join(kind.prefix_rule for kind in kinds() if kind.prefix_rule)
    parser.add_argument("--prefix", help=f"file name and C function prefix (default: {rules}); robots linked into one program need prefixes that differ in more than case (their macros are the prefix in upper case)")
    parser.add_argument("--precision", default=Default("double"), help="double (default) or float")
    parser.add_argument("--out", default=Default("generated"), type=path_option, help="output folder (default ./generated)")
    parser.add_argument("--compile", action="store_true", help="also compile the C with the strict flags and report the library path")
    parser.add_argument("--functions", help="comma-separated functions to emit (default all; a solver such as ik_solve "
                        "brings the functions it calls)")
    parser.add_argument("--cmake", action="store_true", help="also write CMakeLists.txt: a static library target named after the prefix")
    parser.add_argument("--force", action="store_true", help="replace files generated with other options")


def generate_parser(prog: str = "skelarm-sym generate") -> Parser:
    """The parser of ``generate``'s options (model and generation)."""
    parser = Parser(prog=prog, description="emit C and/or Python for a model")
    add_model_options(parser)
    add_generate_options(parser)
    return parser
