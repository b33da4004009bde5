"""Per-function signs on the IR: which locals of a straight-line body to store negated so that the
function pays the fewest negations.

Every real local ``t = e`` may hold ``-e`` instead, its uses reading ``-t``: a sign moves through a
product to wherever the product is used, and a term's sign is a subtraction, so a negation is paid only
where a value must arrive with its own sign: a stored output, a local's value, an argument of a call or
a denominator (with :mod:`.count`'s rules: a sum whose terms are all negative pays one, unless a number
or a product led by one carries the sign; a negative literal carries its sign for free). A product that
must be negated and has a factor ``x`` for which an earlier local ``u = -x`` exists reads ``u`` instead,
free (the derivation hoists such factors: Stanford's ``-sin q2``).

The derivation chooses one sign per step for every function it emits (the chain's sign search weighs
the functions together); this pass settles what is left for each function alone, so a step that one
function only reads negated is stored negated in that function. Negation is exact in floating point:
values are unchanged, except that a sum whose leading term becomes a subtraction starts at its first
added term (``-a + b`` is printed ``b - a``, the same number; a later term moved to the front may round
differently in the last place).

:func:`settle_signs` is greedy (flip a local when that lowers the negations of its definition and its
uses; passes until none does) and leaves a body with no other statements than :class:`Let`,
:class:`TrigBlock` and :class:`Store` untouched."""

from __future__ import annotations

from functools import lru_cache
from typing import Sequence

from .count import count_ops
from .nodes import Add, Bits, Call1, Call2, Cast, Compare, Const, Div, Elem, Let, Logic, Mul, NamedConst, Neg, Not, Select, Store, TrigBlock, Type, Var
from .walk import children, expr_names, statement_reads

PASSES = 4
"""Greedy passes over the locals at most (the chain's bodies settle in two)."""

CHASE_DEPTH = 8
"""Flips in one chain of :meth:`_Signs.chase` at most."""

CHASE_BUDGET = 3
"""The work :meth:`_Signs.chase` may spend, in multiples of the body's size: each flip made or tried costs the
statements it re-prices, each weighted by the names it reads (:meth:`_Signs._work`). Over the example-robot-data
chains 3 finds what no limit finds, 2 loses 12 operations; a 64-joint chain's chases take 0.18 s of its 4.3 s."""

CHASE_OPTIONS = 4
"""Flips tried at each step of a chase at most; the one that costs least is taken (over the example-robot-data chains'
four forward functions 4 finds what 6 finds to 2 operations in 68 000, 2 loses 55)."""

CHASE_READERS = 6
"""Locals read by more statements are not flipped in a chase (each flip re-prices every reader; a chain's frame
entries, where negations travel, have two to four)."""

MOST_READERS = 24
"""A local read by more statements keeps its sign: trying it re-prices every reader (a planar arm's joint
terms are read by each of the long sums after them). On every example robot and planar arms of 3, 8 and 48
links no count changes without this limit."""


