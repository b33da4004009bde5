"""The general serial chain: constant transforms and joint motions, base to tip.

A :class:`Chain` is what every 3-D robot description compiles into (DH tables in
:mod:`skelarm_sym.models.robot_file`, URDF in :mod:`skelarm_sym.models.urdf`):

    T(q) = base * prod_k [ before_k * M_k(theta_k) * after_k ] * tool

with, per moving joint ``k``, ``M_k`` a rotation by ``theta_k`` about the unit ``axis_k``
(revolute) or a translation by ``theta_k`` along it (prismatic), the axis given in the
joint's own frame (the frame after ``before_k``), and ``theta_k = multiplier_k * q[coordinate_k]
+ offset_k``: every joint follows one input coordinate (a URDF ``mimic`` joint follows
another joint's coordinate; all others have their own, multiplier 1).

Frames and units: metres and radians; ``base`` places the first joint's parent frame in the
world (base) frame; ``tool`` places the tool frame in the last joint's frame (after ``after_n``).
Entries are exact SymPy numbers where the source gave simple numbers (angles within 1e-12
of a multiple of pi/2 become that multiple, so their sines and cosines are exactly 0 or +-1),
and named parameters (symbols) where the source named them.
"""

from __future__ import annotations

import functools
import math
import os
import numbers
import operator
import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Iterable, Mapping, Sequence

import sympy as sp

from ...errors import InputError

if TYPE_CHECKING:  # the annotations only: generating code needs no NumPy
    import numpy as np

MAX_JOINTS = 200
"""Largest number of moving joints accepted."""
ANGLE_SNAP = 1e-12
"""An angle within this of a multiple of pi/2 is taken as that multiple (exact 0, +-1 sines and cosines)."""
ANGLE_MAX = 1e5
"""Largest constant angle (rad) of a robot file: one unit in the last place of a double is 1.5e-11 rad there; at
1e20 it is more than a turn, and such an angle was snapped to a quarter turn (a URDF rpy of 1e20) or kept with its
sine and cosine meaningless (a TOML theta of 1e20: check FAILed 36 rows)."""
KINDS = ("revolute", "prismatic")


# -- exact numbers -----------------------------------------------------------------------------

def exact_number(value: object, what: str = "value") -> sp.Expr:
    """A finite real as an exact SymPy number: Integer when whole, else Float; SymPy expressions pass."""
    if isinstance(value, sp.Basic):
        if value.is_number and not value.is_finite:
            raise InputError(f"{what} must be finite, got {value}")
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{what} must be a number, got {value!r}")
    try:
        x = float(value)
    except OverflowError:  # an integer beyond the double range
        raise InputError(f"{what} must be finite, got an integer of {len(str(abs(value)))} digits") from None
    if not math.isfinite(x):
        raise InputError(f"{what} must be finite, got {x!r}")
    if x == 0.0:
        return sp.S.Zero
    if x.is_integer() and abs(x) < 2**53:
        return sp.Integer(int(x))
    return sp.Float(x)


def exact_angle(value: object, what: str = "angle") -> sp.Expr:
    """An angle as an exact SymPy expression; numbers within ``ANGLE_SNAP`` of k pi/2 become k pi/2."""
    expr = exact_number(value, what)
    if expr.free_symbols or not expr.is_number:
        return expr
    x = float(expr)
    if not abs(x) <= ANGLE_MAX:
        raise InputError(f"{what} {x:g} rad is beyond +-{ANGLE_MAX:g} rad, where a double keeps too few digits below "
                         "a turn: write the angle reduced to one turn")
    k = round(x / (math.pi / 2))
    if abs(x - k * math.pi / 2) <= ANGLE_SNAP:
        return sp.Integer(k) * sp.pi / 2
    return expr


def trig_constant(func, angle: sp.Expr) -> sp.Expr:
    """``func(angle)`` (sp.sin or sp.cos): exact where it is rational (0, +-1, +-1/2), else a Float.

    Constants such as ``sqrt(2)/2`` would print as run-time square roots; a Float prints as a literal.
    """
    value = func(angle)
    if value.free_symbols or value.is_Rational:
        return value
    return sp.Float(value.evalf(30), 17)


