"""GPU benchmark of the CUDA backend: the emitted kernels of a 7-joint arm (Panda,
examples/robots/panda.toml) checked against the NumPy reference and timed on the GPU.

    python benchmarks/gpu.py                   # everything, about 3 minutes on an H200
    python benchmarks/gpu.py --quick           # batches up to 10^6, no IK sweep
    python benchmarks/gpu.py --json out.json   # also the numbers as JSON

It needs CuPy and a CUDA GPU (the Python entry compiles the .cu with NVRTC through CuPy's RawModule);
without either it says which is missing and exits 0. No network: pytorch_kinematics is compared only
when it is installed. What it does, in order:

1. generates the CUDA files for Panda in double and float (pose, jacobian, jacobian_dot, kinematics,
   ik_terms, ik_solve) and compiles them (NVRTC; the time is printed);
2. measures the copy bandwidth (a device-to-device copy of 4 GiB, bytes read + written), the ceiling
   every kernel here is judged against;
3. checks every output (T, J, dJ, twist, acc; pose, jacobian, jacobian_dot) of a batch of 10^5 random
   configurations, through the checked batch-first calls, against the reference (max abs error, allowed
   1e-12 in double, 2e-5 in float);
4. times the kinematics kernel (T, J, dJ, twist, acc: pose + J + dJ and the two products) on batches of
   10^4 .. 10^8 configurations in the kernels' layout (SoA, inputs and outputs on the GPU, nothing
   copied), with CUDA events (median of at least 5 launches and 0.2 s), and checks 256 configurations of
   every batch (the first, the last and random ones) against the reference; configurations/s against the
   memory-bound limit, copy bandwidth / bytes each configuration moves (inputs read once, outputs written
   once). Then pose, jacobian and jacobian_dot as three kernels, a register cap of 128
   (NVRTC -maxrregcount), and the batch-first call (transposes included) and PyTorch tensors;
5. solves batches of random reachable pose targets with the ik_solve kernel (one target per thread,
   random starts within the limits): solves/s, converged fraction, iterations, pose errors checked;
6. with pytorch_kinematics installed: its forward_kinematics + jacobian on the same GPU against the
   ik_terms kernel (T and J), same batch, float64 and float32, after checking its poses agree.

The exit status is 1 when a check fails, else 0.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

from skelarm_sym import reference  # noqa: E402
from skelarm_sym.build import load_python  # noqa: E402
from skelarm_sym.generate import generate  # noqa: E402
from skelarm_sym.models.chain.loader import load_robot  # noqa: E402

ROBOT = ROOT / "examples" / "robots" / "panda.toml"
FUNCTIONS = "pose,jacobian,jacobian_dot,kinematics,ik_terms,ik_solve"
SIZES = (10**4, 10**5, 10**6, 10**7, 10**8)
TOLERANCE = {"double": 1e-12, "float": 2e-5}
TARGET = 1e9
"""Configurations per second the issue asks of pose + J + dJ on an H200-class GPU."""
FAILURES: list[str] = []
RESULTS: dict = {"kinematics": [], "kernels": [], "variants": [], "calls": [], "ik": [], "pytorch_kinematics": []}


def say(text: str = "") -> None:
    print(text, flush=True)


def fail(text: str) -> None:
    FAILURES.append(text)
    say(f"CHECK FAILED: {text}")


# -- the environment ---------------------------------------------------------------------------------

def gpu_listed() -> str:
    """What nvidia-smi says about GPUs here (or that it is not there)."""
    if not shutil.which("nvidia-smi"):
        return "nvidia-smi is not on PATH"
    try:
        out = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"nvidia-smi failed: {exc}"
    return (out.stdout.strip() or out.stderr.strip() or "nvidia-smi lists no GPU").splitlines()[0]


def cupy_or_exit():
    try:
        import cupy
    except ImportError as exc:
        say(f"no GPU run: CuPy is not installed ({exc}); nvidia-smi: {gpu_listed()}.")
        say("The kernels compile and launch through CuPy: pip install cupy-cuda12x (or cupy-cuda13x) on a machine with a GPU.")
        raise SystemExit(0)
    try:
        count = cupy.cuda.runtime.getDeviceCount()
    except Exception as exc:  # no driver, no device
        count, reason = 0, str(exc)
    else:
        reason = "CuPy sees 0 devices"
    if count < 1:
        say(f"no GPU run: no CUDA GPU is available ({reason}); nvidia-smi: {gpu_listed()}.")
        raise SystemExit(0)
    return cupy


def device_line(cp) -> str:
    props = cp.cuda.runtime.getDeviceProperties(cp.cuda.Device().id)
    name = props["name"].decode() if isinstance(props["name"], bytes) else props["name"]
    runtime = cp.cuda.runtime.runtimeGetVersion()
    driver = cp.cuda.runtime.driverGetVersion()
    free, total = cp.cuda.runtime.memGetInfo()
    RESULTS["device"] = {"name": name, "sms": props["multiProcessorCount"], "memory_bytes": total,
                         "cuda_runtime": runtime, "cuda_driver": driver, "cupy": cp.__version__}
    return (f"{name}, {props['multiProcessorCount']} SMs, {total / 2**30:.0f} GiB ({free / 2**30:.0f} free), "
            f"CUDA runtime {runtime // 1000}.{runtime % 1000 // 10}, driver {driver // 1000}.{driver % 1000 // 10}, "
            f"CuPy {cp.__version__}, NumPy {np.__version__}, Python {platform.python_version()}")


# -- timing --------------------------------------------------------------------------------------------

def time_gpu(cp, run, min_seconds: float = 0.2, max_runs: int = 50, warmup: int = 2) -> float:
    """Median seconds of ``run()`` by CUDA events on the current stream (at least 5 runs and ``min_seconds``)."""
    for _ in range(warmup):
        run()
    cp.cuda.Device().synchronize()
    start, stop = cp.cuda.Event(), cp.cuda.Event()
    times: list[float] = []
    while len(times) < 5 or (sum(times) < min_seconds and len(times) < max_runs):
        start.record()
        run()
        stop.record()
        stop.synchronize()
        times.append(cp.cuda.get_elapsed_time(start, stop) / 1e3)
    return float(np.median(times))


def time_torch(torch, run, min_seconds: float = 0.2, max_runs: int = 50, warmup: int = 2) -> float:
    for _ in range(warmup):
        run()
    torch.cuda.synchronize()
    times: list[float] = []
    while len(times) < 5 or (sum(times) < min_seconds and len(times) < max_runs):
        start, stop = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
        start.record()
        run()
        stop.record()
        stop.synchronize()
        times.append(start.elapsed_time(stop) / 1e3)
    return float(np.median(times))


def copy_bandwidth(cp) -> float:
    """Bytes per second of a device-to-device copy of 4 GiB (less on a small GPU), counting bytes read and written."""
    n = int(min(2**29, cp.cuda.runtime.memGetInfo()[0] / 8 / 4))  # doubles: 4 GiB
    a = cp.random.random(n)
    b = cp.empty_like(a)
    seconds = time_gpu(cp, lambda: cp.copyto(b, a))
    del a, b
    cp.get_default_memory_pool().free_all_blocks()
    return 2 * n * 8 / seconds


# -- the kernels -----------------------------------------------------------------------------------------

class Arm:
    """The generated files of one precision, compiled: ``gpu`` (the Python entry's Kernels) and the
    byte counts of each function."""

    def __init__(self, chain, precision: str, options=()):
        prefix = "panda" if precision == "double" else "pandaf"
        t0 = time.perf_counter()
        self.generated = generate(chain, langs="cuda", out=None, prefix=prefix, precision=precision, functions=FUNCTIONS)
        t1 = time.perf_counter()
        self.entry = load_python(self.generated.sources[f"{prefix}_cuda.py"], f"{prefix}_cuda")
        code = self.entry.source_text(self.generated.sources[f"{prefix}.cuh"], self.generated.sources[f"{prefix}.cu"])
        self.gpu = self.entry.load(code=code, options=tuple(options))
        for name in ("pose", "jacobian", "jacobian_dot", "kinematics", "ik_terms", "ik_solve"):
            self.gpu.kernel(name).attributes  # compiles and loads now, not inside a timing
        t2 = time.perf_counter()
        self.precision, self.options = precision, tuple(options)
        self.itemsize = 8 if precision == "double" else 4
        self.dtype = np.float64 if precision == "double" else np.float32
        self.generate_seconds, self.compile_seconds = t1 - t0, t2 - t1

    def spec(self, name):
        return self.entry.FUNCTIONS[name][1]

    def bytes_per_config(self, name: str) -> int:
        """Bytes one configuration moves: each batched input read once, each output written once."""
        return sum(size for _, how, size, *_ in self.spec(name) if how in ("soa", "status")) * self.itemsize

    def registers(self, name: str) -> int:
        return int(self.gpu.kernel(name).attributes.get("num_regs", -1))


def soa_inputs(cp, arm: Arm, name: str, m: int, seed: int):
    """Random SoA inputs of kernel ``name`` on the GPU: q in [-2.5, 2.5], rates in [-1, 1]."""
    rs = cp.random.RandomState(seed)
    arrays = []
    for arg, how, size, shape, output, is_int, domain in arm.spec(name):
        if how == "soa" and not output:
            low, high = (-2.5, 2.5) if arg in ("q", "q0") else (-1.0, 1.0)
            arrays.append(rs.uniform(low, high, (size, m), dtype=arm.dtype))
    return arrays


def soa_outputs(cp, arm: Arm, name: str, m: int):
    return [cp.empty((size, m), dtype=np.int32 if is_int else arm.dtype)
            for arg, how, size, shape, output, is_int, _ in arm.spec(name) if output]


def reference_error(cp, chain, arm: Arm, name: str, inputs, outputs, columns) -> float:
    """Max abs error of ``outputs`` (SoA, on the GPU) at ``columns`` against the NumPy reference."""
    index = cp.asarray(columns)
    host_in = [cp.asnumpy(x[:, index]).T.astype(np.float64) for x in inputs]
    ref = reference.chain_kinematics(chain, *host_in)
    expected = {"T": ref.T, "J": ref.J, "dJ": ref.dJ, "twist": ref.twist, "acc": ref.acc}
    names = [arg for arg, how, size, shape, output, *_ in arm.spec(name) if output]
    worst = 0.0
    for arg, out in zip(names, outputs):
        got = cp.asnumpy(out[:, index]).T.reshape(expected[arg].shape)
        worst = max(worst, float(np.abs(got - expected[arg]).max()))
    return worst


def sample_columns(m: int, count: int = 256, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.unique(np.concatenate([[0, 1, m // 2, m - 1], rng.integers(0, m, count - 4)]))


def fits(cp, nbytes: int) -> bool:
    free, _ = cp.cuda.runtime.memGetInfo()
    return nbytes < 0.85 * free


def free_all(cp) -> None:
    cp.get_default_memory_pool().free_all_blocks()


# -- the sections ----------------------------------------------------------------------------------------

def check_outputs(cp, chain, arm: Arm, m: int = 10**5) -> None:
    rng = np.random.default_rng(1)
    q = rng.uniform(-2.5, 2.5, (m, 7))
    dq, ddq = rng.uniform(-1, 1, (2, m, 7))
    ref = reference.chain_kinematics(chain, q, dq, ddq)
    expected = {"T": ref.T, "J": ref.J, "dJ": ref.dJ, "twist": ref.twist, "acc": ref.acc}
    got = dict(zip(("T", "J", "dJ", "twist", "acc"), arm.gpu.kinematics(cp.asarray(q), cp.asarray(dq), cp.asarray(ddq))))
    got["T (pose)"] = arm.gpu.pose(cp.asarray(q))
    got["J (jacobian)"] = arm.gpu.jacobian(cp.asarray(q))
    got["dJ (jacobian_dot)"] = arm.gpu.jacobian_dot(cp.asarray(q), cp.asarray(dq))
    allowed = TOLERANCE[arm.precision]
    for name, value in got.items():
        want = expected[name.split()[0]]
        error = float(np.abs(cp.asnumpy(value) - want).max())
        scale = max(1.0, float(np.abs(want).max()))
        ok = error <= allowed * scale
        say(f"  {arm.precision:6s} {name:18s} max abs error {error:.2e} (allowed {allowed * scale:.1e}) {'ok' if ok else 'FAIL'}")
        if not ok:
            fail(f"{arm.precision} {name}: error {error:.2e} against the reference")


def sweep(cp, chain, arm: Arm, sizes, bandwidth: float, name: str = "kinematics", record: str = "kinematics") -> list[dict]:
    rows = []
    per_config = arm.bytes_per_config(name)
    for m in sizes:
        if not fits(cp, m * per_config):
            say(f"  {arm.precision:6s} {name} m = {m:.0e}: skipped, {m * per_config / 1e9:.0f} GB does not fit")
            continue
        inputs = soa_inputs(cp, arm, name, m, seed=m % 1000)
        outputs = soa_outputs(cp, arm, name, m)
        seconds = time_gpu(cp, lambda: arm.gpu.launch(name, m, *inputs, *outputs))
        error = reference_error(cp, chain, arm, name, inputs, outputs, sample_columns(m))
        allowed = TOLERANCE[arm.precision] * 10  # |T|, |J| of Panda up to ~2, dJ up to ~5: scale folded in
        if not error <= allowed:
            fail(f"{arm.precision} {name} m = {m}: error {error:.2e} against the reference")
        rate = m / seconds
        limit = bandwidth / per_config
        row = {"function": name, "precision": arm.precision, "options": " ".join(arm.options) or "-", "m": m,
               "ms": seconds * 1e3, "configs_per_s": rate, "bytes_per_config": per_config,
               "GB_per_s": m * per_config / seconds / 1e9, "memory_bound_configs_per_s": limit,
               "fraction_of_limit": rate / limit, "max_abs_error": error, "registers": arm.registers(name)}
        rows.append(row)
        RESULTS[record].append(row)
        say(f"  {arm.precision:6s} {name:12s} m = {m:>9d}: {seconds * 1e3:9.3f} ms  {rate:9.3e} configs/s  "
            f"{row['GB_per_s']:7.0f} GB/s  ({row['fraction_of_limit']:.0%} of the memory-bound {limit:.2e})  error {error:.1e}")
        del inputs, outputs
        free_all(cp)
    return rows


def batch_first_calls(cp, arm: Arm, m: int) -> None:
    """The checked and unchecked batch-first calls (transposes, allocation, checks included)."""
    if not fits(cp, 3 * m * arm.bytes_per_config("kinematics")):
        say(f"  batch-first calls: m = {m:.0e} does not fit, skipped")
        return
    q = cp.random.uniform(-2.5, 2.5, (m, 7)).astype(arm.dtype)
    dq = cp.random.uniform(-1, 1, (m, 7)).astype(arm.dtype)
    ddq = cp.random.uniform(-1, 1, (m, 7)).astype(arm.dtype)
    for check in (False, True):
        seconds = time_gpu(cp, lambda: arm.gpu.kinematics(q, dq, ddq, check=check))
        row = {"call": f"gpu.kinematics(q, dq, ddq, check={check}) batch-first", "precision": arm.precision, "m": m,
               "ms": seconds * 1e3, "configs_per_s": m / seconds}
        RESULTS["calls"].append(row)
        say(f"  {arm.precision:6s} {row['call']:55s} m = {m:.0e}: {seconds * 1e3:8.3f} ms  {m / seconds:.3e} configs/s")
    del q, dq, ddq
    free_all(cp)


def torch_calls(cp, arm: Arm, m: int) -> None:
    try:
        import torch
    except ImportError:
        say("  PyTorch tensors: torch is not installed, skipped")
        return
    if not torch.cuda.is_available():
        say("  PyTorch tensors: torch sees no GPU, skipped")
        return
    dtype = torch.float64 if arm.precision == "double" else torch.float32
    q = (torch.rand((7, m), dtype=dtype, device="cuda") - 0.5) * 5
    dq = torch.rand((7, m), dtype=dtype, device="cuda") - 0.5
    ddq = torch.rand((7, m), dtype=dtype, device="cuda") - 0.5
    T, J, dJ, twist, acc = arm.gpu.kinematics(q, dq, ddq, soa=True)
    if not isinstance(T, torch.Tensor) or T.shape != (4, 4, m):
        fail(f"torch tensors in, {type(T).__name__} {tuple(T.shape)} out")
    seconds = time_torch(torch, lambda: arm.gpu.kinematics(q, dq, ddq, soa=True, check=False))
    row = {"call": "gpu.kinematics(torch tensors, soa=True, check=False)", "precision": arm.precision, "m": m,
           "ms": seconds * 1e3, "configs_per_s": m / seconds}
    RESULTS["calls"].append(row)
    say(f"  {arm.precision:6s} {row['call']:55s} m = {m:.0e}: {seconds * 1e3:8.3f} ms  {m / seconds:.3e} configs/s")
    del q, dq, ddq, T, J, dJ, twist, acc
    torch.cuda.empty_cache()


def ik(cp, chain, arm: Arm, m: int) -> None:
    lo = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
    hi = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
    rng = np.random.default_rng(7)
    q_true = rng.uniform(lo, hi, (m, 7))
    targets = reference.chain_kinematics(chain, q_true).T.reshape(m, 16)
    q0 = rng.uniform(lo, hi, (m, 7))
    inputs = [cp.asarray(np.ascontiguousarray(q0.T), dtype=arm.dtype), cp.asarray(np.ascontiguousarray(targets.T), dtype=arm.dtype)]
    outputs = soa_outputs(cp, arm, "ik_solve", m)
    tol = 1e-10 if arm.precision == "double" else 1e-5
    seconds = time_gpu(cp, lambda: arm.gpu.launch("ik_solve", m, *inputs, 0.0, tol, 100, *outputs), min_seconds=0.5, max_runs=5, warmup=1)
    q, error, iterations, status = (cp.asnumpy(x) for x in outputs)
    converged = status[0] == 0
    columns = sample_columns(m, 256)
    reached = reference.chain_kinematics(chain, q[:, columns].T.astype(np.float64)).T.reshape(-1, 16)
    ok = converged[columns]
    pose_error = float(np.abs(reached[ok] - targets[columns][ok]).max()) if ok.any() else float("nan")
    allowed = 1e-9 if arm.precision == "double" else 1e-4
    if not pose_error <= allowed:
        fail(f"ik_solve {arm.precision}: a converged solution is {pose_error:.1e} off its target")
    row = {"precision": arm.precision, "m": m, "ms": seconds * 1e3, "solves_per_s": m / seconds,
           "converged": float(converged.mean()), "median_iterations": float(np.median(iterations[0])),
           "max_iterations": int(iterations[0].max()), "pose_error_checked": pose_error,
           "statuses": {int(s): int((status[0] == s).sum()) for s in np.unique(status[0])}}
    RESULTS["ik"].append(row)
    say(f"  {arm.precision:6s} ik_solve m = {m:>7d}: {seconds * 1e3:9.2f} ms  {m / seconds:9.3e} solves/s  converged "
        f"{row['converged']:.1%}  iterations median {row['median_iterations']:.0f} max {row['max_iterations']}  "
        f"pose error of converged (256 checked) {pose_error:.1e}  statuses {row['statuses']}")
    del inputs, outputs
    free_all(cp)


def urdf_of(chain) -> str:
    """A URDF of a plain numeric chain (revolute joints about z after constant placements, a fixed tool)."""
    def origin(M):
        R, p = M[:3, :3], [float(x) for x in M[:3, 3]]
        pitch = math.asin(max(-1.0, min(1.0, -float(R[2, 0]))))
        roll, yaw = math.atan2(float(R[2, 1]), float(R[2, 2])), math.atan2(float(R[1, 0]), float(R[0, 0]))
        return f'<origin xyz="{p[0]!r} {p[1]!r} {p[2]!r}" rpy="{roll!r} {pitch!r} {yaw!r}"/>'

    links = ['<link name="link0"/>']
    joints = []
    placement = np.asarray(chain.base, dtype=float)
    for k, j in enumerate(chain.joints):
        if j.kind != "revolute" or j.multiplier != 1 or j.offset != 0 or j.coordinate != k:
            raise ValueError("urdf_of handles plain revolute chains")
        M = placement @ np.asarray(j.before, dtype=float)
        axis = " ".join(repr(float(x)) for x in j.axis)
        links.append(f'<link name="link{k + 1}"/>')
        joints.append(f'<joint name="joint{k + 1}" type="revolute"><parent link="link{k}"/><child link="link{k + 1}"/>'
                      f'{origin(M)}<axis xyz="{axis}"/><limit lower="-6.3" upper="6.3" effort="1" velocity="1"/></joint>')
        placement = np.asarray(j.after, dtype=float)
    M = placement @ np.asarray(chain.tool, dtype=float)
    links.append('<link name="tool"/>')
    joints.append(f'<joint name="tool_joint" type="fixed"><parent link="link{len(chain.joints)}"/><child link="tool"/>{origin(M)}</joint>')
    return '<robot name="bench">' + "".join(links + joints) + "</robot>"


def pytorch_kinematics_comparison(cp, chain, arms: dict, sizes) -> None:
    try:
        import torch
        import pytorch_kinematics as pk
    except ImportError as exc:
        say(f"  pytorch_kinematics: not installed ({exc}); skipped (carry its wheels to compare: docs/gpu-and-autodiff.md)")
        return
    if not torch.cuda.is_available():
        say("  pytorch_kinematics: torch sees no GPU, skipped")
        return
    urdf = urdf_of(chain)
    for precision, arm in arms.items():
        dtype = torch.float64 if precision == "double" else torch.float32
        pk_chain = pk.build_serial_chain_from_urdf(urdf, "tool").to(dtype=dtype, device="cuda")
        rng = np.random.default_rng(3)
        q_check = rng.uniform(-2.5, 2.5, (64, 7))
        T_pk = pk_chain.forward_kinematics(torch.as_tensor(q_check, dtype=dtype, device="cuda")).get_matrix().cpu().numpy()
        agree = float(np.abs(T_pk - reference.chain_kinematics(chain, q_check).T).max())
        say(f"  pytorch_kinematics {pk.__version__ if hasattr(pk, '__version__') else ''} {precision}: its poses agree with the reference to {agree:.1e}")
        if agree > 1e-4:
            fail(f"pytorch_kinematics' chain is not Panda's ({agree:.1e}): its times are not comparable")
        for m in sizes:
            if not fits(cp, 40 * m * 48 * arm.itemsize):
                say(f"  pytorch_kinematics m = {m:.0e}: skipped (memory)")
                continue
            q_bf = torch.rand((m, 7), dtype=dtype, device="cuda") * 5 - 2.5
            try:
                pk_seconds = time_torch(torch, lambda: (pk_chain.forward_kinematics(q_bf).get_matrix(), pk_chain.jacobian(q_bf)),
                                        min_seconds=0.2, max_runs=10, warmup=1)
            except RuntimeError as exc:  # out of memory at large batches
                say(f"  pytorch_kinematics m = {m:.0e}: {str(exc).splitlines()[0]}")
                torch.cuda.empty_cache()
                continue
            ours_call = time_torch(torch, lambda: arm.gpu.ik_terms(q_bf, check=False))
            q_soa = q_bf.T.contiguous()
            ours_kernel = time_torch(torch, lambda: arm.gpu.ik_terms(q_soa, soa=True, check=False))
            row = {"precision": precision, "m": m, "pk_ms": pk_seconds * 1e3, "ours_batch_first_ms": ours_call * 1e3,
                   "ours_soa_ms": ours_kernel * 1e3, "speedup_batch_first": pk_seconds / ours_call, "speedup_soa": pk_seconds / ours_kernel}
            RESULTS["pytorch_kinematics"].append(row)
            say(f"  {precision:6s} pose + J m = {m:>8d}: pytorch_kinematics {pk_seconds * 1e3:9.3f} ms, ik_terms kernel batch-first "
                f"{ours_call * 1e3:8.3f} ms ({row['speedup_batch_first']:.0f}x), SoA {ours_kernel * 1e3:8.3f} ms ({row['speedup_soa']:.0f}x)")
            del q_bf, q_soa
            torch.cuda.empty_cache()


def summary(bandwidth: float) -> None:
    say()
    say("== summary ==")
    say(f"device: {RESULTS['device']['name']}; copy bandwidth {bandwidth / 1e12:.2f} TB/s (measured, read + write)")
    say("kinematics kernel (T, J, dJ, twist, acc of Panda; SoA, one configuration per thread):")
    say("| precision | m | ms | configs/s | bytes/config | GB/s | memory-bound configs/s | of the bound | registers | max abs error |")
    say("|---|---|---|---|---|---|---|---|---|---|")
    for r in RESULTS["kinematics"]:
        say(f"| {r['precision']} | {r['m']:.0e} | {r['ms']:.3f} | {r['configs_per_s']:.3e} | {r['bytes_per_config']} | "
            f"{r['GB_per_s']:.0f} | {r['memory_bound_configs_per_s']:.3e} | {r['fraction_of_limit']:.0%} | {r['registers']} | {r['max_abs_error']:.1e} |")
    best = max((r["configs_per_s"] for r in RESULTS["kinematics"] if r["precision"] == "double"), default=float("nan"))
    say(f"target: pose + J + dJ at >= {TARGET:.0e} configurations/s (double): best {best:.3e} -> "
        f"{'met' if best >= TARGET else 'NOT met'}")
    for key in ("kernels", "variants"):
        for r in RESULTS[key]:
            say(f"  {key[:-1]}: {r['function']} {r['precision']} {r['options']} m = {r['m']:.0e}: {r['configs_per_s']:.3e} configs/s "
                f"({r['fraction_of_limit']:.0%} of its memory bound), {r['registers']} registers")
    for r in RESULTS["calls"]:
        say(f"  call: {r['call']} {r['precision']} m = {r['m']:.0e}: {r['configs_per_s']:.3e} configs/s")
    for r in RESULTS["ik"]:
        say(f"  ik_solve {r['precision']} m = {r['m']:.0e}: {r['solves_per_s']:.3e} solves/s, converged {r['converged']:.1%}")
    for r in RESULTS["pytorch_kinematics"]:
        say(f"  vs pytorch_kinematics {r['precision']} m = {r['m']:.0e}: {r['speedup_batch_first']:.0f}x batch-first, {r['speedup_soa']:.0f}x SoA")
    say(f"checks: {'all passed' if not FAILURES else f'{len(FAILURES)} FAILED: ' + '; '.join(FAILURES)}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="batches up to 10^6, no IK sweep, no pytorch_kinematics")
    parser.add_argument("--json", type=Path, help="also write the numbers here")
    parser.add_argument("--max-size", type=float, default=1e8, help="largest batch (default 1e8)")
    args = parser.parse_args(argv)

    cp = cupy_or_exit()
    say(f"device: {device_line(cp)}")
    chain = load_robot(ROBOT)
    numeric = chain.numeric()
    arms = {}
    for precision in ("double", "float"):
        arm = arms[precision] = Arm(chain, precision)
        say(f"compiled {precision}: generate {arm.generate_seconds:.1f} s, NVRTC + load {arm.compile_seconds:.1f} s; registers: "
            + ", ".join(f"{name} {arm.registers(name)}" for name in ("pose", "jacobian", "jacobian_dot", "kinematics", "ik_terms", "ik_solve")))
    bandwidth = copy_bandwidth(cp)
    RESULTS["copy_bandwidth_bytes_per_s"] = bandwidth
    say(f"copy bandwidth: {bandwidth / 1e12:.2f} TB/s (4 GiB device-to-device, read + write)")

    say("\n== outputs against the reference (10^5 random configurations, batch-first checked calls) ==")
    for arm in arms.values():
        check_outputs(cp, numeric, arm)

    sizes = [m for m in SIZES if m <= min(args.max_size, 1e6 if args.quick else args.max_size)] or [int(args.max_size)]
    say("\n== kinematics kernel (SoA, nothing copied) ==")
    for arm in arms.values():
        sweep(cp, numeric, arm, sizes, bandwidth)
    largest = max(sizes)
    say(f"\n== pose, jacobian, jacobian_dot as three kernels (m = {largest:.0e}) ==")
    for arm in arms.values():
        for name in ("pose", "jacobian", "jacobian_dot"):
            sweep(cp, numeric, arm, [largest], bandwidth, name=name, record="kernels")
    say(f"\n== register cap (NVRTC -maxrregcount=128), kinematics, m = {min(largest, 10**7):.0e} ==")
    for precision in arms:
        try:
            capped = Arm(chain, precision, options=("-maxrregcount=128",))
        except Exception as exc:  # a variant that does not compile is reported, not fatal
            say(f"  {precision}: -maxrregcount=128 did not compile: {exc}")
            continue
        sweep(cp, numeric, capped, [min(largest, 10**7)], bandwidth, record="variants")
    say(f"\n== whole calls (m = {min(largest, 10**7):.0e}) ==")
    for arm in arms.values():
        batch_first_calls(cp, arm, min(largest, 10**7))
        torch_calls(cp, arm, min(largest, 10**7))
    if not args.quick:
        say("\n== ik_solve kernel (random reachable pose targets, random starts within the limits) ==")
        for m in [m for m in (10**4, 10**5) if m <= args.max_size] or [int(args.max_size)]:
            ik(cp, numeric, arms["double"], m)
        say("\n== pytorch_kinematics on the same GPU (pose + J) ==")
        pytorch_kinematics_comparison(cp, numeric, arms, [m for m in (10**4, 10**5, 10**6, 10**7) if m <= largest])
    summary(bandwidth)
    if args.json:
        args.json.write_text(json.dumps(RESULTS, indent=1, default=float))
        say(f"wrote {args.json}")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
