"""The CUDA backend (issue 20) beyond the conformance test, which already checks its host build against the
references for every model kind: the kernels' per-thread body against the single calls (indexing of the
structure-of-arrays layout, the solver's kernel), float precision, the three ways the .cu compiles (host
C++ under g++ and clang++, nvcc, NVRTC: each skipped with its reason where the tool is missing), the
Python entry's layout handling and checks (through a stand-in for CuPy that runs the host build, so it is
exercised without a GPU), benchmarks/gpu.py on that stand-in, and the text rules (deterministic, ASCII, robot-file text escaped)."""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym import reference
from skelarm_sym.backends import BACKENDS
from skelarm_sym.backends.cuda.host import HostArm, compile_host, cuda_sources
from skelarm_sym.build import load_python
from skelarm_sym.check import compare
from skelarm_sym.generate import file_stamp, generate
from skelarm_sym.models import PlanarArm
from skelarm_sym.models.chain.loader import load_robot

import cupy_standin

ROOT = Path(__file__).resolve().parents[1]
PANDA = ROOT / "examples" / "robots" / "panda.toml"
HOSTILE = ROOT / "tests" / "fixtures" / "robots" / "hostile_names.toml"
cuda = BACKENDS["cuda"]


def _nvcc() -> str | None:
    found = shutil.which("nvcc")
    if found:
        return found
    for root in (os.environ.get("CUDA_HOME"), os.environ.get("CUDA_PATH"), "/usr/local/cuda"):
        if root and os.access(os.path.join(root, "bin", "nvcc"), os.X_OK):
            return os.path.join(root, "bin", "nvcc")
    return None


NVCC = _nvcc()
needs_nvcc = pytest.mark.skipif(NVCC is None, reason="no nvcc (a CUDA toolkit on PATH, $CUDA_HOME or /usr/local/cuda): the .cu is not compiled for the GPU here")


PANDA_FUNCTIONS = "pose,jacobian,twist,kinematics,inverse_velocity,ik_solve"
"""What the tests of Panda's kernels and Python entry call (``panda``); the checks over every kernel take ``panda_every``."""


@pytest.fixture(scope="module")
def panda():
    chain = load_robot(PANDA)
    generated = generate(chain, langs="cuda", out=None, prefix="panda", functions=PANDA_FUNCTIONS)
    return chain.numeric(), generated, cuda.load(generated)  # the numeric chain: what the reference takes


@pytest.fixture(scope="module")
def panda_every():
    """Panda with every function, for the checks that go over all of its kernels (nvcc, NVRTC, a real GPU); the
    host build is left to the test that runs it."""
    chain = load_robot(PANDA)
    return chain.numeric(), generate(chain, langs="cuda", out=None, prefix="panda")


@pytest.fixture(scope="module")
def planar_float():
    generated = generate(PlanarArm(3), langs="cuda", out=None, prefix="arm3f", precision="float")
    return generated, cuda.load(generated)


def _configurations(rng, m, n=7):
    return rng.uniform(-2.5, 2.5, (m, n)), rng.uniform(-1, 1, (m, n)), rng.uniform(-1, 1, (m, n))


# -- the kernels' per-thread body -------------------------------------------------------------------

def test_the_kernel_body_writes_every_element_where_the_soa_layout_says(panda, rng):
    chain, generated, arm = panda
    m = 37
    q, dq, ddq = _configurations(rng, m)
    outs = {name: np.full((size, m), np.nan) for name, size in (("T", 16), ("J", 42), ("dJ", 42), ("twist", 6), ("acc", 6))}
    arm.host_batch("kinematics", m, *(np.ascontiguousarray(x.T) for x in (q, dq, ddq)), *outs.values())
    assert all(np.isfinite(o).all() for o in outs.values())  # every [k*m + i] written
    ref = reference.chain_kinematics(chain, q, dq, ddq)
    expected = {"T": ref.T, "J": ref.J, "dJ": ref.dJ, "twist": ref.twist, "acc": ref.acc}
    for name, soa in outs.items():
        got = soa.T.reshape(expected[name].shape)  # configuration i is column i
        np.testing.assert_allclose(got, expected[name], rtol=0, atol=1e-12, err_msg=name)
    for i in (0, 17, m - 1):  # the body of thread i is the single call on configuration i, bit for bit
        single = arm.kinematics(q[i], dq[i], ddq[i])
        for (name, soa), one in zip(outs.items(), single):
            assert np.array_equal(soa[:, i], one.reshape(-1)), (name, i)


