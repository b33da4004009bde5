"""A stand-in for CuPy on NumPy, for machines without a GPU: its ``RawModule`` compiles the code it is
given as host C++ (the CUDA backend's host build) and a kernel launch ``{name}_kernel(grid, block, args)``
runs ``{name}_host``, the kernel's per-thread body in a loop over the batch, on the same arguments. So the
Python entry ({prefix}_cuda.py) and benchmarks/gpu.py run end to end here with the arithmetic of the
.cu; only the device itself is missing. Install it with ``monkeypatch.setitem(sys.modules, "cupy", make())``.
"""

from __future__ import annotations

import ctypes
import time
import types

import numpy as np

from skelarm_sym.backends.cuda.host import compile_host_library

FREE_BYTES = 64 * 2**20
"""The memory the stand-in reports free: the benchmark sizes its buffers by it."""


class Kernel:
    def __init__(self, library, name: str):
        self.function = getattr(library, name[: -len("_kernel")] + "_host")
        self.name = name
        self.launches: list[int] = []
        self.attributes = {"num_regs": -1}

    def __call__(self, grid, block, args):
        m = int(args[0])
        assert type(args[0]) is np.int64, "m is passed as int64 (the kernels take long long)"
        assert grid[0] * block[0] >= m > (grid[0] - 1) * block[0], "one configuration per thread"
        converted: list = [ctypes.c_longlong(m)]
        for x in args[1:]:
            if isinstance(x, np.ndarray):
                assert x.flags.c_contiguous, f"{self.name}: a non-contiguous array"
                ctype = {np.dtype(np.float64): ctypes.c_double, np.dtype(np.float32): ctypes.c_float,
                         np.dtype(np.int32): ctypes.c_int}[x.dtype]
                converted.append(x.ctypes.data_as(ctypes.POINTER(ctype)))
            else:
                ctype = {np.float64: ctypes.c_double, np.float32: ctypes.c_float, np.int32: ctypes.c_int}[type(x)]
                converted.append(ctype(x))
        self.launches.append(m)
        self.function(*converted)


class RawModule:
    def __init__(self, code: str, options=()):
        self.options = tuple(options)
        self.library = ctypes.CDLL(str(compile_host_library({"standin.cu": code})))
        self.kernels: dict[str, Kernel] = {}

    def get_function(self, name: str) -> Kernel:
        if name not in self.kernels:
            self.kernels[name] = Kernel(self.library, name)
        return self.kernels[name]


class Event:
    def record(self):
        self.time = time.perf_counter()

    def synchronize(self):
        pass


class _Device:
    id = 0

    def __init__(self, index: int = 0):
        pass

    def synchronize(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


class _RandomState:
    def __init__(self, seed=None):
        self.rng = np.random.default_rng(seed)

    def uniform(self, low=0.0, high=1.0, size=None, dtype=float):
        return self.rng.uniform(low, high, size).astype(dtype)

    def random(self, size=None):
        return self.rng.random(size)


def make() -> types.ModuleType:
    cp = types.ModuleType("cupy")
    cp.__version__ = "stand-in"
    for name in ("ndarray", "asarray", "ascontiguousarray", "broadcast_to", "empty", "empty_like", "copyto", "isfinite",
                 "float64", "float32", "int32"):
        setattr(cp, name, getattr(np, name))
    cp.asnumpy = np.asarray
    cp.RawModule = RawModule
    default = _RandomState(0)
    cp.random = types.SimpleNamespace(RandomState=_RandomState, uniform=default.uniform, random=default.random)
    cp.get_default_memory_pool = lambda: types.SimpleNamespace(free_all_blocks=lambda: None)
    runtime = types.SimpleNamespace(
        getDeviceCount=lambda: 1,
        getDeviceProperties=lambda index: {"name": b"CuPy stand-in (host C++ build, no GPU)", "multiProcessorCount": 0},
        memGetInfo=lambda: (FREE_BYTES, FREE_BYTES),
        runtimeGetVersion=lambda: 0,
        driverGetVersion=lambda: 0,
    )
    cp.cuda = types.SimpleNamespace(runtime=runtime, Device=_Device, Event=Event,
                                    get_elapsed_time=lambda start, stop: 1e3 * (stop.time - start.time))
    return cp
