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

Names (robot, links, joints; ``base`` and ``tip``) are text, kept as written: any printable
characters, but a control, format (bidi, zero-width) or line-separator character anywhere in the
file's names is refused (:func:`~skelarm_sym.names.check_printable`). Limits: a file of at most
16 MiB (``MAX_URDF_BYTES``) with at most 100 000 ``<link>`` and 100 000 ``<joint>`` elements
(``MAX_URDF_ELEMENTS``); reading is linear in the file's size. :func:`urdf_tree` lists the link
tree with its joints and leaves, to choose ``tip``.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import sympy as sp

from ...errors import InputError
from ...names import check_printable, identifier_from, quoted
from .model import Chain, Joint, Transform, exact_angle, exact_number, unit_axis
from .dh_file import read_robot_bytes

MOVING = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}
REFUSED = ("floating", "planar")
TYPES = (*MOVING, "fixed", *REFUSED)
_LISTED = 12  # names listed in an error message before "..."
_SUGGESTED = 20_000  # close matches are looked for among at most this many links (difflib is slow)
MAX_URDF_BYTES = 16 * 1024 * 1024
"""Largest URDF file read (16 MiB; the largest robot of example-robot-data has 0.2 MiB)."""
MAX_URDF_ELEMENTS = 100_000
"""Most ``<link>`` elements, and most ``<joint>`` elements, a URDF may have."""


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
    tag = element.tag
    if not isinstance(tag, str):  # a comment or processing instruction
        return ""
    return _local(tag)


def _local(name: str) -> str:
    """A tag's or attribute's name without its XML namespace (``{uri}name``)."""
    return name if "}" not in name else name.rsplit("}", 1)[-1]


def _children(element: ET.Element, tag: str) -> list[ET.Element]:
    return [e for e in element if _tag(e) == tag]


def _by_tag(element: ET.Element) -> dict[str, list[ET.Element]]:
    """The children of ``element`` grouped by tag, in one pass."""
    out: dict[str, list[ET.Element]] = {}
    for child in element:
        out.setdefault(_tag(child), []).append(child)
    return out


def _one(element: ET.Element, tag: str, what: str) -> ET.Element | None:
    found = _children(element, tag)
    if len(found) > 1:
        raise InputError(f"{what} has {len(found)} <{tag}> elements, expected at most one")
    return found[0] if found else None


def _listing(names) -> str:
    names = list(names)
    shown = ", ".join(quoted(n, 40) for n in names[:_LISTED])
    return shown + (f", ... ({len(names)} in all)" if len(names) > _LISTED else "")


_DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|[+-]?(?:inf|infinity|nan)", re.I)
"""A number as URDF readers take it (urdfdom reads with the C locale's strtod): no digit group separator, no
other script's digits (``inf`` and ``nan`` pass here, to be refused as not finite)."""


def _numbers(text: str | None, count: int, what: str, default: tuple[float, ...]) -> list[float]:
    """``count`` floats from a space-separated attribute (``default`` when absent)."""
    if text is None:
        return list(default)
    parts = text.split()
    if len(parts) != count:
        raise InputError(f"{what} must be {'a number' if count == 1 else f'{count} numbers'}, got {quoted(text.strip())}")
    if not all(_DECIMAL.fullmatch(p) for p in parts):  # float() takes "1_0" (10), "١" and "infinity" too
        raise InputError(f"{what} must be decimal numbers (ASCII digits, a point, an exponent), got {quoted(text.strip())}")
    values = [float(p) for p in parts]
    for v in values:
        if not math.isfinite(v):
            raise InputError(f"{what} must be finite, got {quoted(text.strip())}")
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
        raise InputError(f"{what} refers to joint {quoted(followed)}, which is not in the file")
    multiplier = _scalar(element, "multiplier", what)
    offset = _scalar(element, "offset", what)
    if multiplier is not None and not abs(multiplier) <= MIMIC_MULTIPLIER_MAX:
        raise InputError(f"{what} multiplier {multiplier:g} is beyond +-{MIMIC_MULTIPLIER_MAX:g}: the follower would "
                         "move that many times its leader")
    return followed, 1.0 if multiplier is None else multiplier, 0.0 if offset is None else offset


MIMIC_MULTIPLIER_MAX = 1e3
"""Largest ``|multiplier|`` of a ``<mimic>`` (grippers and geared joints use 0.5 to a few tens): 1e300 was taken,
and the follower's angle overflowed (check FAILed with inf and NaN rows)."""


def _c_name(text: str | None, fallback: str) -> str:
    """A C identifier from a robot name (see :func:`~skelarm_sym.names.identifier_from`), else from ``fallback``."""
    return identifier_from(text) or identifier_from(fallback) or "robot"


