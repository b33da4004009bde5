"""Autodiff through the emitted PyTorch and JAX modules (issue 20): differentiating the emitted pose must
give the emitted Jacobian, and differentiating the emitted Jacobian along dq the emitted dJ/dt, to 1e-12
in double precision; the function transforms (torch.func.vmap, torch.compile, jax.jit, jax.vmap) must
give the numbers of the plain call. The pose and the Jacobian are derived separately (SymPy, then two
straight-line programs), so agreement is a real check of both, and of the backends' autodiff-friendly
form. UR5 and Panda come from examples/robots; the planar arm takes its link lengths as an argument.

Each backend's cases skip with the reason when its library is not installed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from skelarm_sym.build import load_python
from skelarm_sym.generate import generate
from skelarm_sym.models import PlanarArm
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = {
    "ur5": lambda: load_robot(ROOT / "examples" / "robots" / "ur5.toml"),
    "panda": lambda: load_robot(ROOT / "examples" / "robots" / "panda.toml"),
    "planar": lambda: PlanarArm(3),
}
TOL = 1e-12


@pytest.fixture(scope="module", params=list(ROBOTS))
def robot(request):
    """(name, generated set with NumPy, PyTorch and JAX sources, NumPy module)."""
    name = request.param
    g = generate(ROBOTS[name](), langs="python,torch,jax", out=None, prefix=f"ad_{name}",
                 functions="position,jacobian,coriolis" if name == "planar" else "pose,jacobian,jacobian_dot")
    return name, g, load_python(g.sources[f"ad_{name}.py"], f"ad_{name}")


def _inputs(name: str, batch: int = 5, seed: int = 3):
    rng = np.random.default_rng(seed)
    n = {"ur5": 6, "panda": 7, "planar": 3}[name]
    q = rng.uniform(-2.5, 2.5, (batch, n))
    dq = rng.uniform(-1.5, 1.5, (batch, n))
    extra = (rng.uniform(0.5, 1.5, n),) if name == "planar" else ()
    return q, dq, extra


def _names(name: str):
    """(position function, its slice to the position, Jacobian rows of the position, dJ function)."""
    if name == "planar":
        return "position", (lambda p: p), 2, "coriolis"
    return "pose", (lambda T: T[..., :3, 3]), 3, "jacobian_dot"


# -- PyTorch -------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def torch_module(robot):
    torch = pytest.importorskip("torch", reason="PyTorch is not installed: pip install 'skelarm-sym[torch]'")
    name, g, reference = robot
    return torch, name, load_python(g.sources[f"ad_{name}_torch.py"], f"ad_{name}_torch"), reference


def test_torch_gradient_of_the_position_is_the_jacobian(torch_module):
    torch, name, mod, reference = torch_module
    position, part, rows, _ = _names(name)
    q, _, extra = _inputs(name)
    extra_t = tuple(torch.as_tensor(x) for x in extra)
    pos = getattr(mod, f"{position}_unchecked")
    for qi in q:
        qt = torch.as_tensor(qi, dtype=torch.float64)
        auto = torch.autograd.functional.jacobian(lambda x: part(pos(x, *extra_t)), qt)
        J = mod.jacobian(qt, *extra_t)[:rows]
        np.testing.assert_allclose(auto.numpy(), J.numpy(), rtol=0, atol=TOL)
        np.testing.assert_allclose(J.numpy(), reference.jacobian(qi, *extra)[:rows], rtol=0, atol=TOL)


def test_torch_derivative_of_the_jacobian_along_dq_is_dj(torch_module):
    torch, name, mod, reference = torch_module
    _, _, _, dj = _names(name)
    q, dq, extra = _inputs(name)
    extra_t = tuple(torch.as_tensor(x) for x in extra)
    jac = lambda x: mod.jacobian_unchecked(x, *extra_t)  # noqa: E731
    qt, dqt = torch.as_tensor(q), torch.as_tensor(dq)
    _, tangent = torch.func.jvp(jac, (qt,), (dqt,))  # the whole batch at once
    want = getattr(mod, dj)(qt, dqt, *extra_t)
    np.testing.assert_allclose(tangent.numpy(), want.numpy(), rtol=0, atol=TOL)
    np.testing.assert_allclose(want.numpy(), getattr(reference, dj)(q, dq, *extra), rtol=0, atol=TOL)
    # and by reverse mode, one configuration: d(J dq)/dq contracted the other way round
    J_dq = lambda x: (mod.jacobian_unchecked(x, *extra_t) @ dqt[0])  # noqa: E731
    full = torch.autograd.functional.jacobian(J_dq, qt[0])  # d(J dq)/dq = sum_j dJ/dq_j dq... (rows x n)
    np.testing.assert_allclose((full @ dqt[0]).numpy(), (want[0] @ dqt[0]).numpy(), rtol=0, atol=TOL)


def test_torch_vmap_gives_the_batched_numbers(torch_module):
    torch, name, mod, _ = torch_module
    position, _, _, dj = _names(name)
    q, dq, extra = _inputs(name, batch=7)
    extra_t = tuple(torch.as_tensor(x) for x in extra)
    qt, dqt = torch.as_tensor(q), torch.as_tensor(dq)
    for fname, args in ((position, (qt,)), ("jacobian", (qt,)), (dj, (qt, dqt))):
        f = getattr(mod, f"{fname}_unchecked")
        mapped = torch.func.vmap(lambda *a: f(*a, *extra_t))(*args)
        np.testing.assert_allclose(mapped.numpy(), f(*args, *extra_t).numpy(), rtol=0, atol=1e-14, err_msg=fname)
    # the checked function too: its value checks stand aside under vmap
    mapped = torch.func.vmap(lambda x: mod.jacobian(x, *extra_t))(qt)
    np.testing.assert_allclose(mapped.numpy(), mod.jacobian(qt, *extra_t).numpy(), rtol=0, atol=1e-14)


def test_torch_float32_keeps_its_dtype_and_device(torch_module):
    torch, name, mod, reference = torch_module
    position, part, _, _ = _names(name)
    q, _, extra = _inputs(name)
    extra_t = tuple(torch.as_tensor(x, dtype=torch.float32) for x in extra)
    out = mod.jacobian(torch.as_tensor(q, dtype=torch.float32), *extra_t)
    assert out.dtype == torch.float32 and out.device.type == "cpu"
    np.testing.assert_allclose(out.numpy(), reference.jacobian(q.astype(np.float32), *extra), rtol=0, atol=2e-5)


@pytest.mark.slow  # torch.compile: a C++ compile
def test_torch_compile_gives_the_same_numbers(torch_module):
    torch, name, mod, _ = torch_module
    if name != "ur5":
        pytest.skip("torch.compile is checked on one robot (a compile takes tens of seconds on two cores)")
    position, _, _, _ = _names(name)
    q, _, _ = _inputs(name, batch=64)
    qt = torch.as_tensor(q)
    try:
        compiled = torch.compile(getattr(mod, f"{position}_unchecked"), fullgraph=True)
        got = compiled(qt)
    except Exception as exc:  # no C++ compiler, an inductor that does not run on this build, ...
        pytest.skip(f"torch.compile does not run on this machine: {type(exc).__name__}: {str(exc).splitlines()[0][:200]}")
    want = getattr(mod, f"{position}_unchecked")(qt)
    np.testing.assert_allclose(got.numpy(), want.numpy(), rtol=0, atol=TOL)


# -- JAX -----------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def jax_module(robot):
    jax = pytest.importorskip("jax", reason="JAX is not installed: pip install 'skelarm-sym[jax]'")
    jax.config.update("jax_enable_x64", True)
    name, g, reference = robot
    return jax, name, load_python(g.sources[f"ad_{name}_jax.py"], f"ad_{name}_jax"), reference


def test_jax_jacfwd_of_the_position_is_the_jacobian(jax_module):
    jax, name, mod, reference = jax_module
    position, part, rows, _ = _names(name)
    q, _, extra = _inputs(name)
    pos = getattr(mod, f"{position}_unchecked")
    auto = jax.vmap(jax.jacfwd(lambda x: part(pos(x, *extra))))(q)
    J = np.asarray(mod.jacobian(q, *extra))[:, :rows]
    assert np.asarray(auto).dtype == np.float64
    np.testing.assert_allclose(np.asarray(auto), J, rtol=0, atol=TOL)
    np.testing.assert_allclose(J, reference.jacobian(q, *extra)[:, :rows], rtol=0, atol=TOL)
    rev = jax.jacrev(lambda x: part(pos(x, *extra)))(q[0])
    np.testing.assert_allclose(np.asarray(rev), J[0], rtol=0, atol=TOL)


def test_jax_derivative_of_the_jacobian_along_dq_is_dj(jax_module):
    jax, name, mod, reference = jax_module
    _, _, _, dj = _names(name)
    q, dq, extra = _inputs(name)
    _, tangent = jax.jvp(lambda x: mod.jacobian_unchecked(x, *extra), (q,), (dq,))
    want = np.asarray(getattr(mod, dj)(q, dq, *extra))
    np.testing.assert_allclose(np.asarray(tangent), want, rtol=0, atol=TOL)
    np.testing.assert_allclose(want, getattr(reference, dj)(q, dq, *extra), rtol=0, atol=TOL)


def test_jax_jit_and_vmap_give_the_plain_numbers(jax_module):
    jax, name, mod, _ = jax_module
    position, _, _, dj = _names(name)
    q, dq, extra = _inputs(name, batch=7)
    for fname, args in ((position, (q,)), ("jacobian", (q,)), (dj, (q, dq))):
        f = getattr(mod, f"{fname}_unchecked")
        plain = np.asarray(f(*args, *extra))
        np.testing.assert_allclose(np.asarray(jax.jit(f)(*args, *extra)), plain, rtol=0, atol=TOL, err_msg=fname)
        mapped = jax.vmap(lambda *a: f(*a, *extra))(*args)
        np.testing.assert_allclose(np.asarray(mapped), plain, rtol=0, atol=TOL, err_msg=fname)
    mapped = jax.jit(jax.vmap(lambda x: mod.jacobian(x, *extra)))(q)  # the checked function under tracing
    np.testing.assert_allclose(np.asarray(mapped), np.asarray(mod.jacobian(q, *extra)), rtol=0, atol=TOL)


# -- singular poses ------------------------------------------------------------------------------------------


def _singular_module(lang: str):
    """The Panda's manipulability, its gradient and the damped inverse velocity in ``lang`` and NumPy."""
    g = generate(load_robot(ROOT / "examples" / "robots" / "panda.toml"), langs=f"python,{lang}", out=None,
                 prefix=f"sg_{lang}", functions="manipulability,manipulability_gradient,inverse_velocity")
    return load_python(g.sources[f"sg_{lang}_{lang}.py"], f"sg_{lang}_{lang}"), load_python(g.sources[f"sg_{lang}.py"], f"sg_{lang}")


