"""Candidate ways to write the pose and the Jacobian's columns (base axes, rows as cofactors, the next frame's
axes, summed tip positions); :func:`~skelarm_sym.models.chain.price._choose` picks among them."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .algebra import Rows, Vector, _rows, _rz, _times_rz, matmul, matvec
from .canonical import _Canonical
from .frames import _Frames, _actual, _horner_step, _scaled_entry, _turned_rows
from .joints import E_Z, add, cross
from .model import Transform
from .price import Pose, _flat, _price
from .rates import _Rates, _velocities
from .steps import _Steps


def _row_tag(dropped: int | None) -> str:
    """The part of a step's label that tells a candidate with frame row ``dropped`` as cofactors from the one
    carrying every row: it ends in ``_``, so that the joint number after it never reads as part of it."""
    return "" if dropped is None else f"c{dropped}_"


def _cofactor_view(step: _Steps, M: Rows, dropped: int | None, label: str, column2: Vector | None = None,
                   factors: Sequence[sp.Expr] = (1, 1, 1), pair: sp.Expr | None = None) -> Rows:
    """The rotation ``M`` with row ``dropped`` written as cofactors of its other two rows (``r_d = r_(d+1) x
    r_(d+2)``, 3 operations an entry): a chain that carries two rows of its frames gets the third's
    entries only where an output uses them. ``M`` itself when ``dropped`` is ``None`` or the row is constant.
    ``column2``: the third column's entry of that row when known already (``G_k = F_s Rz`` keeps ``F_s``'s).
    ``factors``: ``M`` is kept with its columns scaled (the third by :func:`_scaled_frames`, the first two by
    :func:`_twist_scaled_frames`), and these numbers make a kept entry of each column true; the view is the true
    matrix, each cofactor times the factors of the two columns it reads (``pair`` for the first two where their
    product is known exactly: ``S (1 / S)`` is 1, which its double need not be)."""
    scaled = any(x != 1 for x in factors)
    if dropped is None or not any(sp.sympify(x).free_symbols for x in M[dropped]):
        return [[r[j] * factors[j] for j in range(3)] for r in M] if scaled else M
    a, b = (dropped + 1) % 3, (dropped + 2) % 3
    out = [[r[j] * factors[j] for j in range(3)] for r in M]
    for j in range(3):
        if j == 2 and column2 is not None:
            out[dropped][j] = column2[dropped]
            continue
        if factors[0] == factors[1] == 1 and _cheap(step, M[dropped][j]):  # one product of sines (times a factor: two)
            continue
        expr = M[a][(j + 1) % 3] * M[b][(j + 2) % 3] - M[a][(j + 2) % 3] * M[b][(j + 1) % 3]
        known = step.recorded(-expr)  # the same cofactor met before with the other sign (a permuted frame)
        out[dropped][j] = -known if known is not None else step(f"{label}{dropped}{j}", expr)
        read = pair if j == 2 and pair is not None else factors[(j + 1) % 3] * factors[(j + 2) % 3]
        if read != 1:
            out[dropped][j] = out[dropped][j] * read
    return out


def _cheap(step: _Steps, x: sp.Expr) -> bool:
    """True when ``x`` is a constant, an input, a sine or cosine, or one product or sum of those (at most one
    operation, cheaper than a cofactor's three)."""
    x = sp.sympify(x)
    definitions = step.definitions()
    if x.could_extract_minus_sign():
        x = -x
    if not x.is_Symbol:
        return x.is_Number
    rhs = definitions.get(x)
    if rhs is None:
        return True
    if isinstance(rhs, (sp.sin, sp.cos)):
        return True
    return (rhs.is_Mul or rhs.is_Add) and len(rhs.args) == 2 and all(
        a.is_Number or (a.is_Symbol and isinstance(definitions.get(a, sp.sin(a)), (sp.sin, sp.cos))) for a in rhs.args)


def _after_joint(step: _Steps, f: _Frames, k: int, dropped: int | None, axis: Vector) -> Rows:
    """``G_k = F_s Rz(psi_k)``, the rotation after joint ``k``'s motion in base axes (row ``dropped`` as
    cofactors; its third column is the joint's ``axis``), true-valued also where ``f`` keeps it scaled."""
    s = f.segment[k]
    G = _kept_after_joint(step, f, k)
    if f.turns is not None:
        mu = _scaled_entry(1, 1, f.turns[k][2])
        return _cofactor_view(step, G, dropped, f"Hc{f.tag}{k + 1}_", axis, (mu, mu, 1))
    return _cofactor_view(step, G, dropped, f"Hc{f.tag}{k + 1}_", axis, (1, 1, f.scale[s]) if f.scale else (1, 1, 1))


def _kept_after_joint(step: _Steps, f: _Frames, k: int) -> Rows:
    """``G_k = F_s Rz(psi_k)`` as ``f`` keeps it (:func:`_twist_scaled_frames`: ``G_k diag(mu, mu, 1)``)."""
    s = f.segment[k]
    if f.turns is not None:
        return step.mat(f"H{f.tag}{k + 1}_", _turned_rows(step, f, k, f.rotation[s], f.turns[k]))
    return step.mat(f"H{f.tag}{k + 1}_", _times_rz(f.rotation[s], f.trig[k]))


def _base_offsets(step: _Steps, joints: Sequence[_Canonical], f: _Frames, tool: Transform, axes: list[Vector],
                  dropped: int | None = None, tag: str | None = None, turned: bool = False) -> tuple[list[Vector], list[Vector]]:
    """``(r, columns)``: ``r_k = p_e - o_k`` in base axes, tip to base, ``r_k = r_(k+1) + G_k t_(k+1)`` plus the
    joint's own advance along ``z_k`` (:func:`_after_joint`; suffix sums of the links in base axes: no rotation
    of a whole vector, only the columns of ``G_k`` a translation uses), and the linear columns
    ``column(z_k, r_k)``, or ``column(z_k, r_(k+1))`` where the link runs along the axis (standard DH with
    ``a = 0``: ``z_k x G_k t = G_k (e_z x t) = 0``), which makes the last column of a wrist exactly zero.
    ``turned``: the last link (:func:`_last_link`) as ``F_s (Rz(psi_k) t)``, the offset turned instead of the
    frame's rows (:func:`_turned_last_axes`)."""
    n = len(joints)
    r: list[Vector] = [None] * n
    linear: list[Vector] = [None] * n
    below = [sp.S.Zero] * 3
    tag = _row_tag(dropped) if tag is None else tag
    for k in reversed(range(n)):
        t = list((joints[k + 1].before if k + 1 < n else tool).translation)
        advance = joints[k].motion.advance(f.theta[k])
        G = _after_joint(step, f, k, dropped, axes[k]) if any(x != 0 for x in t) else None
        moved = joints[k].motion.follows_tool(E_Z, [t[0], t[1], t[2] + advance])
        along = moved is None or all(x == 0 for x in moved)  # the link runs along the axis: z_k x r_k = z_k x r_(k+1)
        if G is not None and not along and dropped is not None and advance == 0 and joints[k].motion.kind == "revolute" \
                and all(x == 0 for x in below) and (turned or _last_link_pays(step, axes[k], G, t, moved, dropped)):
            if turned:  # G = F_s Rz(psi): G t = F_s t' with t' = Rz(psi) t, and G (e_z x t) = F_s (e_z x t')
                G = _cofactor_view(step, f.rotation[f.segment[k]], dropped, f"Fc{f.tag}{f.segment[k] + 1}_")
                scales = f.columns[f.segment[k]] if f.columns is not None else (1, 1)  # F_s t' = F~_s t'~
                turned_t = _rz(f.trig[k], t)
                t = step.vec(f"tl{tag}{k + 1}", [turned_t[0] * scales[0], turned_t[1] * scales[1], turned_t[2]])
                ratio = _scaled_entry(scales[0], 1, scales[1])  # e_z x t' in the kept columns' scales, from t'~
                moved = [step(f"tm{tag}{k + 1}x", -t[1] * ratio), step(f"tm{tag}{k + 1}y", t[0] / ratio), sp.S.Zero]
            r[k], linear[k] = _last_link(step, f"r{tag}{k + 1}", f"Jb{tag}_{k + 1}", axes[k], G, t, moved, dropped)
            below, turned = r[k], False
            continue
        if turned and G is not None:
            raise ValueError(f"internal error: joint {k + 1}'s link was to be turned, and is not the last link")
        v = add(below, matvec(G, t)) if G is not None else list(below)
        r[k] = step.vec(f"r{tag}{k + 1}", [v[i] + axes[k][i] * advance for i in range(3)])
        linear[k] = step.vec(f"Jb{tag}_{k + 1}", joints[k].motion.column(axes[k], below if along else r[k])[0])
        below = r[k]
    return r, linear


def _last_link(step: _Steps, offset_label: str, column_label: str, z: Vector, G: Rows, t: Vector, moved: Vector,
               dropped: int) -> tuple[Vector, Vector]:
    """``(u, z x u)`` for ``u = G t``, the offset to the tool from the last revolute joint with a link across its
    axis (``z`` the axis, ``G``'s third column; ``moved = e_z x t``): both from the two carried rows of ``G``
    (``z x u = G moved``), and their entries in row ``dropped`` by one cross product each, ``(z x u)_d`` and
    ``u_d = ((z x u) x z)_d + t_z z_d`` (``u - t_z z`` is perpendicular to the unit ``z``), 3 operations
    each, instead of ``G``'s cofactors and a whole cross product ``z x u``: xArm7's last offset costs 18
    operations instead of 24."""
    a, b = (dropped + 1) % 3, (dropped + 2) % 3
    u, w = matvec(G, t), matvec(G, moved)
    for i in (a, b):  # named first: the dropped entries read them
        u[i] = step(f"{offset_label}{'xyz'[i]}", u[i])
        w[i] = step(f"{column_label}{'xyz'[i]}", w[i])
    u, w = _dropped_entries(z, u, w, t[2], dropped)
    return step.vec(offset_label, u), step.vec(column_label, w)


def _dropped_entries(z: Vector, u: Vector, w: Vector, t_z: sp.Expr, d: int) -> tuple[Vector, Vector]:
    """``u`` and ``w = z x u`` with their entries in row ``d`` from the other two of each (:func:`_last_link`)."""
    a, b = (d + 1) % 3, (d + 2) % 3
    w = list(w)
    w[d] = z[a] * u[b] - z[b] * u[a]
    u = list(u)
    u[d] = w[a] * z[b] - w[b] * z[a] + t_z * z[d]
    return u, w


def _last_link_pays(step: _Steps, z: Vector, G: Rows, t: Vector, moved: Vector, dropped: int) -> bool:
    """True when :func:`_last_link` costs at least 2 operations fewer than ``u = G t`` with ``G``'s cofactors and
    the cross product ``z x u`` (priced as written, nothing recorded). One fewer is within what the sign pass
    moves afterwards (TALOS's left arm: 71 against 72 here, and 136 against 135 emitted): the cross product."""
    u = matvec(G, t)
    steps = step.definitions()
    return _price(steps, sum(_dropped_entries(z, u, matvec(G, moved), t[2], dropped), []))[0] + 1 \
        < _price(steps, u + cross(z, u))[0]


def _dense_constants(joints: Sequence[_Canonical], f: _Frames) -> bool:
    """True when some segment starts with a constant rotation that is not a signed permutation (URDF angles
    written with few decimals: xArm7's 1.5708): there every way to carry the frames is worth trying."""
    return any(x not in (-1, 0, 1) for k in f.starts[1:] for x in joints[k].before.rotation)


CANDIDATES_UP_TO = 16
"""Chains of at most this many joints try every candidate (summed positions, base-axes columns with a row as
cofactors); longer ones only Horner's rule and the segment columns (and the base-axes columns with every row
where constants are dense, as before): each candidate costs about 20 ms a joint to derive and price."""


@dataclass
class _Columns:
    """One way to write the Jacobian: per joint its linear and angular columns in base axes, the axes ``z_k``
    they use, their rates (:func:`_velocities`) and the tool position their offsets give (``None``: none)."""

    linear: list[Vector]
    angular: list[Vector]
    axes: list[Vector]
    rates: "_Rates"
    tip: Vector | None


def _column_candidates(step: _Steps, joints, f: _Frames, tool: Transform, W: Sequence[Vector], linear, angular, dq, ddq,
                       rows: Sequence[int | None], twisted: _Frames | None = None) -> list[_Columns]:
    """The columns in segment axes (:func:`_columns`, with ``p_e`` by Horner's rule), and in base axes
    (``z_k x r_(k+1)``, :func:`_base_offsets`) with the frames' rows carried whole (``None`` in ``rows``) or
    one row as cofactors of the other two (:func:`_cofactor_view`); for the row whose columns cost least,
    two more: some axes' entries in that row from the frame before (:func:`_propagated_views`), and then the
    last link turned instead of its frame (:func:`_turned_last_axes`). Where ``twisted`` is given (the frames
    kept with their first two columns scaled, :func:`_twist_scaled_frames`: every twist 2 operations a row
    cheaper), those two and the base-axes columns once more are built from it instead (xArm7: 210, 6 fewer
    operations than the same from ``f``)."""
    out = [_Columns(linear, angular, f.axes, _velocities(step, joints, f.axes, linear, angular, dq, ddq,
                                                         axis_cross=_axis_cross(joints, f, f.rotation, f.axes)), None)]
    seen: list[list[Rows]] = []
    cheapest: tuple[int, int] | None = None
    for dropped in rows:
        views = [_cofactor_view(step, f.rotation[s], dropped, f"Fc{s + 1}_") for s in range(len(f.rotation))]
        if views in seen:  # that row is constant in every frame (a planar chain): nothing new
            continue
        seen.append(views)
        columns = _base_columns(step, joints, f, tool, W, views, dropped, _row_tag(dropped), dq, ddq)
        price = _price(step.definitions(), _flat(columns.linear, columns.angular))[0]
        if price > 0.98 * _price(step.definitions(), _flat(linear, angular))[0]:
            continue  # not 2 % cheaper without their rates (which follow the columns; see _choose): not worth those
        out.append(columns)
        if dropped is not None and (cheapest is None or price < cheapest[0]):
            cheapest = (price, dropped)
    if cheapest is None:
        return out
    dropped = cheapest[1]
    if twisted is None:
        views = [_cofactor_view(step, f.rotation[s], dropped, f"Fc{s + 1}_") for s in range(len(f.rotation))]
        return out + _more_columns(step, joints, f, tool, W, views, dropped, _row_tag(dropped), dq, ddq)
    tag = f"{_row_tag(dropped)}{twisted.tag}_"  # each of these costs less with the twisted frames than with f
    views = [_cofactor_view(step, twisted.rotation[s], dropped, f"Fc{twisted.tag}{s + 1}_", factors=(*twisted.columns[s], 1),
                            pair=sp.S.One) for s in range(len(twisted.rotation))]
    out.append(_base_columns(step, joints, twisted, tool, W, views, dropped, tag, dq, ddq))
    return out + _more_columns(step, joints, twisted, tool, W, views, dropped, tag, dq, ddq)


def _base_columns(step: _Steps, joints, f: _Frames, tool: Transform, W, views: list[Rows], dropped: int | None, tag: str,
                  dq, ddq, tip: bool = True) -> _Columns:
    """The base-axes columns from the frames' ``views`` (:func:`_cofactor_view`), with the tip position their
    offsets give where ``tip``."""
    axes = [[row[2] for row in views[f.segment[k]]] for k in range(len(joints))]
    r, base = _base_offsets(step, joints, f, tool, axes, dropped, tag)
    base = _next_frame_columns(step, joints, f, views, axes, r, W, base, dropped, tag)
    ang = [matvec(views[f.segment[k]], joint.motion.column(E_Z, [0, 0, 0])[1]) for k, joint in enumerate(joints)]
    position = step.vec(f"pb{tag}", add(list(joints[0].before.translation), r[0])) if tip else None
    return _Columns(base, ang, axes, _velocities(step, joints, axes, base, ang, dq, ddq, f"a{tag}",
                                                 _axis_cross(joints, f, views, axes)), position)


def _more_columns(step: _Steps, joints, f: _Frames, tool: Transform, W, views: list[Rows], dropped: int, tag: str,
                  dq, ddq) -> list[_Columns]:
    """The base-axes columns with some axes' entries in row ``dropped`` from the frame before
    (:func:`_propagated_views`), then with the last link turned instead of its frame (:func:`_turned_last_axes`)."""
    out = []
    turned = _propagated_views(step, joints, f, tool, views, dropped)
    if turned is not None:
        views = turned
        out.append(_base_columns(step, joints, f, tool, W, views, dropped, f"{tag}p_", dq, ddq, tip=False))
    link = _turned_last_axes(joints, f, tool, dropped)
    if link is not None:  # and the last link's offset turned instead of its frame's rows
        k, coefficients, moved_axes = link
        axes = [[row[2] for row in views[f.segment[j]]] for j in range(len(joints))]
        r, base = _base_offsets(step, joints, f, tool, axes, dropped, f"{tag}t_", turned=True)
        last = step.vec(f"zt{tag}{k + 2}", [sum((c * x[i] for c, x in zip(coefficients, (r[k], base[k], axes[k]))), sp.S.Zero)
                                              for i in range(3)])
        axes = [last if j in moved_axes else axes[j] for j in range(len(joints))]
        ang = [joint.motion.column(axes[j], [0, 0, 0])[1] for j, joint in enumerate(joints)]
        out.append(_Columns(base, ang, axes, _velocities(step, joints, axes, base, ang, dq, ddq, f"a{tag}t_",
                                                         _axis_cross(joints, f, views, axes)), None))
    return out


def _turned_last_axes(joints, f: _Frames, tool: Transform, dropped: int | None):
    """Where the chain ends in a link across a revolute joint ``k``'s axis (offset ``t`` in ``G_k``'s axes,
    numbers) followed by joints without offsets in at most one more segment: ``(k, (alpha, beta, gamma), J)``
    with ``J`` the joints of that segment, whose axis ``z' = G_k C e_z`` is ``alpha u + beta w + gamma z_k``
    (``u = G_k t``, ``w = z_k x u = G_k (e_z x t)``: ``G_k e_x = (t_x (u - t_z z_k) - t_y w) / rho``,
    ``G_k e_y = (t_y (u - t_z z_k) + t_x w) / rho``, ``rho = t_x^2 + t_y^2``), 15 operations from what the
    Jacobian computes anyway; else ``None``. With that, and the offset turned by ``psi_k`` before the frame
    ``F_s`` takes it (``_base_offsets(turned=True)``), nothing in the Jacobian reads ``G_k``'s first two
    columns: xArm7's ``jacobian`` saves their 12 operations and pays 9 more for the offset and the axis."""
    n = len(joints)
    if dropped is None or f.scale is not None:
        return None
    k = n - 1
    while k >= 0 and all(x == 0 for x in (joints[k + 1].before if k + 1 < n else tool).translation):
        if joints[k].motion.advance(f.theta[k]) != 0:
            return None
        k -= 1
    if k < 0 or joints[k].motion.kind != "revolute" or f.trig[k] is None:
        return None
    t = [sp.sympify(x) for x in (joints[k + 1].before if k + 1 < n else tool).translation]
    rho = t[0] ** 2 + t[1] ** 2
    if rho == 0 or any(x.free_symbols for x in t):
        return None
    after = [j for j in range(k + 1, n) if f.segment[j] != f.segment[k]]
    if any(f.segment[j] != f.segment[k] + 1 for j in after):
        return None
    if not after:
        return k, (sp.S.Zero, sp.S.Zero, sp.S.One), frozenset()
    C = _rows(joints[after[0]].before.rotation)
    if any(sp.sympify(C[i][2]).free_symbols for i in range(3)):
        return None
    alpha = (C[0][2] * t[0] + C[1][2] * t[1]) / rho
    beta = (C[1][2] * t[0] - C[0][2] * t[1]) / rho
    return k, (alpha, beta, C[2][2] - alpha * t[2]), frozenset(after)


def _propagated_views(step: _Steps, joints, f: _Frames, tool: Transform, views: list[Rows],
                      dropped: int | None) -> list[Rows] | None:
    """``views`` (the frames with row ``dropped`` as cofactors) with that row's third-column entry of a frame
    ``F_s = G C`` (``G = F_(s-1) Rz(psi)``, the frame after the joint before it; ``C`` the constant rotation
    that starts segment ``s``) written ``sum_i G[d][i] C[i][2]``: ``G``'s third column is the axis before, its
    first two columns' entries are cofactors of ``G`` (3 operations each), taken only where the link after that
    joint has an offset along them (a frame whose offsets read its first two columns). The cofactor of ``F_s``
    it replaces needs ``F_s``'s other rows in their first two columns, which nothing else may need: xArm7's last
    axis, whose frame's other columns only the tool's rotation reads, costs 6 operations instead of 9 in its
    ``jacobian``. A candidate of its own (:func:`_choose` prices it per function). ``None`` when no frame's
    entry can be written so (or no row is dropped)."""
    if dropped is None or f.scale is not None:
        return None
    out = [list(map(list, v)) for v in views]
    changed = False
    for s in range(1, len(f.rotation)):
        k = f.starts[s]
        C = _rows(joints[k].before.rotation)
        t = list(joints[k].before.translation)
        need = [i for i in range(3) if C[i][2] != 0]
        if any(i < 2 and t[i] == 0 for i in need) or not any(sp.sympify(x).free_symbols for x in f.rotation[s][dropped]):
            continue
        Gv = _after_joint(step, f, k - 1, dropped, [row[2] for row in out[s - 1]])  # the true G
        entry = step(f"Fp{f.tag}{s + 1}_{dropped}2", sum((Gv[dropped][i] * C[i][2] for i in need), sp.S.Zero))
        if entry != out[s][dropped][2]:
            out[s][dropped][2] = entry
            changed = True
    return out if changed else None


def _axis_cross(joints, f: _Frames, views: list[Rows], axes: list[Vector]):
    """``z_j x z_k`` (``j < k``) without a cross product where the frames give it, else ``None``: zero for
    parallel axes (one segment), the cross product itself for a constant axis with one nonzero entry, and for
    consecutive segments ``F_s ((C^T e_z) x e_z)`` (``z_j = F_s C^T e_z``, ``C`` the constant rotation that
    starts segment ``s``), one column of ``F_s`` where ``C`` takes ``z`` to ``+-x`` or ``+-y``."""

    def known(j: int, k: int) -> Vector | None:
        if all(a == b for a, b in zip(axes[j], axes[k])):
            return [sp.S.Zero] * 3
        if not any(sp.sympify(x).free_symbols for x in axes[j]) and sum(x != 0 for x in axes[j]) == 1:
            return cross(axes[j], axes[k])
        s = f.segment[k]
        if f.segment[j] != s - 1:
            return None
        C = joints[f.starts[s]].before.rotation
        v = [C[2, i] for i in range(3)]
        if v[2] != 0 or sum(abs(x) == 1 for x in v[:2]) != 1 or any(x not in (-1, 0, 1) for x in v):
            return None
        return matvec(views[s], [v[1], -v[0], sp.S.Zero])

    return known


def _next_frame_columns(step: _Steps, joints, f: _Frames, views: list[Rows], axes: list[Vector], r: list[Vector],
                        W: Sequence[Vector], base: list[Vector], dropped: int | None,
                        tag: str | None = None) -> list[Vector]:
    """The base-axes columns ``base``, each replaced by the same column taken in the axes of the frame that
    starts at the next joint where that needs fewer operations (SYMORO's choice of projection frame):
    ``z_k x (p_e - o_k) = F' ((C^T e_z) x W_(k+1)) + G_k (e_z x t)``, with ``F'`` that frame
    (:func:`_cofactor_view`), ``C`` the constant rotation before it, ``W_(k+1)`` the tool offset in its axes
    (:func:`_tool_offsets`) and ``t`` the translation to the next joint. Near a wrist ``W`` has a zero and the
    column is one column of ``F'`` times one number (3 multiplications instead of a cross product)."""
    steps = step.definitions()
    paid = frozenset(_price(steps, _flat(axes, r))[1])
    out = list(base)
    tag = _row_tag(dropped) if tag is None else tag
    for k in range(len(joints) - 1):
        if f.segment[k + 1] == f.segment[k]:
            continue
        nxt = joints[k + 1].before
        turned = [nxt.rotation[2, i] for i in range(3)]  # z_k in the next frame's axes
        local = joints[k].motion.column(turned, W[k + 1])[0]
        if sum(x != 0 for x in local) > 1:  # two terms or more: no cheaper than the cross product in base axes
            continue
        column = matvec(views[f.segment[k + 1]], local)
        t = list(nxt.translation)
        moved = joints[k].motion.follows_tool(E_Z, [t[0], t[1], t[2] + joints[k].motion.advance(f.theta[k])])
        if moved is not None and any(x != 0 for x in moved):
            column = add(column, matvec(_after_joint(step, f, k, dropped, axes[k]), moved))
        if _price(steps, column, paid)[0] < _price(steps, base[k], paid)[0]:
            out[k] = step.vec(f"Jn{tag}_{k + 1}", column)
    return out


def _pose(step: _Steps, joints: Sequence[_Canonical], f: _Frames, tool: Transform,
          W: Sequence[Vector], scaled: _Frames | None = None) -> tuple[list[Pose], list[Pose], int | None]:
    """Candidates for the tool rotation ``R`` (rows) and position ``p_e``: those of every function with a pose,
    those of the ``pose`` function alone, and the row the cheapest rotation drops (``None``: all three carried).

    ``R = F_last Rz(psi_n) C_tool``: all rows multiplied out, or two of them and the third as their cross
    product (``r_0 = r_1 x r_2`` cyclically): carrying two rows down the chain instead of three saves six
    operations per dense step. ``p_e = o_1 + F_1 W_1`` (Horner's rule, shared with the Jacobian's offsets)
    or, with the cheapest rotation, summed link by link in base axes (:func:`_link_shares`). :func:`_choose`
    picks per function. ``scaled``: the frames with their third columns scaled (:func:`_scaled_frames`, where
    constants are dense), for one more candidate: the rotation and the summed position from those. For the
    ``pose`` function alone, the position cut at a joint (:func:`_split_tips`); ``kinematics`` takes its
    position from its Jacobian's offsets where that is cheaper.
    """
    rows = _tool_rows(step, f, tool)
    horner = step.vec("pe", add(list(joints[0].before.translation), matvec(f.rotation[0], W[0])))
    rotations, dropped = _rotations(step, rows, f.tag)
    poses = [(r, horner) for r in rotations]
    alone: list[Pose] = []
    cheapest = rotations[(None, 0, 1, 2).index(dropped)]
    if len(joints) <= CANDIDATES_UP_TO:
        shares = _link_shares(step, joints, f, tool, cheapest, dropped)
        poses.append((cheapest, _summed_tip(step, f, dropped, shares)))
        alone = [(cheapest, tip) for tip in _split_tips(step, joints, f, shares, dropped)]
        if scaled is not None:
            others, other_dropped = _rotations(step, _tool_rows(step, scaled, tool), scaled.tag)
            rotation = others[(None, 0, 1, 2).index(other_dropped)]
            shares = _link_shares(step, joints, scaled, tool, rotation, other_dropped)
            poses.append((rotation, _summed_tip(step, scaled, other_dropped, shares)))
    return poses, alone, dropped


def _tool_rows(step: _Steps, f: _Frames, tool: Transform) -> Rows:
    """``R = F_last Rz(psi_n) C_tool``, every entry a step (the unused ones are dropped later)."""
    last = len(f.rotation) - 1
    turned = _actual(f, last, step.mat(f"Ge{f.tag}_", _times_rz(f.rotation[last], f.trig[-1])))
    full = matmul(turned, _rows(tool.rotation))
    return [[step(f"Re{f.tag}{i}{j}", e) for j, e in enumerate(row)] for i, row in enumerate(full)]


def _rotations(step: _Steps, rows: Rows, tag: str) -> tuple[list[Rows], int | None]:
    """The rotation ``rows`` as it is, then with row 0, 1 or 2 as the cross product of the other two; and the
    row the cheapest of them drops (``None``: none)."""
    rotations = []
    for d in (None, 0, 1, 2):
        candidate = [list(r) for r in rows]
        if d is not None:
            candidate[d] = step.vec(f"Rx{tag}{d}", cross(rows[(d + 1) % 3], rows[(d + 2) % 3]))
        rotations.append(candidate)
    steps = step.definitions()
    prices = [_price(steps, _flat(r))[0] for r in rotations]
    return rotations, (None, 0, 1, 2)[prices.index(min(prices))]


def _link_shares(step: _Steps, joints: Sequence[_Canonical], f: _Frames, tool: Transform, rotation: Rows,
                 dropped: int | None) -> list[list[sp.Expr]]:
    """What each part of the chain adds to ``p_e`` in base axes, as terms of a sum per axis: ``o_1``; then per joint
    ``k`` its advance along ``z_k`` and ``G_k t_(k+1)`` (``G_k = F_s Rz(psi_k)``, the frame after joint ``k``'s motion,
    ``t_(k+1)`` the translation to the next joint; :func:`_after_joint`); last the tool's share
    ``R (C_tool^T t_tool)`` from the pose's rotation: ``n + 2`` entries of three term lists each. Where the pose drops
    row ``dropped`` of the rotation, that row's entries of the frames are cofactors of the two carried rows
    (:func:`_cofactor_view`)."""
    n = len(joints)
    views = [_cofactor_view(step, f.rotation[s], dropped, f"Fc{f.tag}{s + 1}_", factors=(1, 1, f.scale[s]) if f.scale else (1, 1, 1))
             for s in range(len(f.rotation))]
    axes = [[row[2] for row in views[f.segment[k]]] for k in range(n)]
    shares = [[[x] for x in joints[0].before.translation]]
    for k in range(n):
        terms: list[list[sp.Expr]] = [[], [], []]
        advance = joints[k].motion.advance(f.theta[k])
        if advance != 0:
            for i in range(3):
                terms[i].append(axes[k][i] * advance)
        t = list(joints[k + 1].before.translation) if k + 1 < n else []
        if any(x != 0 for x in t):
            for i, x in enumerate(matvec(_after_joint(step, f, k, dropped, axes[k]), t)):
                terms[i].append(x)
        shares.append(terms)
    shift = tool.rotation.T * tool.translation
    shares.append([[x] for x in matvec(rotation, [shift[i] for i in range(3)])])
    return shares


def _summed_tip(step: _Steps, f: _Frames, dropped: int | None, shares: Sequence[list[list[sp.Expr]]]) -> Vector:
    """``p_e`` summed link by link in base axes (:func:`_link_shares`), as a step of the frames ``f``."""
    return step.vec(f"ps{f.tag}{'' if dropped is None else dropped}", _summed(shares))


def _summed(shares: Sequence[list[list[sp.Expr]]]) -> Vector:
    """The per-axis sums of :func:`_link_shares`' terms (one sum per axis, its terms in chain order)."""
    return [sp.Add(*[x for share in shares for x in share[i]]) for i in range(3)]


def _split_tips(step: _Steps, joints: Sequence[_Canonical], f: _Frames, shares: Sequence[list[list[sp.Expr]]],
                dropped: int | None) -> list[Vector]:
    """``p_e = o_1 + F_1 W'_1 + (p_e - o_m)``, one candidate per joint ``m`` after the first: the links before
    joint ``m`` by Horner's rule (``W'`` the tool offsets of the chain cut at ``o_m``, :func:`_cut_offsets`), the
    rest summed in base axes (``shares``: :func:`_link_shares`). Where the last links are short and their frames'
    rows are carried for the rotation anyway, their share costs a few products of those rows, and Horner's rule
    before them turns fewer dense vectors (TALOS's arm: the gripper's offset from the last frame's rows, the
    elbow by Horner's rule; ABB IRB 140 `pose` 69 -> 62). Only cuts with a share on both sides; cuts that give
    the same sums, one candidate."""
    n = len(joints)
    tail = [any(share[i] for i in range(3)) for share in shares[1:]]  # per joint, then the tool
    tips: dict[tuple, Vector] = {}
    for m in range(1, n):
        if not any(tail[:m]) or not any(tail[m:]):
            continue
        head = matvec(f.rotation[0], _cut_offsets(step, joints, f, m))
        v = add(add([sp.Add(*x) for x in shares[0]], head), _summed(shares[m + 1:]))
        key = tuple(v)
        if key not in tips:
            tips[key] = step.vec(f"pm{f.tag}{m}_{'' if dropped is None else dropped}", v)
    return list(tips.values())


def _cut_offsets(step: _Steps, joints: Sequence[_Canonical], f: _Frames, m: int) -> Vector:
    """``W'_1 = o_m - o_1`` in the axes of the first segment's frame: :func:`~.frames._tool_offsets`'s Horner
    rule over joints ``1 .. m - 1``, with nothing after joint ``m``'s origin."""
    w: Vector | None = None
    for k in reversed(range(m)):
        w = _horner_step(step, joints, f, k, joints[k + 1].before, w, f"Wm{f.tag}{m}_{k + 1}")
    return w