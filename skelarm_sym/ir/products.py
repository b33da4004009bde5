"""Per-function reuse of products on the IR: a product of several factors is written with the locals that
already hold part of it, and a local product is dropped where its readers do as well without it.

A local ``p = a*b*...`` whose factors are variables or array elements (its *atoms*, other such locals
expanded) is a product the function pays for. A product ``M`` elsewhere whose atoms include all of ``p``'s
can read ``p`` and multiply the rest: Stanford's ``J[1] = (cos q2 q3) cos q1`` is ``(cos q1 cos q2) q3``,
and the first product is already there for the rotation. So:

1. every product is written with the largest earlier local products its atoms contain (greedy, largest
   first), where that is cheaper;
2. a local product whose every reader is a product is dropped when its readers, written without it as in
   1., pay fewer multiplications in all than it costs.

Only multiplications change (a product is reassociated: the value may round differently in the last
place); additions, negations and the order of statements stay. Bodies with control flow come back as
they are."""

from __future__ import annotations

from collections import Counter
from functools import lru_cache
from typing import Sequence

from .nodes import Const, Elem, Let, Mul, Store, TrigBlock, Var
from .walk import children, statement_reads, with_children

PASSES = 3
"""Rounds of dropping products at most."""


class _Products:
    def __init__(self, body: Sequence) -> None:
        self.body = list(body)
        self.position = {s.var.name: i for i, s in enumerate(self.body) if type(s) is Let}
        self.atoms: dict[str, Counter] = {}  # local product -> its atoms
        self.reads: dict[str, set[str]] = {}  # local product -> every local product its value reads (transitively)
        for s in self.body:
            if type(s) is Let and type(s.value) is Mul and all(type(f) in (Var, Elem) for f in s.value.factors):
                atoms, reads = Counter(), set()
                for f in s.value.factors:
                    if type(f) is Var and f.name in self.atoms:
                        atoms.update(self.atoms[f.name])
                        reads |= {f.name} | self.reads[f.name]
                    else:
                        atoms[f] += 1
                self.atoms[s.var.name] = atoms
                self.reads[s.var.name] = reads
        self.dropped: set[str] = set()
        self.sizes = sizes = {name: sum(atoms.values()) for name, atoms in self.atoms.items()}
        ranked = sorted((name for name in self.atoms if sizes[name] >= 2), key=lambda name: (-sizes[name], self.position[name]))
        self.rank = {name: k for k, name in enumerate(ranked)}
        # each product (of two atoms or more) filed under its rarest atom: a product inside a set of atoms has
        # that atom among them, so the atoms' files hold every candidate, each once
        frequency = Counter(a for name in ranked for a in self.atoms[name])
        first = {a: k for k, a in enumerate(frequency)}  # ties: the atom met first (any rule files each product once)
        self.by_atom: dict = {}
        for name in ranked:
            rarest = min(self.atoms[name], key=lambda a: (frequency[a], first[a]))
            self.by_atom.setdefault(rarest, []).append(name)
        self.containing: dict = {}  # atom -> every product (of two atoms or more) that contains it
        for name in ranked:
            for a in self.atoms[name]:
                self.containing.setdefault(a, []).append(name)
        self.readers: dict[str, set[int]] = {name: set() for name in self.atoms}
        for i, s in enumerate(self.body):
            if type(s) in (Let, Store):
                self._note(i, s, 1)

    def _note(self, i: int, statement, sign: int) -> None:
        """Record (``sign`` 1) or forget (-1) statement ``i`` as a reader of the products ``statement`` reads."""
        for name in statement_reads(statement):
            readers = self.readers.get(name)
            if readers is not None:
                (readers.add if sign > 0 else readers.discard)(i)

    def replace(self, i: int, statement) -> None:
        """Statement ``i`` becomes ``statement`` (the readers follow)."""
        old = self.body[i]
        if old is statement:
            return
        self._note(i, old, -1)
        self.body[i] = statement
        self._note(i, statement, 1)

    def size(self, factors) -> int:
        """How many atoms the product of ``factors`` has (the total of :meth:`expand`, without building it)."""
        return sum(self.sizes.get(f.name, 1) if type(f) is Var else 1 for f in factors)

    def expand(self, factors) -> Counter:
        """The atoms of a product of ``factors`` (local products expanded; other factors as they are)."""
        atoms: Counter = Counter()
        for f in factors:
            if type(f) is Var and f.name in self.atoms:
                atoms.update(self.atoms[f.name])
            else:
                atoms[f] += 1
        return atoms

    def cover(self, atoms: Counter, at: int, without: str | None, own: str | None) -> tuple:
        """Factors for the product of ``atoms`` in statement ``at``: the largest earlier local products
        inside it first (not ``without``, nor one that reads it; not the statement's own local ``own``)."""
        left = Counter(atoms)
        chosen = []
        names = [name for a in atoms for name in self.by_atom.get(a, ())]
        for name in sorted(names, key=self.rank.__getitem__):
            if (self.position[name] >= at or name == own or name == without or name in self.dropped
                    or (without is not None and without in self.reads[name])):
                continue
            need = self.atoms[name]
            while all(left[a] >= k for a, k in need.items()):
                chosen.append(Var(name))
                left.subtract(need)
        rest = [a for a in atoms if left[a] > 0 for _ in range(left[a])]
        return tuple(chosen) + tuple(rest)

    # -- rewriting expressions ----------------------------------------------------------------------------
    def rewrite(self, e, at: int, own: str | None, without: str | None = None):
        """``e`` with its products written by :meth:`cover` where that is cheaper (and ``without`` replaced
        wherever it is a factor); ``(expr, multiplications saved)``."""
        t = type(e)
        if t is Mul:
            factors, saved = [], 0
            for f in e.factors:
                g, s = self.rewrite(f, at, own, without)
                factors.append(g)
                saved += s
            plain = all(type(f) in (Var, Elem, Const) for f in factors)
            uses = without is not None and any(type(f) is Var and f.name == without for f in factors)
            atoms = self.expand(factors) if plain and (uses or without is None) else None
            # two atoms: the CSE has shared that product already; dropping a product rewrites only its readers
            if plain and (uses or (without is None and sum(atoms.values()) > 2)):
                new = self.cover(atoms, at, without, own)
                if uses or len(new) < len(factors):
                    return Mul(new) if len(new) > 1 else new[0], saved + len(factors) - len(new)
            return with_children(e, tuple(factors)), saved
        parts = [self.rewrite(x, at, own, without) for x in children(e)]
        return with_children(e, tuple(x for x, _ in parts)), sum(saved for _, saved in parts)

    def statement(self, i: int, without: str | None = None):
        """Statement ``i`` rewritten, and the multiplications that saves."""
        s = self.body[i]
        if type(s) is Let:
            value, saved = self.rewrite(s.value, i, s.var.name, without)
            return (s if value is s.value else Let(s.var, value)), saved
        if type(s) is Store:
            value, saved = self.rewrite(s.value, i, None, without)
            return (s if value is s.value else Store(s.output, s.index, value)), saved
        return s, 0

    def run(self) -> tuple:
        # only a product of three atoms or more can read an earlier product (of two, the CSE has shared it): a
        # statement with none keeps its form (most readers of a product read it whole, as a term of a sum)
        wanted = [i for i, s in enumerate(self.body)
                  if type(s) in (Let, Store) and any(self.size(m.factors) > 2 for m in _products_in(s))]
        for i in wanted:
            self.replace(i, self.statement(i)[0])
        for _ in range(PASSES):
            if not any([self.drop(name) for name in reversed(list(self.atoms)) if name not in self.dropped]):
                break
        return tuple(s for s in self.body if not (type(s) is Let and s.var.name in self.dropped))

    def might_replace(self, name: str, last: int) -> bool:
        """Whether another product could stand in for part of ``name`` in a reader up to statement ``last``:
        one that shares an atom with it and has one it lacks (without such, each reader pays at least the
        multiplications ``name`` saved it, and dropping it cannot gain)."""
        own = self.atoms[name]
        for a in own:
            for other in self.containing.get(a, ()):
                if (other != name and other not in self.dropped and self.position[other] < last
                        and name not in self.reads[other] and any(b not in own for b in self.atoms[other])):
                    return True
        return False

    def drop(self, name: str) -> bool:
        """Drop local product ``name`` when every reader is a product and does better without it."""
        readers = sorted(self.readers[name])
        if not readers or not self.might_replace(name, readers[-1]):
            return False
        value = self.body[self.position[name]].value
        if type(value) is not Mul:  # written as a copy of an equal product: it costs nothing
            return False
        cost = len(value.factors) - 1
        # first an estimate from the products that read it (the readers' other parts stay as they are)
        target = Var(name)
        estimate = cost
        for i in readers:
            own = self.body[i].var.name if type(self.body[i]) is Let else None
            for site in _products_in(self.body[i]):
                if target in site.factors:
                    estimate += len(site.factors) - len(self.cover(self.expand(site.factors), i, name, own))
        if estimate <= 0:
            return False
        if not all(_only_factor(self.body[i].value, name) for i in readers):
            return False
        rewritten = {}
        for i in readers:
            new, saved = self.statement(i, without=name)
            if name in statement_reads(new):
                return False
            rewritten[i] = (new, saved)
        if sum(s for _, s in rewritten.values()) + cost <= 0:
            return False
        for i, (new, _) in rewritten.items():
            self.replace(i, new)
        self.dropped.add(name)
        self._note(self.position[name], self.body[self.position[name]], -1)  # its own reads go with it
        self.readers[name] = set()
        return True


@lru_cache(maxsize=1 << 16)
def _products_in(statement) -> tuple:
    """The products of plain factors (variables, array elements, numbers) in a statement's value."""
    found, stack = [], [statement.value]
    while stack:
        e = stack.pop()
        if type(e) is Mul and all(type(f) in (Var, Elem, Const) for f in e.factors):
            found.append(e)
        else:
            stack.extend(children(e))
    return tuple(found)


def _only_factor(e, name: str) -> bool:
    """Whether every occurrence of variable ``name`` in ``e`` is a factor of a product."""
    if type(e) is Var:
        return e.name != name
    factors = e.factors if type(e) is Mul else ()
    return all(_only_factor(x, name) for x in children(e) if not (x in factors and type(x) is Var and x.name == name))


def reuse_products(body: Sequence) -> tuple:
    """``body`` with its products written with the local products already there (see the module docstring)."""
    if not all(type(s) in (Let, TrigBlock, Store) for s in body):
        return tuple(body)
    products = _Products(body)
    if not products.atoms:
        return tuple(body)
    return products.run()
