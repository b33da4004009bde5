"""The README's examples run and do what they say."""

import runpy
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def test_track_line_example_follows_the_line(capsys):
    example = runpy.run_path(str(ROOT / "examples" / "track_line.py"))
    worst = example["main"]()
    assert worst < 1e-4  # Euler steps of 1 ms with a position gain of 20: about 1e-5
    times, actual, desired, joints = example["track_line"]()
    np.testing.assert_allclose(actual[-1], [0.2, 1.5], atol=1e-4)
    assert np.all(np.isfinite(joints))
    assert "largest tracking error" in capsys.readouterr().out


def _declarations(text):
    """C function declarations in ``text``, comments dropped and whitespace collapsed."""
    import re

    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return {" ".join(d.split()) for d in re.findall(r"(?:void|int)\s+\w+\([^;{]*\);", text)}


def test_readme_c_signatures_are_what_generate_writes():
    from skelarm_sym.generate import generate

    readme = (ROOT / "README.md").read_text()
    block = readme.split("```c\n", 1)[1].split("```", 1)[0]
    documented = _declarations(block)
    header = generate(3, lengths=(1.0, 0.8, 0.5), prefix="arm3", langs="c", out=None).sources["arm3.h"]
    assert len(documented) >= 10
    assert documented <= _declarations(header), documented - _declarations(header)


def test_diffdrive_doc_signatures_are_what_generate_writes():
    from skelarm_sym.generate import generate
    from skelarm_sym.models.diffdrive import DiffDrive

    doc = (ROOT / "docs" / "diffdrive.md").read_text()
    documented = _declarations(doc.split("```c\n", 1)[1].split("```", 1)[0])
    header = generate(DiffDrive(), langs="c", out=None).sources["diffdrive.h"]
    assert len(documented) == 3 and documented <= _declarations(header)
