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
