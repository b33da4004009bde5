"""3-D chains: derivation and emitted code against the twist-propagation reference and the planar model."""

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skelarm_sym import reference
from skelarm_sym.build import DEFAULT_FLAGS, compile_arm, load_python
from skelarm_sym.check import compare
from skelarm_sym.models.chain.derive import derive_chain
from skelarm_sym.generate import generate
from skelarm_sym.models.chain import Chain, Joint, Transform, dh_joint
from skelarm_sym.models.chain.dh_file import chain_from_table

ROBOTS = Path(__file__).resolve().parents[1] / "examples" / "robots"
HALF_PI = "pi/2"


def dh_table(name, convention, rows, tool=None, base=None):
    data = {"name": name, "convention": convention, "joints": rows}
    if tool:
        data["tool"] = tool
    if base:
        data["base"] = base
    return chain_from_table(data)


UR5 = dh_table("ur5", "standard", [
    {"type": "revolute", "d": 0.089159, "alpha": HALF_PI},
    {"type": "revolute", "a": -0.425},
    {"type": "revolute", "a": -0.39225},
    {"type": "revolute", "d": 0.10915, "alpha": HALF_PI},
    {"type": "revolute", "d": 0.09465, "alpha": "-pi/2"},
    {"type": "revolute", "d": 0.0823},
])
PUMA = dh_table("puma", "standard", [
    {"type": "revolute", "alpha": HALF_PI},
    {"type": "revolute", "a": 0.4318},
    {"type": "revolute", "a": 0.0203, "d": 0.15005, "alpha": "-pi/2"},
    {"type": "revolute", "d": 0.4318, "alpha": HALF_PI},
    {"type": "revolute", "alpha": "-pi/2"},
    {"type": "revolute"},
])
PANDA = dh_table("panda", "modified", [
    {"type": "revolute", "d": 0.333},
    {"type": "revolute", "alpha": "-pi/2"},
    {"type": "revolute", "d": 0.316, "alpha": HALF_PI},
    {"type": "revolute", "a": 0.0825, "alpha": HALF_PI},
    {"type": "revolute", "a": -0.0825, "d": 0.384, "alpha": "-pi/2"},
    {"type": "revolute", "alpha": HALF_PI},
    {"type": "revolute", "a": 0.088, "alpha": HALF_PI},
], tool={"xyz": [0.0, 0.0, 0.107]})
STANFORD = dh_table("stanford", "standard", [
    {"type": "revolute", "d": 0.412, "alpha": "-pi/2"},
    {"type": "revolute", "d": 0.154, "alpha": HALF_PI},
    {"type": "prismatic", "theta": "-pi/2"},
    {"type": "revolute", "alpha": "-pi/2"},
    {"type": "revolute", "alpha": HALF_PI},
    {"type": "revolute", "d": 0.263},
], base={"xyz": [0.1, 0.2, 0.3], "rpy": [0.3, -0.2, 0.5]})
PRISMATIC = dh_table("cartesian", "modified", [
    {"type": "prismatic", "alpha": 0.3, "a": 0.2, "theta": 0.4},
    {"type": "prismatic", "alpha": 1.1, "a": 0.1, "theta": -0.4},
    {"type": "prismatic", "alpha": -0.7, "d": 0.2},
])
PARAMS = dh_table("params", "standard", [
    {"type": "revolute", "a": "a1", "alpha": HALF_PI},
    {"type": "revolute", "a": "a2", "alpha": "al2", "d": 0.1, "theta": "th2"},
    {"type": "prismatic", "a": 0.3},
])


def _mimic_chain() -> Chain:
    z = (0, 0, 1)
    joints = (
        Joint("j1", "revolute", Transform.identity(), z, Transform.translate(x=0.5), 0),
        Joint("j2", "revolute", Transform.rotate("x", sp.pi / 2), (0, 1, 1), Transform.translate(x=0.3, z=0.1), 1),
        Joint("j3", "revolute", Transform.from_xyz_rpy([0.1, 0.0, 0.2], [0.2, 0.3, -0.1]), (1, 0, 0), Transform.identity(), 1,
              offset=sp.Float(0.25), multiplier=sp.Float(-0.5)),
        Joint("j4", "prismatic", Transform.translate(y=0.2), (0.3, -0.4, 1.0), Transform.translate(z=0.05), 2),
    )
    return Chain("mimic", joints, tool=Transform.from_xyz_rpy([0.0, 0.1, 0.1], [0.0, 0.4, 0.0]), coordinates=("a", "b", "c"))


