"""The CUDA backend (see :mod:`.backend`): ``{prefix}.cuh``, ``{prefix}.cu`` and the Python entry
``{prefix}_cuda.py``. ``load`` compiles the ``.cu`` as host C++ (no GPU needed) so that the conformance
test checks its arithmetic everywhere; :mod:`.host` says how."""

from __future__ import annotations

from .backend import FILE_SUFFIXES, LANGUAGE, render

LABEL = "CUDA-host"
"""How ``check`` names this backend's implementation (the .cu's functions compiled as host C++)."""
SUPPORTS = ("straight", "procedure")
"""The kinds of IR function this backend prints: straight-line functions and the solvers, each with a
batch kernel (one configuration or IK target per thread)."""


def load(generated):
    """The ``.cu`` compiled as host C++ (``__host__ __device__`` defined away; cached like the C) and loaded
    through ctypes: one method per public function, batches through the kernels' per-thread body."""
    from .host import compile_host

    return compile_host(generated)


__all__ = ["FILE_SUFFIXES", "LABEL", "LANGUAGE", "SUPPORTS", "load", "render"]
