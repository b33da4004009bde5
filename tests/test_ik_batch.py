"""Solvers over a batch of problems: the C ``_batch`` of every public solver (``ik_all``, ``ik_nearest``,
``ik_solve``), the NumPy module's masked batches (targets ``(..., 4, 4)`` -> ``q`` ``(..., S, N)`` with NaN rows
past ``count``) and the compiled wrapper's batches.

Each problem of a batch is judged against the same problem solved alone (the C single call, bit for bit; the
NumPy single call, whose scalar code shares no statement with the masked program), and every returned row
against the independent forward recursion (``models/chain/reference_ik_all.pose_error``)."""

from __future__ import annotations

import ctypes
import functools

import numpy as np
import pytest

from skelarm_sym.build import compile_arm, load_python
from skelarm_sym.generate import generate
from skelarm_sym.models.chain import reference_ik_all as judge
from skelarm_sym.models.chain.lock import with_ik_lock

from closed_ik_support import load_arm, random_configurations, targets_of

DP = ctypes.POINTER(ctypes.c_double)
IP = ctypes.POINTER(ctypes.c_int)


class Solvers:
    """One arm's solvers in C (ctypes library and wrapper) and NumPy."""

    def __init__(self, name: str, functions: str) -> None:
        chain, lock = load_arm(name)
        if lock is not None:
            chain = with_ik_lock(chain, lock + 1)
        self.chain, self.n = chain, chain.n
        self.lock = None if lock is None else chain.joints[lock].coordinate
        self.generated = generate(chain, out=None, functions=functions)
        self.prefix = self.generated.module.prefix
        self.c = compile_arm(self.generated)
        self.py = load_python(self.generated.sources[f"{self.prefix}.py"], self.prefix)
        self.numeric = chain.numeric()

    def raw(self, name: str):
        return getattr(self.c._lib, f"{self.prefix}_{name}")


@functools.lru_cache(maxsize=None)
def solvers(name: str, functions: str = "ik_solve,ik_all,ik_nearest") -> Solvers:
    return Solvers(name, functions)