MIMIC = _mimic_chain()
ALL = [UR5, PUMA, PANDA, STANFORD, PRISMATIC, PARAMS, MIMIC]


def _reference(chain, q, dq, ddq, params=None):
    return reference.chain_kinematics(chain.numeric(params), q, dq, ddq)


def _random_state(chain, m, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-np.pi, np.pi, (m, chain.n)), rng.uniform(-2, 2, (m, chain.n)), rng.uniform(-2, 2, (m, chain.n))


@pytest.mark.parametrize("chain", ALL, ids=lambda c: c.name)
def test_python_module_matches_the_reference(chain):
    g = generate(chain, langs="python", out=None, functions="jacobian_tool,kinematics")
    module = load_python(g.sources[f"{chain.name}.py"], chain.name)
    q, dq, ddq = _random_state(chain, 40)
    params = np.linspace(0.3, 0.9, len(chain.parameters))
    extra = (params,) if chain.parameters else ()
    ref = _reference(chain, q, dq, ddq, params if chain.parameters else None)
    T, J, dJ, twist, acc = module.kinematics(q, dq, ddq, *extra)
    for got, want in ((T, ref.T), (J, ref.J), (dJ, ref.dJ), (twist, ref.twist), (acc, ref.acc)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * max(1.0, np.abs(want).max()))
    np.testing.assert_allclose(module.jacobian_tool(q, *extra), ref.J_tool, rtol=0, atol=1e-12)
    np.testing.assert_allclose(twist, np.einsum("...ij,...j->...i", J, dq), atol=1e-12)
    np.testing.assert_allclose(acc, np.einsum("...ij,...j->...i", J, ddq) + np.einsum("...ij,...j->...i", dJ, dq), atol=1e-11)


@pytest.mark.parametrize("precision", ["double", "float"])
@pytest.mark.parametrize("chain", [UR5, pytest.param(STANFORD, marks=pytest.mark.slow), PARAMS,
                                   pytest.param(MIMIC, marks=pytest.mark.slow)], ids=lambda c: c.name)
def test_check_passes_in_both_precisions(chain, precision):
    results = compare(generate(chain, precision=precision, out=None), cases=30, precision=precision)
    assert results and all(r.ok for r in results), [r for r in results if not r.ok]


def test_batch_equals_single_bit_for_bit():
    # -O2: bit-equality of the optimised library's batch and single paths is the point
    arm = compile_arm(generate(PANDA, langs="c", out=None, functions="kinematics"), flags=DEFAULT_FLAGS)
    q, dq, ddq = _random_state(PANDA, 37, seed=3)
    batch = arm.kinematics(q, dq, ddq)
    for i in (0, 15, 31, 32, 36):
        single = arm.kinematics(q[i], dq[i], ddq[i])
        for b, s in zip(batch, single):
            np.testing.assert_array_equal(b[i], s)


@pytest.mark.parametrize("chain, budget", [(PUMA, 400), (UR5, 480), (PANDA, 640)], ids=["puma560", "ur5", "panda"])
def test_operation_counts_meet_the_budget(chain, budget):
    kin = next(p for p in generate(chain, langs="c", out=None, functions="kinematics").programs if p.name == "kinematics")
    revolute = sum(j.kind == "revolute" for j in chain.joints)
    assert kin.ops.sin <= revolute and kin.ops.cos <= revolute
    assert kin.ops.div == kin.ops.sqrt == 0
    assert kin.ops.arithmetic <= budget