def _fold(expr: sp.Expr) -> sp.Expr:
    """Exact zero for a Float that is zero or below any precision's range (products of rounded
    constants leave such dust, 1e-330 say, where the exact value is 0), an exact integer for a
    whole Float (``1.0``: SymPy does not count ``Float(1.0) == 1``); other expressions stay."""
    expr = sp.sympify(expr)
    if expr.is_Float:
        if expr.is_zero or abs(expr) < 1e-300:
            return sp.S.Zero
        if float(expr).is_integer() and abs(float(expr)) < 2**53:
            return sp.Integer(int(float(expr)))
    return expr


# -- constant transforms --------------------------------------------------------------------------

def _folded(value: object) -> sp.ImmutableMatrix:
    """``value`` as an immutable matrix with every entry folded (:func:`_fold`). An immutable matrix whose
    entries are folded already (what ``@`` and the constructors below pass) is returned as it is: building
    SymPy matrices again, not the folding, was most of the time spent reading a URDF."""
    if isinstance(value, sp.ImmutableMatrix):
        entries = value.flat()  # the same entries as list(value), a third of the time
        folded = [_fold(e) for e in entries]
        if all(a is b for a, b in zip(entries, folded)):
            return value
        return sp.ImmutableMatrix(value.rows, value.cols, folded)
    return sp.ImmutableMatrix(sp.Matrix(value).applyfunc(_fold))


_IDENTITY = sp.ImmutableMatrix(sp.eye(3))
_ZERO = sp.ImmutableMatrix(sp.zeros(3, 1))
_IDENTITY_ENTRIES = tuple(_IDENTITY.flat())


@functools.lru_cache(maxsize=4096)
def _xyz_rpy(xyz: tuple[sp.Expr, ...], rpy: tuple[sp.Expr, ...]) -> "Transform":
    """:meth:`Transform.from_xyz_rpy` of exact values (a Transform is immutable: one per distinct origin; a
    file loaded once per tip, and the many origins of a URDF that repeat, are built once). A zero angle
    contributes no factor: most origins have no rotation at all."""
    factors = [Transform.rotate(axis, angle) for axis, angle in zip("zyx", reversed(rpy)) if angle is not sp.S.Zero]
    rotation = functools.reduce(operator.matmul, factors).rotation if factors else _IDENTITY
    return Transform(rotation, sp.ImmutableMatrix(list(xyz)))


