"""skelarm_sym.names: the one rule for foreign text (check_printable), error quoting and the
identifier made from a file name or robot name (identifier_from)."""

from __future__ import annotations

from pathlib import Path

import pytest

from skelarm_sym.errors import InputError
from skelarm_sym.names import IDENTIFIER_LENGTH, check_printable, identifier_from, quoted, reserved_name

PRINTABLE = [
    'x */ __attribute__((constructor)) void f(void){} /*',
    '"""; __import__("os").system("touch pwned"); """',
    "#[[ bracket ]] ${CMAKE_COMMAND} $(id) `id`",
    "back\\slash \\\\ ??/ ??= ??' %s %n {0}",
    "Gelenk_ä θ₂ 関節 'single' \"double\"",
    "no-break\u00a0space and ideographic\u3000space",  # Zs: printable spacing, escaped as data
]


@pytest.mark.parametrize("text", PRINTABLE)
def test_printable_hostile_text_is_data(text):
    assert check_printable(text, "link name") is text


@pytest.mark.parametrize(
    "text, code, label",
    [
        ("a\nb", "U+000A", ""),
        ("a\rb", "U+000D", ""),
        ("a\tb", "U+0009", ""),
        ("a\x00b", "U+0000", ""),
        ("a\x7fb", "U+007F", ""),
        ("a\x85b", "U+0085", ""),  # NEL: a line break to some readers
        ("a\u202eb", "U+202E", " (RIGHT-TO-LEFT OVERRIDE)"),
        ("a\u202ab", "U+202A", " (LEFT-TO-RIGHT EMBEDDING)"),
        ("a\u2066b", "U+2066", " (LEFT-TO-RIGHT ISOLATE)"),
        ("a\u2069b", "U+2069", " (POP DIRECTIONAL ISOLATE)"),
        ("a\u200eb", "U+200E", " (LEFT-TO-RIGHT MARK)"),
        ("a\u200fb", "U+200F", " (RIGHT-TO-LEFT MARK)"),
        ("a\u200bb", "U+200B", " (ZERO WIDTH SPACE)"),
        ("a\u200db", "U+200D", " (ZERO WIDTH JOINER)"),
        ("\ufeffab", "U+FEFF", " (ZERO WIDTH NO-BREAK SPACE)"),
        ("a\u2028b", "U+2028", " (LINE SEPARATOR)"),
        ("a\u2029b", "U+2029", " (PARAGRAPH SEPARATOR)"),
        ("a\ud800b", "U+D800", ""),  # a lone surrogate cannot even be written as UTF-8
    ],
)
def test_control_format_and_separator_characters_are_refused(text, code, label):
    with pytest.raises(InputError) as info:
        check_printable(text, "link name")
    message = str(info.value)
    assert message == f"link name {text!r} holds the control character {code}{label}; robot-file names must be printable text"
    assert message.isprintable()  # one line, and no refused character reaches the terminal