@dataclass
class _Tree:
    """A URDF's link tree as read, with the indexes every step below needs (each built in one pass).

    ``links``: link names in file order; ``joints``: joints by name, in file order; ``parent_joint``:
    each child link's joint; ``children``: each parent link's joints, in file order; ``roots``: the links
    without a parent, in file order."""

    links: dict[str, None]
    joints: dict[str, _UrdfJoint]
    parent_joint: dict[str, _UrdfJoint]
    children: dict[str, list[_UrdfJoint]]
    roots: list[str]


def _name(element: ET.Element, what: str) -> str:
    name = element.get("name")
    if not name:
        raise InputError(f"a <{what}> has no name")
    return check_printable(name, f"{what} name")


def _read_tree(root: ET.Element) -> _Tree:
    """The link tree of a ``<robot>``; checks names (printable, unique), types, the ends of joints, the
    limits on element counts and that the joints form a tree. Linear in the number of elements."""
    if _tag(root) != "robot":
        raise InputError(f"the root element is <{_tag(root)}>, expected <robot>")
    if root.get("name") is not None:
        check_printable(root.get("name"), "robot name")
    grouped = _by_tag(root)
    link_elements, joint_elements = grouped.get("link", []), grouped.get("joint", [])
    for tag, found in (("link", link_elements), ("joint", joint_elements)):
        if len(found) > MAX_URDF_ELEMENTS:
            raise InputError(f"{len(found)} <{tag}> elements: at most {MAX_URDF_ELEMENTS} are read")
    links: dict[str, None] = {}
    for element in link_elements:
        name = _name(element, "link")
        if name in links:
            raise InputError(f"link {quoted(name)} is defined twice")
        links[name] = None
    if not links:
        raise InputError("no <link> elements")
    joints: dict[str, _UrdfJoint] = {}
    parent_joint: dict[str, _UrdfJoint] = {}
    children: dict[str, list[_UrdfJoint]] = {}
    for element in joint_elements:
        name = _name(element, "joint")
        if name in joints:
            raise InputError(f"joint {quoted(name)} is defined twice")
        kind = element.get("type")
        if kind not in TYPES:
            raise InputError(f"joint {quoted(name)}: type must be one of {', '.join(TYPES)}, got {'no type' if kind is None else quoted(kind)}")
        ends, parts = {}, _by_tag(element)
        for end in ("parent", "child"):
            found = parts.get(end, ())
            if len(found) > 1:
                raise InputError(f"joint {quoted(name)} has {len(found)} <{end}> elements, expected at most one")
            link = found[0].get("link") if found else None
            if not link:
                raise InputError(f"joint {quoted(name)} has no <{end} link=...>")
            if link not in links:
                raise InputError(f"joint {quoted(name)}: {end} link {quoted(link)} is not a <link> in the file")
            ends[end] = link
        if ends["parent"] == ends["child"]:
            raise InputError(f"joint {quoted(name)} connects link {quoted(ends['child'])} to itself")
        joint = _UrdfJoint(name, kind, ends["parent"], ends["child"], element)
        if joint.child in parent_joint:
            other = parent_joint[joint.child]
            raise InputError(f"link {quoted(joint.child)} has two parents: joints {quoted(other.name)} and {quoted(name)}")
        joints[name] = joint
        parent_joint[joint.child] = joint
        children.setdefault(joint.parent, []).append(joint)
    roots = [link for link in links if link not in parent_joint]
    # every link has at most one parent: the links not reached from a root lie on or below a cycle
    reached, stack = set(roots), list(roots)
    while stack:
        for joint in children.get(stack.pop(), ()):
            reached.add(joint.child)
            stack.append(joint.child)
    if len(reached) < len(links):
        link = next(link for link in links if link not in reached)
        seen: dict[str, None] = {}
        while link not in seen:  # up the parents of an unreached link: they end in the cycle
            seen[link] = None
            link = parent_joint[link].parent
        loop = list(seen)[list(seen).index(link):]
        raise InputError(f"the joints form a cycle through links {_listing(loop)}")
    return _Tree(links, joints, parent_joint, children, roots)


def _unknown_link(name: str, what: str, links: dict[str, None]) -> InputError:
    """The error for a ``base`` or ``tip`` that names no link: close matches first, then the links."""
    close = difflib.get_close_matches(name, links, n=3, cutoff=0.6) if len(links) <= _SUGGESTED else []
    hint = f"; did you mean {' or '.join(quoted(c) for c in close)}?" if close else ""
    return InputError(f"no link {quoted(name)} ({what}){hint} (links: {_listing(links)})")


