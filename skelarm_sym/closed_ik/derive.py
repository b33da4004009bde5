"""``derive_ik_all``: every closed-form IK candidate of a chain as named steps plus outputs.

Inputs (SymPy symbols): ``target`` (16): the tool pose ``T`` (4 x 4, row-major, base frame; the frame
conventions of the chain's ``pose``: base and tool transforms included; the last row is not read), and
with a lock ``lock`` (1): the locked coordinate's value (rad or m).

Outputs: ``Q`` (S x N, S = the family's bound, 8; N = the chain's coordinates): one candidate per row,
in branch order (fixed by the derivation, see :mod:`.families`), revolute angles unwrapped (any real:
post-processing shifts them by multiples of 2 pi into the limits), the locked coordinate equal to
``lock``; ``flags`` (S): ``1`` if the branch used a least-squares answer (the target is out of its reach;
the candidate is the closest the subproblems give, not an exact solution), ``+2`` if it met a singular
case (a continuum, represented by one member, or a double root); ``0``: an exact regular solution.
Every output is finite for finite input (no NaN: discriminants are clamped, divisions guarded by selects).

Operations in the steps and outputs (what the code generator lowers): Add, Mul, Pow (integer exponents
and 1/2), sin, cos (of the lock only), atan2, Max, Min, Piecewise, relationals ``<``, ``<=``, ``>``, ``>=``, And, Or
(``Abs`` can appear in the prismatic quadratic's scale).
:func:`operations` lists them for a derivation.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from ..derive.core import Constant, Derivation, FunctionSpec
from ..models.chain import Chain
from ..models.chain.lock import named_joint
from ..models.chain.target_rotation import ORTHO_CONSTANT
from .classify import (LOCK_C, LOCK_S, MAX_SOLUTIONS, ClosedFormError, Family, chain_geometry, classify, closest_point,
                       problem_geometry)
from .postprocess import (DUP_TOL, DUP_TOL_FLOAT, DUP_TOL_SINGULAR, DUP_TOL_SINGULAR_FLOAT, LIMIT_TOL, LIMIT_TOL_FLOAT, LOCK_MAX,
                          LOCK_MAX_FLOAT, TRANSLATION_MAX,
                          TRANSLATION_MAX_FLOAT, WRIST_ALIGNED_TOL, WRIST_ALIGNED_TOL_FLOAT)
from .families import (AXIS_SYMBOL, AXIS_TOL, AXIS_TOL_FLOAT, SPLIT_SYMBOL, SPLIT_TOL, SPLIT_TOL_FLOAT, Problem, spherical_wrist,
                       three_parallel)
from ..derive.float_facts import float_facts
from .subproblems import (LS_SYMBOL, LS_TOL, LS_TOL_FLOAT, ROOT_SYMBOL, ROOT_TOL, ROOT_TOL_FLOAT, SING_SYMBOL, SING_TOL,
                          SING_TOL_FLOAT, Steps, any_of)

Step = tuple[sp.Symbol, sp.Expr]

FLAG_LS = 1
"""Bit of ``flags``: a least-squares (unreachable) candidate."""
FLAG_SINGULAR = 2
"""Bit of ``flags``: a singular candidate (a continuum represented by one member, or a double root)."""


@dataclass(frozen=True, eq=False)
class ClosedIK:
    """A chain's closed-form IK: ``inputs`` (``target``: 16 symbols; ``lock``: 1, when locked), ``steps``
    (ordered ``(symbol, expr)``), ``Q`` (S x N) and ``flags`` (S x 1) written with the steps, and what
    post-processing needs: ``revolute`` (per coordinate), ``lower``/``upper`` (per coordinate, ``None`` when
    absent), ``lock`` (the locked coordinate or ``None``)."""

    chain: Chain
    family: Family
    inputs: dict[str, tuple[sp.Symbol, ...]]
    steps: tuple[Step, ...]
    Q: sp.Matrix
    flags: sp.Matrix
    revolute: tuple[bool, ...]
    lower: tuple[float | None, ...]
    upper: tuple[float | None, ...]
    lock: int | None = None
    notes: tuple[str, ...] = field(default=())
    principal: tuple[bool, ...] = field(default=())
    """Per coordinate: every row's value is an angle in ``[-pi, pi]`` (``pi`` the double 3.141592653589793;
    :meth:`~.subproblems.Steps.is_principal`), so a 2 pi shift toward a centre of 0 leaves it as it is."""
    continuum: tuple = field(default=())
    """The wrist's continuum, ``(a, w, b, sigma, sigma_odd, w0)`` (see :func:`wrist_continuum`), or ``()``."""
    members: sp.Matrix | None = None
    """Rows of a continuum at the reference configuration (input ``q_ref``), or None. Three parallel axes with a
    wrist flip (UR): the aligned wrist's continuum at the reference's ``phi = q2 + s3 q3 + s4 q4`` (``s_k = h2 .
    h_k``), per root of q1 the 2R arm's two branches (4 x N). A spherical wrist whose wrist centre can lie on axis 1:
    that continuum at the reference's ``q1``, the candidates' eight branches with their own wrist (8 x N)."""
    member_flags: sp.Matrix | None = None
    """``members``' flags: bit 2 always; bit 1 where the row is no exact member (no continuum: the wrist not aligned,
    the wrist centre off axis 1; or the branch does not reach: UR's 2R arm the wrist point that ``phi`` gives, a
    least-squares branch)."""
    member_wrist: tuple[int, ...] = ()
    """With a UR's ``members``: the chain coordinates of joints 5 and 6 (the wrist angle, and the joint that turns
    with phi at the aligned wrist); ``()`` for a spherical wrist's."""

    @property
    def max_solutions(self) -> int:
        """S, the number of candidate rows."""
        return self.Q.rows


