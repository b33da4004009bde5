"""What ``check`` judges and refuses beyond the straight-line table: the iterative position IK
(``ik_solve_position``) gets rows of its own; an undamped inverse velocity may keep a direction the judge's
cut-off drops and is then judged against the exact answer on that rank (with an honest bound, which zero
does not meet); ``check --from`` refuses, in one line, files whose robot file has changed since."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from skelarm_sym.check import compare, load_implementations
from skelarm_sym.cli import main
from skelarm_sym.generate import generate
from skelarm_sym.models.chain.check import chain_scenarios, pose_rows
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]

THREE_JOINTS = """name = "arm"
convention = "standard"
[[joints]]
type = "revolute"
d = 0.3
alpha = "pi/2"
[[joints]]
type = "revolute"
a = 0.4
[[joints]]
type = "revolute"
a = 0.35
"""
FOURTH_JOINT = """[[joints]]
type = "revolute"
d = 0.1
alpha = "pi/2"
"""


def test_ik_solve_position_has_rows_that_judge_the_answer_by_the_reference():
    generated = generate(load_robot(ROOT / "examples/robots/ur5.toml"), langs="python", out=None,
                         functions="ik_solve_position")
    (label, module), = load_implementations(generated)
    rows = pose_rows(generated.derivation, [(label, module)], 5, 0, "double")
    assert [r.implementation for r in rows] == ["Python ik_solve_position"]
    assert rows[0].ok and rows[0].targets == 5 and rows[0].worst_rotation is None

    def claims_success(q0, target, **options):  # returns its start, and says it converged
        return SimpleNamespace(q=np.asarray(q0), status="converged")

    wrong = pose_rows(generated.derivation, [(label, SimpleNamespace(ik_solve_position=claims_success))], 5, 0, "double")
    assert not wrong[0].ok and wrong[0].converged == 0 and wrong[0].worst_error > 1e-3


def test_check_from_a_folder_with_only_the_position_ik_checks_it(tmp_path, capsys):
    generate(load_robot(ROOT / "examples/robots/scara.toml"), langs="python", out=tmp_path, functions="ik_solve_position")
    assert main(["check", "--from", str(tmp_path), "--cases", "5"]) == 0
    printed = capsys.readouterr().out
    assert "Python ik_solve_position: converged 5/5" in printed and "ik: 1 passed, 0 failed" in printed


def test_an_undamped_solve_that_keeps_a_direction_the_judge_drops_is_judged_on_that_rank():
    """Float UR5, seed 0: a configuration 1.7e-4 rad from the wrist singularity, whose smallest scaled
    singular value (3.6e-6 of the largest) is below the judge's cut-off but above the code's rank rule: the
    code answers |dq| = 1.2e4, the exact inverse to 3e-4; the truncated answer is |dq| = 5.7. Before the
    second answer, this row failed by default (``check --robot ur5.toml --precision float``)."""
    generated = generate(load_robot(ROOT / "examples/robots/ur5.toml"), langs="python", precision="float", out=None,
                         functions="inverse_velocity")
    (label, module), = load_implementations(generated)
    rows = compare(generated, 100, 0, "float", [(label, module)])
    assert rows and all(r.ok for r in rows), [(r.output, r.max_rel) for r in rows]

    scenario, = [s for s in chain_scenarios(generated.derivation, 100, 0, "float") if s.label == "lambda=0"]
    answer = np.asarray(module.inverse_velocity(scenario.values["q"], scenario.values["twist"], 0.0), dtype=float)
    case = int(np.argmax(np.abs(answer).max(axis=-1)))
    assert np.abs(answer[case]).max() > 1e3 > 10 > np.abs(scenario.expected["dq"][case]).max()
    assert np.abs(answer[case] - scenario.alternatives["dq"][case]).max() < 1e-3 * np.abs(answer[case]).max()

    for wrong in (np.zeros_like(answer), 1.5 * answer):  # neither the first nor the second answer
        fake = SimpleNamespace(inverse_velocity=lambda q, twist, lambda_, _w=wrong: _w if lambda_ == 0 else
                               module.inverse_velocity(q, twist, lambda_))
        judged = compare(generated, 100, 0, "float", [("fake", fake)])
        assert [r.ok for r in judged] == [False, True]  # lambda = 0, lambda = 0.1


def test_check_from_refuses_files_of_a_robot_file_that_changed_since(tmp_path, capsys):
    robot = tmp_path / "arm.toml"
    robot.write_text(THREE_JOINTS)
    out = tmp_path / "out"
    generate(load_robot(robot), langs="python", out=out, functions="pose")
    assert main(["check", "--from", str(out), "--cases", "3"]) == 0
    capsys.readouterr()
    robot.write_text(THREE_JOINTS + FOURTH_JOINT)
    assert main(["check", "--from", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "arm.py was generated for 3 coordinate(s)" in err and "now gives 4 coordinate(s)" in err
    assert "the robot file changed since" in err


def test_check_from_refuses_files_without_a_function_their_command_emits(tmp_path, capsys):
    robot = tmp_path / "arm.toml"
    robot.write_text(THREE_JOINTS)
    generate(load_robot(robot), langs="python", out=tmp_path, functions="pose,jacobian")
    source = tmp_path / "arm.py"
    source.write_text(source.read_text().replace("def jacobian(", "def jacobian_gone("))
    assert main(["check", "--from", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "arm.py has no jacobian" in err, err


@pytest.mark.parametrize("precision", ["double", "float"])
def test_every_example_robots_check_of_the_inverse_velocity_passes_at_the_default_seed(precision):
    """``check --robot X.toml [--precision float]`` with its defaults must not fail on correct code (it
    did for float UR5, PUMA 560 and ABB IRB 140, see above). Stanford in float is left out: its code
    keeps a direction whose singular value is 1e-8 of the largest, below float's epsilon (its rank rule,
    a Gram-Schmidt residual without pivoting, sees two residuals of 5e-5 and 6e-4 instead); the check
    rightly fails it (docs/robots.md, known limits)."""
    for name in ("ur5", "puma560", "puma560_modified", "abb_irb140", "kuka_kr6"):
        generated = generate(load_robot(ROOT / f"examples/robots/{name}.toml"), langs="python", precision=precision,
                             out=None, functions="inverse_velocity,inverse_velocity_position")
        rows = compare(generated, 100, 0, precision)
        assert all(r.ok for r in rows), (name, [(r.output, r.max_rel) for r in rows if not r.ok])