def _leaves(tree: _Tree, base: str) -> list[str]:
    """The leaf links below ``base`` (depth first, in file order)."""
    leaves, stack = [], [base]
    while stack:
        link = stack.pop()
        below = tree.children.get(link, [])
        if not below:
            leaves.append(link)
        stack.extend(joint.child for joint in reversed(below))
    return leaves


def chain_from_urdf(root: ET.Element, base: str | None = None, tip: str | None = None, source: str | None = None,
                    default_name: str = "robot", prefix: str = "") -> Chain:
    """Build a :class:`Chain` from a parsed URDF ``<robot>`` element (see the module docstring).

    ``default_name`` names the robot when its ``<robot>`` has no usable name; ``prefix`` is the chain's
    default prefix (empty: its name)."""
    for given, what in ((base, "base"), (tip, "tip")):
        if given is not None:
            check_printable(given, f"{what} link")
    tree = _read_tree(root)
    links, joints, parent_joint = tree.links, tree.joints, tree.parent_joint
    if base is None:
        if len(tree.roots) != 1:
            raise InputError(f"{len(tree.roots)} root links ({_listing(tree.roots)}): choose one as base")
        base = tree.roots[0]
    elif base not in links:
        raise _unknown_link(base, "base", links)
    if tip is None:
        leaves = _leaves(tree, base)
        if leaves == [base]:
            raise InputError(f"base {quoted(base)} has no links below it")
        if len(leaves) > 1:
            raise InputError(f"{len(leaves)} leaf links below {quoted(base)} ({_listing(leaves)}): choose one as tip")
        tip = leaves[0]
    elif tip not in links:
        raise _unknown_link(tip, "tip", links)
    if tip == base:
        raise InputError(f"tip and base are the same link {quoted(base)}")
    path: list[_UrdfJoint] = []
    link = tip
    while link != base:
        if link not in parent_joint:
            raise InputError(f"link {quoted(tip)} is not below base {quoted(base)}")
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
        source, description=f"URDF, base {base}, tip {tip}", prefix=prefix,
    )


@dataclass(frozen=True)
class UrdfLink:
    """One link of a URDF's link tree, as :func:`urdf_links` lists them (depth first, in file order).

    ``depth``: joints between its root and it (0 for a root); ``parent``, ``joint``, ``joint_type``: the
    link above it, the joint from there and its type (None for a root); ``coordinates``: moving joints
    that are not mimic joints between its root and it (the length of ``q`` of a chain ending here);
    ``leaf``: no joint below it (a candidate ``tip``)."""

    name: str
    depth: int
    parent: str | None
    joint: str | None
    joint_type: str | None
    coordinates: int
    leaf: bool
    stray_mimic: str | None = None
    """For a leaf: ``"'f' follows 'l'"`` when a mimic joint between its root and it follows a joint off that path
    (a chain to this tip is refused), else None."""


TREE_INDENT_LIMIT = 24
""":func:`urdf_tree` indents by depth up to this many levels; deeper lines say their depth instead."""


def urdf_links(path: str | os.PathLike, base: str | None = None) -> list[UrdfLink]:
    """Every link of the URDF file ``path`` in depth-first order from its roots (file order among
    siblings), or from link ``base`` down, with the joint above it; InputError (one line naming the file) on
    a bad file or an unknown ``base``. Linear in the number of elements (and in the depth, per leaf below a mimic
    joint)."""
    path = Path(path)
    root = _parse(path)
    try:
        tree = _read_tree(root)
        if base is not None and base not in tree.links:
            raise _unknown_link(base, "base", tree.links)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    starts = tree.roots if base is None else [base]
    out: list[UrdfLink] = []
    # per entry: link, depth, joint above, coordinates, the (follower, leader) pairs of the mimic joints above it
    stack: list[tuple] = [(r, 0, None, 0, ()) for r in reversed(starts)]
    while stack:
        link, depth, joint, coordinates, mimics = stack.pop()
        if joint is not None and joint.type in MOVING:
            mimic = _children(joint.element, "mimic")
            if mimic:
                mimics = mimics + ((joint.name, mimic[0].get("joint")),)
            else:
                coordinates += 1
        below = tree.children.get(link, [])
        stray = None
        if mimics and not below:  # a leaf below a mimic joint: are the leaders on its path? (a walk up, rare)
            path = _joints_above(tree, link, depth)  # moving joints only: a mimic of a fixed joint is refused too
            stray = next((f"{f!r} follows {lead!r}" for f, lead in mimics if lead not in path), None)
        out.append(UrdfLink(link, depth, None if joint is None else joint.parent, None if joint is None else joint.name,
                            None if joint is None else joint.type, coordinates, not below, stray))
        stack.extend((j.child, depth + 1, j, coordinates, mimics) for j in reversed(below))
    return out


