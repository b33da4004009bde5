"""Robots through the command line: generate, check, show; bad robot files and URDFs fail cleanly."""

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym.build import compile_shared
from skelarm_sym.cli import main
from skelarm_sym.generate import generate
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = sorted((ROOT / "examples" / "robots").glob("*.toml"))


COMPILERS = (None, *(("clang",) if shutil.which("clang") else ()))
"""compile_shared's default compiler, and clang when installed."""
QUICK_ROBOTS = ("puma560", "scara", "ur5")  # the others (5 to 7 s each: every function derived) are in the slow set


@pytest.mark.parametrize("precision", ["double", "float"])
@pytest.mark.parametrize("robot", [pytest.param(p, id=p.stem, marks=() if p.stem in QUICK_ROBOTS else pytest.mark.slow)
                                   for p in ROBOTS])
def test_every_example_robot_compiles_with_the_strict_flags(robot, precision):
    """Every function, under the default compiler and under clang (when installed), with compile_shared's strict
    flags (-std=c99 -Wall -Wextra -Werror -pedantic: a warning fails the compile), at -O0: nearly all of clang's
    warnings come from its front end, at any level."""
    g = generate(load_robot(robot), langs="c", precision=precision, out=None)
    for compiler in COMPILERS:
        compile_shared(dict(g.sources), flags=("-O0",), compiler=compiler)


DEGENERATE = {  # chains whose functions coincide: GCC's optimiser folds identical bodies (-fipa-icf) into one
    "two prismatic joints": '[[joints]]\ntype = "prismatic"\n\n[[joints]]\ntype = "prismatic"\nalpha = "pi/2"\n',
}


@pytest.mark.parametrize("text", DEGENERATE.values(), ids=DEGENERATE.keys())
def test_degenerate_chains_compile_with_the_strict_flags_optimised(tmp_path, text):
    """Every function at -O2 under the default compiler and clang: where two bodies are identical (the inverse
    velocity and the position-only one of a prismatic pair) GCC folds them into one, and a body that took its
    arrays with sizes then read as a 6-element argument given 3 elements (-Wstringop-overread)."""
    robot = tmp_path / "degenerate.toml"
    robot.write_text(text)
    g = generate(load_robot(robot), langs="c", out=None)
    for compiler in COMPILERS:
        compile_shared(dict(g.sources), flags=("-O2",), compiler=compiler)


def test_generate_check_show_a_robot_file(tmp_path, capsys):
    robot = str(ROOT / "examples" / "robots" / "stanford.toml")
    assert main(["generate", "--robot", robot, "--out", str(tmp_path), "--lang", "c"]) == 0
    assert {p.name for p in tmp_path.iterdir()} >= {"stanford.h", "stanford.c"}
    assert main(["check", "--robot", robot, "--cases", "10", "--lang", "python"]) == 0
    assert "0 failed" in capsys.readouterr().out
    assert main(["show", "--robot", robot, "--what", "J", "--format", "text"]) == 0
    text = capsys.readouterr().out
    assert "intermediate steps" in text and "J =" in text