@dataclass(frozen=True)
class Transform:
    """A constant rigid transform ``[R t; 0 1]``: ``rotation`` 3 x 3 and ``translation`` 3 x 1 (SymPy)."""

    rotation: sp.ImmutableMatrix = field(default_factory=lambda: _IDENTITY)
    translation: sp.ImmutableMatrix = field(default_factory=lambda: _ZERO)

    def __post_init__(self) -> None:
        object.__setattr__(self, "rotation", _folded(self.rotation))
        object.__setattr__(self, "translation", _folded(self.translation))

    @staticmethod
    def identity() -> "Transform":
        """The identity transform (one shared instance: a Transform is immutable)."""
        return _IDENTITY_TRANSFORM

    @staticmethod
    def translate(x: sp.Expr = 0, y: sp.Expr = 0, z: sp.Expr = 0) -> "Transform":
        """Translation by ``(x, y, z)``."""
        return Transform(translation=sp.ImmutableMatrix([x, y, z]))

    @staticmethod
    def rotate(axis: str, angle: sp.Expr) -> "Transform":
        """Rotation by ``angle`` about the frame's ``"x"``, ``"y"`` or ``"z"`` axis."""
        c, s = trig_constant(sp.cos, angle), trig_constant(sp.sin, angle)
        matrices = {
            "x": [[1, 0, 0], [0, c, -s], [0, s, c]],
            "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
            "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]],
        }
        return Transform(rotation=sp.ImmutableMatrix(matrices[axis]))

    @staticmethod
    def from_xyz_rpy(xyz: Sequence[sp.Expr], rpy: Sequence[sp.Expr]) -> "Transform":
        """URDF origin: translation ``xyz``, rotation ``Rz(yaw) Ry(pitch) Rx(roll)``."""
        return _xyz_rpy(tuple(sp.sympify(v) for v in xyz), tuple(sp.sympify(v) for v in rpy))

    def __matmul__(self, other: "Transform") -> "Transform":
        if self._is_identity_entries() and other._is_numeric():  # a URDF's chain is mostly identities
            return other
        if other._is_identity_entries() and self._is_numeric():
            return self
        rotation = (self.rotation * other.rotation).applyfunc(lambda e: _fold(sp.expand(e)))
        translation = (self.rotation * other.translation + self.translation).applyfunc(lambda e: _fold(sp.expand(e)))
        return Transform(sp.ImmutableMatrix(rotation), sp.ImmutableMatrix(translation))

    def _is_identity_entries(self) -> bool:
        """Whether every entry is SymPy's exact 1 or 0 where the identity has it (a cheap identity test:
        folded entries are those singletons)."""
        return all(x is y for x, y in zip(self.rotation.flat(), _IDENTITY_ENTRIES)) and all(x is sp.S.Zero for x in self.translation.flat())

    def _is_numeric(self) -> bool:
        """Whether every entry is a number. The product of such a transform with the identity is that
        transform, entry for entry (SymPy's product and expansion leave a number alone); an entry with
        symbols could come back expanded, so those take the general product."""
        return all(x.is_Number for x in self.rotation.flat()) and all(x.is_Number for x in self.translation.flat())

    @property
    def matrix(self) -> sp.Matrix:
        """The 4 x 4 homogeneous matrix."""
        top = self.rotation.row_join(self.translation)
        return top.col_join(sp.Matrix([[0, 0, 0, 1]]))

    @property
    def is_identity(self) -> bool:
        """True when the transform is exactly the identity."""
        return self.rotation == sp.eye(3) and self.translation == sp.zeros(3, 1)

    @property
    def free_symbols(self) -> set[sp.Symbol]:
        """Named parameters this transform uses."""
        return self.rotation.free_symbols | self.translation.free_symbols

    def numeric(self, values: Mapping[sp.Symbol, float] | None = None) -> np.ndarray:
        """The 4 x 4 matrix as floats, with parameter ``values`` substituted."""
        import numpy as np  # here, not at import: generating code needs no NumPy

        matrix = self.matrix.xreplace(dict(values or {}))
        try:
            return np.array(matrix.evalf(), dtype=float)
        except TypeError:
            missing = sorted(str(s) for s in matrix.free_symbols)
            raise InputError(f"no value for parameter(s) {', '.join(missing)}") from None


_IDENTITY_TRANSFORM = Transform()
"""The identity transform (:meth:`Transform.identity`)."""


# -- joints and chains ------------------------------------------------------------------------------

@dataclass(frozen=True)
class Joint:
    """One moving joint: ``before * M(theta) * after`` with ``theta = multiplier * q[coordinate] + offset``.

    ``axis`` is a unit vector (exact where possible) in the frame after ``before``. Limits (optional):
    ``lower``/``upper`` on ``theta`` (rad or m) and ``velocity`` on its rate.
    """

    name: str
    kind: str
    before: Transform
    axis: tuple[sp.Expr, sp.Expr, sp.Expr]
    after: Transform
    coordinate: int
    offset: sp.Expr = sp.S.Zero
    multiplier: sp.Expr = sp.S.One
    lower: float | None = None
    upper: float | None = None
    velocity: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InputError(f"joint {self.name!r}: type must be revolute or prismatic, got {self.kind!r}")
        object.__setattr__(self, "axis", unit_axis(self.axis, f"joint {self.name!r} axis"))

    @property
    def free_symbols(self) -> set[sp.Symbol]:
        """Named parameters this joint uses."""
        out = self.before.free_symbols | self.after.free_symbols
        for e in (self.offset, self.multiplier, *self.axis):
            out |= sp.sympify(e).free_symbols
        return out