def problems(s: Solvers, m: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    q = random_configurations(s.chain, m, np.random.default_rng(seed), within_limits=True)
    return q, targets_of(s.chain, q)


def pointer(x: np.ndarray, kind=DP):
    return x.ctypes.data_as(kind)


def test_c_ik_all_batch_is_each_single_call_bit_for_bit():
    """X_ik_all_batch over 40 targets (a few of them not rotations, one out of reach) writes, per problem, exactly
    what X_ik_all writes; count, flags and status may be NULL."""
    s = solvers("puma560")
    q, T = problems(s, 40, 1)
    T = T.copy()
    T[3, :3, :3] *= 1.01  # not a rotation: INVALID for that problem only
    T[7, :3, 3] *= 50.0  # far out of reach
    m, S = len(T), 8
    flat = np.ascontiguousarray(T.reshape(m, 16))
    rows = np.full((m, S * s.n), 7.0)
    count, flags, status = np.full(m, -5, np.intc), np.full((m, S), -5, np.intc), np.full(m, -5, np.intc)
    s.raw("ik_all_batch")(ctypes.c_size_t(m), pointer(flat), pointer(rows), pointer(count, IP), pointer(flags, IP), pointer(status, IP))
    seen = set()
    for j in range(m):
        one, c1, f1 = np.full(S * s.n, 7.0), ctypes.c_int(-5), np.full(S, -5, np.intc)
        code = s.raw("ik_all")(pointer(flat[j]), pointer(one), ctypes.byref(c1), pointer(f1, IP))
        assert status[j] == code and count[j] == c1.value
        assert np.array_equal(rows[j], one, equal_nan=True) and np.array_equal(flags[j], f1)
        seen.add(int(code))
    assert seen >= {0, 1, 3}, seen  # ok, unreachable and invalid problems were all in the batch
    again = np.zeros_like(rows)
    s.raw("ik_all_batch")(ctypes.c_size_t(m), pointer(flat), pointer(again), None, None, None)
    assert np.array_equal(again, rows, equal_nan=True)


def test_c_solver_batches_share_scalars_and_match_single_calls():
    """X_ik_solve_batch (shared lambda, tol, max_iter; optional error and iterations NULL or not) and
    X_ik_nearest_batch equal their single calls problem by problem."""
    s = solvers("puma560")
    q, T = problems(s, 12, 2)
    m = len(T)
    flat = np.ascontiguousarray(T.reshape(m, 16))
    q0 = np.ascontiguousarray(q + np.random.default_rng(3).normal(0.0, 0.3, q.shape))
    out, error, iters, status = np.zeros((m, s.n)), np.zeros((m, 2)), np.zeros(m, np.intc), np.zeros(m, np.intc)
    args = (ctypes.c_double(1e-3), ctypes.c_double(1e-10), ctypes.c_int(100))
    s.raw("ik_solve_batch")(ctypes.c_size_t(m), pointer(q0), pointer(flat), *args, pointer(out), pointer(error), pointer(iters, IP),
                            pointer(status, IP))
    for j in range(m):
        one, e1, i1 = np.zeros(s.n), np.zeros(2), ctypes.c_int(0)
        code = s.raw("ik_solve")(pointer(q0[j]), pointer(flat[j]), *args, pointer(one), pointer(e1), ctypes.byref(i1))
        assert (code, i1.value) == (status[j], iters[j]) and np.array_equal(one, out[j]) and np.array_equal(e1, error[j])
    bare = np.zeros_like(out)
    s.raw("ik_solve_batch")(ctypes.c_size_t(m), pointer(q0), pointer(flat), *args, pointer(bare), None, None, None)
    assert np.array_equal(bare, out)
    near, codes = np.zeros((m, s.n)), np.zeros(m, np.intc)
    s.raw("ik_nearest_batch")(ctypes.c_size_t(m), pointer(q0), pointer(flat), pointer(near), pointer(codes, IP))
    for j in range(m):
        one = np.zeros(s.n)
        assert s.raw("ik_nearest")(pointer(q0[j]), pointer(flat[j]), pointer(one)) == codes[j]
        assert np.array_equal(one, near[j], equal_nan=True)


@pytest.mark.parametrize("impl", ["numpy", "compiled"])
def test_ik_all_over_a_batch_shape(impl):
    """Targets (5, 6, 4, 4) give q (5, 6, 8, N), count and status (5, 6), flags (5, 6, 8); each problem equals its
    single call (bit for bit), NaN rows past count, and every row reproduces its target (forward recursion)."""
    s = solvers("puma560")
    q, T = problems(s, 30, 4)
    arm = s.py if impl == "numpy" else s.c
    r = arm.ik_all(T.reshape(5, 6, 4, 4))
    assert r.q.shape == (5, 6, 8, s.n) and r.count.shape == (5, 6) and r.status.shape == (5, 6) and r.flags.shape == (5, 6, 8)
    q_flat, count, status, flags = r.q.reshape(30, 8, s.n), r.count.reshape(30), r.status.reshape(30), r.flags.reshape(30, 8)
    for j in range(30):
        one = arm.ik_all(T[j])
        assert (one.status, one.count) == (status[j], count[j])
        assert np.array_equal(one.q, q_flat[j], equal_nan=True) and np.array_equal(one.flags, flags[j])
        rows = q_flat[j, : count[j]]
        assert np.all(np.isnan(q_flat[j, count[j]:]))
        pos, rot = judge.pose_error(s.numeric, rows, T[j])
        assert max(pos.max(), rot.max()) <= 1e-12
        # the configuration the target was made from is among the rows (modulo 2 pi)
        d = (rows - q[j] + np.pi) % (2 * np.pi) - np.pi
        assert np.min(np.max(np.abs(d), axis=1)) <= 1e-7
    assert np.all(status == "ok")


def test_numpy_and_c_batches_agree_and_broadcast():
    """The NumPy masked batch and the C batch agree (statuses and counts exactly, rows to 1e-12); one q_ref
    broadcasts over many targets in ik_nearest and one start over many targets in ik_solve."""
    s = solvers("puma560")
    q, T = problems(s, 25, 5)
    a, b = s.py.ik_all(T), s.c.ik_all(T)
    assert np.array_equal(a.status, b.status) and np.array_equal(a.count, b.count) and np.array_equal(a.flags, b.flags)
    np.testing.assert_allclose(a.q, b.q, atol=1e-12, rtol=0)
    near = s.py.ik_nearest(q[0], T)
    assert near.q.shape == (25, s.n)
    for j in (0, 7, 24):
        one = s.py.ik_nearest(q[0], T[j])
        assert one.status == near.status[j] and np.array_equal(one.q, near.q[j], equal_nan=True)
    assert np.allclose(near.q[0], q[0], atol=1e-7)  # the nearest solution to a target's own configuration is it
    q0 = q[0] + 0.05
    for arm in (s.py, s.c):
        r = arm.ik_solve(q0, T[:6], 0.0, 1e-10, 100)
        assert r.q.shape == (6, s.n) and r.iterations.shape == (6,) and r.position_error.shape == (6,)
        for j in range(6):
            one = arm.ik_solve(q0, T[j], 0.0, 1e-10, 100)
            assert (one.status, one.iterations) == (r.status[j], r.iterations[j]) and np.array_equal(one.q, r.q[j])


@pytest.mark.parametrize("impl", ["numpy", "compiled"])
def test_locked_joint_per_problem(impl):
    """iiwa 14 with joint 3 locked: a lock value per problem (one target, 16 locks; the C batch shares
    scalars, so the wrapper calls once per problem) gives rows that hold joint 3 at its lock and reproduce the
    target; each equals its single call."""
    s = solvers("iiwa14_lock3", "ik_all")
    q, T = problems(s, 1, 6)
    locks = np.linspace(-2.0, 2.0, 16)
    arm = s.py if impl == "numpy" else s.c
    r = arm.ik_all(T[0], locks)
    assert r.q.shape == (16, 8, s.n)
    assert r.count.sum() > 16  # several locks reach the target with several branches
    for j, lock in enumerate(locks):
        one = arm.ik_all(T[0], lock)
        assert one.count == r.count[j] and np.array_equal(one.q, r.q[j], equal_nan=True)
        rows = r.q[j, : r.count[j]]
        assert np.all(rows[:, s.lock] == lock)
        if len(rows):
            pos, rot = judge.pose_error(s.numeric, rows, T[0])
            assert max(pos.max(), rot.max()) <= 1e-11
    shared = arm.ik_all(T[0][None].repeat(3, 0), float(locks[5]))
    assert np.array_equal(shared.q[2], r.q[5], equal_nan=True)


@pytest.mark.parametrize("impl", ["numpy", "compiled"])
def test_batch_input_errors_name_the_problem(impl):
    """A batch with a target that is not a rotation raises ValueError naming that problem; shapes that do not
    broadcast and a (4, 15) target are one-line ValueErrors naming the argument; (m, 16) targets are a batch;
    an empty batch returns empty arrays."""
    s = solvers("puma560")
    q, T = problems(s, 4, 7)
    arm = s.py if impl == "numpy" else s.c
    bad = T.copy()
    bad[2, 0, 0] += 0.1
    with pytest.raises(ValueError, match=r"ik_all: problem \(2,\)"):
        arm.ik_all(bad)
    with pytest.raises(ValueError, match="broadcast"):
        arm.ik_nearest(q[:3], T)
    with pytest.raises(ValueError, match=r"target must have shape \(4, 4\)"):
        arm.ik_all(T.reshape(4, 16)[:, :15])
    flat = arm.ik_all(T.reshape(4, 16))  # targets stored flat, as the C batch takes them
    assert np.array_equal(flat.q, arm.ik_all(T).q, equal_nan=True) and flat.q.shape == (4, 8, s.n)
    nan = T.copy()
    nan[1, 0, 3] = np.nan
    with pytest.raises(ValueError, match="target must be finite"):
        arm.ik_all(nan)
    empty = arm.ik_all(np.zeros((0, 4, 4)))
    assert empty.q.shape == (0, 8, s.n) and empty.status.shape == (0,) and empty.count.shape == (0,)


def test_planar_solver_batch_with_default_tolerance():
    """A planar arm's ik_solve, whose tol defaults to a multiple of the arm's reach: per-problem link lengths
    give a per-problem default; each problem equals its single call in NumPy and through the C wrapper."""
    generated = generate(3, out=None, functions="ik_solve")
    c = compile_arm(generated)
    py = load_python(generated.sources["arm3.py"], "arm3")
    rng = np.random.default_rng(8)
    l = rng.uniform(0.2, 2.0, (5, 3))
    q = rng.uniform(-2, 2, (5, 3))
    target = np.stack([(l * np.cos(np.cumsum(q, 1))).sum(1), (l * np.sin(np.cumsum(q, 1))).sum(1)], 1)
    for arm in (py, c):
        r = arm.ik_solve(q + 0.1, target, l)
        for j in range(5):
            one = arm.ik_solve(q[j] + 0.1, target[j], l[j])
            assert one.status == r.status[j] and np.array_equal(one.q, r.q[j])
        assert np.all(r.status == "converged")


@pytest.mark.parametrize("language", ["torch", pytest.param("jax", marks=pytest.mark.slow)])  # XLA compiles ik_all
def test_torch_and_jax_ik_all_agree_with_the_numpy_batch(language):
    """The PyTorch and JAX modules' ik_all (the same masked program, their own printers) over 20 targets equal
    the NumPy batch: statuses and counts exactly, rows to 1e-12. (Their loop over the 48 output slots has data
    bounds while an earlier loop over the same counter has constant ones: the counter must stay a value per lane.)"""
    pytest.importorskip(language)
    if language == "jax":
        import jax

        jax.config.update("jax_enable_x64", True)
    s = solvers("puma560")
    q, T = problems(s, 20, 9)
    from skelarm_sym.generate import render_all

    name = f"{s.prefix}_{language}"
    module = load_python(render_all(s.generated.module, (language,), False)[f"{name}.py"], name)
    r, ref = module.ik_all(T), s.py.ik_all(T)
    codes = {"ok": 0, "unreachable": 1, "out_of_limits": 2}
    assert np.array_equal(np.asarray(r.status), [codes[x] for x in ref.status])
    assert np.array_equal(np.asarray(r.count), ref.count)
    np.testing.assert_allclose(np.asarray(r.q), ref.q, atol=1e-12, rtol=0)