def test_prismatic_columns_are_axes_and_their_derivative_rotates_with_the_chain():
    """The classic bug: a prismatic column is [z; 0], not [z x r; z]; its dJ is [w x z; 0]."""
    chain = dh_table("rp", "standard", [
        {"type": "revolute", "a": 0.3, "alpha": 0.7},
        {"type": "prismatic", "alpha": HALF_PI, "a": 0.1},
        {"type": "revolute", "d": 0.2},
    ])
    g = generate(chain, langs="python", out=None, functions="kinematics")
    module = load_python(g.sources["rp.py"], "rp")
    q, dq, ddq = np.array([0.4, 0.3, -0.6]), np.array([1.5, -0.7, 0.4]), np.zeros(3)
    T, J, dJ, twist, acc = module.kinematics(q, dq, ddq)
    z1 = np.array([0.0, 0.0, 1.0])
    # the prismatic axis: z of frame 1 (standard DH: frame 1 after joint 1's rotation and alpha)
    A1 = _dh_standard(q[0], 0.0, 0.3, 0.7)
    z = A1[:3, 2]
    np.testing.assert_allclose(J[:3, 1], z, atol=1e-15)
    np.testing.assert_allclose(J[3:, 1], 0.0, atol=0)
    np.testing.assert_allclose(dJ[:3, 1], np.cross(z1 * dq[0], z), atol=1e-15)
    np.testing.assert_allclose(dJ[3:, 1], 0.0, atol=0)


def _dh_standard(theta, d, a, alpha):
    ct, st_, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st_ * ca, st_ * sa, a * ct], [st_, ct * ca, -ct * sa, a * st_], [0, sa, ca, d], [0, 0, 0, 1]])


def test_a_planar_dh_table_gives_the_planar_model():
    lengths = np.array([1.0, 0.8, 0.5, 0.3])
    chain = dh_table("flat", "standard", [{"type": "revolute", "a": float(x)} for x in lengths])
    g = generate(chain, langs="python", out=None, functions="kinematics")
    module = load_python(g.sources["flat.py"], "flat")
    q, dq, ddq = _random_state(chain, 20, seed=5)
    T, J, dJ, twist, acc = module.kinematics(q, dq, ddq)
    planar = reference.kinematics(q, dq, ddq, lengths)
    np.testing.assert_allclose(J[:, :2, :], planar.J, atol=1e-13)
    np.testing.assert_allclose(J[:, 5, :], 1.0, atol=0)
    np.testing.assert_allclose(J[:, 2:5, :], 0.0, atol=1e-15)
    np.testing.assert_allclose(dJ[:, :2, :], planar.H, atol=1e-12)
    np.testing.assert_allclose(T[:, :2, 3], planar.p, atol=1e-13)
    np.testing.assert_allclose(acc[:, :2], planar.a, atol=1e-11)


def test_parallel_axes_share_angle_sums():
    """UR5's joints 2-4 are parallel: their rotations add up, one sine and cosine each, no more."""
    steps = dict(derive_chain(UR5).steps)
    sums = [rhs for rhs in steps.values() if rhs.is_Add and rhs.free_symbols <= set(sp.symbols("q1:7", real=True)) | set(steps)]
    assert any(sp.Symbol("q3", real=True) in rhs.free_symbols for rhs in sums)


def _random_chain(draw) -> Chain:
    n = draw(st.integers(1, 8))
    convention = draw(st.sampled_from(["standard", "modified"]))
    number = st.floats(-1.0, 1.0, allow_nan=False).map(lambda x: round(x, 3))
    angle = st.one_of(st.sampled_from([0.0, np.pi / 2, -np.pi / 2, np.pi]), st.floats(-3.0, 3.0).map(lambda x: round(x, 3)))
    joints = []
    for i in range(n):
        kind = draw(st.sampled_from(["revolute", "prismatic"]))
        joints.append(dh_joint(f"j{i}", kind, convention, sp.sympify(draw(number)), sp.sympify(draw(angle)),
                               sp.sympify(draw(number)), sp.sympify(draw(angle)), i))
    xyz = st.lists(number, min_size=3, max_size=3)
    rpy = st.lists(angle, min_size=3, max_size=3)
    base = Transform.from_xyz_rpy([sp.sympify(x) for x in draw(xyz)], [sp.sympify(x) for x in draw(rpy)])
    tool = Transform.from_xyz_rpy([sp.sympify(x) for x in draw(xyz)], [sp.sympify(x) for x in draw(rpy)])
    return Chain("rnd", tuple(joints), base, tool)


