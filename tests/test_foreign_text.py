"""Text from robot files is data (issue 16, items 1 and 2): every fixture under tests/fixtures/robots/ (pi/2
offsets written as 1.570796327, continuous, prismatic, mimic and fixed joints, hostile but printable names)
generates C that compiles with the strict flags under gcc and clang, a NumPy module that imports, and a
CMakeLists.txt; nothing written in a robot file runs, and no byte of it reaches the output unescaped."""

from __future__ import annotations

import ctypes
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym import reference
from skelarm_sym.build import STRICT_FLAGS, load_python
from skelarm_sym.generate import generate
from skelarm_sym.models.chain.loader import load_robot

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "robots"
FILES = sorted(p.name for p in FIXTURES.iterdir() if p.suffix in (".urdf", ".toml"))
COMPILERS = [cc for cc in ("gcc", "clang") if shutil.which(cc)]


def foreign_texts(chain) -> list[str]:
    """Every piece of robot-file text the model carries (names, description, loader options)."""
    texts = [chain.name, chain.description, *chain.coordinates, *(j.name for j in chain.joints)]
    texts += [value for _, value in chain.load_options]
    return [t for t in texts if t]


@pytest.fixture(scope="module", params=FILES)
def emitted(request, tmp_path_factory):
    path = FIXTURES / request.param
    chain = load_robot(path)
    out = tmp_path_factory.mktemp(path.stem)
    generated = generate(chain, langs="c,python", out=out, cmake=True, prefix="fixture", force=True)
    return chain, generated, out


def test_every_fixture_loads():
    assert {"ur_like.urdf", "ur_like.toml", "gantry_gripper.urdf", "hostile_names.urdf", "hostile_names.toml"} <= set(FILES)


def test_the_output_is_printable_ascii_with_no_foreign_text_raw(emitted):
    chain, generated, out = emitted
    for name, text in generated.sources.items():
        bad = sorted({ch for ch in text if not (32 <= ord(ch) < 127 or ch == "\n")})
        assert bad == [], (name, bad)
        # what could end a comment or string, form a trigraph or splice a line in this kind of file
        sequences = {".c": ("*/", "/*", "??", "\\"), ".h": ("*/", "/*", "??", "\\"), ".py": ('"', "\\"), ".txt": ()}
        for foreign in foreign_texts(chain):
            dangerous = any(s in foreign for s in sequences[Path(name).suffix]) or any(ord(ch) >= 127 for ch in foreign)
            if dangerous:
                assert foreign not in text, (name, foreign)
    c_text = generated.sources["fixture.c"] + generated.sources["fixture.h"]
    # no comment is ended early: every */ closes a /* opened on the same or an earlier line, none nests
    stripped = re.sub(r"/\*.*?\*/", "", c_text, flags=re.S)
    assert "*/" not in stripped and "/*" not in stripped
    assert "M_PI" not in c_text and "math.pi" not in generated.sources["fixture.py"]


@pytest.mark.parametrize("cc", COMPILERS)
def test_the_c_compiles_strictly_and_runs_nothing_on_load(emitted, cc, tmp_path):
    chain, generated, out = emitted
    library = tmp_path / "libfixture.so"
    marker = tmp_path / "pwned"
    result = subprocess.run([cc, *STRICT_FLAGS, "-O0", "-fPIC", "-shared", "-o", str(library), str(out / "fixture.c"), "-lm"],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[:2000]
    ctypes.CDLL(str(library))  # a planted constructor would run here
    assert not marker.exists()
    assert not any(p.name == "pwned" for p in Path(tmp_path).iterdir())


def test_the_python_imports_runs_nothing_and_agrees_with_the_reference(emitted, tmp_path, monkeypatch):
    chain, generated, out = emitted
    monkeypatch.chdir(tmp_path)
    module = load_python(generated.sources["fixture.py"], "fixture")
    assert not (tmp_path / "pwned").exists()
    assert isinstance(module.__doc__, str)
    for foreign in foreign_texts(chain):  # the docstring holds the text as data, unescaped again by Python
        if "\n" not in foreign and foreign in (chain.description, chain.name):
            assert foreign in module.__doc__ or chain.name == foreign
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.0, 1.0, (5, chain.n))
    params = rng.uniform(0.2, 1.2, len(chain.parameters))
    args = (params,) if chain.parameters else ()
    want = reference.chain_kinematics(chain.numeric(params if chain.parameters else None), q).T
    np.testing.assert_allclose(module.pose(q, *args), want, rtol=0, atol=1e-12)


def test_the_cmake_file_is_comments_and_commands_only(emitted):
    chain, generated, out = emitted
    text = generated.sources["CMakeLists.txt"]
    for line in text.splitlines():
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            assert not stripped.startswith(("#[[", "#[=")), line  # a bracket comment would span lines
            continue
        assert all(32 <= ord(ch) < 127 for ch in line)
    for foreign in foreign_texts(chain):
        if "${" in foreign or "#[[" in foreign:
            for line in text.splitlines():
                if foreign in line:
                    assert line.lstrip().startswith("# "), line


def test_a_file_name_reaches_the_terminal_escaped_or_is_refused(tmp_path):
    """Security reviews: a robot file named with an ESC sequence (``\\x1b]0;PWNED\\x07`` retitles a terminal) reached
    stdout raw, a newline in a name forged output lines, and a byte that is not UTF-8 ended ``generate`` with a
    UnicodeEncodeError traceback after the files were written (exit 1). A path with a control or format character is
    refused in one line (nothing written); an undecodable byte is printed as an escape and the command succeeds."""
    import os
    import sys

    robot = (Path(__file__).parent.parent / "examples" / "robots" / "scara.toml").read_bytes()
    env = {**os.environ, "PYTHONIOENCODING": "utf-8"}
    for raw, shown, status in ((b"sc\xffara.toml", "sc\\xffara.toml", 0), (b"x\x1b]0;PWNED\x07.toml", "('\\x1b')", 2),
                               (b"d\nwrote pwned\n\xe2\x80\xae.toml", "('\\n')", 2)):
        path = os.path.join(os.fsencode(tmp_path), raw)
        with open(path, "wb") as handle:
            handle.write(robot)
        out = tmp_path / f"out{status}"
        r = subprocess.run([sys.executable, "-m", "skelarm_sym", "generate", "--robot", path, "--lang", "c", "--out",
                            str(out), "--force"], capture_output=True, env=env)
        text = (r.stdout + r.stderr).decode("utf-8")
        assert r.returncode == status, text
        assert shown in text and "\x1b" not in text and "\x07" not in text and "\u202e" not in text, text
        if status:
            assert len(r.stderr.splitlines()) == 1 and "holds a control or format character" in text and not out.exists()