def unit_axis(axis: Iterable[object], what: str = "axis") -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """``axis`` normalised: exact when it is along x, y or z (either sign), else Floats; length 0 is refused.

    Components whose squares would overflow or underflow (magnitudes beyond 1e150 or below 1e-150) are
    divided by the largest magnitude before the length is formed, so huge (``1e300 1e300 0``) and
    subnormal (``1e-310 0 0``) axes normalise like ``1 1 0`` and ``1 0 0``; only the zero vector has
    length zero."""
    values = list(axis)
    if len(values) != 3:
        raise InputError(f"{what} must have three components, got {len(values)}")
    exprs = [exact_number(v, what) for v in values]
    if any(e.free_symbols for e in exprs):
        raise InputError(f"{what} must be numbers")
    floats = [float(e) for e in exprs]
    largest = max(abs(x) for x in floats)
    if not largest > 0.0:
        raise InputError(f"{what} has length zero")
    if not math.isfinite(largest):
        raise InputError(f"{what} must be finite")
    nonzero = [i for i, x in enumerate(floats) if x != 0.0]
    if len(nonzero) == 1:
        i = nonzero[0]
        out = [sp.S.Zero] * 3
        out[i] = sp.Integer(1 if floats[i] > 0 else -1)
        return tuple(out)  # type: ignore[return-value]
    if not 1e-150 < largest < 1e150:  # squares would overflow or lose digits: scale first
        floats = [x / largest for x in floats]  # the largest becomes +-1, the others stay in [-1, 1]
    length = math.sqrt(sum(x * x for x in floats))
    return tuple(_fold(sp.Float(x / length)) for x in floats)  # type: ignore[return-value]


@dataclass(frozen=True)
class NumericJoint:
    """A joint with every constant as floats (what the NumPy reference reads)."""

    name: str
    kind: str
    before: np.ndarray  # (4, 4)
    axis: np.ndarray  # (3,)
    after: np.ndarray  # (4, 4)
    coordinate: int
    offset: float
    multiplier: float


@dataclass(frozen=True)
class NumericChain:
    """A chain with parameters substituted: ``base`` and ``tool`` (4, 4), ``joints``, ``n`` coordinates."""

    joints: tuple[NumericJoint, ...]
    base: np.ndarray
    tool: np.ndarray
    n: int


