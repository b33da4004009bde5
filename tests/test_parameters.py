"""Issue 13 (4): generation refuses parameters the precision cannot hold, and whatever it emits compiles."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skelarm_sym import InputError
from skelarm_sym.build import compile_arm, load_python
from skelarm_sym.cli import main
from skelarm_sym.generate import generate
from skelarm_sym.models.diffdrive import DiffDrive
from skelarm_sym.models.planar import PlanarArm


@pytest.mark.parametrize("model, precision, named", [
    (PlanarArm(3, (1e39, 1.0, 1.0)), "float", "l1"),      # inff in C before
    (PlanarArm(2, (1.0, 1e-46)), "float", "l2"),          # rounds to zero
    (PlanarArm(2, (1.0, 1e-40)), "float", "l2"),          # subnormal
    (PlanarArm(2, (1e10, 1e10)), "float", "sum of the link lengths"),  # its fourth power overflows
    (PlanarArm(2, (1e100, 1.0)), "double", "sum of the link lengths"),
    (PlanarArm(1, (5e-324,)), "double", "l1"),
    (DiffDrive(5e-324), "double", "track"),               # inf in C, NameError in Python before
    (DiffDrive(1e39), "float", "track"),
    (DiffDrive(1e-38), "float", "track"),                 # normal, but 1/track overflows
    (DiffDrive(1e308), "double", "track"),                # 1/track is subnormal
])
def test_unrepresentable_parameters_are_refused(model, precision, named):
    with pytest.raises(InputError, match=named) as info:
        generate(model, precision=precision, out=None)
    assert "\n" not in str(info.value) and precision in str(info.value)


def test_command_line_refuses_with_one_line(tmp_path, capsys):
    assert main(["generate", "--links", "3", "--lengths", "1e39,1,1", "--precision", "float", "--out", str(tmp_path / "o")]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "l1" in err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_extremes_that_fit_are_accepted():
    generate(PlanarArm(2, (1e8, 1e8)), precision="float", out=None)
    generate(DiffDrive(1e-30), precision="float", out=None)
    generate(PlanarArm(2, (1e-70, 1e-70)), precision="double", out=None)


magnitudes = st.floats(min_value=-330.0, max_value=310.0).map(lambda e: 10.0**e if e < 308.25 else 1.7e308)


def _outcome(model, precision):
    try:
        return generate(model, precision=precision, out=None)
    except InputError:
        return None


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(length=magnitudes, precision=st.sampled_from(["double", "float"]))
def test_fuzzed_lengths_either_refused_or_compile_and_run(length, precision):
    model = PlanarArm(1, (length,)) if length > 0 else None
    if model is None:
        return
    g = _outcome(model, precision)
    if g is None:
        return
    dtype = np.float32 if precision == "float" else np.float64
    want = float(dtype(length))
    assert math.isfinite(want) and want != 0.0
    for impl in (compile_arm(g), load_python(g.sources["arm1.py"], "arm1")):
        p = impl.position(np.zeros(1, dtype=dtype))
        assert np.all(np.isfinite(p)) and p[0] == pytest.approx(want, rel=1e-6)
        dq = impl.inverse_velocity(np.zeros(1, dtype=dtype), np.array([0.0, 1.0], dtype=dtype), 0.0)
        assert np.all(np.isfinite(dq))


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(track=magnitudes, precision=st.sampled_from(["double", "float"]))
def test_fuzzed_track_either_refused_or_compile_and_run(track, precision):
    if not track > 0:
        return
    g = _outcome(DiffDrive(track), precision)
    if g is None:
        return
    dtype = np.float32 if precision == "float" else np.float64
    for impl in (compile_arm(g), load_python(g.sources["diffdrive.py"], "diffdrive")):
        rates = impl.body_rates(np.array([0.0, 1e-30 if precision == "double" else 1e-3], dtype=dtype))
        assert np.all(np.isfinite(rates))
        assert rates[1] == pytest.approx(float(rates.dtype.type(1e-30 if precision == "double" else 1e-3)) / float(dtype(track)), rel=1e-5)