def lock_index(chain: Chain, lock: int | str | None) -> int | None:
    """The locked joint as a 0-based index: ``lock`` is that index, or a joint or coordinate name."""
    if lock is None:
        return None
    if isinstance(lock, str):
        return named_joint(chain, lock, ClosedFormError)
    if isinstance(lock, bool) or not isinstance(lock, int) or not 0 <= lock < len(chain.joints):
        raise ClosedFormError(f"{chain.name}: lock must be a joint index 0..{len(chain.joints) - 1} or a joint name, got {lock!r}")
    return lock


FLIP_TOL = 1e-15
"""The wrist flip (:func:`~.families.spherical_wrist`) is used when its conditions hold to this (cosines, sines):
exact zeros from pi/2 angles, or a URDF's rounding of them (6e-17), not a wrist that is merely near one."""


def _sampled_axes(geom, reversed_: bool, locked: bool):
    """The problem's unit axes ``H`` (6 x 3, in problem order: reversed for a reversed family) at each sampled lock
    value (at the one configuration without a lock)."""
    from .classify import LOCK_SAMPLES, _lock_subs

    for value in (LOCK_SAMPLES if locked else (0.0,)):
        _, H, _ = geom.numeric(_lock_subs(geom, value))
        yield H[::-1] if reversed_ else H


def wrist_flips(geom, reversed_: bool, locked: bool, joints: tuple[int, int, int] = (3, 4, 5)) -> bool:
    """Whether problem axes ``joints`` (a, b, c; 0-based) have ``a . b = 0``, ``b . c = 0`` and ``a || c`` within
    :data:`FLIP_TOL` at every sampled lock value: the wrist flip of :mod:`.families` (joints 4, 5, 6 of a spherical
    wrist; 2, 5, 6 of three parallel axes)."""
    for H in _sampled_axes(geom, reversed_, locked):
        h4, h5, h6 = H[joints[0]], H[joints[1]], H[joints[2]]
        if abs(h4 @ h5) > FLIP_TOL or abs(h5 @ h6) > FLIP_TOL or np.linalg.norm(np.cross(h4, h6)) > FLIP_TOL:
            return False
    return True


ALIGNMENT_TOL = 1e-12
"""A wrist aligned at a ``q5`` other than a multiple of pi: h6 turned by it must meet h4's line within this (sine)."""


