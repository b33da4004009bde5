"""Every code block of README.md and docs/*.md that can run is run.

* ```sh blocks: each line, split at ``&&``, is either a ``skelarm-sym ...`` command, run through
  :func:`skelarm_sym.cli.main` in a temporary folder (with the repository's ``examples/`` beside it)
  and expected to exit 0, or an install/test step on the explicit allow-list ``NOT_RUN``. Anything
  else fails the test: a new kind of command needs a decision here.
* ```python blocks: executed as they are, in the same kind of temporary folder.
* ```c blocks: compared with emitted headers in tests/test_examples.py.
* A block right after a ``<!-- not run -->`` line is skipped.

New sections and new docs files are picked up automatically.
"""

from __future__ import annotations

import contextlib
import io
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym.cli import main

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
NOT_RUN = ("python3 -m venv", ". .venv/bin/activate", "pip install", "pytest", "python benchmarks/", "python3 benchmarks/",
           "PYTHONPATH=. python3 scripts/regenerate.py", "python scripts/regenerate.py")
"""Set-up and test commands that the suite does not run from inside itself."""
SKIP_MARK = "<!-- not run -->"
_FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def blocks(language: str):
    """``(file, line, text)`` of every block in ``language`` not marked ``<!-- not run -->``."""
    found = []
    for path in DOCS:
        text = path.read_text()
        for match in _FENCE.finditer(text):
            if match.group(1) != language:
                continue
            before = text[: match.start()].rstrip().splitlines()
            if before and before[-1].strip() == SKIP_MARK:
                continue
            found.append((path.relative_to(ROOT).as_posix(), text.count("\n", 0, match.start()) + 1, match.group(2)))
    return found


def _id(block):
    return f"{block[0]}:{block[1]}"


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(ROOT))
    return tmp_path


def commands(text: str) -> list[list[str]]:
    """The ``skelarm-sym`` commands of a shell block (comments dropped), checking every other step."""
    found = []
    for line in text.splitlines():
        if not line.strip():
            continue
        for part in line.split("&&"):
            part = part.strip()
            words = shlex.split(part, comments=True)
            if not words:
                continue
            if words[0] == "skelarm-sym":
                found.append(words[1:])
            elif not part.startswith(NOT_RUN):
                raise AssertionError(f"a shell step neither run nor on the NOT_RUN allow-list: {part!r}")
    return found


def test_the_documents_have_blocks_to_run():
    assert len(blocks("sh")) >= 5 and len(blocks("python")) >= 2
    assert ["generate", "--robot", "examples/robots/ur5.urdf", "--tip", "tool0", "--out", "generated/quickstart",
            "--compile"] in commands(blocks("sh")[0][2])


def _checks_a_robot(block) -> bool:
    """A shell block that runs ``check --robot``: a 3-D arm's every function and solver (7 to 8 s of CPU)."""
    try:
        runs = commands(block[2])
    except AssertionError:  # a step neither run nor allowed: the test itself reports it
        return False
    return any(args and args[0] == "check" and "--robot" in args for args in runs)


@pytest.mark.parametrize("block", [pytest.param(b, marks=pytest.mark.slow if _checks_a_robot(b) else ()) for b in blocks("sh")],
                         ids=_id)
def test_shell_block(block, workdir, capsys):
    runs = commands(block[2])
    assert runs or all(part.strip().startswith(NOT_RUN) for line in block[2].splitlines() for part in line.split("&&") if part.strip())
    for args in runs:
        if "--plot" in args:
            pytest.importorskip("matplotlib")
        status = main(args)
        captured = capsys.readouterr()
        assert status == 0, f"skelarm-sym {' '.join(args)} -> {status}: {captured.err}"
        assert "error" not in captured.err


@pytest.mark.parametrize("block", blocks("python"), ids=_id)
def test_python_block(block, workdir):
    namespace = {"__name__": "__main__"}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(block[2], f"{block[0]}:{block[1]}", "exec"), namespace)
    if "to about 1e-5" in block[2]:  # the resolved-rate example ends where it says
        final = namespace["arm"].position(namespace["q"], namespace["l"])
        assert np.abs(final - np.array([0.2, 1.5])).max() < 2e-5
        printed = np.array([float(x) for x in out.getvalue().strip().strip("[]").split()])
        np.testing.assert_allclose(printed, [0.2, 1.5], atol=2e-5)


def test_a_block_marked_not_run_is_skipped(tmp_path, monkeypatch):
    doc = tmp_path / "x.md"
    doc.write_text("```sh\nskelarm-sym show --links 2\n```\n\n<!-- not run -->\n```sh\nrm -rf /\n```\n")
    monkeypatch.setattr(f"{__name__}.ROOT", tmp_path)
    monkeypatch.setattr(f"{__name__}.DOCS", [doc])
    found = blocks("sh")
    assert [b[2] for b in found] == ["skelarm-sym show --links 2\n"]
    with pytest.raises(AssertionError, match="neither run nor on the NOT_RUN allow-list"):
        commands("rm -rf /")