class _Signs:
    """The body, which locals are flipped, and each statement's negations under those flips."""

    def __init__(self, body: Sequence) -> None:
        self.body = list(body)
        self.position = {s.var.name: i for i, s in enumerate(self.body) if type(s) is Let}
        # a local u = -x (x a variable): read as -x everywhere, and offered as the negation of x after it
        self.alias_of: dict[str, Var] = {}
        self.negation_of: dict[str, tuple[int, Var]] = {}
        for i, s in enumerate(self.body):  # u stores -x whatever x stores: it follows x's sign
            if type(s) is Let and type(s.value) is Neg and type(s.value.x) is Var and s.value.x.type is Type.REAL:
                self.alias_of[s.var.name] = s.value.x
                self.negation_of.setdefault(s.value.x.name, (i, s.var))
        angles = set()
        for s in self.body:
            if type(s) is TrigBlock:
                for a in s.angles:
                    expr_names(a, angles)
        opaque = set()  # read where normal() moves no sign (an index, a cast, bit operations): never flipped
        for s in self.body:
            if type(s) in (Let, Store):
                opaque |= _opaque_reads(s.value)
        self.flippable = [
            s.var.name for s in self.body
            if type(s) is Let and s.var.type is Type.REAL and s.var.name not in angles and s.var.name not in self.alias_of
            and s.var.name not in opaque
        ]
        self.users: dict[str, list[int]] = {name: [] for name in self.position}
        self.names: list[frozenset[str]] = [statement_reads(s) for s in self.body]
        for i, s in enumerate(self.body):
            if type(s) in (Let, Store):  # a trig block's angles are never flipped (above)
                for name in self.names[i]:
                    while True:  # a copy's reader reads what it copies (a copy of a copy: down the chain)
                        if name in self.users:
                            self.users[name].append(i)
                        alias = self.alias_of.get(name)
                        if alias is None:
                            break
                        name = alias.name
        self.flipped: set[str] = set()
        self.info: dict = {}  # sum or product -> the locals it reads (None: not plain), and memoised normal forms
        self.memo: dict = {}
        # per statement: the negations it pays and the negated copies (aliases) it reads; a copy costs its
        # one negation while anything reads it
        self.cost: list[int] = []
        self.reads: list[frozenset] = []
        self.unflipped: dict[int, object] = {}  # statement -> as written with no flip (kept for written())
        # settled with no flip (_settled): then it stays so while it reads no flipped local (its reads include what
        # _settled does not look into, which only makes the test stricter)
        self.settled = [type(s) in (Let, Store) and _settled(s.value, self.alias_of) for s in self.body]
        for i in range(len(self.body)):
            paid, reads = self.price(i)
            self.cost.append(paid)
            self.reads.append(reads)
        # the search's clock: when each statement last changed, each local was last tried, a copy last came or went
        self.clock, self.copies_at = 0, 0
        self.changed_at = [0] * len(self.body)
        self.tried_at: dict[str, int] = {}
        self.readers: dict[str, int] = {u: 0 for u in self.alias_of}
        for reads in self.reads:
            for u in reads:
                self.readers[u] += 1

    def price(self, i: int) -> tuple[int, frozenset]:
        """``(negations, aliases read)`` of statement ``i`` under the current flips."""
        s = self.body[i]
        unflipped = type(s) is Store or (type(s) is Let and s.var.name not in self.flipped)
        if unflipped and self.settled[i] and self.names[i].isdisjoint(self.flipped):
            return 0, frozenset()
        s, paid = self.statement(i)
        if not self.flipped:
            self.unflipped[i] = s
        if type(s) not in (Let, Store) or (type(s) is Let and s.var.name in self.alias_of):
            return 0, frozenset()
        return paid, statement_reads(s) & self.alias_of.keys()

    # -- one statement under the current flips -------------------------------------------------------
    def statement(self, i: int):
        """``(statement, negations)`` of statement ``i`` written with the current flips."""
        s = self.body[i]
        t = type(s)
        if t is Let:
            if s.var.name in self.alias_of:
                return s, 1  # priced by its readers (price)
            sign, e, inside = self.normal(s.value, i)
            if s.var.name in self.flipped:
                sign = -sign
            value, paid = self.materialise(sign, e, i)
            return Let(s.var, value), inside + paid
        if t is Store:
            sign, e, inside = self.normal(s.value, i)
            value, paid = self.materialise(sign, e, i)
            return Store(s.output, s.index, value), inside + paid
        return s, 0

    def normal(self, e, at: int):
        """``(sign, e', negations)``: ``e`` as ``sign * e'`` with the sign pulled out as far as it goes for
        free, and the negations paid inside ``e'`` (where a child must carry its own sign: an argument of a
        call, a denominator)."""
        t = type(e)
        if t is Var:
            alias = self.alias_of.get(e.name)
            if alias is not None:
                sign, x, paid = self.normal(alias, at)
                return -sign, x, paid
            return (-1 if e.name in self.flipped else 1), e, 0
        if t is Const:
            if e.type is Type.REAL and e.value < 0:
                return -1, Const(-e.value), 0
            return 1, e, 0
        if t is Neg:
            sign, x, paid = self.normal(e.x, at)
            return -sign, x, paid
        if t is Mul or t is Add:
            info = self.info.get(e)
            if info is None:
                info = self.info[e] = self._plain_names(e)
            if info is not None:  # memoised by the flips among the locals it reads
                key = (e, info & self.flipped) if info else e
                found = self.memo.get(key)
                if found is None:
                    found = self.memo[key] = self._normal_sum_or_product(e, at)
                return found
            return self._normal_sum_or_product(e, at)
        return self._normal_other(e, at)

    def _plain_names(self, e) -> frozenset | None:
        """The flippable locals a sum or product of plain parts (variables, elements, numbers, negations, sums,
        products) reads, through copies; ``None`` where it has another part (its form may depend on where it is)."""
        names, stack = set(), [e]
        while stack:
            x = stack.pop()
            t = type(x)
            if t is Var:
                name = self._copied(x.name)
                if name in self.position:
                    names.add(name)
            elif t is Add:
                stack.extend(x.terms)
            elif t is Mul:
                stack.extend(x.factors)
            elif t is Neg:
                stack.append(x.x)
            elif t is not Const and t is not Elem:
                return None
        return frozenset(names)

    def _normal_sum_or_product(self, e, at: int):
        t = type(e)
        if t is Mul:
            sign, factors, paid = 1, [], 0
            for f in e.factors:
                s, x, p = self.normal(f, at)
                sign *= s
                paid += p
                factors.append(x)
            return sign, Mul(tuple(factors)), paid
        if t is Add:
            parts = [self.normal(x, at) for x in e.terms]
            paid = sum(p for _, _, p in parts)
            if all(s < 0 for s, _, _ in parts):
                return -1, Add(tuple(x for _, x, _ in parts)), paid
            terms = [x if s > 0 else Neg(x) for s, x, _ in parts]
            first = next(k for k, (s, _, _) in enumerate(parts) if s > 0)
            if first:
                terms.insert(0, terms.pop(first))
            return 1, Add(tuple(terms)), paid

    def _normal_other(self, e, at: int):
        t = type(e)
        if t is Div:
            sign, num, paid = self.normal(e.num, at)
            den, p = self.written_out(e.den, at)
            return sign, Div(num, den, e.guarded), paid + p
        if t is Call1:
            x, p = self.written_out(e.x, at)
            return 1, Call1(e.function, x), p
        if t in (Call2, Compare):
            a, p = self.written_out(e.a, at)
            b, q = self.written_out(e.b, at)
            return 1, (Call2(e.function, a, b) if t is Call2 else Compare(e.op, a, b)), p + q
        if t is Select:
            c, r = self.written_out(e.cond, at)
            a, p = self.written_out(e.then, at)
            b, q = self.written_out(e.otherwise, at)
            return 1, Select(c, a, b), p + q + r
        if t is Logic:
            parts = [self.written_out(x, at) for x in e.terms]
            return 1, Logic(e.op, tuple(x for x, _ in parts)), sum(p for _, p in parts)
        if t is Not:
            x, p = self.written_out(e.x, at)
            return 1, Not(x), p
        return 1, e, 0  # array elements, named constants, integer expressions: no real local in them

    def written_out(self, e, at: int):
        """``(expr, negations)``: ``e`` with its own sign (:meth:`normal`, then :meth:`materialise`)."""
        sign, x, paid = self.normal(e, at)
        expr, p = self.materialise(sign, x, at)
        return expr, paid + p

    def materialise(self, sign: int, e, at: int):
        """``(expr, negations)``: ``sign * e`` written out where it must carry its own sign (the negations
        this adds; those inside ``e`` are :meth:`normal`'s)."""
        if sign > 0:
            return e, 0
        t = type(e)
        if t is Const:
            return Const(-e.value, e.type), 0
        if t is Mul:
            for k, f in enumerate(e.factors):
                if type(f) is Const and f.type is Type.REAL:
                    return Mul(e.factors[:k] + (Const(-f.value),) + e.factors[k + 1:]), 0
            for k, f in enumerate(e.factors):
                if type(f) is Var:
                    found = self.negation_of.get(f.name)
                    if found is not None and found[0] < at:
                        return Mul(e.factors[:k] + (found[1],) + e.factors[k + 1:]), 0
            return Neg(e), 1
        if t is Var:
            found = self.negation_of.get(e.name)
            if found is not None and found[0] < at:
                return found[1], 0
        if t is Add:  # each term's sign turns; where none is left positive, a number or a product led by one takes it
            terms = [x.x if type(x) is Neg else Neg(x) for x in e.terms]
            first = next((k for k, x in enumerate(terms) if type(x) is not Neg), None)
            if first is not None:
                return Add((terms[first],) + tuple(terms[:first] + terms[first + 1:])), 0
            for k, x in enumerate(e.terms):
                if type(x) is Const and x.type is Type.REAL:
                    lead = Const(-x.value)
                elif type(x) is Mul and type(x.factors[0]) is Const and x.factors[0].type is Type.REAL:
                    lead = Mul((Const(-x.factors[0].value),) + x.factors[1:])
                else:
                    continue
                return Add((lead,) + tuple(terms[:k] + terms[k + 1:])), 0
            return Add(tuple(terms)), 1
        return Neg(e), 1

    # -- the search ------------------------------------------------------------------------------------
    def _evaluate(self, name: str) -> tuple[dict, dict, int]:
        """Flip ``name`` and price what that changes: the new prices of its statements, the new reader counts of
        the copies, and the change in negations (the flip stays made; :meth:`_commit` or flip back)."""
        affected = [self.position[name]] + self.users[name]
        self.clock += 1
        self.flipped ^= {name}
        new = {i: self.price(i) for i in affected}
        readers = {}
        for i, (_, reads) in new.items():
            for u in self.reads[i] - reads:
                readers[u] = readers.get(u, self.readers[u]) - 1
            for u in reads - self.reads[i]:
                readers[u] = readers.get(u, self.readers[u]) + 1
        delta = sum(c - self.cost[i] for i, (c, _) in new.items())
        delta += sum(bool(n) - bool(self.readers[u]) for u, n in readers.items())
        return new, readers, delta

    def _commit(self, new: dict, readers: dict) -> None:
        for i, (c, reads) in new.items():
            self.cost[i], self.reads[i] = c, reads
            self.changed_at[i] = self.clock
        if any(bool(n) != bool(self.readers[u]) for u, n in readers.items()):
            self.copies_at = self.clock  # a copy is now read or unread: every price that reads it moved
        self.readers.update(readers)

    def try_flip(self, name: str) -> bool:
        """Flip ``name`` if that lowers the negations; say whether it did."""
        affected = [self.position[name]] + self.users[name]
        if len(affected) > MOST_READERS or not any(self._pays(i) for i in affected):
            return False  # nothing there pays a negation: a flip can only add some
        tried = self.tried_at.get(name)
        if tried is not None and tried >= self.copies_at and all(self.changed_at[i] <= tried for i in affected):
            return False  # refused before, and nothing it depends on has moved since
        new, readers, delta = self._evaluate(name)
        self.tried_at[name] = self.clock
        if delta < 0:
            self._commit(new, readers)
            return True
        self.flipped ^= {name}
        return False

    def greedy(self) -> None:
        for _ in range(PASSES):
            changed = False
            for name in reversed(self.flippable):
                changed |= self.try_flip(name)
            if not changed:
                break

    def _suspects(self, i: int) -> list[str]:
        """The locals whose flip may move the negation statement ``i`` pays on: its own (a flip hands the sign to its
        readers), then those it reads (a flip there can make a term of its sum positive); where it pays none but is a
        negated copy ``u = -x`` (``T[2] = u``), ``x`` (a flip of ``x`` can leave the copy unread)."""
        s = self.body[i]
        if not self.cost[i]:  # a stored output or local that is a copy: T[2] = u
            copied = self._copied(s.value.name) if type(s) in (Let, Store) and type(s.value) is Var else None
            return [copied] if copied in self.chaseable else []
        own = [s.var.name] if type(s) is Let and s.var.name in self.chaseable else []
        return own + [n for n in sorted(self.names[i]) if n in self.chaseable]

    def _pays(self, i: int) -> bool:
        """Whether statement ``i`` pays a negation or reads a negated copy (which pays one while it is read)."""
        return bool(self.cost[i] or self.reads[i])

    def _copied(self, name: str) -> str:
        """The local a copy ``u = -x`` (of a copy ...) stores the negation of; ``name`` itself if it is no copy."""
        while name in self.alias_of:
            name = self.alias_of[name].name
        return name

    def _work(self, name: str) -> int:
        """What a flip of ``name`` re-prices: its statement and its readers, each by the names it reads."""
        return sum(1 + len(self.names[i]) for i in [self.position[name]] + self.users[name])

    def _next_flip(self, last: dict, changed: set[int], taken: list[str]) -> tuple[str | None, int]:
        """The chase's next flip: of the suspects of the statements that the ``last`` flip re-priced and that now pay
        (where none does, of those the chain's earlier flips re-priced, ``changed``; in body order, at most
        CHASE_OPTIONS), the one whose flip costs least; and the work of the tries (:meth:`_work`)."""
        paying = [i for i in sorted(last) if self._pays(i)]
        if not paying:  # nothing the last flip moved pays: what an earlier flip of the chain left paying
            paying = [i for i in sorted(changed - last.keys()) if self._pays(i)]
        options = dict.fromkeys(n for i in paying for n in self._suspects(i) if n not in taken)
        best, least, work = None, 0, 0
        for name in list(options)[:CHASE_OPTIONS]:
            delta = self._evaluate(name)[2]
            self.flipped ^= {name}  # tried only: flipped back (_evaluate committed nothing)
            work += self._work(name)
            if best is None or delta < least:
                best, least = name, delta
        return best, work

    def chase(self) -> bool:
        """Chains of flips that no single flip makes: flipping a local moves a negation its statement pays to a
        reader, flipping that one or a local it reads moves it on, until a subtraction or another sign absorbs it
        (TALOS's arm: ``T[2] = -t34``, ``T[6] = -t36`` and ``t41 = t34*t37 - t35*t36`` lose both negations when
        ``t34``, ``t36`` and ``t17``, which ``t36`` reads, are flipped, each flip alone saving nothing). From each
        local where a negation is paid or copied, take at each step the cheapest of the next suspects (those of what
        the last flip left paying, else of what an earlier flip of the chain did: the simple humanoid's
        ``T[6] = -t31``, ``T[10] = -t33``), flipping even where it costs, up to CHASE_DEPTH flips and while the
        chain is within one negation of its best; keep the best prefix if it saves, else flip back. Say whether
        any saved."""
        saved = False
        budget = CHASE_BUDGET * sum(1 + len(names) for names in self.names)
        starts = [n for i in range(len(self.body)) if self._pays(i) for n in self._suspects(i)]
        for start in dict.fromkeys(starts):
            taken: list[str] = []
            touched: set[int] = set()  # the statements the chain's flips re-priced
            total = best = best_length = 0
            name: str | None = start
            while name is not None and len(taken) < CHASE_DEPTH and budget > 0 and total <= best + 1:
                budget -= self._work(name)
                new, readers, delta = self._evaluate(name)
                self._commit(new, readers)
                taken.append(name)
                touched.update(new)
                total += delta
                if total < best:
                    best, best_length = total, len(taken)
                name, work = self._next_flip(new, touched, taken)
                budget -= work
            for undo in reversed(taken[best_length:]):
                self._commit(*self._evaluate(undo)[:2])
            saved |= best < 0
        return saved

    def search(self) -> None:
        self.greedy()
        self.chaseable = {n for n in self.flippable if len(self.users[n]) <= CHASE_READERS}
        if self.chase():
            self.greedy()

    def written(self) -> tuple[tuple, int, int]:
        """The body with the flips applied, copies no longer read dropped, and the negations that the
        statements it changed or dropped paid before and pay now (as :mod:`.count` counts them)."""
        # a statement with no sign in it (no negation, negative literal, copy or flipped local) stays as it is;
        # one that reads no flipped local (nor is one) is as the search first wrote it
        moved = {self.position[name] for name in self.flipped}
        for name in self.flipped:
            moved.update(self.users[name])
        out = list(self.body)
        names = list(self.names)
        before = after = 0
        for i, s in enumerate(self.body):
            new = self.statement(i)[0] if i in moved else self.unflipped.get(i)
            if new is None or new == s:
                continue
            out[i] = new
            names[i] = statement_reads(new)
            before += _negations(s)
            after += _negations(new)
        read: set[str] = set()
        kept = []
        for i in reversed(range(len(out))):
            s = out[i]
            if type(s) is Let and s.var.name not in read and s.var.name in self.alias_of:
                after -= _negations(s)  # a negation nothing reads any more
                continue
            read |= names[i]
            kept.append(s)
        return tuple(reversed(kept)), before, after


