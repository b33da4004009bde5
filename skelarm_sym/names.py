"""Names the emitted code reserves: C and C++ keywords, the math functions it calls, its inputs.

Shared by everything that turns user text into C identifiers (prefixes, robot names, parameter
names), so that a name accepted by a loader is never refused, or miscompiled, later.
"""

from __future__ import annotations

import keyword
import re

C_RESERVED = frozenset(
    """auto break case char const continue default do double else enum extern float for goto if inline int long
    register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while
    _Bool _Complex _Imaginary _Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert _Thread_local
    alignas alignof and bool catch class compl constexpr decltype delete explicit export false friend mutable
    namespace new noexcept not nullptr operator or private protected public template this throw true try typeid
    typename using virtual wchar_t xor asm main errno math sin cos sqrt""".split()
)
"""Words a prefix or name may not be: C99 and C++ keywords, and names the emitted code itself relies on."""

_INPUT = re.compile(r"params|d{0,2}q\d*|lambda|xi_\w*|nu_\w*|RANK_TOL")
"""Names of the SymPy symbols the derivations create for their inputs (``q1``, ``dq3``, ``lambda``,
the twist's ``xi_vx`` ...): a parameter of the same name would be the same symbol."""


def reserved_name(name: str) -> bool:
    """True when ``name`` may not name a robot or a parameter: a keyword (C, C++ or Python), a name the
    emitted code relies on, or the name of an input's symbol (``q``, ``q1``, ``params``, ``lambda``, ...)."""
    return name in C_RESERVED or keyword.iskeyword(name) or bool(_INPUT.fullmatch(name))
