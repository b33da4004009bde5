"""A spherical wrist's continuum in the post-processing, written once in the IR for ``ik_all`` and ``ik_nearest``.

Statement for statement :func:`skelarm_sym.closed_ik.postprocess.continuum_sign` and ``continuum_member``: a row
flagged singular whose wrist angle ``q[w]`` is within ``IK_WRIST_ALIGNED_TOL`` of ``k pi`` has joints ``a`` and ``b``
turning about one axis, ``q[a] + sigma q[b]`` fixed modulo 2 pi (``sigma = s`` for even ``k``, ``-s`` for odd), and
the member within both joints' limits nearest a reference is chosen: ``ik_all`` takes the row's own values as the
reference (the row when it fits, else the member the least turn away), ``ik_nearest`` takes ``q_ref``.

In offsets from the row, ``u = q'[a] - q[a]`` and ``v = sigma (q'[b] - q[b])``, the members are the lines
``u + v = 2 pi m``; on each the nearest point within the limits is the unconstrained one clamped to the line's
segment in the windows of ``u`` and ``v`` (each at most a turn wide: a point further out has a nearer copy within the
limits), and the member is built from the row, so it stays on the continuum whatever the reference's magnitude.
At most three lines cross the windows (fewer where the ranges are narrower), known at generation time: they
unroll.
"""

from __future__ import annotations

import contextlib
import math

from ...closed_ik.postprocess import INV_TWO_PI, TWO_PI
from ...ir.build import Body, fabs, fmax, fmin, select
from ...ir.nodes import Call1, Const, NamedConst, Type, eq, ne



def _width(lo: float | None, hi: float | None) -> float:
    """The most width of the window of offsets a nearest point can take (postprocess._window): the range, at most a
    turn."""
    return min(hi - lo, TWO_PI) if lo is not None and hi is not None else TWO_PI