def _negations(s) -> int:
    """Negations statement ``s`` pays (:mod:`.count`'s rules)."""
    return count_ops((s,)).neg


@lru_cache(maxsize=1 << 16)
def _opaque_reads(e) -> frozenset[str]:
    """The names read inside array indices, casts and bit operations of ``e`` (remembered: the functions of one
    derivation share most statements)."""
    out: set[str] = set()
    stack = [e]
    while stack:
        x = stack.pop()
        if type(x) in (Elem, Cast, Bits):
            expr_names(x, out)
        else:
            stack.extend(children(x))
    return frozenset(out)


def _settled(e, aliases: dict) -> bool:
    """Whether :meth:`_Signs.normal` with no flip leaves ``e`` as it is: sign +1, the same tree, nothing paid. So
    it is where no sign is anywhere (no negated copy, no negative literal) but subtractions: a sum whose
    first term is added and each other term added or subtracted (``a - b + c``), of such parts. Such a statement
    pays nothing and reads no copy, as :meth:`_Signs.statement` would find at more cost (most statements of a
    body are such sums)."""
    t = type(e)
    if t is Var:
        return e.name not in aliases
    if t is Const:
        return not (e.type is Type.REAL and e.value < 0)
    if t is Add:
        terms = e.terms
        return type(terms[0]) is not Neg and all(_settled(x.x if type(x) is Neg else x, aliases) for x in terms)
    if t is Neg:
        return False
    if t in _WRITTEN_AS_THEY_ARE:
        return True
    return all(_settled(x, aliases) for x in children(e))


_WRITTEN_AS_THEY_ARE = (Elem, NamedConst, Cast, Bits)
"""Parts :meth:`_Signs.normal` returns untouched, whatever they hold (an array index, a cast, bit operations)."""


def settle_signs(body: Sequence) -> tuple:
    """``body`` with each real local stored in the sign that leaves the fewest negations (see the module
    docstring); the same statements otherwise. Bodies with control flow come back as they are."""
    if not all(type(s) in (Let, TrigBlock, Store) for s in body):
        return tuple(body)
    signs = _Signs(body)
    signs.search()
    if not signs.flipped and not signs.alias_of:
        return tuple(body)
    written, before, after = signs.written()
    return written if after <= before else tuple(body)
