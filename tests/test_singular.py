"""Closed-form minors, det J, manipulability and singular poses; the plot."""

import numpy as np
import pytest
import sympy as sp

from skelarm_sym import reference
from skelarm_sym.models.planar import singular
from skelarm_sym.cli import main
from skelarm_sym import derive


@pytest.mark.parametrize("n", [2, 3, 4])
def test_minor_formula_equals_the_expanded_jacobian(n, rng):
    d = derive(n)
    J = d.J
    for i in range(1, n + 1):
        for j in range(i + 1, n + 1):
            direct = J[0, i - 1] * J[1, j - 1] - J[0, j - 1] * J[1, i - 1]
            # exactly zero as a polynomial in exp(i q_k): rewrite and expand
            diff = sp.expand((direct - singular.minor(d, i, j)).rewrite(sp.exp))
            assert diff == 0, (i, j)


def test_determinants_are_the_seed_closed_forms():
    l1, l2 = sp.symbols("l1 l2", positive=True)
    q2 = sp.Symbol("q2", real=True)
    assert singular.determinant(derive(2)) == l1 * l2 * sp.sin(q2)  # seed 002
    assert singular.determinant(derive(3)) == l1 * l2 * sp.sin(q2)  # det J3: l3 drops out
    assert singular.determinant(derive(4)) is None
    assert derive(2).det == l1 * l2 * sp.sin(q2) and derive(5).det is None  # exposed by derive too
    assert derive(1).manipulability == 0
    # and numerically against NumPy on J3
    rng = np.random.default_rng(4)
    q, l = rng.uniform(-np.pi, np.pi, 3), rng.uniform(0.3, 2, 3)
    want = np.linalg.det(reference.kinematics(q, lengths=l).J3)
    assert want == pytest.approx(l[0] * l[1] * np.sin(q[1]), rel=1e-12)


@pytest.mark.parametrize("n", [2, 3, 5])
def test_manipulability_closed_form_matches_numpy(n, rng):
    d = derive(n)
    w = sp.lambdify([*d.q, *d.l], singular.manipulability(d), "numpy")
    for _ in range(5):
        q, l = rng.uniform(-np.pi, np.pi, n), rng.uniform(0.3, 2, n)
        J = reference.kinematics(q, lengths=l).J
        assert w(*q, *l) == pytest.approx(np.sqrt(np.linalg.det(J @ J.T)), rel=1e-10)


def test_singular_configurations():
    two = singular.singular_configurations(derive(2))
    assert two.solutions["q2"] == sp.FiniteSet(0, sp.pi)  # one turn, (-pi, pi]: -pi is the pose pi
    three = singular.singular_configurations(derive(3))
    assert three.solutions["q2"] == sp.FiniteSet(0, sp.pi)
    assert "checked on all 4" in three.statement
    assert "everywhere" in singular.singular_configurations(derive(1)).statement


def test_show_det_manipulability_singular(capsys):
    assert main(["show", "--links", "2", "--what", "det", "--format", "text"]) == 0
    assert capsys.readouterr().out.strip() == "det J =\nl1*l2*sin(q2)"
    assert main(["show", "--links", "3", "--what", "det", "--format", "text"]) == 0
    assert capsys.readouterr().out.strip() == "det J3 =\nl1*l2*sin(q2)"  # J3: J with the row of ones (phi)
    assert main(["show", "--links", "2", "--what", "manipulability", "--format", "text"]) == 0
    out = capsys.readouterr().out
    assert "w = sqrt(det(J J^T)) =" in out and "l1*l2*Abs(sin(q2))" in out
    assert main(["show", "--links", "2", "--what", "singular"]) == 0
    out = capsys.readouterr().out
    assert "q2 in {0, pi}" in out and "q2 each in {0, pi}" in out  # one turn, each pose once, on both lines


def test_plot_writes_an_image(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    target = tmp_path / "arm.png"
    assert main(["show", "--links", "3", "--lengths", "1,0.8,0.5", "--pose", "0.3,1.2,-0.5", "--plot", str(target)]) == 0
    data = target.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    out = capsys.readouterr().out
    J = reference.kinematics(np.array([0.3, 1.2, -0.5]), lengths=np.array([1, 0.8, 0.5])).J
    w = np.sqrt(np.linalg.det(J @ J.T))
    assert f"w = {w:.6g}" in out
    assert [p.name for p in tmp_path.iterdir()] == ["arm.png"]  # no temporary left


def test_plot_bad_input(tmp_path, capsys):
    assert main(["show", "--links", "3", "--pose", "1,2", "--plot", str(tmp_path / "a.png")]) == 2
    assert "--pose has 2 angles" in capsys.readouterr().err
    assert main(["show", "--links", "2", "--plot", str(tmp_path / "missing" / "a.png")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_plot_without_matplotlib_says_what_to_install(tmp_path, monkeypatch, capsys):
    import builtins

    real_import = builtins.__import__

    def no_matplotlib(name, *args, **kwargs):
        if name.startswith("matplotlib"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_matplotlib)
    assert main(["show", "--links", "2", "--plot", str(tmp_path / "a.png")]) == 2
    assert "pip install 'skelarm-sym[plot]'" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