@dataclass(frozen=True)
class Chain:
    """A serial chain (see the module docstring).

    ``coordinates``: names of the input coordinates ``q[0..n-1]`` in order (usually one per
    joint, base to tip). ``parameters``: named parameters in order of first appearance; the
    emitted code takes their values as ``params``. ``source``: the file it came from.
    ``prefix``: the default prefix of the emitted files (empty: ``name``; a URDF's file name).
    ``name``, ``description`` and the joint names are text from the robot file: printable (checked by
    the loaders with :func:`~skelarm_sym.names.check_printable`) but otherwise any characters, data
    that printers escape.
    """

    name: str
    joints: tuple[Joint, ...]
    base: Transform = field(default_factory=Transform.identity)
    tool: Transform = field(default_factory=Transform.identity)
    coordinates: tuple[str, ...] = ()
    parameters: tuple[sp.Symbol, ...] = ()
    source: str | None = None
    description: str = ""
    load_options: tuple[tuple[str, str], ...] = ()
    """The loader's options besides the file (``(("--base", "world"), ("--tip", "tool0"))`` for a URDF chain)."""
    prefix: str = ""

    def __post_init__(self) -> None:
        joints = tuple(self.joints)
        object.__setattr__(self, "joints", joints)
        if not joints:
            raise InputError("a chain needs at least one moving joint")
        if len(joints) > MAX_JOINTS:
            raise InputError(f"a chain may have at most {MAX_JOINTS} moving joints, got {len(joints)}")
        coordinates = tuple(self.coordinates) or tuple(j.name for j in joints)
        object.__setattr__(self, "coordinates", coordinates)
        n = len(coordinates)
        if len(set(coordinates)) != n:
            raise InputError("coordinate names must be distinct")
        for j in joints:
            if not 0 <= j.coordinate < n:
                raise InputError(f"joint {j.name!r} follows coordinate {j.coordinate}, but there are {n}")
        followed = {j.coordinate for j in joints}
        if followed != set(range(n)):
            raise InputError(f"coordinate(s) {sorted(set(range(n)) - followed)} move no joint")
        used: set[sp.Symbol] = self.base.free_symbols | self.tool.free_symbols
        for j in joints:
            used |= j.free_symbols
        params = tuple(self.parameters)
        missing = used - set(params)
        if missing:
            params = params + tuple(sorted(missing, key=str))
        object.__setattr__(self, "parameters", params)
        self.limits()  # followers' limits that leave a coordinate no value are refused here, at load

    @property
    def n(self) -> int:
        """Number of input coordinates (the length of ``q``)."""
        return len(self.coordinates)

    @property
    def default_prefix(self) -> str:
        """File name and C prefix when none is given: ``prefix``, else the robot's name."""
        return self.prefix or self.name

    def command_args(self, folder: str | None = None) -> list[str]:
        """The ``skelarm-sym generate`` options (words) that describe this model: the robot file (relative
        to ``folder`` when given, where the emitted files go, so the record holds no machine path; from real
        paths, so it names the file from wherever links lead) and the loader's options."""
        if not self.source:
            return []
        import os

        path = self.source
        if folder is not None:
            try:
                # real paths: the system resolves a relative path from the folder's real place (through a linked
                # folder, "../x.toml" leaves the link's target, not the folder the link sits in)
                path = os.path.relpath(os.path.realpath(self.source), os.path.realpath(folder))
            except ValueError:  # another drive (Windows)
                path = os.path.abspath(self.source)
        return ["--robot", path] + [word for option in self.load_options for word in option]

    def summary(self) -> list[str]:
        """What ``generate`` prints about the model: the chain and the joints it holds, base to tip."""
        joints = ", ".join(f"{j.name} ({j.kind}{', mimic' if self.coordinates[j.coordinate] != j.name else ''})" for j in self.joints)
        return [self.describe(), f"joints, base to tip: {joints}"]

    def describe(self) -> str:
        """One line for file headers."""
        kinds = [j.kind for j in self.joints]
        counts = ", ".join(f"{kinds.count(k)} {k}" for k in KINDS if k in kinds)
        origin = f" from {os.path.basename(self.source)}" if self.source else ""
        text = f"serial chain {self.name!r}{origin}: {self.n} coordinate(s), {len(self.joints)} moving joint(s) ({counts})"
        return text + (f"; {self.description}" if self.description else "")

    def for_precision(self, precision: str) -> "Chain":
        """The chain as ``precision`` holds it: a constant of a transform or an axis, or a limit, below the precision's
        smallest normal number is 0 (what the precision rounds it to: iCub's URDF writes a translation of 2.67e-51
        m, which float cannot hold and a C compiler truncates with a warning), then :meth:`check_representable`."""
        from ..numbers import FLOAT_RANGES

        tiny = FLOAT_RANGES[precision][0]

        def flushed(entry):
            return sp.S.Zero if entry.is_number and not entry.is_zero and abs(float(entry)) < tiny else entry

        def limit(value):
            return 0.0 if value is not None and 0 < abs(float(value)) < tiny else value

        def transform(t: Transform) -> Transform:
            return Transform(t.rotation.applyfunc(flushed), t.translation.applyfunc(flushed))

        transforms = [self.base, self.tool] + [t for j in self.joints for t in (j.before, j.after)]
        entries = [e for t in transforms for m in (t.rotation, t.translation) for e in m.flat()]
        entries += [sp.sympify(a) for j in self.joints for a in j.axis]
        limits = [v for j in self.joints for v in (j.lower, j.upper, j.velocity)]
        chain = self
        if any(flushed(e) is not e for e in entries) or any(limit(v) != v for v in limits):  # (a scan: rarely so)
            joints = tuple(dataclasses.replace(j, before=transform(j.before), after=transform(j.after),
                                               axis=tuple(flushed(sp.sympify(a)) for a in j.axis),
                                               lower=limit(j.lower), upper=limit(j.upper), velocity=limit(j.velocity))
                           for j in self.joints)
            chain = dataclasses.replace(self, base=transform(self.base), tool=transform(self.tool), joints=joints)
        chain.check_representable(precision)
        return chain

    def check_representable(self, precision: str) -> None:
        """Raise :class:`InputError` (one line naming the value) unless every nonzero constant of the chain
        is a normal finite number of ``precision``, and its reach (the sum of the constant translations'
        lengths) has a normal reciprocal and fourth power (the inverse functions scale by it and form
        products of four lengths). The message starts with the robot file's path, where there is one."""
        try:
            self._check_representable(precision)
        except InputError as exc:
            if self.source:
                raise InputError(f"{self.source}: {exc}") from None
            raise

    def _check_representable(self, precision: str) -> None:
        from ..numbers import check_number

        reach = 0.0
        named = [("base", self.base), ("tool", self.tool)]
        named += [(f"joint {j.name!r} {side}", getattr(j, side)) for j in self.joints for side in ("before", "after")]
        for where, transform in named:
            for entry in list(transform.rotation) + list(transform.translation):
                if entry.is_number and not entry.is_zero:
                    check_number(float(entry), f"a constant of the {where} transform", precision)
            if not transform.translation.free_symbols:
                reach += math.hypot(*(float(x) for x in transform.translation))
        for j in self.joints:
            for what, value in (("offset", j.offset), ("multiplier", j.multiplier)):
                value = sp.sympify(value)
                if value.is_number and not value.is_zero:
                    check_number(float(value), f"joint {j.name!r} {what}", precision)
                    if what == "offset" and j.kind == "prismatic":  # a slide's constant offset is a translation too
                        reach += abs(float(value))
            for what, value in (("lower limit", j.lower), ("upper limit", j.upper), ("velocity limit", j.velocity)):
                if value is not None and value != 0:  # the emitted Q_MIN, Q_MAX, DQ_MAX hold them in this precision
                    check_number(float(value), f"joint {j.name!r} {what}", precision)
            _check_resolved_range(j, precision)
        if reach > 0:
            check_number(reach, "the robot's reach (sum of its constant translations and slide offsets)", precision, 4,
                         "the inverse functions use its fourth power")
            check_number(reach, "the robot's reach (sum of its constant translations and slide offsets)", precision, -1)

    def _own_joints(self) -> dict[int, Joint]:
        """Per coordinate, its own joint: the one it is named after, else the first that follows it with multiplier 1
        and offset 0."""
        own: dict[int, Joint] = {}
        for j in self.joints:
            if self.coordinates[j.coordinate] == j.name:
                own.setdefault(j.coordinate, j)
        for j in self.joints:
            if _fold(j.multiplier) == 1 and _fold(j.offset) == 0:
                own.setdefault(j.coordinate, j)
        return own

    def followers(self) -> tuple[Joint, ...]:
        """The joints, base to tip, that follow a coordinate other than as its own joint (URDF ``mimic`` joints)."""
        own = self._own_joints()
        return tuple(j for j in self.joints if own.get(j.coordinate) is not j)

    def limits(self) -> dict[str, tuple[float | None, ...]]:
        """Per coordinate (in input order): ``lower``, ``upper`` (rad or m) and ``velocity`` limits, ``None`` where absent.

        A coordinate's own joint (the one it is named after; else the first that follows it with multiplier 1 and
        offset 0) gives its limits as they are: a DH row's ``lower``/``upper`` bound the joint variable, its
        ``theta`` offset aside. Every other joint that follows the coordinate, ``theta = m q + offset`` (a URDF
        ``mimic`` joint), narrows the range to where it stays within its own limits, and the speed limit to
        ``velocity / |m|``; a multiplier or offset that is a named parameter narrows nothing."""
        own = self._own_joints()
        out: dict[str, list] = {"lower": [None] * self.n, "upper": [None] * self.n, "velocity": [None] * self.n}
        for c, j in own.items():
            out["lower"][c], out["upper"][c], out["velocity"][c] = j.lower, j.upper, j.velocity
        followers = self.followers()
        for j in followers:
            m, offset = _fold(j.multiplier), _fold(j.offset)
            if m.free_symbols or offset.free_symbols:
                continue
            if m == 0:  # held at its offset whatever the coordinate: the offset must lie within its limits
                held = float(offset)
                if (j.lower is not None and held < j.lower) or (j.upper is not None and held > j.upper):
                    raise InputError(f"joint {j.name!r} follows {self.coordinates[j.coordinate]!r} with multiplier 0: it "
                                     f"is held at {held:g}, outside its limits [{_bound(j.lower, '-inf')}, "
                                     f"{_bound(j.upper, 'inf')}]")
                continue
            m, offset = float(m), float(offset)
            c = j.coordinate
            bounds = [None if b is None else (b - offset) / m for b in (j.lower, j.upper)]
            low, high = bounds if m > 0 else bounds[::-1]
            if low is not None and (out["lower"][c] is None or low > out["lower"][c]):
                out["lower"][c] = low
            if high is not None and (out["upper"][c] is None or high < out["upper"][c]):
                out["upper"][c] = high
            if j.velocity is not None:
                v = j.velocity / abs(m)
                out["velocity"][c] = v if out["velocity"][c] is None else min(v, out["velocity"][c])
        for c in range(self.n):
            low, high = out["lower"][c], out["upper"][c]
            if low is not None and high is not None and low > high:
                names = ", ".join(repr(j.name) for j in followers if j.coordinate == c)
                raise InputError(f"coordinate {self.coordinates[c]!r}: the limits of the joints that follow it ({names}) "
                                 f"leave no value within its range (lower {low:g} above upper {high:g})")
        return {k: tuple(v) for k, v in out.items()}

    def numeric(self, params: Sequence[float] | Mapping[str, float] | None = None) -> NumericChain:
        """The chain with parameter values substituted, as floats (for the NumPy reference).

        ``params``: values in the order of :attr:`parameters`, or a mapping by name. Computed once per chain
        and parameter values (SymPy's evaluation of every constant takes milliseconds; checks and judges
        ask again and again): the arrays are read-only, shared by every caller.
        """
        values = self.parameter_values(params)
        key = tuple(sorted((str(k), float(v)) for k, v in values.items()))
        memo = self.__dict__.setdefault("_numeric_memo", {})  # not a field: no part of the chain's value
        hit = memo.get(key)
        if hit is None:
            hit = memo[key] = self._numeric(values)
        return hit

    def _numeric(self, values: dict) -> NumericChain:
        import numpy as np

        def frozen(a):
            a = np.array(a, dtype=float)
            a.setflags(write=False)
            return a

        exact = {k: sp.Float(v) for k, v in values.items()}

        def num(e) -> float:
            return float(sp.sympify(e).xreplace(exact).evalf())

        joints = tuple(
            NumericJoint(
                j.name, j.kind, frozen(j.before.numeric(values)), frozen([num(a) for a in j.axis]),
                frozen(j.after.numeric(values)), j.coordinate, num(j.offset), num(j.multiplier),
            )
            for j in self.joints
        )
        return NumericChain(joints, frozen(self.base.numeric(values)), frozen(self.tool.numeric(values)), self.n)

    def parameter_values(self, params: Sequence[float] | Mapping[str, float] | None) -> dict[sp.Symbol, float]:
        """``{symbol: value}`` for every named parameter; InputError when one is missing or not finite."""
        if not self.parameters:
            return {}
        if params is None:
            raise InputError(f"{self.name} has parameters {', '.join(map(str, self.parameters))}: give their values")
        if isinstance(params, Mapping):
            by_name = dict(params)
            missing = [str(p) for p in self.parameters if str(p) not in by_name]
            if missing:
                raise InputError(f"no value for parameter(s) {', '.join(missing)}")
            values = [by_name[str(p)] for p in self.parameters]
        else:
            import numpy as np

            values = list(np.asarray(params, dtype=float).reshape(-1))
            if len(values) != len(self.parameters):
                raise InputError(f"expected {len(self.parameters)} parameter values, got {len(values)}")
        out = {}
        for p, v in zip(self.parameters, values):
            v = float(v)
            if not math.isfinite(v):
                raise InputError(f"parameter {p} must be finite")
            out[p] = v
        return out