@pytest.mark.slow  # 25 random tables, each derived: 6 s of CPU
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_random_tables_match_the_reference(data):
    chain = _random_chain(data.draw)
    g = generate(chain, langs="python", out=None, functions="kinematics")
    module = load_python(g.sources["rnd.py"], "rnd")
    q, dq, ddq = _random_state(chain, 5, seed=1)
    ref = _reference(chain, q, dq, ddq)
    T, J, dJ, twist, acc = module.kinematics(q, dq, ddq)
    for got, want in ((T, ref.T), (J, ref.J), (dJ, ref.dJ), (twist, ref.twist), (acc, ref.acc)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-11 * max(1.0, np.abs(want).max()))


def test_a_long_chain_with_dense_twists_tries_every_candidate_and_matches_the_reference():
    """Twists written as 1.5708 (not pi/2: dense constant rotations, as in xArm7's URDF) make the derivation build
    the base-axes columns with every frame row carried and with each row as cofactors, for chains of up to
    CANDIDATES_UP_TO joints. With 12 joints the candidates' step labels once read alike ("r" of row 1 at joint 1
    and "r" at joint 11: one SymPy symbol for two expressions); the recorder now refuses that, and the values
    are the reference's."""
    rows = [{"type": "revolute", "a": 0.1 + 0.05 * (k % 3), "d": 0.05, "alpha": ("1.5708", "0", "-1.5708")[k % 3]}
            for k in range(12)]
    chain = dh_table("dense12", "standard", rows, tool={"xyz": [0.0, 0.02, 0.1]})
    g = generate(chain, langs="python", out=None, functions="pose,jacobian,jacobian_dot,kinematics")
    module = load_python(g.sources["dense12.py"], "dense12")
    q, dq, ddq = _random_state(chain, 10, seed=3)
    ref = _reference(chain, q, dq, ddq)
    T, J, dJ, twist, acc = module.kinematics(q, dq, ddq)
    for got, want in ((T, ref.T), (J, ref.J), (dJ, ref.dJ), (twist, ref.twist), (acc, ref.acc),
                      (module.pose(q), ref.T), (module.jacobian(q), ref.J), (module.jacobian_dot(q, dq), ref.dJ)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * max(1.0, np.abs(want).max()))


@pytest.mark.fresh_derivation  # times the derivation itself
def test_generation_stays_linear_and_fast():
    import time

    rows = [{"type": "revolute", "a": 0.1 * (1 + i % 3), "alpha": ["pi/2", "0", "-pi/2"][i % 3], "d": 0.05} for i in range(24)]
    chain = dh_table("chain24", "standard", rows)
    start = time.perf_counter()
    kin = next(p for p in generate(chain, langs="c", out=None).programs if p.name == "kinematics")
    assert time.perf_counter() - start < 30  # a bound against accidental blow-ups, not a benchmark
    assert kin.ops.sin == kin.ops.cos == 24
    assert kin.ops.arithmetic < 24 * 120