def test_torch_gradients_at_a_singular_pose_are_finite():
    """At q = 0 (the Panda stretched: singular) the forward values are finite, but autograd gave NaN for every
    joint of manipulability and inverse_velocity: sqrt's gradient at 0 is inf, and the branch a where leaves out
    is multiplied by 0 (0 * inf = NaN), which poisons a training loop started at the home pose. The modules' sqrt
    has gradient 0 at 0: w's gradient there is the emitted manipulability_gradient's (0), and away from the
    singular pose it is still that gradient."""
    torch = pytest.importorskip("torch", reason="PyTorch is not installed: pip install 'skelarm-sym[torch]'")
    module, numpy_module = _singular_module("torch")
    for q0 in (np.zeros(7), np.random.default_rng(5).uniform(-1.5, 1.5, 7)):
        q = torch.tensor(q0, dtype=torch.float64, requires_grad=True)
        module.manipulability(q).sum().backward()
        np.testing.assert_allclose(q.grad.numpy(), numpy_module.manipulability_gradient(q0), rtol=0, atol=1e-12)
        q = torch.tensor(q0, dtype=torch.float64, requires_grad=True)
        module.inverse_velocity(q, torch.ones(7 - 1, dtype=torch.float64), 0.0).sum().backward()
        assert bool(torch.all(torch.isfinite(q.grad)))


def test_jax_gradients_at_a_singular_pose_are_finite():
    """The same through jax.grad of the unchecked functions."""
    pytest.importorskip("jax", reason="JAX is not installed: pip install 'skelarm-sym[jax]'")
    import jax
    import jax.numpy as jnp

    jax.config.update("jax_enable_x64", True)
    module, numpy_module = _singular_module("jax")
    for q0 in (np.zeros(7), np.random.default_rng(5).uniform(-1.5, 1.5, 7)):
        grad = jax.grad(lambda q: jnp.sum(module.manipulability_unchecked(q)))(jnp.asarray(q0))
        np.testing.assert_allclose(np.asarray(grad), numpy_module.manipulability_gradient(q0), rtol=0, atol=1e-12)
        grad = jax.grad(lambda q: jnp.sum(module.inverse_velocity_unchecked(q, jnp.ones(6), 0.0)))(jnp.asarray(q0))
        assert bool(jnp.all(jnp.isfinite(grad)))
