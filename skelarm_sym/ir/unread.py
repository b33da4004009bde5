"""The last per-function pass: a straight-line body without the locals nothing reads.

The products pass (:mod:`.products`) rewrites a statement to read a product another local already holds; the
local the statement read before can then be read by nothing (a 2-joint chain's ``manipulability_gradient`` kept
one, which C compilers report as an unused variable). Such a :class:`~.nodes.Let` is dropped, and so, in turn,
are the locals only it read. Trigonometry blocks and output stores stay: they are what the function is for.
"""

from __future__ import annotations

from typing import Sequence

from .nodes import Let, Store, TrigBlock
from .walk import statement_reads


def drop_unread(body: Sequence) -> tuple:
    """``body`` (straight-line: lets, trigonometry blocks, stores) without the lets nothing after them reads.

    Read from the last statement back, so that a let read only by a dropped one goes too; any other body
    comes back as it is."""
    if not all(type(s) in (Let, TrigBlock, Store) for s in body):
        return tuple(body)
    read: set[str] = set()
    kept: list = []
    for s in reversed(body):
        if type(s) is Let and s.var.name not in read:
            continue
        read.update(statement_reads(s))
        kept.append(s)
    if len(kept) == len(body):
        return tuple(body)
    return tuple(reversed(kept))
