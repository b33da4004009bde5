"""Names the emitted code reserves: C and C++ keywords, the math functions it calls, its inputs.

Shared by everything that turns user text into C identifiers (prefixes, robot names, parameter
names), so that a name accepted by a loader is never refused, or miscompiled, later.
"""

from __future__ import annotations

import keyword
import re
import sys
import unicodedata

from .errors import InputError

C_RESERVED = frozenset(
    """auto break case char const continue default do double else enum extern float for goto if inline int long
    register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while
    _Bool _Complex _Imaginary _Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert _Thread_local
    alignas alignof and bool catch class compl constexpr decltype delete explicit export false friend mutable
    namespace new noexcept not nullptr operator or private protected public template this throw true try typeid
    typename using virtual wchar_t xor asm main errno math sin cos sqrt""".split()
)
"""Words a prefix or name may not be: C99 and C++ keywords, and names the emitted code itself relies on."""

C_HEADERS = frozenset(
    """assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal stdalign stdarg
    stdatomic stdbool stddef stdint stdio stdlib stdnoreturn string tgmath threads time uchar wchar wctype
    features
    aio alloca arpa byteswap cpio dirent dlfcn endian err error execinfo fcntl fnmatch ftw getopt glob grp iconv
    langinfo libgen link malloc memory monetary mqueue ndbm netdb nl_types poll pthread pwd regex sched search
    semaphore spawn strings stropts syslog tar termios ucontext ulimit unistd utime utmpx values wordexp
    immintrin x86intrin xmmintrin emmintrin pmmintrin tmmintrin smmintrin nmmintrin wmmintrin ammintrin avxintrin
    avx2intrin intrin arm_neon arm_sve omp python pyconfig windows cuda cuda_runtime
    mm_malloc mm3dnow cpuid arm_acle arm_fp16 arm_bf16 winsock2 io process mpi zlib cuda_fp16 vector_types""".split()
)
"""Names of system headers: the standard C headers (C99 and C11), glibc's ``features.h`` (which ``<math.h>``
includes), POSIX's and glibc's, the compilers' intrinsics, Python's, OpenMP's, Windows' and CUDA's main ones. A file
``{name}.h`` in a folder on the include path is read for the system header of its name (``<stddef.h>``, which the
emitted header includes) or hides it from the user's own code (``-Ibuild`` and the CMake target's include folder put
it there). Compared in lower case (a file system may not tell ``Stddef.h`` from ``stddef.h``)."""


def standard_header(name: str) -> bool:
    """True when ``{name}.h`` is, or on a case-insensitive file system would be, a system header's file name
    (:data:`C_HEADERS`, or a compiler's ``*intrin.h``, which ``<immintrin.h>`` and its kin include)."""
    return name.lower() in C_HEADERS or name.lower().endswith("intrin")


_INPUT = re.compile(r"params|d{0,2}q\d*|lambda|xi_\w*|nu_\w*|RANK_TOL")
"""Names of the SymPy symbols the derivations create for their inputs (``q1``, ``dq3``, ``lambda``,
the twist's ``xi_vx`` ...): a parameter of the same name would be the same symbol."""

_DERIVATION_SYMBOL = re.compile(r"target\d*|lock(_[cs])?|_\w*")
"""More names of SymPy symbols a chain's derivations create: the closed-form IK's target entries (``target0`` to
``target15``) and lock (``lock``, ``lock_c``, ``lock_s``), and every intermediate step (``_ch_c1``, ``_angle_0``:
all start with ``_``). A parameter of the same name would be the same symbol, and the code built from it wrong."""


def derivation_symbol(name: str) -> bool:
    """True when ``name`` is (or has the form of) a symbol a chain's derivation makes itself: not a parameter's name."""
    return bool(_DERIVATION_SYMBOL.fullmatch(name))


IMPORTED_MODULES = ("numpy", "np", "torch", "jax", "jaxlib", "cupy")
"""Modules the emitted Python imports (NumPy as ``np``; PyTorch, JAX, CuPy): a ``{prefix}.py`` of one of these names
beside the others would be imported in its place (``torch.py`` made ``torch_torch.py`` fail: no ``torch.float64``)."""


def reserved_prefix(name: str) -> bool:
    """True when ``name`` may not be the files' prefix: a C, C++ or Python keyword or a name the emitted code
    relies on, or ``numpy``/``np`` (the NumPy module's own import). (A Python standard module's name, or another
    module the emitted Python imports, :data:`IMPORTED_MODULES`, is refused only where a ``.py`` file is written.)"""
    return name in C_RESERVED or keyword.iskeyword(name) or name.lower() in ("numpy", "np")