def test_a_byte_that_is_not_utf8_is_named_as_such(tmp_path, capsys):
    """A probe: ``--tip $'\\xff\\xfe'`` said the tip "holds the control character U+DCFF" (Python keeps an undecodable
    byte of a command line as a surrogate); it is a byte that is not UTF-8, and the message now says so."""
    import os

    from skelarm_sym.cli import main

    with pytest.raises(InputError) as info:
        check_printable("ab\udcff", "tip link")
    assert str(info.value) == "tip link 'ab\\udcff' holds the byte 0xFF, which is not UTF-8; robot-file names must be UTF-8 text"
    tip = os.fsdecode(b"\xff\xfe")
    robot = Path(__file__).resolve().parents[1] / "examples" / "robots" / "ur5.urdf"
    assert main(["generate", "--robot", str(robot), "--tip", tip, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "holds the byte 0xFF, which is not UTF-8" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_the_kind_of_text_ends_the_message_and_long_text_is_shortened():
    text = "d" * 300 + "\n" + "import os"
    with pytest.raises(InputError) as info:
        check_printable(text, "description", "descriptions")
    message = str(info.value)
    assert message == (
        f"description {'d' * 80!r}... (310 characters) holds the control character U+000A at character 301; "
        "robot-file descriptions must be printable text"
    )


def test_quoted():
    assert quoted("a\nb") == "'a\\nb'"
    assert quoted("x" * 80) == repr("x" * 80)
    assert quoted("x" * 81) == repr("x" * 80) + "... (81 characters)"
    assert quoted("abcdef", 3) == "'abc'... (6 characters)"


@pytest.mark.parametrize(
    "text, expected",
    [
        ("xarm7", "xarm7"),
        ("UR5e", "UR5e"),  # case kept as written
        ("UF_ROBOT", "UF_ROBOT"),
        ("ur5 (copy)", "ur5_copy"),
        ("my-robot 2", "my_robot_2"),
        ("panda_arm_hand.urdf", "panda_arm_hand_urdf"),
        ("__x__y__", "x_y"),
        ("2dof", "robot_2dof"),
        ("Gelenk-ä-arm", "Gelenk_arm"),
        ("double", "double_robot"),  # a C keyword
        ("class", "class_robot"),  # a C++ and Python keyword
        ("q1", "q1_robot"),  # the name of an input
        ("code", "code_robot"),  # a Python standard module: code.py would shadow it
        ("numpy", "numpy_robot"),
        ("torch", "torch_robot"),  # torch.py beside torch_torch.py was imported for PyTorch (a security review)
        ("JAX", "JAX_robot"),
        ("stddef", "stddef_robot"),  # a C system header: stddef.h would be read for <stddef.h>
        ("Features", "Features_robot"),  # glibc's <features.h>, which <math.h> includes (any case)
        ("unistd", "unistd_robot"),  # POSIX: -Ibuild made <unistd.h> the robot's header (a security review)
        ("immintrin", "immintrin_robot"),  # the compiler's intrinsics
        ("Python", "Python_robot"),  # Python.h, which the CPython extension includes
        ("a" * 60, "a" * IDENTIFIER_LENGTH),
        ("ロボット", None),
        ("", None),
        ("---", None),
        (None, None),
    ],
)
def test_identifier_from(text, expected):
    got = identifier_from(text)
    assert got == expected
    if got is not None:
        assert got.isidentifier() and got[0].isalpha() and len(got) <= IDENTIFIER_LENGTH and not reserved_name(got)


@pytest.mark.skipif(not __import__("shutil").which("cc"), reason="no C compiler")
def test_robots_named_after_c_headers_compile_with_their_folder_on_the_include_path(tmp_path):
    """A TOML robot named ``stddef`` and a URDF file ``stdio.urdf`` gave ``stddef.h`` and ``stdio.h``: with the
    folder on the include path (as its CMakeLists.txt and the README's build put it), the header's own
    ``#include <stddef.h>`` read itself (``unknown type name 'size_t'``), and a caller's ``<stdio.h>`` was the
    robot's. Their default prefixes now get ``_robot``."""
    import shutil
    import subprocess
    from pathlib import Path

    from skelarm_sym.generate import generate
    from skelarm_sym.models.chain.loader import load_robot

    robots = Path(__file__).resolve().parents[1] / "examples" / "robots"
    toml = tmp_path / "arm.toml"
    toml.write_text((robots / "scara.toml").read_text().replace('name = "scara"', 'name = "stddef"'))
    shutil.copy(robots / "ur5.urdf", tmp_path / "stdio.urdf")
    caller = tmp_path / "main.c"
    for chain, prefix in ((load_robot(toml), "stddef_robot"), (load_robot(tmp_path / "stdio.urdf", tip="tool0"), "stdio_robot")):
        out = tmp_path / prefix
        generate(chain, langs="c", out=out, functions="pose")
        assert sorted(p.name for p in out.iterdir()) == [f"{prefix}.c", f"{prefix}.h"]
        caller.write_text(f'#include <stdio.h>\n#include "{prefix}.h"\nint main(void) {{ double q[8] = {{0}}, T[16];\n'
                          f'    {prefix}_pose(q, T); printf("%g\\n", T[15]); return 0; }}\n')
        built = subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", f"-I{out}", str(caller),
                                str(out / f"{prefix}.c"), "-o", str(tmp_path / "a.out"), "-lm"], capture_output=True, text=True)
        assert built.returncode == 0, built.stderr
        assert subprocess.run([str(tmp_path / "a.out")], capture_output=True, text=True).stdout == "1\n"