def test_a_batch_call_goes_through_the_kernel_body_in_soa_layout(panda, rng):
    chain, generated, arm = panda
    q = rng.uniform(-2.5, 2.5, (4, 5, 7))
    calls = []
    original = arm.host_batch
    arm.host_batch = lambda name, m, *args: (calls.append((name, m, [a.shape for a in args])), original(name, m, *args))[1]
    try:
        J = arm.jacobian(q)
    finally:
        del arm.host_batch
    assert calls == [("jacobian", 20, [(7, 20), (42, 20)])]
    np.testing.assert_allclose(J, reference.chain_kinematics(chain, q).J, rtol=0, atol=1e-12)


def test_the_solver_kernel_solves_each_target_as_a_single_call_does(panda, rng):
    chain, generated, arm = panda
    lo, hi = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973]), np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
    m = 6
    q_true = rng.uniform(lo, hi, (m, 7))
    targets = reference.chain_kinematics(chain, q_true).T.reshape(m, 16).copy()
    targets[4, 3] = np.nan  # one invalid target among valid ones
    q0 = np.clip(q_true + rng.uniform(-0.3, 0.3, (m, 7)), lo, hi)
    q = np.full((7, m), np.nan)
    error = np.full((2, m), np.nan)
    iterations = np.full((1, m), -1, dtype=np.intc)
    status = np.full((1, m), -1, dtype=np.intc)
    arm.host_batch("ik_solve", m, np.ascontiguousarray(q0.T), np.ascontiguousarray(targets.T), 0.0, 1e-10, 100, q, error, iterations, status)
    codes = {name: value for name, value, _ in generated.module.function("ik_solve").statuses}
    for i in range(m):
        if i == 4:
            assert status[0, i] == codes["IK_INVALID"]
            assert np.array_equal(q[:, i], q0[i]) and np.isinf(error[:, i]).all()
            continue
        single = arm.ik_solve(q0[i], targets[i].reshape(4, 4), 0.0, 1e-10, 100)
        assert (status[0, i], single.status) == (codes["IK_CONVERGED"], "converged")
        assert np.array_equal(q[:, i], single.q)
        assert (error[0, i], error[1, i], iterations[0, i]) == (single.position_error, single.rotation_error, single.iterations)
        reached = reference.chain_kinematics(chain, q[:, i]).T.reshape(16)
        np.testing.assert_allclose(reached, targets[i], rtol=0, atol=1e-9)


def test_the_host_build_takes_the_level_of_the_c_and_keeps_the_strict_flags(monkeypatch):
    """The host C++ builds at -O2, or at the level of $SKELARM_SYM_OPT as the C does; the level is part of the
    cache key, and the strict language flags stay at every level."""
    import skelarm_sym.backends.cuda.host as host

    sources = cuda_sources(generate(PlanarArm(2), langs="cuda", out=None, prefix="arm2lvl", functions="position"))
    commands = []
    real_run = host.subprocess.run
    monkeypatch.setattr(host.subprocess, "run", lambda command, **kw: commands.append(command) or real_run(command, **kw))
    monkeypatch.setenv("SKELARM_SYM_OPT", "0")
    fast = host.compile_host_library(sources)
    monkeypatch.delenv("SKELARM_SYM_OPT")
    optimised = host.compile_host_library(sources)
    assert fast != optimised and host.compile_host_library(sources, flags=("-O2",)) == optimised
    assert len(commands) == 2
    for command, level in zip(commands, ("-O0", "-O2")):
        assert level in command and all(flag in command for flag in host.HOST_FLAGS)


def test_float_precision_meets_the_float_tolerance(planar_float):
    generated, arm = planar_float
    assert "sincosf" in generated.sources["arm3f.cu"] and "sinf(x)" in generated.sources["arm3f.cu"]
    results = compare(generated, cases=10, seed=3, precision="float", implementations=[(cuda.LABEL, arm)])
    assert results and all(r.ok for r in results), [r for r in results if not r.ok]


def test_the_host_build_is_strict_cxx_under_clang_too(tmp_path):
    if not shutil.which("clang++"):
        pytest.skip("no clang++ on PATH")
    generated = generate(PlanarArm(2), langs="cuda", out=None, prefix="arm2")
    arm = compile_host(generated, compiler="clang++")
    q = np.array([[0.3, -1.2], [2.0, 0.5]])
    l = np.array([1.0, 0.7])
    np.testing.assert_allclose(arm.position(q, l), reference.kinematics(q, lengths=l).p, rtol=0, atol=1e-15)


