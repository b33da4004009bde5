"""The examples of the README and docs/ run and do what they say; their C declarations are what generate writes."""

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


def test_planar_doc_c_signatures_are_what_generate_writes():
    from skelarm_sym.generate import generate

    doc = (ROOT / "docs" / "planar.md").read_text()
    block = doc.split("```c\n", 1)[1].split("```", 1)[0]
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


def test_ur5_resolved_rate_example_tracks_and_avoids_singularities(capsys):
    example = runpy.run_path(str(ROOT / "examples" / "ur5_resolved_rate.py"))
    (plain_error, plain_w, _), (avoid_error, avoid_w, q) = example["main"]()
    assert plain_error < 1e-5 and avoid_error < 1e-5  # the line is followed either way
    assert avoid_w > 1.1 * plain_w  # the null-space term keeps the manipulability up
    assert np.all(np.isfinite(q))
    assert "with null-space term" in capsys.readouterr().out


def test_ur5_c_example_prints_the_reference_pose(tmp_path):
    import shutil
    import subprocess

    from skelarm_sym import reference
    from skelarm_sym.models.chain.dh_file import load_robot_file

    cc = shutil.which("cc") or shutil.which("gcc")
    exe = tmp_path / "ur5_demo"
    subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", f"-I{ROOT / 'generated'}",
                    str(ROOT / "examples" / "ur5_demo.c"), str(ROOT / "generated" / "ur5.c"), "-o", str(exe), "-lm"], check=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    values = np.array([float(x) for x in out])
    q = np.array([0.1, -1.2, 1.5, -1.9, -1.4, 0.3])
    dq = np.array([0.2, 0.1, -0.3, 0.4, 0.0, 0.5])
    k = reference.chain_kinematics(load_robot_file(ROOT / "examples" / "robots" / "ur5.toml").numeric(), q, dq, np.zeros(6))
    np.testing.assert_allclose(values[:3], k.T[:3, 3], atol=1e-12)
    np.testing.assert_allclose(values[3:9], k.twist, atol=1e-12)


def test_robot_doc_signatures_are_what_generate_writes():
    header = (ROOT / "generated" / "ur5.h").read_text()
    doc = (ROOT / "docs" / "robots.md").read_text()
    block = doc.split("## The emitted functions", 1)[1].split("```c\n", 1)[1].split("```", 1)[0]
    documented = _declarations(block)
    assert len(documented) >= 13
    assert documented <= _declarations(header), documented - _declarations(header)


def test_readme_quickstart_builds_runs_and_matches_the_reference(tmp_path):
    """The README's four steps: the URDF's chain generated, examples/quickstart.c built with the strict
    flags and run; its printed pose and velocity are the reference's, its IK converges."""
    import shutil
    import subprocess

    from skelarm_sym import reference
    from skelarm_sym.cli import main
    from skelarm_sym.models.chain.loader import load_robot

    robot = ROOT / "examples" / "robots" / "ur5.urdf"
    assert main(["generate", "--robot", str(robot), "--tip", "tool0", "--lang", "c", "--out", str(tmp_path / "build")]) == 0
    cc = shutil.which("cc") or shutil.which("gcc")
    exe = tmp_path / "quickstart"
    subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", f"-I{tmp_path / 'build'}",
                    str(ROOT / "examples" / "quickstart.c"), str(tmp_path / "build" / "ur5.c"), "-o", str(exe), "-lm"], check=True)
    run = subprocess.run([str(exe)], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    first, second = run.stdout.splitlines()
    numbers = [float(x) for x in first.replace("tool at", "").replace("m, moving at", "").replace("m/s", "").split()]
    q = np.array([0.1, -1.2, 1.5, -1.9, -1.4, 0.3])
    dq = np.array([0.2, 0.1, -0.3, 0.4, 0.0, 0.5])
    k = reference.chain_kinematics(load_robot(robot, tip="tool0").numeric(), q, dq, np.zeros(6))
    np.testing.assert_allclose(numbers[:3], k.T[:3, 3], atol=1e-6)
    np.testing.assert_allclose(numbers[3:6], k.twist[:3], atol=1e-6)
    assert "status 0 (converged)" in second