BAD_FILES = {
    "not TOML": ("x.toml", "joints = [", "not valid TOML"),
    "unknown key": ("x.toml", 'nmae = "x"\n[[joints]]\ntype = "revolute"\n', "unknown key 'nmae'"),
    "no type": ("x.toml", "[[joints]]\na = 1.0\n", "missing type"),
    "bad expression": ("x.toml", '[[joints]]\ntype = "revolute"\nalpha = "pi/+"\n', "cannot parse"),
    "no joints": ("x.toml", 'name = "x"\n', "no joints"),
    "nan": ("x.toml", '[[joints]]\ntype = "revolute"\na = nan\n', "finite"),
    "malformed urdf": ("x.urdf", "<robot name='r'><link name='a'>", "x.urdf"),
    "zero axis": ("x.urdf", """<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="revolute">
        <parent link="a"/><child link="b"/><axis xyz="0 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>""",
        "length zero"),
    "floating": ("x.urdf", """<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="floating">
        <parent link="a"/><child link="b"/></joint></robot>""", "floating"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_robot_files_fail_with_one_line_and_no_files(case, tmp_path):
    name, text, expected = BAD_FILES[case]
    path = tmp_path / name
    path.write_text(text)
    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, "-m", "skelarm_sym", "generate", "--robot", str(path), "--out", str(out)],
        capture_output=True, text=True, cwd=ROOT,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("skelarm-sym: error: ") and str(path) in lines[0]
    assert expected in lines[0]
    assert not out.exists() or not any(out.iterdir())


def test_tip_that_is_not_a_link_is_refused(tmp_path, capsys):
    path = tmp_path / "r.urdf"
    path.write_text("""<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="revolute">
        <parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>""")
    assert main(["generate", "--robot", str(path), "--tip", "nowhere", "--out", str(tmp_path / "o")]) == 2
    assert "nowhere" in capsys.readouterr().err
    assert main(["generate", "--robot", str(ROOT / "examples" / "robots" / "ur5.toml"), "--tip", "x", "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("value, precision", [(1e39, "float"), (1e300, "double")])
def test_robot_constants_the_precision_cannot_hold_are_refused(tmp_path, capsys, value, precision):
    path = tmp_path / "big.toml"
    path.write_text(f'[[joints]]\ntype = "revolute"\na = {value!r}\n[[joints]]\ntype = "prismatic"\nd = 0.5\n')
    assert main(["generate", "--robot", str(path), "--precision", precision, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not representable" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("name", ["q1", "dq2", "ddq", "params", "lambda", "xi_vx", "sin", "main"])
def test_parameter_names_that_collide_with_inputs_or_keywords_are_refused(tmp_path, name):
    """A parameter named q1 was the joint input's own symbol: the code silently used q[0] for it."""
    from skelarm_sym.errors import InputError

    path = tmp_path / "p.toml"
    path.write_text(f'[[joints]]\ntype = "revolute"\na = "{name}"\n')
    with pytest.raises(InputError, match=f"parameter name '{name}' is a reserved word"):
        load_robot(path)


def test_urdf_robot_named_after_a_reserved_word_gets_a_usable_prefix(tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text("""<robot name="main"><link name="a"/><link name="b"/><joint name="j" type="revolute">
        <parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>""")
    chain = load_robot(path)
    assert chain.name != "main"
    generate(chain, langs="c", out=None)  # the prefix is accepted


def test_newcomer_path_functions_links_joints_and_prefix_rule(tmp_path, capsys):
    """Issue 16 (17): --functions takes the header's solver names and lists one consistent set; show --what
    links prints a URDF's link tree to choose --tip; generate names the joints the chain holds; --help
    states the default-prefix rule."""
    from skelarm_sym.cli import main

    robot = str(Path(__file__).resolve().parent / "fixtures" / "robots" / "ur_like.urdf")
    assert main(["generate", "--robot", robot, "--functions", "ik_solve,ik_solve_position", "--out", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert "joints, base to tip:" in out and "shoulder_pan_joint (revolute)" in out
    header = (tmp_path / "a" / "ur_like.h").read_text()
    assert "int ur_like_ik_solve(" in header and "int ur_like_ik_solve_position(" in header
    assert "void ur_like_ik_terms(" in header  # what the solvers call comes with them
    assert main(["generate", "--robot", robot, "--functions", "nope", "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("skelarm-sym: error: unknown function 'nope'; choose from pose, ")
    # the chain is in a closed-form family: its functions are listed too
    assert err.endswith("ik_solve, ik_solve_position, ik_all, ik_nearest, ik_nearest_weighted") and not (tmp_path / "b").exists()
    assert main(["show", "--robot", robot, "--what", "links"]) == 0
    tree = capsys.readouterr().out
    assert "tool0" in tree and "leaf" in tree and "(fixed)" in tree
    with pytest.raises(SystemExit):
        main(["generate", "--help"])
    assert "xarm7.urdf: xarm7" in " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize("value, precision", [(-2.67276e-51, "float"), (1e-46, "float"), (1e-310, "double")])
def test_robot_constants_below_the_smallest_normal_are_zero(tmp_path, value, precision):
    """iCub's URDF writes a translation of -2.67276e-51 m: float was refused ("use a value between 1.18e-38 and
    3.4e+38", a vendor file to edit), though float rounds it to 0 and a C compiler truncates it with a warning.
    Such constants are now 0 in that precision; the C compiles warning-free and the pose has no trace of them."""
    from skelarm_sym.build import compile_arm, find_compiler

    path = tmp_path / "tiny.toml"
    path.write_text(f'[[joints]]\ntype = "revolute"\na = 0.4\nd = {value!r}\n[[joints]]\ntype = "revolute"\na = 0.3\n')
    chain = load_robot(path)
    generated = generate(chain, langs="c", precision=precision, out=None, functions="pose")
    assert generated.derivation.model.joints[0].after.translation[2] == 0
    if precision == "float":
        assert chain.joints[0].after.translation[2] != 0  # the file's model is not changed (double holds it)
    if find_compiler():
        arm = compile_arm(generated)  # -Werror: "floating constant truncated to zero" would fail it
        T = arm.pose(np.array([0.3, -0.2]))
        assert abs(T[2, 3]) == 0.0


def test_show_explains_every_step_name_and_the_legend_holds():
    """``show --what all`` lists a legend of the step names it prints: every name of every example robot's
    listing is explained, and what the legend says of Jv<k>, w<k>, u<k> and dJv<k> holds for UR5's numbers (the
    steps evaluated in order against the NumPy reference). A new user found the names (G3_00, W5x, u4z) explained
    nowhere."""
    import math
    import re

    from skelarm_sym import reference
    from skelarm_sym.models.chain.show import LEGEND, show_chain
    from skelarm_sym.models.chain.derive import derive_chain

    for robot in ROBOTS:
        text = show_chain(derive_chain(load_robot(robot)), "all", "text")
        steps = [line.split(" = ", 1) for line in text.splitlines() if " = " in line and not line.startswith("#")]
        legend = [line for line in text.splitlines() if line.startswith("#   ")]
        for name, _ in steps:
            texts = [t for pattern, t in LEGEND if re.match(pattern, name)]
            assert texts and all(f"#   {t}" in legend for t in texts), (robot.name, name)
    chain = load_robot(ROOT / "examples" / "robots" / "ur5.toml")
    text = show_chain(derive_chain(chain), "all", "text")
    rng = np.random.default_rng(2)
    q, dq = rng.uniform(-2, 2, 6), rng.uniform(-1, 1, 6)
    values = {"cos": math.cos, "sin": math.sin, "sqrt": math.sqrt}
    values.update({f"q{k + 1}": q[k] for k in range(6)} | {f"dq{k + 1}": dq[k] for k in range(6)})
    for line in text.splitlines():
        if " = " in line and not line.startswith("#"):
            name, expr = line.split(" = ", 1)
            values[name] = eval(expr, {}, values)  # the listing's own steps, in order
    ref = reference.chain_kinematics(chain.numeric(None), q[None], dq[None], np.zeros((1, 6)))
    J, dJ = ref.J[0], ref.dJ[0]
    checked = 0
    for k in range(1, 7):
        for i, axis in enumerate("xyz"):
            expected = {f"Jv{k}{axis}": J[i, k - 1], f"w{k}{axis}": J[3 + i, :k] @ dq[:k],
                        f"u{k}{axis}": J[i, k - 1:] @ dq[k - 1:], f"dJv{k}{axis}": dJ[i, k - 1]}
            for name, value in expected.items():
                if name in values:
                    assert abs(values[name] - value) < 1e-12, name
                    checked += 1
    assert checked > 40
    pretty = show_chain(derive_chain(load_robot(ROOT / "examples" / "robots" / "scara.toml")), "T", "pretty")
    assert "⎡c4  s4" in pretty and "₄" not in pretty  # the matrices name the steps as the listing does (not c₄)