CMAKE_RESERVED = frozenset(
    """all clean help install install_local install_strip list_install_components test package package_source depend
    edit_cache rebuild_cache all_build zero_check run_tests preinstall m""".split()
)
"""Target names CMake reserves or its generators make (compared in lower case: Visual Studio's ``ALL_BUILD`` and
``INSTALL``), and ``m``, the math library the target links."""
CMAKE_KEYWORDS = frozenset(
    """SHARED STATIC MODULE OBJECT INTERFACE ALIAS IMPORTED GLOBAL UNKNOWN EXCLUDE_FROM_ALL PROPERTIES PUBLIC PRIVATE
    BEFORE AFTER SYSTEM EXPORT ARCHIVE LIBRARY RUNTIME OBJECTS FRAMEWORK BUNDLE PRIVATE_HEADER PUBLIC_HEADER RESOURCE
    INCLUDES FILE_SET CXX_MODULES_BMI DESTINATION PERMISSIONS CONFIGURATIONS COMPONENT NAMELINK_ONLY NAMELINK_SKIP
    OPTIONAL LINK_PRIVATE LINK_PUBLIC LINK_INTERFACE_LIBRARIES""".split()
)
"""Keywords of the commands the CMakeLists.txt passes the target to (add_library, set_target_properties,
target_include_directories, target_link_libraries, install): a target of that name is read as the keyword."""


def cmake_reserved(name: str) -> bool:
    """True when CMake cannot take ``name`` as the library target's name: a target it reserves or makes
    (:data:`CMAKE_RESERVED`, any case), a keyword of the commands the target is passed to (:data:`CMAKE_KEYWORDS`), or
    ``CMAKE``/``CMAKE_*`` (its variables would be CMake's own)."""
    upper = name.upper()
    return name.lower() in CMAKE_RESERVED or name in CMAKE_KEYWORDS or upper == "CMAKE" or upper.startswith("CMAKE_")


PYTHON_MODULES = frozenset(sys.stdlib_module_names) | {"test"}
"""Python's standard modules (``sys.stdlib_module_names``, which leaves out the regression-test package ``test``
that CPython installs): a ``{prefix}.py`` of one of these names would shadow it."""


def unusable_default(name: str) -> bool:
    """True when a robot's name or file name cannot be its files' default prefix in some output: a reserved
    prefix (:func:`reserved_prefix`), a Python standard module, a module the emitted Python imports, a C system
    header, or a name CMake reserves (:func:`cmake_reserved`). Such a name gets ``_robot`` after it
    (:func:`identifier_from`), so that every language and ``--cmake`` take the default."""
    return (reserved_prefix(name) or name in PYTHON_MODULES or name.lower() in IMPORTED_MODULES or standard_header(name)
            or cmake_reserved(name))


def reserved_name(name: str) -> bool:
    """True when ``name`` may not name a robot or a parameter: a keyword (C, C++ or Python), a name the
    emitted code relies on, or the name of an input's symbol (``q``, ``q1``, ``params``, ``lambda``, ...)."""
    return name in C_RESERVED or keyword.iskeyword(name) or bool(_INPUT.fullmatch(name))


REFUSED_CATEGORIES = frozenset({"Cc", "Cf", "Cs", "Zl", "Zp"})
"""Unicode categories refused in robot-file text: controls (Cc: newline, tab, NUL, DEL...), format
characters (Cf: the bidi controls U+202A-202E and U+2066-2069, U+200E/F, zero-width characters, the
BOM...), surrogates (Cs) and the line and paragraph separators U+2028/9 (Zl, Zp). Everything else is
printable data."""

BIDI_CONTROLS = frozenset("\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")
"""The characters that reorder displayed text (Trojan Source): refused in paths, where other format characters
(U+200C and U+200D, which Persian and emoji need) are not."""


def path_argument(text: str) -> str:
    """A file or folder named on the command line, unchanged; InputError where it holds a control character (a
    newline in a file name forged output lines, an ESC sequence drove the terminal), a line or paragraph separator or
    a bidirectional control. A byte that is not UTF-8 (kept by Python as a surrogate) is accepted and printed as an
    escape; other format characters are printed as escapes."""
    for ch in text:
        if unicodedata.category(ch) in ("Cc", "Zl", "Zp") or ch in BIDI_CONTROLS:
            raise InputError(f"{quoted(text)} holds a control or format character ({ch!r}): name a file without one")
    return text