def wrist_continuum(geom, family: Family, locked: bool) -> tuple:
    """The continuum of an aligned spherical wrist as ``(a, w, b, sigma, sigma_odd, w0)`` (chain coordinates,
    0-based; ``w0`` rad), or ``()``: joint w at ``w0 + k pi`` puts h6 on the line of h4, with ``sigma`` for even
    ``k`` and ``sigma_odd`` for odd ``k`` (0: not aligned there), and joints a and b turn about one axis there.

    Where ``h4 || h6`` at ``q = 0``, ``q5 = 0`` (an even multiple of pi) puts h6 on the line of h4 and joints 4 and 6
    turn about one axis: every ``(q4 + t, q6 - s t)`` is the same pose, ``s = h4 . h6`` (+1 or -1). For a wrist that
    flips (:func:`wrist_flips`: ``h4 . h5 = 0`` and ``h5 . h6 = 0`` as well) an odd multiple of pi aligns it too, with
    ``-s``; a wrist whose middle axis is skewed is aligned at even multiples only (``sigma_odd = 0``). A skewed wrist
    whose h6 meets h4 only when turned half a turn about h5 (``h6' = 2 (h5 . h6) h5 - h6 || h4``: two equal skew
    twists, DH alpha4 = alpha5) is aligned at odd multiples only: ``sigma = 0``, ``sigma_odd = h4 . h6'``. Those have
    ``w0 = 0``. A wrist whose h6 meets h4's line at another turn ``w0`` (a file whose zero pose bends joint 5) has
    ``(s, -s or 0, w0)`` alike. In chain coordinates: ``a``, ``w``, ``b`` the coordinates of joints 4, 5, 6 (of the
    reversed chain for a spherical shoulder: its variables are negated, which keeps the relation with ``-w0``).
    ``()`` for the other families, where no turn of h6 about h5 meets h4's line, or where the sign or the turn is not
    the same at every sampled lock value."""
    if family.name not in ("spherical_wrist", "spherical_shoulder"):
        return ()
    wrist = [5 - k if family.reversed else k for k in (3, 4, 5)]  # geometry indices of problem joints 4, 5, 6
    if any(geom.kinds[k] != "revolute" for k in wrist):
        return ()
    samples = list(_sampled_axes(geom, family.reversed, locked))
    coordinates = tuple(geom.coordinates[k] for k in wrist)
    for half_turn in (False, True):
        ends = [(H[3], 2.0 * float(H[4] @ H[5]) * H[4] - H[5] if half_turn else H[5]) for H in samples]
        if any(np.linalg.norm(np.cross(h4, h6)) > FLIP_TOL for h4, h6 in ends):
            continue
        signs = {1 if float(h4 @ h6) > 0 else -1 for h4, h6 in ends}
        if len(signs) != 1:
            return ()
        s = signs.pop()
        if half_turn:
            return (*coordinates, 0, s, 0.0)
        return (*coordinates, s, -s if wrist_flips(geom, family.reversed, locked) else 0, 0.0)
    turns = [_aligning_turn(H[3], H[4], H[5]) for H in samples]
    if any(t is None for t in turns):
        return ()
    if len({sign for _, sign in turns}) != 1 or max(abs(math.remainder(t - turns[0][0], 2 * math.pi))
                                                   for t, _ in turns) > ALIGNMENT_TOL:
        return ()
    w0, s = turns[0]
    # half a turn further: on h4's line again (a wrist that flips), with the other sign
    flips = all(np.linalg.norm(np.cross(_turned(H[5], H[4], w0 + math.pi), H[3])) <= ALIGNMENT_TOL for H in samples)
    return (*coordinates, s, -s if flips else 0, -w0 if family.reversed else w0)


def _turned(v: np.ndarray, k: np.ndarray, phi) -> np.ndarray:
    """Vectors ``v`` (..., 3) turned by ``phi`` (rad; a number, or one per vector) about the unit axis ``k``:
    :func:`~.classify.rotate` (Rodrigues) in NumPy."""
    v = np.asarray(v, dtype=float)
    c, s = np.cos(phi), np.sin(phi)
    c, s = (np.asarray(c)[..., None], np.asarray(s)[..., None]) if np.ndim(phi) else (c, s)
    return v * c + np.cross(k, v) * s + np.multiply.outer(v @ k, k) * (1.0 - c)


def _aligning_turn(h4: np.ndarray, h5: np.ndarray, h6: np.ndarray) -> tuple[float, int] | None:
    """``(phi, s)``: h6 turned by ``phi`` (rad, in ``(-pi, pi]``) about h5 is ``s h4`` (``s`` +1 or -1), or None where
    no turn brings it onto h4's line (within :data:`ALIGNMENT_TOL`)."""
    for s in (1, -1):
        target = s * h4
        if abs(float(h5 @ h6) - float(h5 @ target)) > ALIGNMENT_TOL:  # not on the same cone about h5
            continue
        p, t = h6 - float(h5 @ h6) * h5, target - float(h5 @ target) * h5
        if np.linalg.norm(p) <= ALIGNMENT_TOL or np.linalg.norm(t) <= ALIGNMENT_TOL:
            continue  # on h5's line: no turn moves it
        phi = math.atan2(float(h5 @ np.cross(p, t)), float(p @ t))
        if np.linalg.norm(np.cross(_turned(h6, h5, phi), h4)) <= ALIGNMENT_TOL:
            return phi, s
    return None


