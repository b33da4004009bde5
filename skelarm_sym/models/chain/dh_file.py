"""Robot files: a Denavit-Hartenberg table in TOML, read into a :class:`~skelarm_sym.models.chain.Chain`.

```toml
name = "ur5"                 # default prefix of the emitted files
convention = "standard"      # standard: A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)   (Spong, Siciliano, Corke)
                             # modified: A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)  (Craig, Khalil)
[[joints]]
type = "revolute"            # or "prismatic"
a = 0.0                      # metres; angles in radians
alpha = "pi/2"               # radians, within one turn: a number, or an arithmetic expression of numbers and pi
d = 0.089159
theta = 0.0                  # revolute: theta_i = q_i + theta; prismatic: d_i = q_i + d
name = "shoulder_pan"        # optional joint name (default q1, q2, ...)
lower = -3.14                # optional joint limits (rad or m) and velocity limit
upper = 3.14
velocity = 3.15

[tool]                       # optional fixed transform after the last joint
xyz = [0.0, 0.0, 0.107]
rpy = [0.0, 0.0, 0.0]        # R = Rz(yaw) Ry(pitch) Rx(roll), as in URDF
[base]                       # optional fixed transform before the first joint, same keys
```
A string that is a plain identifier other than ``pi`` makes the value a named parameter
(the emitted functions then take ``params``, in order of first appearance). Angles within
1e-12 of a multiple of pi/2 count as that multiple. Every error names the file and the key.
"""

from __future__ import annotations

import ast
import dataclasses
import math
import operator
import os
import re
import stat
import tomllib
from pathlib import Path

import sympy as sp

from ...errors import InputError
from ...names import (IDENTIFIER_LENGTH, check_printable, derivation_symbol, identifier_from, quoted, reserved_name,
                      unusable_default)
from .model import CONVENTIONS, KINDS, Chain, Transform, dh_joint, exact_angle, exact_number

TOP_KEYS = {"name", "convention", "joints", "tool", "base", "description"}
JOINT_KEYS = {"type", "a", "alpha", "d", "theta", "name", "lower", "upper", "velocity"}
FRAME_KEYS = {"xyz", "rpy"}
ANGLE_KEYS = {"alpha", "theta"}
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}
MAX_TOML_BYTES = 1024 * 1024
"""Largest robot file read (1 MiB; a DH table of 200 joints has about 30 KiB)."""
MAX_EXPRESSION_LENGTH = 256
"""Longest expression string (``"-155*pi/180"``) read as a value."""
_EXPRESSION_TEXT = re.compile(r"(?:pi|[0-9.eE+\-*/() \t])*")
"""The characters an expression may hold: decimal numbers (with an exponent), ``pi``, ``+ - * /``, parentheses, blanks."""
MAX_EXPRESSION_DEPTH = 64
"""Deepest nesting of operators and parentheses in an expression (``"1+1+...+1"`` nests once per ``+``)."""


