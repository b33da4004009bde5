"""The PyTorch and JAX backends beyond the conformance test (issue 20): robot-file text stays data in
their modules, the 64-bit random-number generator they emulate with 32-bit halves draws exactly the
NumPy module's numbers (the restarts of ik_solve depend on it), the batched solvers give each problem
the NumPy solver's outcome, and the PyTorch example of docs/gpu-and-autodiff.md runs.

Cases that need PyTorch or JAX skip with the reason when it is not installed; the text checks need
neither."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym import reference
from skelarm_sym.build import load_python
from skelarm_sym.generate import generate
from skelarm_sym.models import PlanarArm
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "robots"
HOSTILE = sorted(p.name for p in FIXTURES.iterdir() if p.suffix in (".urdf", ".toml"))


def _torch():
    return pytest.importorskip("torch", reason="PyTorch is not installed: pip install 'skelarm-sym[torch]'")


def _jax():
    jax = pytest.importorskip("jax", reason="JAX is not installed: pip install 'skelarm-sym[jax]'")
    jax.config.update("jax_enable_x64", True)
    return jax


@pytest.mark.parametrize("fixture", HOSTILE)
def test_robot_file_text_reaches_the_modules_only_escaped(fixture, tmp_path, monkeypatch):
    chain = load_robot(FIXTURES / fixture)
    g = generate(chain, langs="torch,jax", out=None, prefix="fixture", functions="pose")
    texts = [chain.name, chain.description, *chain.coordinates, *(j.name for j in chain.joints)]
    for name, text in g.sources.items():
        bad = sorted({ch for ch in text if not (32 <= ord(ch) < 127 or ch == "\n")})
        assert bad == [], (name, bad)
        for foreign in filter(None, texts):
            if any(s in foreign for s in ('"', "\\")) or any(ord(ch) >= 127 for ch in foreign):
                assert foreign not in text, (name, foreign)
    monkeypatch.chdir(tmp_path)
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.0, 1.0, (4, chain.n))
    params = rng.uniform(0.2, 1.2, len(chain.parameters))
    args = (params,) if chain.parameters else ()
    want = reference.chain_kinematics(chain.numeric(params if chain.parameters else None), q).T
    for lang in ("torch", "jax"):
        if lang == "torch":
            _torch()
        else:
            _jax()
        module = load_python(g.sources[f"fixture_{lang}.py"], f"fixture_{lang}")
        assert not any(tmp_path.iterdir())  # importing ran nothing written in the robot file
        assert chain.description in module.__doc__ or not chain.description
        np.testing.assert_allclose(np.asarray(module.pose(q, *args)), want, rtol=0, atol=1e-12)


def _xorshift_star(state: int, count: int) -> list[int]:
    """xorshift64* in Python integers (the generator's definition): the 53-bit numbers it draws."""
    out = []
    mask = (1 << 64) - 1
    for _ in range(count):
        state ^= state >> 12
        state ^= (state << 25) & mask
        state ^= state >> 27
        out.append(((state * 0x2545F4914F6CDD1D) & mask) >> 11)
    return out


SEEDS = [0x9E3779B921A722F8, 1, (1 << 64) - 1, 0x8000000000000001, 0x123456789ABCDEF0]


def _draws(module, halves_dtype, backend, count: int = 200) -> np.ndarray:
    """The 53-bit numbers the module's helpers draw from each seed, as float64 (exact)."""
    xp = backend
    out = []
    for seed in SEEDS:
        s = (xp.asarray([seed >> 32], dtype=halves_dtype), xp.asarray([seed & 0xFFFFFFFF], dtype=halves_dtype))
        row = []
        for _ in range(count):
            s = module._u64_xor(s, module._u64_shr(s, 12))
            s = module._u64_xor(s, module._u64_shl(s, 25))
            s = module._u64_xor(s, module._u64_shr(s, 27))
            word = module._u64_shr(module._u64_mul(s, (0x2545F491, 0x4F6CDD1D)), 11)
            row.append(float(np.asarray(module._u64_real(word, xp.float64))[0]))
        out.append(row)
    return np.array(out)


def test_torch_draws_the_generators_numbers_exactly():
    torch = _torch()
    g = generate(load_robot(ROOT / "examples" / "robots" / "ur5.toml"), langs="torch", out=None, prefix="rng",
                 functions="ik_solve")
    module = load_python(g.sources["rng_torch.py"], "rng_torch")
    got = _draws(module, torch.int64, torch)
    want = np.array([[float(x) for x in _xorshift_star(seed, 200)] for seed in SEEDS])
    np.testing.assert_array_equal(got, want)


def test_jax_draws_the_generators_numbers_exactly():
    jax = _jax()
    import jax.numpy as jnp

    g = generate(load_robot(ROOT / "examples" / "robots" / "ur5.toml"), langs="jax", out=None, prefix="rng",
                 functions="ik_solve")
    module = load_python(g.sources["rng_jax.py"], "rng_jax")
    got = _draws(module, jnp.uint32, jnp)
    want = np.array([[float(x) for x in _xorshift_star(seed, 200)] for seed in SEEDS])
    np.testing.assert_array_equal(got, want)
    assert jax.config.jax_enable_x64


def test_jax_rounds_draws_to_float32_once_without_x64(tmp_path):
    """Without x64 JAX has no float64: the 53-bit word is rounded to float32 by hand (top 26 bits and a
    sticky bit); it must equal a single rounding, as C's (float) conversion does."""
    _jax()
    g = generate(PlanarArm(2, (1.0, 0.5)), langs="jax", out=None, prefix="rngf", precision="float")
    g2 = generate(load_robot(ROOT / "examples" / "robots" / "ur5.toml"), langs="jax", out=None, prefix="rngf",
                  precision="float", functions="ik_solve")
    (tmp_path / "rngf_jax.py").write_text(g2.sources["rngf_jax.py"])
    assert g.sources  # the planar float module renders too
    script = textwrap.dedent(f"""
        import sys, numpy as np
        sys.path.insert(0, {str(tmp_path)!r})
        import jax, jax.numpy as jnp
        assert not jax.config.jax_enable_x64
        import rngf_jax as m
        rng = np.random.default_rng(7)
        words = [int(x) for x in rng.integers(0, 2**53, 4000, dtype=np.uint64)]
        words += [2**53 - 1, 2**24 + 1, 2**25 + 3, (2**24 + 1) << 20, ((2**24 + 1) << 20) + 1, 0, 1, 2**32 - 1, 2**32 + 1]
        hi = jnp.asarray([w >> 32 for w in words], dtype=jnp.uint32)
        lo = jnp.asarray([w & 0xFFFFFFFF for w in words], dtype=jnp.uint32)
        got = np.asarray(m._u64_real((hi, lo), jnp.float32))
        want = np.array([np.float32(w) for w in words], dtype=np.float32)
        bad = [(w, g, x) for w, g, x in zip(words, got, want) if g != x]
        print(len(bad), bad[:3])
        sys.exit(1 if bad else 0)
    """)
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                            env={"JAX_ENABLE_X64": "0", "PATH": "/usr/bin:/bin", "JAX_PLATFORMS": "cpu"})
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]


