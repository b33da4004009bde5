"""URDF files read into a :class:`~skelarm_sym.models.chain.Chain`: the path from one link to another.

Parsed with :mod:`xml.etree.ElementTree` (no ROS, no meshes, no network; ``<visual>``,
``<collision>``, ``<inertial>``, ``<transmission>``, ``<gazebo>`` and ``package://`` URIs are
ignored). The chain is the path from ``base`` (default: the root link) to ``tip`` (default: the
only leaf below ``base``) in the link tree; joints elsewhere (another arm, the fingers) are left out.

Joints on the path:

- ``revolute`` and ``continuous`` become revolute joints, ``prismatic`` prismatic ones: ``before`` =
  (fixed transforms since the previous moving joint) * ``origin``, ``axis`` = ``<axis xyz>``
  (default ``1 0 0``) normalised, ``after`` = identity;
- ``fixed`` joints are folded into the constant transforms: into the next moving joint's ``before``,
  into the chain's ``tool`` after the last moving joint, into its ``base`` before the first;
- ``<mimic joint="j" multiplier="m" offset="o"/>`` (on a revolute or prismatic joint): the follower
  has no coordinate of its own, ``theta = m * q_j + o`` (``j`` must be on the chain);
- ``floating`` and ``planar`` joints are refused.

``origin rpy`` is ``R = Rz(yaw) Ry(pitch) Rx(roll)``; angles within 1e-12 of a multiple of pi/2
are exactly that multiple, and whole numbers are exact. Position limits (``lower``/``upper``; none
for ``continuous``) and the ``velocity`` limit are kept on the joints. Every error is one line that
names the file and the problem.
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import sympy as sp

from ...errors import InputError
from ...names import reserved_name
from .model import Chain, Joint, Transform, exact_angle, exact_number, unit_axis
from .dh_file import read_robot_bytes

MOVING = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}
REFUSED = ("floating", "planar")
TYPES = (*MOVING, "fixed", *REFUSED)
_LISTED = 12  # names listed in an error message before "..."


@dataclass(frozen=True)
class _UrdfJoint:
    """One ``<joint>`` element as read (no interpretation yet)."""

    name: str
    type: str
    parent: str
    child: str
    element: ET.Element


def _tag(element: ET.Element) -> str:
    """The tag without an XML namespace."""
    return element.tag.rsplit("}", 1)[-1] if isinstance(element.tag, str) else ""


def _children(element: ET.Element, tag: str) -> list[ET.Element]:
    return [e for e in element if _tag(e) == tag]


def _one(element: ET.Element, tag: str, what: str) -> ET.Element | None:
    found = _children(element, tag)
    if len(found) > 1:
        raise InputError(f"{what} has {len(found)} <{tag}> elements, expected at most one")
    return found[0] if found else None


def _listing(names) -> str:
    names = list(names)
    shown = ", ".join(repr(n) for n in names[:_LISTED])
    return shown + (f", ... ({len(names)} in all)" if len(names) > _LISTED else "")


def _numbers(text: str | None, count: int, what: str, default: tuple[float, ...]) -> list[float]:
    """``count`` floats from a space-separated attribute (``default`` when absent)."""
    if text is None:
        return list(default)
    parts = text.split()
    if len(parts) != count:
        raise InputError(f"{what} must have {count} numbers, got {text.strip()!r}")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InputError(f"{what} must be numbers, got {text.strip()!r}") from None
    for v in values:
        if not math.isfinite(v):
            raise InputError(f"{what} must be finite, got {text.strip()!r}")
    return values


def _scalar(element: ET.Element, key: str, what: str) -> float | None:
    text = element.get(key)
    if text is None:
        return None
    return _numbers(text, 1, f"{what} {key}", ())[0]


def _origin(joint: _UrdfJoint) -> Transform:
    what = f"joint {joint.name!r} origin"
    element = _one(joint.element, "origin", f"joint {joint.name!r}")
    if element is None:
        return Transform.identity()
    xyz = _numbers(element.get("xyz"), 3, f"{what} xyz", (0.0, 0.0, 0.0))
    rpy = _numbers(element.get("rpy"), 3, f"{what} rpy", (0.0, 0.0, 0.0))
    written = (element.get("rpy") or "").split() or [None] * 3
    return Transform.from_xyz_rpy(
        [exact_number(v, f"{what} xyz") for v in xyz],
        [written_angle(v, text, f"{what} rpy") for v, text in zip(rpy, written)],
    )


WRITTEN_DIGITS = 8
"""An rpy angle written with at least this many decimals that is the correctly rounded decimal of a
multiple of pi/2 (``1.57079632679`` in ur_description, ``3.14159265``) is that multiple exactly."""


def written_angle(value: float, text: str | None, what: str) -> sp.Expr:
    """``value`` as an exact angle: within 1e-12 of k pi/2 (see ``exact_angle``), or written as the
    rounded decimal of k pi/2 with ``WRITTEN_DIGITS`` or more decimals."""
    angle = exact_angle(value, what)
    if angle.has(sp.pi) or angle == 0 or text is None:
        return angle
    mantissa = text.strip().lower().split("e")[0]
    if "e" in text.lower() or "." not in mantissa:
        return angle
    digits = len(mantissa.split(".")[1])
    k = round(value / (math.pi / 2))
    if digits >= WRITTEN_DIGITS and k != 0 and abs(value - k * math.pi / 2) <= 0.5 * 10.0**-digits + 1e-15:
        return sp.Integer(k) * sp.pi / 2
    return angle


def _axis(joint: _UrdfJoint) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    what = f"joint {joint.name!r} axis"
    element = _one(joint.element, "axis", f"joint {joint.name!r}")
    values = _numbers(None if element is None else element.get("xyz"), 3, f"{what} xyz", (1.0, 0.0, 0.0))
    return unit_axis(values, what)


def _limits(joint: _UrdfJoint) -> dict[str, float | None]:
    what = f"joint {joint.name!r} limit"
    element = _one(joint.element, "limit", f"joint {joint.name!r}")
    out: dict[str, float | None] = {"lower": None, "upper": None, "velocity": None}
    if element is None:
        return out
    if joint.type != "continuous":
        out["lower"] = _scalar(element, "lower", what)
        out["upper"] = _scalar(element, "upper", what)
    out["velocity"] = _scalar(element, "velocity", what)
    if out["lower"] is not None and out["upper"] is not None and out["lower"] > out["upper"]:
        raise InputError(f"{what}: lower {out['lower']} is above upper {out['upper']}")
    if out["velocity"] is not None and out["velocity"] < 0:
        raise InputError(f"{what}: velocity must not be negative, got {out['velocity']}")
    if out["velocity"] == 0:  # URDF files write 0 for "not given"
        out["velocity"] = None
    return out


def _mimic(joint: _UrdfJoint, joints: dict[str, _UrdfJoint]) -> tuple[str, float, float] | None:
    """``(followed joint, multiplier, offset)`` for a ``<mimic>`` joint, else None."""
    element = _one(joint.element, "mimic", f"joint {joint.name!r}")
    if element is None:
        return None
    what = f"joint {joint.name!r} mimic"
    followed = element.get("joint")
    if not followed:
        raise InputError(f"{what} has no joint attribute")
    if followed == joint.name:
        raise InputError(f"{what} refers to itself")
    if followed not in joints:
        raise InputError(f"{what} refers to joint {followed!r}, which is not in the file")
    multiplier = _scalar(element, "multiplier", what)
    offset = _scalar(element, "offset", what)
    return followed, 1.0 if multiplier is None else multiplier, 0.0 if offset is None else offset


def _c_name(text: str | None, fallback: str) -> str:
    """A C identifier (letter first, at most 48 characters) from a robot name."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", (text or "").strip()) or re.sub(r"[^A-Za-z0-9_]", "_", fallback) or "robot"
    if not name[0].isalpha():
        name = "robot_" + name
    name = name[:48]
    if reserved_name(name):
        name = name[:42] + "_robot"
    return name