def parse_expression(text: str, what: str) -> sp.Expr:
    """An arithmetic expression of numbers and ``pi`` (``"-pi/2"``, ``"3*pi/4"``) as an exact SymPy number.

    At most ``MAX_EXPRESSION_LENGTH`` characters and ``MAX_EXPRESSION_DEPTH`` levels of operators and
    parentheses; anything else is an InputError naming ``what``."""
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise InputError(
            f"{what}: the expression {quoted(text, 40)} is longer than {MAX_EXPRESSION_LENGTH} characters"
        )
    cannot = f"{what}: cannot parse {quoted(text)} (numbers, pi, + - * / and parentheses)"
    if not text.isascii() or not _EXPRESSION_TEXT.fullmatch(text):
        # Python's own number spellings (1_0, 0x1, 0o7, 0b1) and the letters it folds (full-width pi) are not the
        # decimal numbers a robot file holds: a URDF refuses them, and so does this
        raise InputError(cannot)
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError):  # ValueError: a NUL byte
        raise InputError(cannot) from None
    except (RecursionError, MemoryError):
        raise InputError(f"{what}: the expression {quoted(text, 40)} is nested too deeply") from None
    depth, stack = 0, [(tree, 0)]
    while stack:  # iterative: the depth is checked before anything recurses
        node, level = stack.pop()
        depth = max(depth, level)
        stack.extend((child, level + 1) for child in ast.iter_child_nodes(node))
    if depth > MAX_EXPRESSION_DEPTH + 1:  # + 1: the Expression node around the body
        raise InputError(
            f"{what}: the expression {quoted(text, 40)} nests operators and parentheses more than "
            f"{MAX_EXPRESSION_DEPTH} levels deep"
        )

    def build(node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Expression):
            return build(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            if not math.isfinite(float(node.value)):
                raise InputError(f"{what}: {quoted(text)} is not finite")
            return sp.Rational(str(node.value)) if isinstance(node.value, float) else sp.Integer(node.value)
        if isinstance(node, ast.Name) and node.id == "pi":
            return sp.pi
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
            value = build(node.operand)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            left, right = build(node.left), build(node.right)
            if isinstance(node.op, ast.Div) and right == 0:
                raise InputError(f"{what}: division by zero in {quoted(text)}")
            return _BINARY[type(node.op)](left, right)
        raise InputError(cannot)

    try:
        return build(tree)
    except OverflowError:
        raise InputError(f"{what}: {quoted(text)} is not finite") from None


def _value(raw: object, what: str, angle: bool, parameters: dict[str, sp.Symbol]) -> sp.Expr:
    """A table value: number, expression string or parameter name; an angle beyond a turn is refused (see
    :func:`_within_a_turn`)."""
    value = _table_value(raw, what, angle, parameters)
    if angle and value.is_number:
        _within_a_turn(float(value), raw, what)
    return value


def _within_a_turn(x: float, raw: object, what: str) -> None:
    """InputError for a constant angle of more than a turn: a twist or offset of ``90`` is degrees typed where the
    file reads radians (a DH table's constant angles lie within one turn)."""
    if abs(x) > 2 * math.pi * (1 + 1e-12):
        written = raw.strip() if isinstance(raw, str) else f"{x:g}"
        raise InputError(f"{what} = {quoted(written, 40)} is {x:g} rad, more than a turn: angles are in radians "
                         f"(for {x:g} degrees write \"{x:g}*pi/180\")")


def _table_value(raw: object, what: str, angle: bool, parameters: dict[str, sp.Symbol]) -> sp.Expr:
    """A table value: number, expression string or parameter name."""
    if isinstance(raw, str):
        text = raw.strip()
        if _IDENTIFIER.fullmatch(text) and text != "pi":
            if text.lower() in ("nan", "inf", "infinity"):
                raise InputError(f"{what}: {quoted(raw)} is not finite")
            if len(text) > IDENTIFIER_LENGTH:
                raise InputError(f"{what}: parameter name {quoted(text, 40)} is longer than {IDENTIFIER_LENGTH} characters")
            if text.startswith("_"):
                raise InputError(f"{what}: parameter name {text!r} starts with _, as the derivation's own names do: "
                                 "start it with a letter")
            if reserved_name(text) or derivation_symbol(text):
                raise InputError(f"{what}: parameter name {text!r} is a reserved word")
            return parameters.setdefault(text, sp.Symbol(text, real=True))
        return _expression_value(text, what, angle)
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise InputError(f"{what} must be a number or a string expression, got {type(raw).__name__}")
    return exact_angle(raw, what) if angle else exact_number(raw, what)


def _expression_value(text: str, what: str, angle: bool) -> sp.Expr:
    """A finite expression string as an exact value (an angle close to k pi/2 snaps to it)."""
    value = parse_expression(text, what)
    try:
        finite = bool(value.is_finite) and math.isfinite(float(value))
    except OverflowError:
        finite = False
    if not finite:
        raise InputError(f"{what}: {quoted(text)} is not finite")
    if angle:  # exact as written; a number close to a multiple of pi/2 snaps to it
        snapped = exact_angle(float(value), what)
        return snapped if snapped.has(sp.pi) or snapped == 0 else value
    return value if value.is_Rational else exact_number(float(value), what)


def _frame(raw: object, what: str, parameters: dict[str, sp.Symbol]) -> Transform:
    if not isinstance(raw, dict):
        raise InputError(f"{what} must be a table with xyz and rpy")
    unknown = sorted(set(raw) - FRAME_KEYS)
    if unknown:
        raise InputError(f"{what}: unknown key {quoted(unknown[0])} (expected xyz, rpy)")
    values = {}
    for key in ("xyz", "rpy"):
        items = raw.get(key, [0.0, 0.0, 0.0])
        if not isinstance(items, list) or len(items) != 3:
            raise InputError(f"{what}.{key} must be a list of three numbers")
        values[key] = [_value(v, f"{what}.{key}[{i}]", key == "rpy", parameters) for i, v in enumerate(items)]
    return Transform.from_xyz_rpy(values["xyz"], values["rpy"])


def _limit(raw: object, what: str) -> float | None:
    """A joint limit (rad, m, rad/s or m/s): a number, or an expression of numbers and pi as for angles
    (``"-155*pi/180"``, ``"pi/2"``); None when absent. Parameters are not allowed here."""
    if raw is None:
        return None
    if isinstance(raw, str):
        text = raw.strip()
        if _IDENTIFIER.fullmatch(text) and text != "pi":
            raise InputError(
                f"{what} must be a number or an expression of numbers and pi (\"-155*pi/180\"), not the name {quoted(text, 40)}"
            )
        return float(_expression_value(text, what, angle=False))
    if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(float(raw)):
        raise InputError(f"{what} must be a finite number")
    return float(raw)


def chain_from_table(data: dict, source: str | None = None, default_name: str = "robot") -> Chain:
    """Build a :class:`Chain` from a parsed robot-file table (see the module docstring)."""
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise InputError(f"unknown key {quoted(unknown[0])} (expected {', '.join(sorted(TOP_KEYS))})")
    name = data.get("name", default_name)
    if isinstance(name, str):
        check_printable(name, "name")
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,47}", name):
        raise InputError(f"name must be a C identifier (a letter, then letters, digits or _; at most 48), got {quoted(name) if isinstance(name, str) else repr(name)}")
    convention = data.get("convention", "standard")
    if convention not in CONVENTIONS:
        raise InputError(f"convention must be standard or modified, got {convention!r}")
    rows = data.get("joints")
    if not isinstance(rows, list) or not rows:
        raise InputError("no joints: add one [[joints]] table per joint, base to tip")
    parameters: dict[str, sp.Symbol] = {}
    base = _frame(data["base"], "base", parameters) if "base" in data else Transform.identity()
    joints = []
    names = []
    for i, row in enumerate(rows):
        where = f"joints[{i}]"
        if not isinstance(row, dict):
            raise InputError(f"{where} must be a table")
        unknown = sorted(set(row) - JOINT_KEYS)
        if unknown:
            raise InputError(f"{where}: unknown key {quoted(unknown[0])} (expected {', '.join(sorted(JOINT_KEYS))})")
        if "type" not in row:
            raise InputError(f"{where}: missing type (revolute or prismatic)")
        kind = row["type"]
        if kind not in KINDS:
            raise InputError(f"{where}.type must be revolute or prismatic, got {kind!r}")
        values = {k: _value(row.get(k, 0.0), f"{where}.{k}", k in ANGLE_KEYS, parameters) for k in ("a", "alpha", "d", "theta")}
        joint_name = row.get("name", f"q{i + 1}")
        if not isinstance(joint_name, str) or not joint_name:
            raise InputError(f"{where}.name must be a non-empty string")
        check_printable(joint_name, f"{where}.name")
        names.append(joint_name)
        joint = dh_joint(joint_name, kind, convention, values["a"], values["alpha"], values["d"], values["theta"], i)
        limits = {k: _limit(row.get(k), f"{where}.{k}") for k in ("lower", "upper", "velocity")}
        if limits["lower"] is not None and limits["upper"] is not None and limits["lower"] > limits["upper"]:
            raise InputError(f"{where}: lower limit {limits['lower']} is above upper limit {limits['upper']}")
        if limits["velocity"] is not None and limits["velocity"] <= 0:
            raise InputError(f"{where}.velocity must be positive")
        joints.append(dataclasses.replace(joint, **limits))
    twice = next((x for i, x in enumerate(names) if x in names[:i]), None)
    if twice is not None:
        raise InputError(f"joint names must be distinct: {quoted(twice)} names joints[{names.index(twice)}] and "
                         f"joints[{names.index(twice, names.index(twice) + 1)}]")
    tool = _frame(data["tool"], "tool", parameters) if "tool" in data else Transform.identity()
    description = data.get("description", f"{convention} DH")
    if not isinstance(description, str):
        raise InputError("description must be a string")
    check_printable(description, "description", "descriptions")
    return Chain(
        name, tuple(joints), base, tool, tuple(names), tuple(parameters.values()), source,
        description=f"{convention} DH" if description == f"{convention} DH" else description,
        prefix=_default_prefix(name),
    )