# -- nvcc and NVRTC ---------------------------------------------------------------------------------

def _write(generated, folder: Path) -> Path:
    for name, text in cuda_sources(generated).items():
        (folder / name).write_text(text, encoding="utf-8")
    return folder / f"{generated.module.prefix}.cu"


@needs_nvcc
@pytest.mark.slow
def test_nvcc_compiles_the_kernels_warning_free_without_spills(panda_every, tmp_path):
    chain, generated = panda_every
    cu = _write(generated, tmp_path)
    command = [NVCC, "-O3", "-arch=sm_90", "-c", str(cu), "-o", str(tmp_path / "panda.o"), "-Werror", "all-warnings",
               "-Xcompiler", "-Wall,-Wextra,-Werror", "-Xptxas", "-v"]
    result = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    report = result.stdout + result.stderr
    kernels = re.findall(r"Compiling entry function '(\w+)'", report)
    assert {f"panda_{f.name}_kernel" for f in generated.functions} == set(kernels)
    # the per-thread input and output arrays of the forward kernels live in registers: no spills
    for name in ("pose", "jacobian", "jacobian_dot"):
        block = report.split(f"Compiling entry function 'panda_{name}_kernel'")[1].split("Compiling entry function")[0]
        assert "0 bytes spill stores" in block, (name, block)