@pytest.mark.parametrize("lang", ["torch", pytest.param("jax", marks=pytest.mark.slow)])  # XLA compiles ik_solve
def test_a_batch_of_ik_problems_ends_as_the_numpy_solver_ends_each(lang):
    """One call over 12 targets (one start shared): every problem's status, iteration count and pose equal
    the NumPy module's for that problem alone; restarts included (the last target is out of reach)."""
    _torch() if lang == "torch" else _jax()
    chain = load_robot(ROOT / "examples" / "robots" / "ur5.toml")
    g = generate(chain, langs=f"python,{lang}", out=None, prefix="batch", functions="ik_solve")
    npm = load_python(g.sources["batch.py"], "batch")
    mod = load_python(g.sources[f"batch_{lang}.py"], f"batch_{lang}")
    rng = np.random.default_rng(11)
    targets = reference.chain_kinematics(chain.numeric(None), rng.uniform(-2.5, 2.5, (12, 6))).T
    targets[-1, 0, 3] += 5.0  # out of reach: its attempts restart until the budget ends
    q0 = rng.uniform(-2.5, 2.5, 6)
    batch = mod.ik_solve(q0, targets, max_iter=60)
    names = [mod.STATUS_NAMES[int(s)] for s in np.asarray(batch.status)]
    singles = [npm.ik_solve(q0, t, max_iter=60) for t in targets]
    assert names == [r.status for r in singles]
    assert np.asarray(batch.iterations).tolist() == [r.iterations for r in singles]
    assert max(r.iterations for r in singles) > 25  # a restart was taken
    np.testing.assert_allclose(np.asarray(batch.q), np.array([r.q for r in singles]), rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.asarray(batch.position_error), [r.position_error for r in singles], rtol=0, atol=1e-9)


def test_torch_solves_float32_problems_of_an_arm_with_an_unlimited_joint():
    """The UR5 URDF's wrist 3 is continuous (no limits): the solver's stand-in for its absent bounds, 1e300, was
    printed as is, and torch.where refused it in a float32 call (``value cannot be converted to type float
    without overflow``). A literal beyond float32 prints as an infinity, which bounds alike."""
    torch = _torch()
    chain = load_robot(ROOT / "examples" / "robots" / "ur5.urdf", tip="tool0")
    assert chain.limits()["upper"][-1] is None
    g = generate(chain, langs="torch", out=None, prefix="open32", functions="ik_solve")
    module = load_python(g.sources["open32_torch.py"], "open32_torch")
    rng = np.random.default_rng(4)
    q = rng.uniform(-3.0, 3.0, (5, 6))
    targets = reference.chain_kinematics(chain.numeric(None), q).T
    start = q + rng.normal(0.0, 0.1, q.shape)
    for dtype, tol in ((torch.float32, 1e-5), (torch.float64, 1e-10)):
        r = module.ik_solve(torch.tensor(start, dtype=dtype), torch.tensor(targets, dtype=dtype), tol=tol)
        assert r.q.dtype == dtype and [module.STATUS_NAMES[int(s)] for s in r.status] == ["converged"] * 5
        assert float(torch.max(r.position_error)) <= tol