# -- Denavit-Hartenberg ---------------------------------------------------------------------------

CONVENTIONS = ("standard", "modified")


def dh_joint(name: str, kind: str, convention: str, a, alpha, d, theta, coordinate: int) -> Joint:
    """One DH row as a :class:`Joint` (see :mod:`skelarm_sym.models.robot_file` for the conventions).

    standard: ``A = Rz(theta) Tz(d) Tx(a) Rx(alpha)``; modified: ``A = Rx(alpha) Tx(a) Rz(theta) Tz(d)``
    (the row then holds ``a_{i-1}`` and ``alpha_{i-1}``). The joint variable adds to ``theta``
    (revolute) or ``d`` (prismatic); the other one is constant.
    """
    T = Transform
    z = (sp.S.Zero, sp.S.Zero, sp.S.One)
    if convention == "standard":
        tail = T.translate(x=a) @ T.rotate("x", alpha)
        if kind == "revolute":
            return Joint(name, kind, T.identity(), z, T.translate(z=d) @ tail, coordinate, offset=theta)
        return Joint(name, kind, T.rotate("z", theta), z, tail, coordinate, offset=d)
    if convention == "modified":
        head = T.rotate("x", alpha) @ T.translate(x=a)
        if kind == "revolute":
            return Joint(name, kind, head, z, T.translate(z=d), coordinate, offset=theta)
        return Joint(name, kind, head @ T.rotate("z", theta), z, T.identity(), coordinate, offset=d)
    raise InputError(f"convention must be standard or modified, got {convention!r}")