@needs_nvcc
@pytest.mark.parametrize("model", ["planar-float", "diffdrive", "hostile"])
def test_nvcc_compiles_other_kinds_and_precisions(model, tmp_path):
    make = {
        "planar-float": lambda: generate(PlanarArm(3), langs="cuda", out=None, prefix="arm3", precision="float"),
        "diffdrive": lambda: generate(__import__("skelarm_sym.models", fromlist=["DiffDrive"]).DiffDrive(None), langs="cuda", out=None, prefix="dd"),
        "hostile": lambda: generate(load_robot(HOSTILE), langs="cuda", out=None, prefix="hostile", functions="pose,kinematics,ik_solve"),
    }
    generated = make[model]()
    cu = _write(generated, tmp_path)
    result = subprocess.run([NVCC, "-arch=sm_90", "-ptx", str(cu), "-o", str(tmp_path / "x.ptx"), "-Werror", "all-warnings"],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    ptx = (tmp_path / "x.ptx").read_text()
    assert {f"{generated.module.prefix}_{f.name}_kernel" for f in generated.functions} <= set(re.findall(r"\.entry (\w+)\(", ptx))


@needs_nvcc
def test_the_nvcc_host_build_gives_the_same_numbers(tmp_path, rng):
    """nvcc's own host pass (its host compiler behind nvcc, the CUDA runtime linked) as a library: the
    single calls and the kernels' per-thread body run on the CPU, no GPU needed."""
    generated = generate(PlanarArm(3), langs="cuda", out=None, prefix="arm3", functions="kinematics,ik_solve")
    cu = _write(generated, tmp_path)
    library = tmp_path / "libarm3_nvcc.so"
    result = subprocess.run([NVCC, "-O2", "-arch=sm_90", "-shared", "-Xcompiler", "-fPIC", "-o", str(library), str(cu)],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    arm = HostArm(library, generated.module)
    q, dq, ddq = (rng.uniform(-2, 2, (9, 3)) for _ in range(3))
    l = np.array([1.0, 0.8, 0.5])
    got = arm.kinematics(q, dq, ddq, l)
    ref = reference.kinematics(q, dq, ddq, l)
    for out, want in zip(got, (ref.p, ref.J, ref.H, ref.v, ref.a)):
        np.testing.assert_allclose(out, want, rtol=0, atol=1e-12)
    solved = arm.ik_solve(np.array([0.2, 0.9, 0.6]), np.array([1.2, 0.4]), l)
    assert solved.status == "converged" and np.abs(reference.kinematics(solved.q, lengths=l).p - [1.2, 0.4]).max() < 1e-8


def _nvrtc():
    """libnvrtc through ctypes (its builtins library loaded first, so that NVRTC finds it), or None."""
    candidates = []
    for folder in sys.path:
        candidates += sorted(glob.glob(os.path.join(folder, "nvidia", "*", "lib", "libnvrtc.so*")))
        candidates += sorted(glob.glob(os.path.join(folder, "nvidia", "cuda_nvrtc", "lib", "libnvrtc.so*")))
    for root in (os.environ.get("CUDA_HOME"), "/usr/local/cuda"):
        if root:
            candidates += sorted(glob.glob(os.path.join(root, "lib64", "libnvrtc.so*")))
    found = ctypes.util.find_library("nvrtc")
    if found:
        candidates.append(found)
    for path in candidates:
        if "builtins" in path or "alt" in os.path.basename(path):
            continue
        try:
            for builtins in sorted(glob.glob(os.path.join(os.path.dirname(path), "libnvrtc-builtins.so*"))):
                if ".alt." not in builtins:
                    ctypes.CDLL(builtins, mode=ctypes.RTLD_GLOBAL)
            return ctypes.CDLL(path)
        except OSError:
            continue
    return None


def test_nvrtc_compiles_what_the_python_entry_hands_to_cupy(panda_every):
    """CuPy's RawModule compiles with NVRTC: the entry's source_text (header, then .cu) must compile there,
    without <math.h> or the CUDA runtime's headers."""
    lib = _nvrtc()
    if lib is None:
        pytest.skip("no libnvrtc (pip install nvidia-cuda-nvrtc, or a CUDA toolkit): CuPy's compile path not checked here")
    chain, generated = panda_every
    entry = load_python(generated.sources["panda_cuda.py"], "panda_cuda")
    code = entry.source_text(generated.sources["panda.cuh"], generated.sources["panda.cu"])
    program = ctypes.c_void_p()
    assert lib.nvrtcCreateProgram(ctypes.byref(program), code.encode(), b"panda.cu", 0, None, None) == 0
    # what CuPy's RawModule adds (its include path aside) for an H100/H200, and the default device space
    options = [b"--gpu-architecture=compute_90", b"-ftz=true", b"--device-as-default-execution-space"]
    status = lib.nvrtcCompileProgram(program, len(options), (ctypes.c_char_p * len(options))(*options))
    size = ctypes.c_size_t()
    lib.nvrtcGetProgramLogSize(program, ctypes.byref(size))
    log = ctypes.create_string_buffer(size.value)
    lib.nvrtcGetProgramLog(program, log)
    lib.nvrtcDestroyProgram(ctypes.byref(program))
    assert status == 0, log.value.decode(errors="replace")[:3000]


# -- the Python entry ---------------------------------------------------------------------------------

@pytest.fixture
def gpu(panda, monkeypatch):
    """The Python entry of Panda on the CuPy stand-in (tests/cupy_standin.py): kernels run as host loops."""
    chain, generated, arm = panda
    monkeypatch.setitem(sys.modules, "cupy", cupy_standin.make())
    entry = load_python(generated.sources["panda_cuda.py"], "panda_cuda")
    kernels = entry.load(code=entry.source_text(generated.sources["panda.cuh"], generated.sources["panda.cu"]))
    return chain, kernels, kernels.module.kernels


def test_the_entry_takes_batch_first_arrays_and_returns_batch_first_views(gpu, rng):
    chain, kernels_obj, launched = gpu
    q = rng.uniform(-2.5, 2.5, (3, 4, 7))
    dq = rng.uniform(-1, 1, (7,))  # broadcast over the batch, as in the NumPy module
    ddq = rng.uniform(-1, 1, (3, 4, 7))
    T, J, dJ, twist, acc = kernels_obj.kinematics(q, dq, ddq)
    assert launched["panda_kinematics_kernel"].launches == [12]
    ref = reference.chain_kinematics(chain, q, np.broadcast_to(dq, q.shape), ddq)
    for got, want in zip((T, J, dJ, twist, acc), (ref.T, ref.J, ref.dJ, ref.twist, ref.acc)):
        assert got.shape == want.shape
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_the_entry_with_soa_copies_nothing_and_returns_batch_last(gpu, rng):
    chain, kernels_obj, launched = gpu
    q = rng.uniform(-2.5, 2.5, (7, 5, 2))  # batch last
    T = kernels_obj.pose(q, soa=True)
    assert T.shape == (4, 4, 5, 2) and T.flags.c_contiguous
    want = reference.chain_kinematics(chain, np.moveaxis(q, 0, -1)).T  # (5, 2, 4, 4)
    np.testing.assert_allclose(np.moveaxis(T, (0, 1), (-2, -1)), want, rtol=0, atol=1e-12)


def test_the_entry_solves_a_batch_of_targets(gpu, panda, rng):
    chain, kernels_obj, launched = gpu
    arm = panda[2]
    q_true = rng.uniform(-1.5, 1.5, (2, 3, 7)) * 0.5 + np.array([0, 0, 0, -1.5, 0, 1.8, 0])
    targets = reference.chain_kinematics(chain, q_true).T
    result = kernels_obj.ik_solve(q_true + 0.2, targets)
    assert result.q.shape == (2, 3, 7) and result.status.shape == (2, 3) and result.iterations.shape == (2, 3)
    for idx in np.ndindex(2, 3):
        single = arm.ik_solve(q_true[idx] + 0.2, targets[idx])
        assert np.array_equal(result.q[idx], single.q) and result.status[idx] == 0 and single.status == "converged"
        assert (result.position_error[idx], result.rotation_error[idx], result.iterations[idx]) == \
               (single.position_error, single.rotation_error, single.iterations)


def test_the_entry_shares_parameters_and_computes_the_solvers_defaults(monkeypatch, rng):
    """A planar arm: the lengths l are one array for the batch, and ik_solve's tol defaults to 1e-9 times the
    reach, computed from l as in the NumPy module."""
    generated = generate(PlanarArm(3), langs="cuda,python", out=None, prefix="arm3", functions="position,ik_solve")
    monkeypatch.setitem(sys.modules, "cupy", cupy_standin.make())
    entry = load_python(generated.sources["arm3_cuda.py"], "arm3_cuda")
    gpu = entry.load(code=entry.source_text(generated.sources["arm3.cuh"], generated.sources["arm3.cu"]))
    numpy_module = load_python(generated.sources["arm3.py"], "arm3")
    q = rng.uniform(-2, 2, (6, 3))
    l = np.array([1.0, 0.8, 0.5])
    np.testing.assert_allclose(gpu.position(q, l), reference.kinematics(q, lengths=l).p, rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="l must have shape"):
        gpu.position(q, np.ones(4))
    with pytest.raises(ValueError, match="l must be > 0"):
        gpu.position(q, np.array([1.0, 0.0, 0.5]))
    targets = reference.kinematics(rng.uniform(-2, 2, (6, 3)), lengths=l).p
    result = gpu.ik_solve(q, targets, l)
    for i in range(6):
        single = numpy_module.ik_solve(q[i], targets[i], l)  # the same defaults, another backend
        assert result.status[i] == entry.IK_CONVERGED and single.status == "converged"
        np.testing.assert_allclose(result.q[i], single.q, rtol=0, atol=1e-12)
        assert result.iterations[i] == single.iterations


def test_the_entry_refuses_bad_input_by_name(gpu, rng):
    chain, kernels_obj, launched = gpu
    q = rng.uniform(-1, 1, (4, 7))
    with pytest.raises(ValueError, match="q must be finite"):
        kernels_obj.pose(np.where(np.arange(7) == 3, np.nan, q))
    with pytest.raises(ValueError, match=r"q must have shape \(\.\.\., 7\)"):
        kernels_obj.pose(q[:, :6])
    with pytest.raises(ValueError, match="q must hold real numbers"):
        kernels_obj.pose(q.astype(complex))
    with pytest.raises(ValueError, match="lambda must be >= 0"):
        kernels_obj.inverse_velocity(q, rng.uniform(-1, 1, (4, 6)), -0.1)
    with pytest.raises(ValueError, match="batch shapes do not broadcast"):
        kernels_obj.twist(q, rng.uniform(-1, 1, (3, 7)))
    with pytest.raises(TypeError):
        kernels_obj.pose(q, q)
    assert np.isnan(kernels_obj.pose(np.full((2, 7), np.nan), check=False)).any()  # check=False: NaN in, NaN out


def test_without_cupy_the_entry_says_what_is_missing(panda, monkeypatch):
    chain, generated, arm = panda
    monkeypatch.setitem(sys.modules, "cupy", None)  # import cupy raises ImportError
    entry = load_python(generated.sources["panda_cuda.py"], "panda_cuda")
    code = entry.source_text(generated.sources["panda.cuh"], generated.sources["panda.cu"])
    with pytest.raises(entry.NoGPU, match=r"needs CuPy .*pip install cupy-cuda12x"):
        entry.load(code=code)


def test_the_entry_refuses_files_of_another_generation(panda):
    chain, generated, arm = panda
    other = generate(load_robot(PANDA), langs="cuda", out=None, prefix="panda", functions="pose")
    entry = load_python(generated.sources["panda_cuda.py"], "panda_cuda")
    with pytest.raises(ValueError, match="panda.cu is not of the generation"):
        entry.source_text(generated.sources["panda.cuh"], other.sources["panda.cu"])


# -- text ----------------------------------------------------------------------------------------------

def test_the_files_sit_beside_c_and_python_and_share_one_stamp(tmp_path):
    generated = generate(PlanarArm(2), langs="c,python,cuda", out=tmp_path, prefix="arm2", functions="position")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm2.c", "arm2.cu", "arm2.cuh", "arm2.h", "arm2.py", "arm2_cuda.py"]
    assert len({file_stamp(text) for text in generated.sources.values()}) == 1


@pytest.mark.fresh_derivation  # two derivations from scratch, not one remembered
def test_the_output_is_deterministic_ascii_and_escapes_robot_text():
    chain = load_robot(HOSTILE)
    first = generate(chain, langs="cuda", out=None, prefix="hostile")
    second = generate(load_robot(HOSTILE), langs="cuda", out=None, prefix="hostile")
    assert first.sources == second.sources
    foreign = [chain.description, *(j.name for j in chain.joints)]
    # what could end a comment or a string, form a trigraph or splice a line in each kind of file
    sequences = {".cu": ("*/", "/*", "??", "\\"), ".cuh": ("*/", "/*", "??", "\\"), ".py": ('"', "\\")}
    for name, text in first.sources.items():
        assert all(32 <= ord(ch) < 127 or ch == "\n" for ch in text), name
        for piece in foreign:
            if any(s in piece for s in sequences[Path(name).suffix]) or any(ord(ch) >= 127 for ch in piece):
                assert piece not in text, (name, piece)
    c_text = first.sources["hostile.cu"] + first.sources["hostile.cuh"]
    stripped = re.sub(r"/\*.*?\*/", "", c_text, flags=re.S)
    assert "*/" not in stripped and "/*" not in stripped and "??" not in c_text
    compile(first.sources["hostile_cuda.py"], "hostile_cuda.py", "exec")  # the docstring holds


# -- benchmarks/gpu.py ---------------------------------------------------------------------------------

def _benchmark():
    import importlib.util

    spec = importlib.util.spec_from_file_location("gpu_benchmark", ROOT / "benchmarks" / "gpu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_benchmark_without_cupy_says_so_and_exits_0(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "cupy", None)
    with pytest.raises(SystemExit) as stop:
        _benchmark().main([])
    assert stop.value.code == 0
    assert "no GPU run: CuPy is not installed" in capsys.readouterr().out


@pytest.mark.slow
def test_the_benchmark_runs_end_to_end_on_the_standin(monkeypatch, capsys, tmp_path):
    """Every section of benchmarks/gpu.py (compile, checks, sweeps, variants, calls, IK) on the CuPy stand-in at
    small sizes: the script a GPU session will run has run here, its checks against the reference included."""
    monkeypatch.setitem(sys.modules, "cupy", cupy_standin.make())
    bench = _benchmark()
    status = bench.main(["--max-size", "300", "--json", str(tmp_path / "gpu.json")])
    out = capsys.readouterr().out
    assert status == 0, out[-3000:]
    assert "checks: all passed" in out and "CHECK FAILED" not in out
    import json

    results = json.loads((tmp_path / "gpu.json").read_text())
    rows = results["kinematics"]
    assert {(r["precision"], r["m"]) for r in rows} == {("double", 300), ("float", 300)}
    assert all(r["bytes_per_config"] == (21 + 112) * (8 if r["precision"] == "double" else 4) for r in rows)
    assert max(r["max_abs_error"] for r in rows if r["precision"] == "double") < 1e-11
    assert {r["function"] for r in results["kernels"]} == {"pose", "jacobian", "jacobian_dot"}
    (solve,) = results["ik"]
    assert solve["m"] == 300 and solve["converged"] > 0.9 and solve["pose_error_checked"] < 1e-9


def test_the_benchmarks_urdf_for_pytorch_kinematics_is_the_same_arm(tmp_path, rng):
    """pytorch_kinematics reads a URDF that benchmarks/gpu.py writes from the chain: read back by this project's
    URDF loader, it has the TOML's kinematics (so the two libraries time the same arm)."""
    chain = load_robot(PANDA).numeric()
    path = tmp_path / "panda.urdf"
    path.write_text(_benchmark().urdf_of(chain))
    again = load_robot(path, tip="tool").numeric()
    q = rng.uniform(-2.5, 2.5, (40, 7))
    a, b = reference.chain_kinematics(chain, q), reference.chain_kinematics(again, q)
    np.testing.assert_allclose(b.T, a.T, rtol=0, atol=1e-14)
    np.testing.assert_allclose(b.J, a.J, rtol=0, atol=1e-14)


def _real_cupy():
    try:
        import cupy
    except ImportError:
        return None
    try:
        return cupy if cupy.cuda.runtime.getDeviceCount() > 0 else None
    except Exception:  # no driver
        return None


def test_on_a_real_gpu_every_kernel_agrees_with_the_host_build(panda_every, rng):
    """The device check (runs where CuPy finds a GPU): every kernel of Panda through the Python entry against
    the host build of the same .cu, which the conformance test holds to the references. Not bit for bit:
    nvcc contracts a*b + c into fused multiply-adds."""
    cp = _real_cupy()
    if cp is None:
        pytest.skip("no GPU: CuPy is not installed or finds no CUDA device")
    chain, generated = panda_every
    arm = cuda.load(generated)
    entry = load_python(generated.sources["panda_cuda.py"], "panda_cuda")
    gpu = entry.load(code=entry.source_text(generated.sources["panda.cuh"], generated.sources["panda.cu"]))
    for f in generated.programs:
        args = []
        for a in f.inputs:
            if a.is_scalar:
                args.append(0.05)
            else:
                args.append(rng.uniform(-2.0, 2.0, (257, a.size)) if a.batched else rng.uniform(0.5, 1.5, a.size))
        want = getattr(arm, f.name)(*args)
        got = getattr(gpu, f.name)(*[cp.asarray(x) if isinstance(x, np.ndarray) else x for x in args])
        for w, g in zip(want if isinstance(want, tuple) else (want,), got if isinstance(got, tuple) else (got,)):
            scale = max(1.0, float(np.abs(w).max()))
            assert float(np.abs(cp.asnumpy(g) - w).max()) <= 1e-10 * scale, f.name  # rounding, amplified by the solves
    q_true = rng.uniform(-1, 1, (64, 7)) * 0.5 + np.array([0, 0, 0, -1.5, 0, 1.8, 0])
    targets = reference.chain_kinematics(chain, q_true).T
    result = gpu.ik_solve(cp.asarray(q_true + 0.2), cp.asarray(targets))
    status, q = cp.asnumpy(result.status), cp.asnumpy(result.q)
    assert (status == entry.IK_CONVERGED).all()
    np.testing.assert_allclose(reference.chain_kinematics(chain, q).T, targets, rtol=0, atol=1e-9)


def test_the_entry_takes_a_pose_target_as_4_x_4(monkeypatch):
    """A straight-line function's pose target (ik_continuum_members) may come as (..., 4, 4), as the other Python
    entries take it (docs/closed-form-ik.md), batch-first or with soa batch-last."""
    chain = load_robot(ROOT / "examples" / "robots" / "ur5.toml")
    generated = generate(chain, langs="cuda", out=None, prefix="ur5m", functions="pose,ik_continuum_members")
    monkeypatch.setitem(sys.modules, "cupy", cupy_standin.make())
    entry = load_python(generated.sources["ur5m_cuda.py"], "ur5m_cuda")
    kernels = entry.load(code=entry.source_text(generated.sources["ur5m.cuh"], generated.sources["ur5m.cu"]))
    q = np.array([[0.3, -1.2, 1.4, -1.8, 0.0, 0.7], [0.1, -0.9, 1.1, -1.5, 0.0, -0.4]])
    T = reference.chain_kinematics(chain.numeric(), q).T
    flat, square = kernels.ik_continuum_members(q, T.reshape(2, 16))[0], kernels.ik_continuum_members(q, T)[0]
    assert flat.shape == square.shape == (2, 4, 6) and np.array_equal(flat, square, equal_nan=True)
    soa = kernels.ik_continuum_members(q.T.copy(), np.moveaxis(T, 0, -1).copy(), soa=True)[0]
    assert np.array_equal(np.moveaxis(soa, -1, 0), flat, equal_nan=True)