def _default_prefix(name: str) -> str:
    """The files' default prefix for a robot named ``name``: ``""`` (the name itself) where the name is usable
    as a prefix in every output, else the name made an identifier (:func:`~skelarm_sym.names.unusable_default`: a C or
    Python keyword, a Python standard module, a module the emitted Python imports, a C system header, a CMake target
    name: ``long`` gives ``long_robot``, ``torch`` ``torch_robot``, ``install`` ``install_robot``), as a URDF's file
    name is."""
    return (identifier_from(name) or "robot") if unusable_default(name) else ""


def read_robot_bytes(path: Path, what: str, max_bytes: int = MAX_TOML_BYTES) -> bytes:
    """The bytes of a robot description of at most ``max_bytes``; InputError naming the file when it
    cannot be read, is larger, or is no regular file (a FIFO's open waited for a writer forever; a device)."""
    nonblocking = getattr(os, "O_NONBLOCK", 0)
    try:
        # O_NONBLOCK: opening a FIFO does not wait for a writer; the check below refuses it before any read
        fd = os.open(path, os.O_RDONLY | nonblocking)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a folder, not a {what}") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        if stat.S_ISDIR(os.fstat(fd).st_mode):
            raise InputError(f"{path}: is a folder, not a {what}")
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise InputError(f"{path}: not a regular file (a pipe or a device): a {what} is read from a file")
        if nonblocking:
            os.set_blocking(fd, True)
        with os.fdopen(fd, "rb") as handle:
            fd = -1
            data = handle.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    finally:
        if fd >= 0:
            os.close(fd)
    if len(data) > max_bytes:
        raise InputError(f"{path}: larger than {_size(max_bytes)}: a {what} is read only up to that size")
    return data