def _check_resolved_range(joint: Joint, precision: str) -> None:
    """Raise :class:`InputError` when a revolute joint's limits hold no angle that ``precision`` resolves to the
    IK solvers' default tolerance: beyond ``tol / epsilon`` rad (4.5e5 in double, 83.9 in float) one unit in the last
    place of the angle exceeds that tolerance, so a range like ``[1e15, 2e15]`` (a typo, or an exponent too many)
    can be neither drawn from nor solved in. A range that holds small angles passes however wide it is (a URDF's
    +-1e16 for a joint without limits)."""
    import numpy as np

    from .solver import SETTINGS

    if joint.kind != "revolute" or joint.lower is None or joint.upper is None:
        return
    lower, upper = float(joint.lower), float(joint.upper)
    nearest = 0.0 if lower <= 0.0 <= upper else min(abs(lower), abs(upper))
    tol = SETTINGS[precision]["tol"]
    bound = tol / float(np.finfo(np.float64 if precision == "double" else np.float32).eps)
    if nearest > bound:
        raise InputError(f"joint {joint.name!r} limits [{lower:g}, {upper:g}] rad hold no angle within {bound:.4g} rad of zero, "
                         f"beyond which {precision} cannot resolve an angle to the IK tolerance {tol:g}: check the limits")


def _bound(value: float | None, absent: str) -> str:
    """A limit for a message: the number, or ``absent`` (``-inf``, ``inf``) where there is none."""
    return absent if value is None else f"{value:g}"