def ascii_number(text: str) -> str:
    """``text`` for ``int``/``float`` where it is written in ASCII without ``_``; ValueError otherwise (Python reads
    ``"٢"`` as 2 and ``"1_0"`` as 10, which a command line recorded as ``--lengths 10.0,2.0`` from ``1_0,٢``)."""
    if not text.isascii() or "_" in text:
        raise ValueError(f"not a plain number: {text!r}")
    return text


def path_option(text: str) -> str:
    """argparse ``type`` of the options that name a file or folder: :func:`path_argument`'s check, its message as
    the option's error."""
    import argparse

    try:
        return path_argument(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


QUOTED_LENGTH = 80
"""Foreign text longer than this is shortened (with its length) when an error message quotes it."""


def quoted(text: str, limit: int = QUOTED_LENGTH) -> str:
    """``repr(text)`` for a one-line error message: every control character escaped, and text longer
    than ``limit`` characters cut to its first ``limit`` with ``... (N characters)`` after it."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text)} characters)"


def check_printable(text: str, what: str, kind: str = "names") -> str:
    """``text`` unchanged when it holds no character of :data:`REFUSED_CATEGORIES`, else InputError.

    The one rule for foreign text that reaches emitted code or a terminal (URDF robot, link and joint
    names, a TOML file's ``name``, ``description`` and joint names, the ``--base``/``--tip`` link names):
    such text is data, escaped by the printers, but a newline, a NUL or a bidi override is refused here,
    where the error can name it. Quotes, ``*/``, ``\"\"\"``, ``#``, ``$``, backslashes, ``??/`` and
    non-ASCII letters pass. The message is one line: ``{what} {text!r} holds the control character
    U+XXXX (ITS NAME); robot-file {kind} must be printable text`` (the text quoted by :func:`quoted`,
    which escapes every refused character). The caller adds the file.
    """
    if text.isprintable():  # the usual case, at C speed: no character of the refused categories
        return text
    for position, char in enumerate(text):
        if unicodedata.category(char) in REFUSED_CATEGORIES:
            label = unicodedata.name(char, "")
            named = f" ({label})" if label else ""
            at = f" at character {position + 1}" if len(text) > QUOTED_LENGTH else ""
            if 0xDC80 <= ord(char) <= 0xDCFF:  # a byte that is not UTF-8, as Python keeps it from a command line
                raise InputError(f"{what} {quoted(text)} holds the byte 0x{ord(char) - 0xDC00:02X}{at}, which is not "
                                 f"UTF-8; robot-file {kind} must be UTF-8 text")
            raise InputError(
                f"{what} {quoted(text)} holds the control character U+{ord(char):04X}{named}{at}; "
                f"robot-file {kind} must be printable text"
            )
    return text


IDENTIFIER_LENGTH = 48
"""Longest prefix or robot name (the emitted C names add at most ``_manipulability_gradient`` to it)."""


def identifier_from(text: str | None) -> str | None:
    """A readable C identifier and Python module name made from ``text`` (a file name's stem, a robot
    name), or None when ``text`` has no ASCII letter or digit.

    Case is kept as written; every run of characters other than ASCII letters and digits (``_``, ``-``,
    spaces, dots, non-ASCII letters) becomes one ``_``, and ``_`` at either end is dropped; a name that starts with a digit gets
    ``robot_`` before it; the result is cut to :data:`IDENTIFIER_LENGTH` characters; a reserved word
    (:func:`reserved_name`) or a name no output can take as a prefix (:func:`unusable_default`: a Python standard
    module such as ``test`` or ``code``, ``numpy``, ``torch``, a standard C header's name such as ``stddef``, a CMake
    target name such as ``install``) gets ``_robot`` after it. ``"xarm7"`` -> ``xarm7``, ``"ur5 (copy)"`` -> ``ur5_copy``,
    ``"2dof"`` -> ``robot_2dof``, ``"double"`` -> ``double_robot``.
    """
    name = re.sub(r"[^A-Za-z0-9]+", "_", text or "").strip("_")
    if not name:
        return None
    if name[0].isdigit():
        name = "robot_" + name
    name = name[:IDENTIFIER_LENGTH].rstrip("_")
    if reserved_name(name) or unusable_default(name):
        name = name[: IDENTIFIER_LENGTH - len("_robot")].rstrip("_") + "_robot"
        if cmake_reserved(name):  # CMAKE_*: still CMake's own variables
            name = "robot_" + name[: IDENTIFIER_LENGTH - len("robot_")]
    return name