def derive_ik_all(chain: Chain, lock: int | str | None = None, atan2: str | None = None) -> ClosedIK:
    """All closed-form IK candidates of ``chain`` (see the module docstring); ``lock``: the joint held at a
    run-time value (0-based index or name) for 7-joint chains; ``atan2``: how angles are written (``None``: the
    emitted code's way, :data:`~skelarm_sym.closed_ik.subproblems.ATAN2`; ``"libm"``: ``atan2`` kept a call, to
    read). :class:`ClosedFormError` (one line) when the chain is in no family. Derived with two Float queries
    answered directly (:func:`~skelarm_sym.derive.float_facts.float_facts`)."""
    with float_facts():
        return _derive_ik_all(chain, lock, atan2)


def _derive_ik_all(chain: Chain, lock: int | str | None, atan2: str | None = None) -> ClosedIK:
    lock_idx = lock_index(chain, lock)
    family = classify(chain, lock_idx)
    geom = problem_geometry(chain, lock_idx)
    steps = Steps("ik", atan2)
    target = sp.symbols("target0:16", real=True)
    inputs: dict[str, tuple[sp.Symbol, ...]] = {"target": target}
    subs: dict = {}
    if lock_idx is not None:
        lam = sp.Symbol("lock", real=True)
        inputs["lock"] = (lam,)
        if chain_geometry(chain).kinds[lock_idx] == "revolute":
            subs = {LOCK_C: steps("lock_c", sp.cos(lam)), LOCK_S: steps("lock_s", sp.sin(lam))}
        else:
            subs = {LOCK_C: sp.S.One, LOCK_S: lam}

    def put(label, v):
        return steps.vec(label, [sp.sympify(x).xreplace(subs) for x in v])

    H = tuple(put(f"h{k}", h) for k, h in enumerate(geom.axes))
    P = tuple(put(f"p{k}", p) for k, p in enumerate(geom.points))
    RM = [put(f"M{i}", row) for i, row in enumerate(geom.home_rotation)]
    pM = put("pM", geom.home_position)
    Rt = [[target[4 * i + j] for j in range(3)] for i in range(3)]
    pt = [target[3], target[7], target[11]]
    RG = tuple(tuple(steps(f"RG{i}{j}", sum(Rt[i][k] * RM[j][k] for k in range(3))) for j in range(3)) for i in range(3))
    tG = steps.vec("tG", [pt[i] - sum(RG[i][k] * pM[k] for k in range(3)) for i in range(3)])
    prob = Problem(geom.kinds, H, P, RG, tG)
    if family.reversed:
        prob = prob.reversed(steps)
    n = chain.n
    members: list | None = None

    def reference_angles() -> list:
        """The problem's joint variables in the reference configuration (input ``q_ref``)."""
        q_ref = sp.symbols(f"q_ref0:{n}", real=True)
        inputs["q_ref"] = q_ref
        return [q_ref[geom.coordinates[k]] if not family.reversed else -q_ref[geom.coordinates[5 - k]] for k in range(6)]

    if family.name in ("spherical_wrist", "spherical_shoulder"):
        flips = wrist_flips(geom, family.reversed, lock_idx is not None)
        if _axis_continuum(geom, family, lock_idx is not None):
            members = []
            branches = spherical_wrist(steps, prob, family.position, flips, members, reference_angles()[0], geom.reach())
        else:
            branches = spherical_wrist(steps, prob, family.position, flips)
    else:
        flip = wrist_flips(geom, family.reversed, lock_idx is not None, (1, 4, 5))
        s0 = _axes_sign(geom, family.reversed, lock_idx is not None, (1, 5)) if flip else 0
        signs = (_axes_sign(geom, family.reversed, lock_idx is not None, (1, 2)),
                 _axes_sign(geom, family.reversed, lock_idx is not None, (1, 3)))
        if 0 in signs:  # parallel at every lock value: the sign of a unit dot product of +-1 cannot change
            raise ValueError(f"internal error: the parallel axes' signs {signs} differ between lock values")
        if s0:
            members = []
            theta = reference_angles()
            phi_ref = steps("phi_ref", theta[1] + signs[0] * theta[2] + signs[1] * theta[3])
            branches = three_parallel(steps, prob, flip, members, phi_ref, s0, signs)
        else:
            branches = three_parallel(steps, prob, flip, signs=signs)

    rows, flags, principal = _rows(chain, geom, family, steps, inputs, lock_idx, branches)
    member_rows = member_flags = None
    if members:  # flagged least squares also where the root's wrist is not the continuum's (no split)
        member_branches = [b for group, _ in members for b in group]
        exact = [split for group, split in members for _ in group]
        member_rows, _, _ = _rows(chain, geom, family, steps, inputs, lock_idx, member_branches)
        member_flags = [FLAG_LS * any_of(b.ls, 1 - e) + FLAG_SINGULAR for b, e in zip(member_branches, exact)]
    limits = chain.limits()
    return ClosedIK(
        chain, family, inputs, tuple(steps.steps), sp.Matrix(rows), sp.Matrix(flags),
        tuple(j.kind == "revolute" for j in sorted(chain.joints, key=lambda j: j.coordinate)),
        limits["lower"], limits["upper"],
        None if lock_idx is None else chain.joints[lock_idx].coordinate,
        (family.describe(),),
        tuple(principal),
        wrist_continuum(geom, family, lock_idx is not None),
        None if member_rows is None else sp.Matrix(member_rows),
        None if member_flags is None else sp.Matrix(member_flags),
        tuple(geom.coordinates[5 - k if family.reversed else k] for k in (4, 5)) if members and family.name.startswith("three_parallel")
        else (),
    )


