"""The differential drive: derived from seed 002's constraints, emitted, checked against rigid-body motion."""

import numpy as np
import pytest
import sympy as sp

from skelarm_sym import InputError, reference
from skelarm_sym.build import compile_arm, load_python
from skelarm_sym.check import compare
from skelarm_sym.cli import main
from skelarm_sym.models.diffdrive.derive import constraint_equations, wheel_to_body
from skelarm_sym.generate import generate
from skelarm_sym.models.diffdrive import DiffDrive

L = sp.Symbol("L", positive=True)


def test_matrix_follows_from_constraints_9_and_10():
    M, M_inv = wheel_to_body(L)
    assert M == sp.Matrix([[sp.Rational(1, 2), sp.Rational(1, 2)], [-1 / L, 1 / L]])
    assert M_inv == sp.Matrix([[1, -L / 2], [1, L / 2]])
    assert sp.simplify(M * M_inv) == sp.eye(2)
    # (10) is implied by (9): the speed of C, u = omega R, is the wheels' mean
    vl, vr, u, w = sp.symbols("v_L v_R u omega", real=True)
    sol = sp.solve(constraint_equations(vl, vr, L, u, w), [u, w], dict=True)[0]
    assert sp.simplify(sol[u] - (vl + vr) / 2) == 0
    # and (9) itself holds for R = u / omega: omega = v_L / (R - L/2) = v_R / (R + L/2)
    R = sol[u] / sol[w]
    assert sp.simplify(vl / (R - L / 2) - sol[w]) == 0 and sp.simplify(vr / (R + L / 2) - sol[w]) == 0


def test_seed_matrix_11_holds_only_with_L_twice_the_track():
    """The seed's (11) in its own symbol L equals the derived matrix for a track of L/2: it holds where its L is
    twice the distance between the wheels (the docs had said half). Checked by rigid-body motion too: wheels 0.5 m
    apart at 0 and 1 m/s turn the robot at 2 rad/s."""
    seed = sp.Matrix([[sp.Rational(1, 2), sp.Rational(1, 2)], [-2 / L, 2 / L]])
    M, _ = wheel_to_body(L)
    assert M != seed
    assert M.subs(L, L / 2) == seed
    track, wheels = 0.5, sp.Matrix([0, 1])
    assert (seed.subs(L, 2 * track) * wheels)[1] == 2.0
    assert (seed.subs(L, track / 2) * wheels)[1] != 2.0


@pytest.mark.parametrize("track", [None, 0.45])
@pytest.mark.parametrize("precision", ["double", "float"])
def test_emitted_code_matches_rigid_body_reference(track, precision):
    results = compare(generate(DiffDrive(track), precision=precision, out=None), cases=50, precision=precision)
    assert len(results) == 6
    assert all(r.ok for r in results), results


def test_wheel_contact_points_move_as_the_wheel_speeds_say(rng):
    """Finite differences: integrate the pose, follow each contact point, project on the heading."""
    g = generate(DiffDrive(), out=None)
    for impl in (compile_arm(g), load_python(g.sources["diffdrive.py"], "diffdrive")):
        track = 0.6
        pose = np.array([0.3, -0.2, 0.7])
        wheels = np.array([0.8, 1.3])
        dt = 1e-6
        mid = pose + 0.5 * dt * impl.pose_rate(pose, wheels, track)  # midpoint rule
        after = pose + dt * impl.pose_rate(mid, wheels, track)

        def contacts(p):
            left = np.array([-np.sin(p[2]), np.cos(p[2])]) * track / 2
            return p[:2] + left, p[:2] - left

        heading = np.array([np.cos(mid[2]), np.sin(mid[2])])
        for before_pt, after_pt, speed in zip(contacts(pose), contacts(after), wheels):
            assert (after_pt - before_pt) @ heading / dt == pytest.approx(speed, rel=1e-8)
        # round trip
        np.testing.assert_allclose(impl.wheel_speeds(impl.body_rates(wheels, track), track), wheels, atol=1e-15)


def test_straight_and_spinning_motion():
    g = generate(DiffDrive(0.5), out=None, functions="body_rates")
    py = load_python(g.sources["diffdrive.py"], "diffdrive")
    np.testing.assert_allclose(py.body_rates([1.0, 1.0]), [1.0, 0.0])  # straight: R infinite, no trouble
    np.testing.assert_allclose(py.body_rates([-1.0, 1.0]), [0.0, 4.0])  # spin in place: omega = 2 / 0.5
    np.testing.assert_allclose(reference.diffdrive_body_rates([-1.0, 1.0], 0.5), [0.0, 4.0])


def test_bad_input():
    with pytest.raises(InputError):
        DiffDrive(-1.0)
    with pytest.raises(InputError):
        DiffDrive(float("nan"))
    g = generate(DiffDrive(), out=None)
    for impl in (compile_arm(g), load_python(g.sources["diffdrive.py"], "diffdrive")):
        with pytest.raises(ValueError, match="track must be > 0"):
            impl.body_rates([1.0, 1.0], 0.0)
        with pytest.raises(ValueError, match="wheels must be finite"):
            impl.body_rates([np.nan, 1.0], 0.5)
        with pytest.raises(ValueError):
            impl.body_rates([1.0, 1.0, 1.0], 0.5)


def test_cli(tmp_path, capsys):
    assert main(["generate", "--model", "diffdrive", "--track", "0.4", "--out", str(tmp_path), "--compile"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["diffdrive.c", "diffdrive.h", "diffdrive.py"]
    assert "regenerate with (in this folder): skelarm-sym generate --model diffdrive --track 0.4 --lang c,python --prefix diffdrive --precision double --out ." in (tmp_path / "diffdrive.c").read_text()
    capsys.readouterr()
    assert main(["show", "--model", "diffdrive", "--what", "matrix", "--format", "text"]) == 0
    assert "[-1/L, 1/L]]" in capsys.readouterr().out
    assert main(["check", "--model", "diffdrive", "--cases", "10"]) == 0
    assert "6 passed, 0 failed" in capsys.readouterr().out
    for bad in (["generate", "--model", "diffdrive", "--links", "2"], ["generate", "--links", "2", "--track", "1"],
                ["generate", "--model", "diffdrive", "--track", "0"], ["show", "--model", "diffdrive", "--what", "J"]):
        assert main(bad + ["--out", str(tmp_path / "x")] if bad[0] == "generate" else bad) == 2
        err = capsys.readouterr().err
        assert err.startswith("skelarm-sym: error:") and err.count("\n") == 1
    assert not (tmp_path / "x").exists()