def _read_tree(root: ET.Element) -> tuple[list[str], dict[str, _UrdfJoint], dict[str, _UrdfJoint]]:
    """Links in file order, joints by name, and each child link's joint; checks names, types and the tree."""
    if _tag(root) != "robot":
        raise InputError(f"the root element is <{_tag(root)}>, expected <robot>")
    links: list[str] = []
    for element in _children(root, "link"):
        name = element.get("name")
        if not name:
            raise InputError("a <link> has no name")
        if name in links:
            raise InputError(f"link {name!r} is defined twice")
        links.append(name)
    if not links:
        raise InputError("no <link> elements")
    known = set(links)
    joints: dict[str, _UrdfJoint] = {}
    parent_joint: dict[str, _UrdfJoint] = {}
    for element in _children(root, "joint"):
        name = element.get("name")
        if not name:
            raise InputError("a <joint> has no name")
        if name in joints:
            raise InputError(f"joint {name!r} is defined twice")
        kind = element.get("type")
        if kind not in TYPES:
            raise InputError(f"joint {name!r}: type must be one of {', '.join(TYPES)}, got {kind!r}")
        ends = {}
        for end in ("parent", "child"):
            tag = _one(element, end, f"joint {name!r}")
            link = None if tag is None else tag.get("link")
            if not link:
                raise InputError(f"joint {name!r} has no <{end} link=...>")
            if link not in known:
                raise InputError(f"joint {name!r}: {end} link {link!r} is not a <link> in the file")
            ends[end] = link
        if ends["parent"] == ends["child"]:
            raise InputError(f"joint {name!r} connects link {ends['child']!r} to itself")
        joint = _UrdfJoint(name, kind, ends["parent"], ends["child"], element)
        if joint.child in parent_joint:
            other = parent_joint[joint.child]
            raise InputError(f"link {joint.child!r} has two parents: joints {other.name!r} and {name!r}")
        joints[name] = joint
        parent_joint[joint.child] = joint
    # every link has at most one parent: a cycle is a loop of parent pointers
    done: set[str] = set()
    for link in links:
        seen: list[str] = []
        while link not in done and link in parent_joint:
            if link in seen:
                loop = seen[seen.index(link):]
                raise InputError(f"the joints form a cycle through links {', '.join(repr(x) for x in loop)}")
            seen.append(link)
            link = parent_joint[link].parent
        done.update(seen)
    return links, joints, parent_joint