def _rows(chain: Chain, geom, family: Family, steps: Steps, inputs: dict, lock_idx: int | None, branches) -> tuple:
    """The branches as rows of chain coordinates (a reversed family's variables negated, in reverse order; the lock
    in its coordinate), their flags, and per coordinate whether every row's value is a principal angle."""
    n = chain.n
    rows, flags = [], []
    principal = [True] * n
    for b in branches:
        thetas = [a.theta for a in b.angles]
        if family.reversed:
            thetas = [-t for t in thetas[::-1]]
        row = [sp.S.Zero] * n
        for k, t in enumerate(thetas):
            row[geom.coordinates[k]] = t
            principal[geom.coordinates[k]] &= geom.kinds[k] == "revolute" and steps.is_principal(t)
        if lock_idx is not None:
            row[chain.joints[lock_idx].coordinate] = inputs["lock"][0]
            principal[chain.joints[lock_idx].coordinate] = False
        rows.append(row)
        flags.append(FLAG_LS * b.ls + FLAG_SINGULAR * b.singular)
    return rows, flags, principal


AXIS_REACH_TOL = AXIS_TOL
"""The wrist centre reaches axis 1 (:func:`_axis_continuum`) where its least distance from it is at most this times the
arm's size: ``IK_AXIS_TOL``, within which a member is exact (Gauss-Newton reaches a zero to rounding)."""


