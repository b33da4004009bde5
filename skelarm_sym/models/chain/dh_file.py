"""Robot files: a Denavit-Hartenberg table in TOML, read into a :class:`~skelarm_sym.models.chain.Chain`.

```toml
name = "ur5"                 # default prefix of the emitted files
convention = "standard"      # standard: A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)   (Spong, Siciliano, Corke)
                             # modified: A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)  (Craig, Khalil)
[[joints]]
type = "revolute"            # or "prismatic"
a = 0.0                      # metres; angles in radians
alpha = "pi/2"               # a number, or an arithmetic expression of numbers and pi
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
import tomllib
from pathlib import Path

import sympy as sp

from ...errors import InputError
from ...names import reserved_name
from .model import CONVENTIONS, KINDS, Chain, Transform, dh_joint, exact_angle, exact_number

TOP_KEYS = {"name", "convention", "joints", "tool", "base", "description"}
JOINT_KEYS = {"type", "a", "alpha", "d", "theta", "name", "lower", "upper", "velocity"}
FRAME_KEYS = {"xyz", "rpy"}
ANGLE_KEYS = {"alpha", "theta"}
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}


def parse_expression(text: str, what: str) -> sp.Expr:
    """An arithmetic expression of numbers and ``pi`` (``"-pi/2"``, ``"3*pi/4"``) as an exact SymPy number."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise InputError(f"{what}: cannot parse {text!r} (numbers, pi, + - * / and parentheses)") from None

    def build(node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Expression):
            return build(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            if not math.isfinite(float(node.value)):
                raise InputError(f"{what}: {text!r} is not finite")
            return sp.Rational(str(node.value)) if isinstance(node.value, float) else sp.Integer(node.value)
        if isinstance(node, ast.Name) and node.id == "pi":
            return sp.pi
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
            value = build(node.operand)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            left, right = build(node.left), build(node.right)
            if isinstance(node.op, ast.Div) and right == 0:
                raise InputError(f"{what}: division by zero in {text!r}")
            return _BINARY[type(node.op)](left, right)
        raise InputError(f"{what}: cannot parse {text!r} (numbers, pi, + - * / and parentheses)")

    return build(tree)


def _value(raw: object, what: str, angle: bool, parameters: dict[str, sp.Symbol]) -> sp.Expr:
    """A table value: number, expression string or parameter name."""
    if isinstance(raw, str):
        text = raw.strip()
        if _IDENTIFIER.fullmatch(text) and text != "pi":
            if text.lower() in ("nan", "inf", "infinity"):
                raise InputError(f"{what}: {raw!r} is not finite")
            if reserved_name(text):
                raise InputError(f"{what}: parameter name {text!r} is a reserved word")
            return parameters.setdefault(text, sp.Symbol(text, real=True))
        value = parse_expression(text, what)
        try:
            finite = bool(value.is_finite) and math.isfinite(float(value))
        except OverflowError:
            finite = False
        if not finite:
            raise InputError(f"{what}: {raw!r} is not finite")
        if angle:  # exact as written; a number close to a multiple of pi/2 snaps to it
            snapped = exact_angle(float(value), what)
            return snapped if snapped.has(sp.pi) or snapped == 0 else value
        return value if value.is_Rational else exact_number(float(value), what)
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise InputError(f"{what} must be a number or a string expression, got {type(raw).__name__}")
    return exact_angle(raw, what) if angle else exact_number(raw, what)


def _frame(raw: object, what: str, parameters: dict[str, sp.Symbol]) -> Transform:
    if not isinstance(raw, dict):
        raise InputError(f"{what} must be a table with xyz and rpy")
    unknown = sorted(set(raw) - FRAME_KEYS)
    if unknown:
        raise InputError(f"{what}: unknown key {unknown[0]!r} (expected xyz, rpy)")
    values = {}
    for key in ("xyz", "rpy"):
        items = raw.get(key, [0.0, 0.0, 0.0])
        if not isinstance(items, list) or len(items) != 3:
            raise InputError(f"{what}.{key} must be a list of three numbers")
        values[key] = [_value(v, f"{what}.{key}[{i}]", key == "rpy", parameters) for i, v in enumerate(items)]
    return Transform.from_xyz_rpy(values["xyz"], values["rpy"])


def _limit(raw: object, what: str) -> float | None:
    if raw is None:
        return None
    if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(float(raw)):
        raise InputError(f"{what} must be a finite number")
    return float(raw)


def chain_from_table(data: dict, source: str | None = None, default_name: str = "robot") -> Chain:
    """Build a :class:`Chain` from a parsed robot-file table (see the module docstring)."""
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise InputError(f"unknown key {unknown[0]!r} (expected {', '.join(sorted(TOP_KEYS))})")
    name = data.get("name", default_name)
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,47}", name):
        raise InputError(f"name must be a C identifier (a letter, then letters, digits or _), got {name!r}")
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
            raise InputError(f"{where}: unknown key {unknown[0]!r} (expected {', '.join(sorted(JOINT_KEYS))})")
        if "type" not in row:
            raise InputError(f"{where}: missing type (revolute or prismatic)")
        kind = row["type"]
        if kind not in KINDS:
            raise InputError(f"{where}.type must be revolute or prismatic, got {kind!r}")
        values = {k: _value(row.get(k, 0.0), f"{where}.{k}", k in ANGLE_KEYS, parameters) for k in ("a", "alpha", "d", "theta")}
        joint_name = row.get("name", f"q{i + 1}")
        if not isinstance(joint_name, str) or not joint_name:
            raise InputError(f"{where}.name must be a non-empty string")
        names.append(joint_name)
        joint = dh_joint(joint_name, kind, convention, values["a"], values["alpha"], values["d"], values["theta"], i)
        limits = {k: _limit(row.get(k), f"{where}.{k}") for k in ("lower", "upper", "velocity")}
        if limits["lower"] is not None and limits["upper"] is not None and limits["lower"] > limits["upper"]:
            raise InputError(f"{where}: lower limit {limits['lower']} is above upper limit {limits['upper']}")
        if limits["velocity"] is not None and limits["velocity"] <= 0:
            raise InputError(f"{where}.velocity must be positive")
        joints.append(dataclasses.replace(joint, **limits))
    if len(set(names)) != len(names):
        raise InputError("joint names must be distinct")
    tool = _frame(data["tool"], "tool", parameters) if "tool" in data else Transform.identity()
    description = data.get("description", f"{convention} DH")
    if not isinstance(description, str):
        raise InputError("description must be a string")
    return Chain(
        name, tuple(joints), base, tool, tuple(names), tuple(parameters.values()), source,
        description=f"{convention} DH" if description == f"{convention} DH" else description,
    )


def read_robot_bytes(path: Path, what: str) -> bytes:
    """The bytes of a robot description; InputError naming the file when it cannot be read."""
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a folder, not a {what}") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None


def load_robot_file(path: str | os.PathLike) -> Chain:
    """Read a TOML robot file; InputError naming the file and the problem on any bad input."""
    path = Path(path)
    text = read_robot_bytes(path, "robot file")
    try:
        data = tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid TOML: {str(exc).splitlines()[0]}") from None
    try:
        return chain_from_table(data, source=str(path), default_name=_default_name(path))
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def _default_name(path: Path) -> str:
    stem = re.sub(r"[^A-Za-z0-9_]", "_", path.stem) or "robot"
    return stem if stem[0].isalpha() else "robot_" + stem