def chain_from_urdf(root: ET.Element, base: str | None = None, tip: str | None = None, source: str | None = None,
                    default_name: str = "robot") -> Chain:
    """Build a :class:`Chain` from a parsed URDF ``<robot>`` element (see the module docstring)."""
    links, joints, parent_joint = _read_tree(root)
    if base is None:
        roots = [link for link in links if link not in parent_joint]
        if len(roots) != 1:
            raise InputError(f"{len(roots)} root links ({_listing(roots)}): choose one as base")
        base = roots[0]
    elif base not in links:
        raise InputError(f"no link {base!r} (links: {_listing(links)})")
    if tip is None:
        children: dict[str, list[str]] = {}
        for joint in joints.values():
            children.setdefault(joint.parent, []).append(joint.child)
        leaves, stack = [], [base]
        while stack:
            link = stack.pop()
            below = children.get(link, [])
            if not below:
                leaves.append(link)
            stack.extend(reversed(below))
        if leaves == [base]:
            raise InputError(f"base {base!r} has no links below it")
        if len(leaves) > 1:
            raise InputError(f"{len(leaves)} leaf links below {base!r} ({_listing(leaves)}): choose one as tip")
        tip = leaves[0]
    elif tip not in links:
        raise InputError(f"no link {tip!r} (links: {_listing(links)})")
    if tip == base:
        raise InputError(f"tip and base are the same link {base!r}")
    path: list[_UrdfJoint] = []
    link = tip
    while link != base:
        if link not in parent_joint:
            raise InputError(f"link {tip!r} is not below base {base!r}")
        path.append(parent_joint[link])
        link = parent_joint[link].parent
    path.reverse()

    on_chain = {j.name for j in path}
    mimics = {}
    for joint in path:
        if joint.type in REFUSED:
            raise InputError(
                f"joint {joint.name!r} is {joint.type}: floating and planar joints are not supported "
                "(choose base and tip to leave it out)"
            )
        mimic = _mimic(joint, joints)  # checked on the chain only: a broken hand elsewhere leaves the arm usable
        if mimic is not None and joint.type in MOVING:
            followed = joints[mimic[0]]
            if followed.name not in on_chain:
                raise InputError(f"joint {joint.name!r} mimic refers to joint {followed.name!r}, which is not on the chain")
            if followed.type not in MOVING:
                raise InputError(f"joint {joint.name!r} mimic refers to joint {followed.name!r}, which is {followed.type}")
            mimics[joint.name] = mimic
    # a mimic of a mimic follows the end of the line: q_a = m1 (m2 q_c + o2) + o1
    resolved: dict[str, tuple[str, float, float]] = {}
    for name in mimics:
        followed, multiplier, offset = mimics[name]
        seen = [name]
        while followed in mimics:
            if followed in seen:
                raise InputError(f"the mimic joints {', '.join(repr(x) for x in seen)} follow each other in a cycle")
            seen.append(followed)
            nxt, m2, o2 = mimics[followed]
            followed, multiplier, offset = nxt, multiplier * m2, multiplier * o2 + offset
        resolved[name] = (followed, multiplier, offset)

    coordinates = [j.name for j in path if j.type in MOVING and j.name not in resolved]
    index = {name: i for i, name in enumerate(coordinates)}
    chain_base = Transform.identity()
    pending = Transform.identity()
    moving: list[Joint] = []
    for joint in path:
        origin = _origin(joint)
        if joint.type == "fixed":
            pending = pending @ origin
            continue
        if not moving:  # fixed joints before the first moving one place the chain in the base frame
            chain_base, pending = pending, Transform.identity()
        kind = MOVING[joint.type]
        if joint.name in resolved:
            followed, multiplier, offset = resolved[joint.name]
            extra = {
                "coordinate": index[followed],
                "multiplier": exact_number(multiplier, f"joint {joint.name!r} mimic multiplier"),
                "offset": (exact_angle if kind == "revolute" else exact_number)(offset, f"joint {joint.name!r} mimic offset"),
            }
        else:
            extra = {"coordinate": index[joint.name]}
        moving.append(Joint(joint.name, kind, pending @ origin, _axis(joint), Transform.identity(), **extra, **_limits(joint)))
        pending = Transform.identity()
    if not moving:
        raise InputError(f"no revolute, continuous or prismatic joint between {base!r} and {tip!r}")
    return Chain(
        _c_name(root.get("name"), default_name), tuple(moving), chain_base, pending, tuple(coordinates), (),
        source, description=f"URDF, base {base}, tip {tip}",
    )


def load_urdf(path: str | os.PathLike, base: str | None = None, tip: str | None = None) -> Chain:
    """Read a URDF file as the chain from link ``base`` to link ``tip``; InputError naming the file and the problem."""
    path = Path(path)
    text = read_robot_bytes(path, "URDF file")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputError(f"{path}: not valid XML: {str(exc).splitlines()[0]}") from None
    try:
        return chain_from_urdf(root, base, tip, source=str(path), default_name=path.stem)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
