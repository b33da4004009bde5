"""IR as Python over ``jax.numpy``: the array expression printer (:mod:`..array_syntax`) with JAX's names, and
masked procedures (:mod:`skelarm_sym.ir.predicate`) as functional control flow.

A loop over data (:class:`~skelarm_sym.ir.predicate.PLoop`) is ``lax.while_loop`` whose state is the
tuple of the names the loop assigns (its ``carried``: numbers per lane, lists of them for arrays, pairs
of 32-bit halves for 64-bit words), ending when no lane runs; a guard (:class:`PGuard`) is ``lax.cond``
on ``any(mask)``; a loop over a constant range whose counter is only a value and whose body is costly
(``rollable``) is ``lax.fori_loop``; other constant loops unroll while tracing. Every variable a loop
carries is an array over the whole batch (``_lanes``), so the state keeps its shape and dtype.
"""

from __future__ import annotations

from ...ir.nodes import Type, Var as Var_
from ...ir.predicate import PFor, PGuard, PLoop, PSet, Predicated
from ..array_syntax import Dialect, ProcedurePrinter, identifier

JAX = Dialect(
    where="jnp.where",
    calls={"sqrt": "_sqrt", "sin": "jnp.sin", "cos": "jnp.cos", "fabs": "jnp.abs", "floor": "jnp.floor",
           "nearbyint": "jnp.rint", "isfinite": "jnp.isfinite", "atan2": "jnp.arctan2", "fmin": "jnp.minimum",
           "fmax": "jnp.maximum"},
    int_dtype="jnp.int32",
    bool_dtype="jnp.bool_",
    cast="{x}.astype({dtype})",
    shared="_shared",
)


class JaxProcedurePrinter(ProcedurePrinter):
    """A :class:`~skelarm_sym.ir.predicate.Predicated` procedure as JAX statements (module docstring): the
    shared printer's statements, but for loops, guards and elements at a traced index, which JAX writes as
    functional control flow and ``_put``; values a loop carries are kept over every lane."""

    def __init__(self, p: Predicated, calls: dict[str, str], dialect: Dialect = JAX, indent: str = "    ") -> None:
        super().__init__(p, calls, dialect, indent, statics=p.statics - p.rollable)
        self.count = 0

    def value(self, e, type_: Type, lanes: bool = True) -> str:
        if self.printer.static(e):
            return self._full(self.printer.expr(e), type_)
        text = self.printer.expr(e)
        if lanes:
            return f"_lu({text})" if type_ is Type.UINT64 else f"_lanes({text})"
        return text

    def dynamic(self, target) -> bool:
        """An element whose index is a counter of a rolled loop (a traced number)."""
        return type(target) is not Var_ and not self.printer.static(target.index)

    def _state(self, carried) -> tuple[str, list[str]]:
        """The state tuple's text and the lines that unpack it inside a body function."""
        names = [identifier(n) for n in carried]
        pack = "(" + "".join(f"{n}, " for n in names) + ")"
        unpack = []
        for i, (raw, n) in enumerate(zip(carried, names)):
            unpack.append(f"{n} = list(_s[{i}])" if raw in self.p.arrays else f"{n} = _s[{i}]")
        return pack, unpack

    def _function(self, header: str, carried, body, depth: int, lines: list[str]) -> str:
        """``def header:`` that unpacks the state, runs ``body`` and returns the state; returns the pack text."""
        pad = self.indent * depth
        inner = self.indent * (depth + 1)
        pack, unpack = self._state(carried)
        lines.append(f"{pad}def {header}:")
        lines.extend(inner + line for line in unpack)
        lines.extend(self.statements(body, depth + 1))
        lines.append(f"{inner}return {pack}")
        return pack

    def statement(self, s, depth: int, lines: list[str]) -> None:
        pad = self.indent * depth
        t = type(s)
        if t is PSet and self.dynamic(s.target):
            name = identifier(s.target.array)
            mask = "None" if s.mask is None else identifier(s.mask.name)
            _, type_ = self.target(s.target)
            lines.append(f"{pad}{name} = _put({name}, {self.printer.expr(s.target.index)}, "
                         f"{self.printer.tensor(s.value, type_)}, {mask})")
        elif t is PFor and s.rollable and s.carried:
            self.count += 1
            name = f"_for{self.count}"
            pack = self._function(f"{name}({identifier(s.var.name)}, _s)", s.carried, s.body, depth, lines)
            lines.append(f"{pad}{pack} = lax.fori_loop({s.start}, {s.stop}, {name}, {pack})")
        elif t is PFor:
            if s.rollable:  # a counter the printer knows after all: unroll
                self.printer.statics.add(s.var.name)
            super().statement(s, depth, lines)
        elif t is PLoop:
            self.count += 1
            name = f"_loop{self.count}"
            index = list(s.carried).index(s.run.name)
            lines.append(f"{pad}def {name}_test(_s):")
            lines.append(f"{pad}{self.indent}return jnp.any(_s[{index}])")
            pack = self._function(f"{name}(_s)", s.carried, s.body, depth, lines)
            lines.append(f"{pad}{pack} = lax.while_loop({name}_test, {name}, {pack})")
        elif t is PGuard:
            if not s.carried:
                return
            self.count += 1
            name = f"_branch{self.count}"
            pack = self._function(f"{name}(_s)", s.carried, s.body, depth, lines)
            lines.append(f"{pad}{pack} = lax.cond(jnp.any({identifier(s.mask.name)}), {name}, _same, {pack})")
        else:
            super().statement(s, depth, lines)