def _axis_continuum(geom, family: Family, locked: bool) -> bool:
    """Whether a spherical-wrist arm's wrist centre can lie on axis 1 in a solution (a continuum of ``q1``:
    :func:`~.families.spherical_wrist`'s ``members``): its least distance from axis 1 over joints 2 and 3 (joint 1
    keeps it; a grid of their values, the nearest points refined by Gauss-Newton) is at most :data:`AXIS_REACH_TOL`
    times the arm's size at some sampled lock value. Not the PUMA 560 nor the Stanford arm (an offset along h2 that
    joints 2 and 3 keep), nor the Panda with joint 7 locked, whose shoulder centre stays 0.057 m from joint 6's axis."""
    from .classify import LOCK_SAMPLES, _lock_subs

    scale = geom.reach()
    for value in (LOCK_SAMPLES if locked else (0.0,)):
        kinds, H, P = geom.numeric(_lock_subs(geom, value))
        if family.reversed:
            kinds, H, P = kinds[::-1], H[::-1], P[::-1]
        if kinds[0] != "revolute" or kinds[1] != "revolute":
            raise ValueError("internal error: a spherical-wrist family with a prismatic joint 1 or 2")
        W0 = np.array([float(x) for x in closest_point(P[3], H[3], P[4], H[4])])
        e1 = np.cross(H[0], [1.0, 0.0, 0.0] if abs(H[0][0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(H[0], e1)
        span = np.pi if kinds[2] == "revolute" else 2.0 * scale

        def offsets(q2, q3):
            """The wrist centre's offset from axis 1 in the plane across it (..., 2)."""
            X = W0 + q3[..., None] * H[2] if kinds[2] == "prismatic" else P[2] + _turned(W0 - P[2], H[2], q3)
            d = P[1] - P[0] + _turned(X - P[1], H[1], q2)
            return np.stack([d @ e1, d @ e2], axis=-1)

        g2, g3 = np.meshgrid(np.linspace(-np.pi, np.pi, 97), np.linspace(-span, span, 97), indexing="ij")
        distance = np.linalg.norm(offsets(g2, g3), axis=-1).ravel()
        for start in np.argsort(distance)[:6]:
            x, last = np.array([g2.ravel()[start], g3.ravel()[start]]), np.inf
            for _ in range(40):
                r = offsets(np.array(x[0]), np.array(x[1]))
                size = np.linalg.norm(r)
                if size <= AXIS_REACH_TOL * scale:
                    return True
                if size > 0.9 * last:  # stalled at a least distance above zero (Gauss-Newton converges fast to a zero)
                    break
                last = size
                step = 1e-7 * np.array([1.0, 1.0 if kinds[2] == "revolute" else scale])
                J = np.column_stack([(offsets(np.array(x[0] + d[0]), np.array(x[1] + d[1])) -
                                      offsets(np.array(x[0] - d[0]), np.array(x[1] - d[1]))) / (2 * np.max(d))
                                     for d in (np.array([step[0], 0.0]), np.array([0.0, step[1]]))])
                x = x - np.linalg.lstsq(J, r, rcond=None)[0]
    return False


def _axes_sign(geom, reversed_: bool, locked: bool, pair: tuple[int, int]) -> int:
    """``h_a . h_b`` (+1 or -1) of two parallel problem axes at ``q = 0``, the same at every sampled lock value; 0 when
    it is not."""
    signs = {1 if float(H[pair[0]] @ H[pair[1]]) > 0 else -1 for H in _sampled_axes(geom, reversed_, locked)}
    return signs.pop() if len(signs) == 1 else 0


def operations(ik: ClosedIK) -> set[str]:
    """The SymPy node types (class names, with ``Pow`` split by exponent) used by the steps and outputs."""
    seen: set[str] = set()
    exprs = [e for _, e in ik.steps] + list(ik.Q) + list(ik.flags)
    for expr in exprs:
        for node in sp.preorder_traversal(expr):
            if node.is_Atom or isinstance(node, sp.functions.elementary.piecewise.ExprCondPair):
                continue
            name = type(node).__name__
            if isinstance(node, sp.Pow):
                e = node.exp
                name = "Pow(1/2)" if e == sp.S.Half else "Pow(-1/2)" if e == -sp.S.Half else (
                    "Pow(int)" if e.is_Integer else f"Pow({e})")
            seen.add(name)
    return seen


# -- as a derivation the code generator emits ----------------------------------------------------------

@dataclass(frozen=True)
class CandidatesSpec(FunctionSpec):
    """:data:`CANDIDATES` with what the post-processing may rely on: ``principal`` (per coordinate, see
    :attr:`ClosedIK.principal`; empty: nothing known)."""

    principal: tuple[bool, ...] = ()
    continuum: tuple = ()
    """The wrist's continuum (:attr:`ClosedIK.continuum`), which the post-processing moves along; ``()``: none."""


CANDIDATES = CandidatesSpec(
    "ik_candidates", ("target", "lock"), ("Q", "flags"),
    "every closed-form IK candidate, raw: Q (S x N, one per row, branch order, angles not wrapped) and flags (S)",
)
"""The straight-line function of the candidates (``lock`` only when the chain has a locked joint)."""

@dataclass(frozen=True)
class MembersSpec(FunctionSpec):
    """:data:`MEMBERS` with ``wrist`` (:attr:`ClosedIK.member_wrist`), which the check's aligned targets need."""

    wrist: tuple[int, ...] = ()


MEMBERS = MembersSpec(
    "ik_continuum_members", ("q_ref", "target", "lock"), ("M", "mflags"),
    "the aligned wrist's continuum at q_ref's phi = q2 +- q3 +- q4 (signs of h2 . h3, h2 . h4; three parallel axes with a wrist flip: UR): M (4 x N, "
    "per root of q1 the 2R arm's two branches), mflags (4: bit 1 where no exact member, bit 2 always)",
)
"""The straight-line function of :attr:`ClosedIK.members` (only where it has some): ``ik_nearest``'s more rows."""
AXIS_MEMBERS = MembersSpec(
    "ik_continuum_members", ("q_ref", "target", "lock"), ("M", "mflags"),
    "the continuum of a wrist centre on axis 1 at q_ref's q1 (joint 1 then turns the wrist centre about itself; "
    "spherical wrist): M (8 x N, the candidates' branches with q_ref's q1 and their own wrist), mflags (8: bit 1 where "
    "no exact member: the wrist centre off axis 1 by more than IK_AXIS_TOL times the arm's size, or the branch least squares; bit 2 always)",
)
"""The same for a spherical wrist (:func:`~.families.spherical_wrist`'s ``members``)."""
AXIS_CONSTANT = Constant(AXIS_SYMBOL, {"double": AXIS_TOL, "float": AXIS_TOL_FLOAT},
                         "spherical wrist: the wrist centre within this times the arm's size of axis 1 is on joint 1's continuum, and "
                         "ik_continuum_members' rows at q_ref's q1 are exact (ik_nearest weighs them)")
"""The constant of a spherical-wrist arm's members (emitted where they use it)."""

SPLIT_CONSTANT = Constant(SPLIT_SYMBOL, {"double": SPLIT_TOL, "float": SPLIT_TOL_FLOAT},
                          "UR wrist: below this sine between h6 and R5^T h2 the aligned wrist's representative split of "
                          "q6 and phi = q2 +- q3 +- q4 is taken (its pose error is about the sine times the arm's size)")
"""The constant of a three-parallel arm's candidates (emitted where they use it)."""
SUBPROBLEM_CONSTANTS = (
    Constant(LS_SYMBOL, {"double": LS_TOL, "float": LS_TOL_FLOAT},
             "a subproblem's discriminant below -this times its scale is least squares, within +-this a double root"),
    Constant(SING_SYMBOL, {"double": SING_TOL, "float": SING_TOL_FLOAT},
             "a subproblem whose rho is at most this times its scale (a sine) is a continuum"),
    Constant(ROOT_SYMBOL, {"double": ROOT_TOL, "float": ROOT_TOL_FLOAT},
             "a double root's discriminant kept from 0 by rounding alone (10 times this of its scale, and for a distance "
             "a move of at most this times the lengths) gives the double root"),
)
"""The subproblems' tolerances (emitted where the candidates use them)."""
STEP_TOLERANCES = (SPLIT_CONSTANT, AXIS_CONSTANT) + SUBPROBLEM_CONSTANTS
"""Every module constant that stands in the candidates' steps (the NumPy spec evaluates them at the double values)."""

EMITTED_CONSTANTS = (
    Constant(sp.Symbol("IK_MAX_SOLUTIONS"), {"double": MAX_SOLUTIONS, "float": MAX_SOLUTIONS},
             "rows of q in ik_all: the most solutions of this arm's closed-form family"),
    Constant(sp.Symbol("IK_FLAG_LEAST_SQUARES"), {"double": FLAG_LS, "float": FLAG_LS},
             "bit of an ik_all flag: a least-squares row (the target is out of reach)"),
    Constant(sp.Symbol("IK_FLAG_SINGULAR"), {"double": FLAG_SINGULAR, "float": FLAG_SINGULAR},
             "bit of an ik_all flag: a singular row (one member of a continuum, or a double root)"),
    ORTHO_CONSTANT,
    Constant(sp.Symbol("IK_TRANSLATION_MAX"), {"double": TRANSLATION_MAX, "float": TRANSLATION_MAX_FLOAT},
             "ik_all refuses a target with a translation entry larger than this in magnitude (m): no arm reaches it"),
    Constant(sp.Symbol("IK_LOCK_MAX"), {"double": LOCK_MAX, "float": LOCK_MAX_FLOAT},
             "ik_all refuses a locked joint's value larger than this in magnitude (rad or m): its last digit would "
             "exceed the tolerance"),
    Constant(sp.Symbol("IK_LIMIT_TOL"), {"double": LIMIT_TOL, "float": LIMIT_TOL_FLOAT},
             "ik_all clips a joint this close outside a limit onto it (rad or m); further out the row is dropped"),
    Constant(sp.Symbol("IK_DUP_TOL"), {"double": DUP_TOL, "float": DUP_TOL_FLOAT},
             "ik_all returns rows closer than this (max over joints, modulo 2 pi for revolute ones) once"),
    Constant(sp.Symbol("IK_DUP_TOL_SINGULAR"), {"double": DUP_TOL_SINGULAR, "float": DUP_TOL_SINGULAR_FLOAT},
             "ik_all returns rows both flagged singular and closer than this once (a double root's two roots)"),
)
"""The module constants the emitted ``ik_all`` and ``ik_nearest`` use (integers print as such)."""


def _without(constants, others) -> tuple:
    """``constants`` less those named in ``others`` (the chain's derivation already defines ``IK_ORTHO_TOL`` for
    ``ik_solve``; it follows the closed form's other constants in the headers)."""
    names = {c.name for c in others}
    return tuple(c for c in constants if c.name not in names)


WRIST_CONSTANT = Constant(sp.Symbol("IK_WRIST_ALIGNED_TOL"), {"double": WRIST_ALIGNED_TOL, "float": WRIST_ALIGNED_TOL_FLOAT},
                          "a row flagged singular with the wrist angle this close to an angle that aligns the wrist (k pi; "
                          "w0 + k pi where the zero pose bends it) (rad) is a member "
                          "of the wrist's continuum, moved along it into the limits (ik_all) or toward q_ref (ik_nearest)")
"""The constant of an arm with a wrist continuum (:attr:`ClosedIK.continuum`)."""


def with_candidates(derivation: Derivation, ik: ClosedIK) -> Derivation:
    """``derivation`` (a chain's) with the closed-form candidates added: inputs ``target`` (and ``lock``), the
    steps, outputs ``Q`` and ``flags``, the function :data:`CANDIDATES`, header notes and the constants of
    :data:`EMITTED_CONSTANTS`. Nothing is simplified or expanded: the steps go to the lowering as derived."""
    S, N = ik.Q.shape
    locked = "lock" in ik.inputs
    clash = [name for name in ik.inputs if name in derivation.inputs]
    if clash:
        raise ValueError(f"internal error: the derivation already has inputs {clash}")
    lock_line = ()
    if locked:
        joint = ik.chain.joints[ik.family.lock]
        lock_line = (f"lock: the value of joint {ik.family.lock + 1} ({joint.name}), held fixed (rad or m); "
                     f"it is q[{ik.lock}] of every row.",)
    notes = (
        f"Closed-form IK: {ik.family.describe()}.",
        f"target: the tool pose T (4 x 4 row-major, 16 numbers; the last row is not read). Q: {S} x {N} candidates",
        "(one per row, in a fixed branch order); flags: bit 1 least squares (unreachable), bit 2 singular.",
        *lock_line,
    )
    members = ik.members is not None
    return dataclasses.replace(
        derivation,
        inputs={**derivation.inputs, **ik.inputs},
        steps=tuple(derivation.steps) + tuple(ik.steps),
        compact={**derivation.compact, "Q": ik.Q, "flags": ik.flags,
                 **({"M": ik.members, "mflags": ik.member_flags} if members else {})},
        shapes={**derivation.shapes, "Q": (S, N), "flags": (S,), **({"M": ik.members.shape, "mflags": (ik.members.rows,)}
                                                                    if members else {})},
        functions=tuple(derivation.functions) + (dataclasses.replace(CANDIDATES, principal=ik.principal, continuum=ik.continuum),)
        + ((dataclasses.replace(MEMBERS if ik.member_wrist else AXIS_MEMBERS, wrist=ik.member_wrist),) if members else ()),
        parameters=tuple(derivation.parameters) + (("lock",) if locked else ()),
        scalars=tuple(derivation.scalars) + (("lock",) if locked else ()),
        domains={**derivation.domains, "target": "finite", **({"lock": "finite"} if locked else {}),
                 **({"q_ref": "finite"} if members else {})},
        constants=_without(derivation.constants, EMITTED_CONSTANTS) + EMITTED_CONSTANTS + ((WRIST_CONSTANT,) if ik.continuum else ())
        + ((SPLIT_CONSTANT,) if ik.family.name.startswith("three_parallel") else ())
        + ((AXIS_CONSTANT,) if members and not ik.member_wrist else ()) + SUBPROBLEM_CONSTANTS,
        notes=tuple(derivation.notes) + notes,
        _cache={},
    )
