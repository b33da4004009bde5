"""Text that is data (robot-file names and descriptions, paths, commands) made safe for each kind of
comment or string it is printed into. Every template prints such text through these functions.

The rule is the same everywhere: the output holds printable ASCII only. Any other character (a
control character, a Unicode bidi control, a non-ASCII letter) becomes ``\\uXXXX`` (or
``\\UXXXXXXXX``), a backslash becomes ``\\\\``, and each comment syntax gets its own escapes for the
sequences that could end the comment or change how the compiler reads it: in C, ``*/`` and ``/*``
(end or nest a comment) and ``??`` (a trigraph); in a Python string, ``"``; in CMake and Python line
comments nothing else is needed, since no newline survives. :func:`unescape` reverses every form,
so a command recorded in a header can be read back exactly.
"""

from __future__ import annotations

import re


def _ascii(text: str) -> str:
    """Backslashes doubled; every character outside printable ASCII as ``\\uXXXX`` / ``\\UXXXXXXXX``."""
    out = []
    for ch in str(text):
        code = ord(ch)
        if ch == "\\":
            out.append("\\\\")
        elif 32 <= code < 127:
            out.append(ch)
        elif code <= 0xFFFF:
            out.append(f"\\u{code:04X}")
        else:
            out.append(f"\\U{code:08X}")
    return "".join(out)


_TRIGRAPH = re.compile(r"\?(?=\?)")


def c_comment(text: str) -> str:
    """``text`` for one line inside a C block comment: nothing in it can end or nest the comment,
    form a trigraph or a line splice, or carry a character the compiler warns about."""
    return _TRIGRAPH.sub("?\\\\", _ascii(text).replace("*/", "*\\/").replace("/*", "/\\*"))


def py_string(text: str) -> str:
    """``text`` for inside a Python ``\"\"\"`` string (a docstring): no quote or backslash can end it."""
    return _ascii(text).replace('"', '\\"')


def line_comment(text: str) -> str:
    """``text`` for a ``#`` line comment (Python, CMake): one line of printable ASCII."""
    return _ascii(text)


_ESCAPE = re.compile(r"\\(u[0-9A-Fa-f]{4}|U[0-9A-Fa-f]{8}|.)", re.S)


def unescape(text: str) -> str:
    """The text that :func:`c_comment`, :func:`py_string` or :func:`line_comment` turned into ``text``."""

    def one(match: re.Match) -> str:
        code = match.group(1)
        if code[0] in "uU" and len(code) > 1:
            return chr(int(code[1:], 16))
        return code

    return _ESCAPE.sub(one, text)