def _size(count: int) -> str:
    return f"{count // (1024 * 1024)} MiB" if count % (1024 * 1024) == 0 else f"{count} bytes"


def load_robot_file(path: str | os.PathLike) -> Chain:
    """Read a TOML robot file (at most ``MAX_TOML_BYTES``); InputError naming the file and the problem
    (and the key, where there is one) on any bad input, too large or too deeply nested values included."""
    path = Path(path)
    raw = read_robot_bytes(path, "robot file", MAX_TOML_BYTES)
    try:
        text = raw.decode("utf-8-sig")  # a byte order mark (Windows editors write one) is not TOML
        data = tomllib.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:  # TOMLDecodeError; ValueError: an integer of over 4300 digits
        reason = (str(exc).splitlines() or [""])[0].split("; use sys.set_int_max_str_digits")[0]
        raise InputError(f"{path}: not valid TOML: {reason[:200]}") from None
    except (RecursionError, MemoryError):
        raise InputError(f"{path}: {_too_deep(text)}") from None
    if _nesting(data) > MAX_TOML_DEPTH:  # parsed where the stack allowed it (a raised recursion limit): the same refusal
        raise InputError(f"{path}: {_too_deep(text)}")
    try:
        return chain_from_table(data, source=str(path), default_name=_default_name(path))
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    except (RecursionError, MemoryError):  # a safety net: no value above should get here
        raise InputError(f"{path}: a value is too large or too deeply nested to read") from None


MAX_TOML_DEPTH = 32
"""Arrays and inline tables nested deeper than this are refused (named as the cause when tomllib gives up, and
checked on what it read where a raised recursion limit let it read more: PyTorch's compiler raises it)."""


def _nesting(document: dict) -> int:
    """How deep arrays and tables nest inside a parsed TOML document (its own table not counted)."""
    deepest, stack = 0, [(document, 0)]
    while stack:
        x, depth = stack.pop()
        deepest = max(deepest, depth)
        children = x.values() if isinstance(x, dict) else x
        stack.extend((v, depth + 1) for v in children if isinstance(v, (dict, list)))
    return deepest


def _too_deep(text: str) -> str:
    """Where ``text`` nests arrays or inline tables too deeply (tomllib ran out of stack): the line
    and key of the first value nested deeper than ``MAX_TOML_DEPTH``, found by a scan that skips
    strings and comments on each line."""
    depth, key, table, counts = 0, None, "", {}
    for number, line in enumerate(text.splitlines(), 1):
        stripped = line.strip()
        if depth == 0:
            header = re.match(r"\[\[\s*([^\]]+?)\s*\]\]|\[\s*([^\]]+?)\s*\]", stripped)
            if header:
                if header.group(1):
                    table = header.group(1)
                    counts[table] = counts.get(table, 0) + 1
                    table = f"{table}[{counts[table] - 1}]"
                else:
                    table = header.group(2)
                continue
            assignment = re.match(r"([A-Za-z0-9_\-.\"' ]+?)\s*=", stripped)
            if assignment:
                key = f"{table}.{assignment.group(1).strip()}" if table else assignment.group(1).strip()
        quote = None
        for char in line:
            if quote:
                quote = None if char == quote else quote
            elif char in "\"'":
                quote = char
            elif char == "#":
                break
            elif char in "[{":
                depth += 1
                if depth > MAX_TOML_DEPTH:
                    where = f"key {quoted(key, 40)}" if key else "a value"
                    return f"line {number}: {where} nests arrays or inline tables more than {MAX_TOML_DEPTH} deep"
            elif char in "]}":
                depth = max(depth - 1, 0)
    return f"a value nests arrays or inline tables more than {MAX_TOML_DEPTH} deep, or is too large to read"


def _default_name(path: Path) -> str:
    """The robot's name when its file has no ``name`` key: the file name's stem made an identifier
    (:func:`~skelarm_sym.names.identifier_from`), else ``robot``."""
    return identifier_from(path.stem) or "robot"