_EXAMPLE_RUNS: dict[str, subprocess.CompletedProcess] = {}
"""The run of each example's text: the documents that hold the same example share one run (a new Python process
importing PyTorch and SymPy: 5 s of CPU)."""


@pytest.mark.slow  # a new process importing PyTorch and SymPy
@pytest.mark.parametrize("document", ["README.md", "docs/gpu-and-autodiff.md"])
def test_the_documented_pytorch_example_runs(tmp_path, document):
    _torch()
    text = (ROOT / document).read_text()
    block = re.search(r"<!-- example: pytorch -->\n<!-- not run -->\n```python\n(.*?)```", text, re.S)
    assert block is not None, f"{document} lost its PyTorch example"
    code = block.group(1)
    assert len(code.strip().splitlines()) <= 12
    result = _EXAMPLE_RUNS.get(code)
    if result is None:
        script = tmp_path / "example.py"
        script.write_text(code + "\nprint(tuple(J.shape), float((q.grad - J[..., :3, :].sum(-2)).abs().max()))\n")
        result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=ROOT, timeout=300)
        _EXAMPLE_RUNS[code] = result
    assert result.returncode == 0, result.stderr[-2000:]
    shape, error = result.stdout.strip().splitlines()[-1].rsplit(" ", 1)
    assert shape == "(4096, 6, 6)" and float(error) < 1e-12


def test_each_result_names_its_own_status_codes():
    """A module with ik_solve and ik_all: STATUS_NAMES maps 0 to "converged" (the first solver's name), but ik_all's
    0 is "ok"; IKAllResult's documentation pointed to STATUS_NAMES alone. Each result now names its codes."""
    chain = load_robot(ROOT / "examples" / "robots" / "ur5.toml")
    g = generate(chain, langs="torch,jax", out=None, prefix="names", functions="ik_solve,ik_all")
    for name in ("names_torch.py", "names_jax.py"):
        text = g.sources[name]
        assert 'STATUS_NAMES = {0: "converged"' in text
        assert 'IKAllResult.__doc__ = """Outcome of ik_all' in text and 'IK_OK = 0 "ok", IK_UNREACHABLE = 1 "unreachable"' in text
        assert 'IK_CONVERGED = 0 "converged", IK_STALLED = 1 "stalled"' in text


@pytest.mark.parametrize("lang", ["python", "torch", pytest.param("jax", marks=pytest.mark.slow)])  # XLA compiles ik_solve
def test_a_lambda_per_problem_may_not_add_a_dimension_to_the_batch(lang):
    """A (m, 1) lambda beside m problems broadcast to m x m problems (a (4, 4, 6) result for 4 configurations): a
    column of lambdas is read as one per problem elsewhere, so it is refused, naming the shape to give. (m,) and a
    single number are one per problem and one for all; beside one problem, a (k,) lambda still makes k."""
    if lang == "torch":
        _torch()
    elif lang == "jax":
        _jax()
    chain = load_robot(ROOT / "examples" / "robots" / "ur5.toml")
    g = generate(chain, langs=f"python,{lang}" if lang != "python" else "python", out=None, prefix="lam",
                 functions="pose,inverse_velocity,ik_solve")
    npm = load_python(g.sources["lam.py"], "lam")
    mod = npm if lang == "python" else load_python(g.sources[f"lam_{lang}.py"], f"lam_{lang}")
    rng = np.random.default_rng(3)
    q, v = rng.uniform(-2.0, 2.0, (4, 6)), rng.uniform(-1.0, 1.0, (4, 6))
    targets = npm.pose(q)
    column = np.full((4, 1), 0.1)
    calls = [lambda lam: mod.ik_solve(q, targets, lam, max_iter=3).q]
    if lang != "python":  # the NumPy module's inverse_velocity takes one lambda for the batch
        calls.append(lambda lam: mod.inverse_velocity(q, v, lam))
    for call in calls:
        with pytest.raises(ValueError, match=r"lambda has shape \(4, 1\), more dimensions than the batch \(4,\).*\(4,\)"):
            call(column)
        assert np.asarray(call(column[:, 0])).shape == (4, 6)
        assert np.asarray(call(0.1)).shape == (4, 6)
    assert np.asarray(mod.ik_solve(q[0], targets[0], np.array([0.0, 0.1, 1.0]), max_iter=3).q).shape == (3, 6)