class Continuum:
    """The locals of the member choice (declared once, before the loops), and the statements that use them.

    ``arm``: an object with ``continuum`` (``(a, w, b, s, s_odd, w0)``), ``lower`` and ``upper`` (per coordinate, ``None``
    where absent); ``reference``: the member is chosen nearest a reference other than the row (``ik_nearest``);
    ``weights``: joint a's and joint b's metric weights (``ik_nearest_weighted``; None: both 1)."""

    def __init__(self, b: Body, arm, reference: bool, weights: tuple | None = None) -> None:
        self.weights = weights
        self.a, self.w, self.b, self.s, self.s_odd, self.w0 = arm.continuum
        self.lower = (arm.lower[self.a], arm.lower[self.b])
        self.upper = (arm.upper[self.a], arm.upper[self.b])
        # the windows take the limits widened by IK_LIMIT_TOL (at most 1e-5, in float): a margin above that keeps
        # the count from missing a line where the widths sum to just under a multiple of a turn
        self.lines = int(math.floor((_width(self.lower[0], self.upper[0]) + _width(self.lower[1], self.upper[1]) + 1e-4)
                                    * INV_TWO_PI)) + 1
        self.sigma = b.var("c_sigma", 0.0)
        self.k = b.var("c_k", 0.0)
        if reference:
            self.da = b.var("c_da", 0.0)
            self.dw = b.var("c_dw", 0.0)
            self.db = b.var("c_db", 0.0)
        self.window = [b.var(f"c_{n}", 0.0) for n in ("ua0", "ua1", "wb0", "wb1", "vb0", "vb1")]
        self.first = b.var("c_first", 0.0)
        self.e = b.var("c_e", 0.0)
        self.lo = b.var("c_lo", 0.0)
        self.hi = b.var("c_hi", 0.0)
        self.u = b.var("c_u", 0.0)
        self.d = b.var("c_d", 0.0)
        self.best_d = b.var("c_best_d", 0.0)
        self.best_u = b.var("c_best_u", 0.0)
        self.best_v = b.var("c_best_v", 0.0)
        self.found = b.var("c_found", Const(0, Type.INT), Type.INT)

    def move(self, b: Body, q_w, singular, x, y, ref_a, ref_b, out_a, out_b, through_ref: bool = False) -> None:
        """Where the row is a continuum's member (``singular``: its flag's singular bit is set, ``None`` where the
        caller has tested it; ``q_w``: its wrist angle within IK_WRIST_ALIGNED_TOL of ``w0 + k pi``), ``out_a``, ``out_b``
        = the member within the limits nearest ``(ref_a, ref_b)`` of the continuum through ``(x, y)`` (see
        :meth:`_member`); a regular row costs one test."""
        with (b.if_(singular) if singular is not None else contextlib.nullcontext()):
            if self.w0:  # aligned at w0 + k pi (a file whose zero pose bends the wrist)
                q_w = q_w - self.w0
            b.set(self.k, Call1("nearbyint", q_w * (1.0 / math.pi)))
            odd = fabs(self.k - 2.0 * Call1("nearbyint", 0.5 * self.k)) > 0.5
            b.set(self.sigma, select(fabs(q_w - math.pi * self.k) <= NamedConst("IK_WRIST_ALIGNED_TOL"),
                                     select(odd, float(self.s_odd), float(self.s)), 0.0))
            with b.if_(ne(self.sigma, 0.0)):
                self._member(b, x, y, ref_a, ref_b, out_a, out_b, through_ref)

    @staticmethod
    def _window(b: Body, lo: float | None, hi: float | None, value, d, start, end) -> None:
        """``start``, ``end`` = the window of offsets ``t`` from ``value`` a nearest point can take (postprocess._window):
        ``[max(low, min(high - 2 pi, d - pi)), min(high, max(low + 2 pi, d + pi))]``, ``low = lo - IK_LIMIT_TOL -
        value``, ``high = hi + IK_LIMIT_TOL - value`` (a member within the tolerance of a limit is clipped onto it, as
        in step 4), a missing limit left out."""
        tol = NamedConst("IK_LIMIT_TOL")
        low = None if lo is None else (lo - tol) - value
        high = None if hi is None else (hi + tol) - value
        first = d - math.pi if high is None else fmin(high - TWO_PI, d - math.pi)
        last = d + math.pi if low is None else fmax(low + TWO_PI, d + math.pi)
        b.set(start, first if low is None else fmax(low, first))
        b.set(end, last if high is None else fmin(high, last))

    def _member(self, b: Body, x, y, ref_a, ref_b, out_a, out_b, through_ref: bool) -> None:
        """``out_a``, ``out_b`` = the member within the limits nearest ``(ref_a, ref_b)`` of the continuum through
        ``(x, y)`` (``sigma`` set), when one is within the limits; else left as they are. ``through_ref``: the
        reference is ``(x, y)`` itself (offsets 0)."""
        ua0, ua1, wb0, wb1, vb0, vb1 = self.window
        sigma = self.sigma
        da, db = (0.0, 0.0) if through_ref else (self.da, self.db)
        if not through_ref:
            b.set(self.da, ref_a - x)
            b.set(self.dw, ref_b - y)
            b.set(self.db, sigma * self.dw)
        self._window(b, self.lower[0], self.upper[0], x, da, ua0, ua1)
        self._window(b, self.lower[1], self.upper[1], y, 0.0 if through_ref else self.dw, wb0, wb1)
        b.set(vb0, select(sigma > 0.0, wb0, -wb1))
        b.set(vb1, select(sigma > 0.0, wb1, -wb0))
        b.set(self.first, -Call1("floor", -(ua0 + vb0) * INV_TWO_PI))
        b.set(self.found, Const(0, Type.INT))
        for j in range(self.lines):
            b.comment(f"line {j + 1} of {self.lines} of the continuum that can cross the windows")
            b.set(self.e, TWO_PI * (self.first + float(j)) if j else TWO_PI * self.first)
            b.set(self.lo, fmax(ua0, self.e - vb1))
            b.set(self.hi, fmin(ua1, self.e - vb0))
            if self.weights is None:
                b.set(self.u, fmax(0.5 * (da + (self.e - db)), self.lo))
                b.set(self.u, fmin(self.u, self.hi))
                b.set(self.d, (self.u - da) * (self.u - da) + ((self.e - self.u) - db) * ((self.e - self.u) - db))
            else:  # the weighted nearest point of the line, as continuum_member computes it
                wa, wb = self.weights
                b.set(self.u, fmax((wa * da + wb * (self.e - db)) / (wa + wb), self.lo))
                b.set(self.u, fmin(self.u, self.hi))
                b.set(self.d, wa * ((self.u - da) * (self.u - da)) + wb * (((self.e - self.u) - db) * ((self.e - self.u) - db)))
            with b.if_((self.lo <= self.hi) & (eq(self.found, 0) | (self.d < self.best_d))):
                b.set(self.best_d, self.d)
                b.set(self.best_u, self.u)
                b.set(self.best_v, self.e - self.u)
                b.set(self.found, Const(1, Type.INT))
        with b.if_(self.found > 0):
            for out, value, offset, lo, hi in ((out_a, x, self.best_u, self.lower[0], self.upper[0]),
                                               (out_b, y, sigma * self.best_v, self.lower[1], self.upper[1])):
                b.set(out, value + offset)
                clipped = out
                if hi is not None:
                    clipped = select(out > hi, hi, clipped)
                if lo is not None:
                    clipped = select(out < lo, lo, clipped)
                if lo is not None or hi is not None:
                    b.set(out, clipped)