def test_joint_limits_are_emitted_in_input_order():
    from skelarm_sym.models.chain.dh_file import load_robot_file

    chain = load_robot_file(ROBOTS / "panda.toml")
    limits = chain.limits()
    g = generate(chain, out=None, functions="pose")  # the limits are module constants, whatever functions are emitted
    module = load_python(g.sources["panda.py"], "panda")
    np.testing.assert_array_equal(module.Q_MIN, np.array(limits["lower"], dtype=float))
    np.testing.assert_array_equal(module.Q_MAX, np.array(limits["upper"], dtype=float))
    np.testing.assert_array_equal(module.DQ_MAX, np.array(limits["velocity"], dtype=float))
    header = g.sources["panda.h"]
    values = header.split("#define PANDA_Q_MAX {")[1].split("}")[0]
    np.testing.assert_array_equal([float(v) for v in values.split(",")], limits["upper"])
    assert "Joint limits (Q_MIN, Q_MAX, DQ_MAX; -: none): " + chain.coordinates[0] in header
    # a C program can use the initialiser
    import shutil
    import subprocess
    import tempfile

    if shutil.which("cc"):
        with tempfile.TemporaryDirectory() as tmp:
            Path(tmp, "panda.h").write_text(header)
            Path(tmp, "use.c").write_text('#include "panda.h"\nint main(void) { static const double hi[7] = PANDA_Q_MAX; return hi[3] < 0.0 ? 0 : 1; }\n')
            assert subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "use.c", "-o", "use"], cwd=tmp).returncode == 0
            assert subprocess.run([str(Path(tmp, "use"))]).returncode == 0


def test_a_joint_with_a_theta_offset_keeps_its_limits():
    """A DH row's limits bound its joint variable, whatever its ``theta`` offset: ABB IRB 140's axis 2 (theta
    -pi/2, limits -90 to +110 degrees) lost them, so its Q_MIN/Q_MAX entries read unbounded and the IK did
    not clamp it."""
    from skelarm_sym.models.chain.dh_file import load_robot_file

    chain = load_robot_file(ROBOTS / "abb_irb140.toml")
    g = generate(chain, out=None, langs="python", functions="pose")
    module = load_python(g.sources["abb_irb140.py"], "abb_irb140")
    assert module.Q_MIN[1] == pytest.approx(-np.pi / 2, abs=1e-15)
    assert module.Q_MAX[1] == pytest.approx(np.radians(110), abs=1e-15)
    assert np.all(np.isfinite(module.Q_MIN)) and np.all(np.isfinite(module.Q_MAX))


def test_urdf_angles_written_as_rounded_multiples_of_half_pi_are_exact(tmp_path):
    from skelarm_sym.models.chain.urdf import load_urdf

    urdf = tmp_path / "r.urdf"
    urdf.write_text("""<robot name="r"><link name="a"/><link name="b"/><link name="c"/>
      <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.1" rpy="1.57079632679 0 3.14159265"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0.2 0 0" rpy="1.5708 0 0"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>""")
    chain = load_urdf(urdf)
    assert all(e.is_Integer for e in chain.joints[0].before.rotation)  # 11 and 8 decimals: snapped
    assert not all(e.is_Integer for e in chain.joints[1].before.rotation)  # 4 decimals: kept as written


def test_product_with_identity_is_the_general_product():
    """``Transform @`` returns the other factor when one is the exact identity and the other holds only
    numbers; the general product (multiplied, expanded, folded) gives the same entries, precision included.
    With symbols the general product runs: an unexpanded entry comes back expanded."""
    def general(a: Transform, b: Transform) -> list[str]:
        rotation = (a.rotation * b.rotation).applyfunc(lambda e: sp.expand(e))
        translation = (a.rotation * b.translation + a.translation).applyfunc(lambda e: sp.expand(e))
        return [sp.srepr(x) for x in list(Transform(rotation, translation).rotation) + list(Transform(rotation, translation).translation)]

    def entries(t: Transform) -> list[str]:
        return [sp.srepr(x) for x in list(t.rotation) + list(t.translation)]

    one = Transform.identity()
    numeric = Transform.from_xyz_rpy([0.1, 0.0, -0.25], [0.0, 0.0, -0.785398163397])  # Panda's TCP: 17-digit floats
    for a, b in ((one, numeric), (numeric, one), (one, Transform.rotate("x", sp.pi / 2)), (one, one)):
        product = a @ b
        assert entries(product) == general(a, b)
    assert (one @ numeric) is numeric and (numeric @ one) is numeric
    a, b, c = sp.symbols("a b c", real=True)
    symbolic = Transform(translation=sp.ImmutableMatrix([a * (b + c), 0, 0]))
    assert (one @ symbolic).translation[0] == a * b + a * c