def _joints_above(tree: _Tree, link: str, depth: int) -> set[str]:
    """The names of the moving joints among the ``depth`` joints above ``link``."""
    names = set()
    for _ in range(depth):
        joint = tree.parent_joint[link]
        if joint.type in MOVING:
            names.add(joint.name)
        link = joint.parent
    return names


def urdf_tree(path: str | os.PathLike, base: str | None = None) -> list[str]:
    """The link tree of the URDF file ``path`` as lines to print, one per link, depth first: the link
    name indented two spaces per level, the joint above it and its type, and for a leaf (a ``tip``
    candidate) how many coordinates a chain from its root to it has::

        world
          base_link  <- world_joint (fixed)
            shoulder_link  <- shoulder_pan_joint (revolute)
            ...
                      tool0  <- wrist_3-tool0 (fixed)  [leaf: 6 coordinates from world]

    From link ``base`` when given (the coordinates counted from there). A leaf whose chain holds a mimic joint
    that follows a joint off it says so (``generate --tip`` refuses it). Names are printed as written (the
    loader refuses control characters in them). Beyond ``TREE_INDENT_LIMIT`` levels a line starts with
    ``[depth N]`` instead of more spaces."""
    lines, root = [], ""
    for entry in urdf_links(path, base):
        if entry.depth == 0:
            root = entry.name
        indent = "  " * min(entry.depth, TREE_INDENT_LIMIT)
        if entry.depth > TREE_INDENT_LIMIT:
            indent += f"[depth {entry.depth}] "
        text = indent + entry.name
        if entry.joint is not None:
            text += f"  <- {entry.joint} ({entry.joint_type})"
        if entry.leaf and entry.depth > 0:
            plural = "" if entry.coordinates == 1 else "s"
            text += f"  [leaf: {entry.coordinates} coordinate{plural} from {root}"
            text += f"; refused as a tip: mimic joint {entry.stray_mimic}, off this chain]" if entry.stray_mimic else "]"
        elif entry.leaf:
            text += "  [no joints]"
        lines.append(text)
    return lines


def _parse(path: Path) -> ET.Element:
    """The ``<robot>`` element of the URDF file ``path`` (at most ``MAX_URDF_BYTES``); InputError naming the file."""
    text = read_robot_bytes(path, "URDF file", MAX_URDF_BYTES)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputError(f"{path}: not valid XML: {str(exc).splitlines()[0]}") from None
    except (RecursionError, MemoryError):
        raise InputError(f"{path}: not valid XML: too deeply nested or too large to read") from None
    markup = _xacro_markup(root)
    if markup is not None:
        raise InputError(f"{path}: {markup}: a xacro file, not a URDF; expand it first (xacro {path.name} > robot.urdf)")
    return root


_XACRO_EXPRESSION = re.compile(r"\$[{(]")
_NAMES = frozenset({"name", "link", "joint"})
"""Attributes that hold names: free text (data), where ``${`` is a character pair like any other."""


def _xacro_markup(root: ET.Element) -> str | None:
    """What in the tree is xacro's (an element in its namespace, or an attribute other than a name holding
    ``${...}`` or ``$(...)``), else None. Read as URDF, such a file loses the joints its macros and includes would expand
    to: the chain comes out shorter, with nothing said."""
    for element in root.iter():
        if not isinstance(element.tag, str):
            continue
        if element.tag.startswith("{") and "xacro" in element.tag[1:element.tag.find("}")]:
            return f"it holds xacro markup (<xacro:{_tag(element)}>)"
        for key, value in element.attrib.items():
            if _local(key) not in _NAMES and _XACRO_EXPRESSION.search(value):
                return f"it holds a xacro expression ({quoted(value, 40)} in <{_tag(element)} {_local(key)}>)"
    return None


def load_urdf(path: str | os.PathLike, base: str | None = None, tip: str | None = None) -> Chain:
    """Read a URDF file as the chain from link ``base`` to link ``tip``; InputError naming the file and the problem.

    The chain's default prefix is :func:`~skelarm_sym.models.chain.loader.default_prefix` of the path
    (the file name's stem made an identifier, else the robot's name)."""
    path = Path(path)
    root = _parse(path)
    try:
        robot = root.get("name") if _tag(root) == "robot" else None
        prefix = identifier_from(path.stem) or identifier_from(robot) or "robot"
        return chain_from_urdf(root, base, tip, source=str(path), default_name=path.stem, prefix=prefix)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
