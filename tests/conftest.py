"""Shared fixtures: one private compile cache for the whole test session, compiles at -O0, derivations
memoised for the session, random generators.

Compile cache. It is keyed by content (sources, compiler, flags), so every test, and every pytest-xdist
worker, shares one folder: an arm compiled by one test is loaded by the next. Compiles that pass no flags
use ``-O0`` (``$SKELARM_SYM_OPT``, see :func:`skelarm_sym.build.default_flags`): the strict warning flags are
the same, and the tests that are about the optimised library (the vectorised batch paths, bit-equality of
batch and single calls, the SIMD trig helpers) pass their ``-O2`` explicitly.

JAX compiles. XLA compiling the emitted solvers (one ``lax.while_loop`` program per solver and input shape) was
the longest single cost of the suite. :func:`pytest_configure` asks XLA for quick CPU compiles (:data:`XLA_QUICK`:
LLVM at ``-O0`` and XLA's older elemental emitters, 2 to 2.5 times less CPU a compile) for the whole session,
workers and the processes they start included, the way the C is compiled at ``-O0``. The HLO programs are the
same; the machine code is not: on a UR5 sample the straight-line functions gave the same bits and the compiled
solvers differed from a default compile by rounding only (at most 3e-14 in double), well within what every test
allows, and no test is about the speed of the JAX code. A JAX that does not take the flags (XLA stops a process
on an unknown one) is found by one probe in a child process (once per installed jaxlib: pytest's cache keeps a
yes) and left as it is, and so is a run that sets ``XLA_FLAGS`` (even empty) or ``SKELARM_SYM_OPT`` (other than
0) itself: ``SKELARM_SYM_OPT=2 pytest`` checks the default, optimised compiles of C and JAX alike.

Python's cyclic collector. A worker keeps what it has loaded (SymPy, JAX, PyTorch) and the session's memoised
derivations alive to the end, millions of objects that every full collection walks again; and SymPy, JAX
tracing and the printers allocate quickly, so the default thresholds (700, 10, 10) start such collections
often. Each worker therefore freezes what exists when the tests are collected (``gc.freeze``: never walked
again) and collects less often (:data:`GC_THRESHOLDS`). Nothing a test checks depends on when cycles are
freed; garbage is still collected (max RSS 4 % higher on the JAX conformance). 0.79-0.96 x the CPU of
``tests/test_chain.py tests/test_closed_ik_emitted.py tests/test_chain_inverse.py`` (four interleaved pairs).

SymPy's cache. SymPy memoises the construction of its expressions in an LRU cache of 1000 entries by default
(``SYMPY_CACHE_SIZE``, read once when SymPy is imported). A worker derives hundreds of arms, closed-form IK
of random arms included, whose small expressions recur from one derivation to the next but are pushed out
of 1000 entries long before they recur. This file sets 20 000 (:data:`SYMPY_CACHE_SIZE`) before anything
imports SymPy, unless the run sets its own: ``tests/test_closed_ik_families.py`` alone 0.75x the CPU (three
interleaved pairs: 23.1 -> 17.2 s), about 15 MB more memory per worker. The cache only saves rebuilding
an expression SymPy has built before; the emitted text is the same (the Panda URDF's files, every
function, byte-identical under 1000 and 20 000; the suite's ``generated/`` check runs under it).

Derivations. Most of the suite's time is SymPy deriving the same robots again: the same arm in several
files, in both precisions, for C and for NumPy. Each worker process therefore keeps, for the whole session,
what a model kind's ``derive(model, wanted)`` returned (the step of :func:`skelarm_sym.generate.generate`,
:func:`skelarm_sym.derive` and ``check`` that holds the SymPy work), keyed by the kind, the model (equal as
a value and by ``repr``, so ``0.5`` and ``1/2``, or Floats of other precisions, are different models) and the
functions asked for. The rule that keeps this honest:

* a cached derivation is the output of the same code for the same input, the first time it is asked for in
  that worker; every test still judges it against its own independent reference (the NumPy references,
  finite differences, the seed closed forms, multi-start numeric IK), so a wrong derivation fails every test
  that uses it, cached or not;
* nothing downstream of the derivation is cached here: lowering to the IR, printing, the stamp, compiling
  (the compile cache only skips a compile whose sources, compiler and flags are byte-identical) all run in
  every test;
* a derivation is never shared between processes (a pickled SymPy expression is rebuilt by its constructors,
  which may not give back the same tree), and one that raised is not kept (the next call raises again);
* a test about the derivation run itself (that two runs give the same text, how long it takes) carries
  ``@pytest.mark.fresh_derivation``: it derives from scratch and stores nothing. ``SKELARM_SYM_TEST_FRESH=1
  pytest`` does that for every test.

Scheduling. ``--dist loadfile`` (pyproject.toml) keeps a file's tests in one worker, which left one worker
alone for minutes with the last long file. :func:`pytest_xdist_make_scheduler` keeps that rule but cuts the
longest files into parts that do not share a module fixture or a cached solver (:data:`_SPLIT`: each JAX
conformance case, each closed-form IK arm, each random family arm) and hands the work units out longest first
(:data:`_COST`, measured CPU seconds), so that both workers stay busy to the end.
"""

import gc
import importlib.metadata
import importlib.util
import os
import subprocess
import sys

import numpy as np
import pytest

SYMPY_CACHE_SIZE = "20000"
"""The size of SymPy's expression cache in every test process (see the module docstring, "SymPy's cache")."""
os.environ.setdefault("SYMPY_CACHE_SIZE", SYMPY_CACHE_SIZE)  # before any test module imports SymPy

XLA_QUICK = "--xla_backend_optimization_level=0 --xla_cpu_use_fusion_emitters=false"
"""XLA's flags for quick CPU compiles (see the module docstring, "JAX compiles")."""


def _quick_xla_flags(cache) -> str | None:
    """:data:`XLA_QUICK` when this session should use it and the installed XLA takes it, else None.

    The probe (a child process that imports JAX: 2.5 s before the workers start) runs once per installed
    jaxlib: a yes is kept in pytest's cache (``cache``, None without the cache plugin), keyed by jaxlib's
    version and the flags."""
    if "XLA_FLAGS" in os.environ or os.environ.get("SKELARM_SYM_OPT") not in (None, "", "0"):
        return None  # the run chose its own compiler settings
    if importlib.util.find_spec("jax") is None:
        return None
    try:
        key = f"skelarm-sym/xla-quick/{importlib.metadata.version('jaxlib')}/{XLA_QUICK}".replace(" ", "_")
    except importlib.metadata.PackageNotFoundError:
        cache = None  # no jaxlib version to key the answer by: probe every time
    if cache is not None and cache.get(key, False):
        return XLA_QUICK
    probe = "import jax.numpy as jnp; jnp.sin(jnp.arange(3.0)).block_until_ready()"
    try:
        done = subprocess.run([sys.executable, "-c", probe], env={**os.environ, "XLA_FLAGS": XLA_QUICK},
                              capture_output=True, timeout=120)
    except (OSError, subprocess.SubprocessError):
        return None
    if done.returncode != 0:
        return None  # not kept: a refusal is asked again (it may have been a failed start)
    if cache is not None:
        cache.set(key, True)
    return XLA_QUICK


def _hypothesis_profile() -> None:
    """CI (``CI=true``) draws Hypothesis's examples from a fixed seed: a run judges the commit, not the luck of
    its draw. Elsewhere each run draws anew (and replays the failures in .hypothesis/): that is how the
    search keeps finding cases (it found tests/test_ir_constants.py's cancelling literals)."""
    if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        from hypothesis import settings

        settings.register_profile("ci", derandomize=True)
        settings.load_profile("ci")


GC_THRESHOLDS = (50_000, 20, 1000)
"""Python's collector thresholds in every test process (see the module docstring, "Python's cyclic collector")."""


def pytest_configure(config):
    gc.set_threshold(*GC_THRESHOLDS)
    _hypothesis_profile()
    # once, in the process that starts the pytest-xdist workers (they inherit the environment), or in a run without them
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        flags = _quick_xla_flags(getattr(config, "cache", None))
        if flags is not None:
            os.environ["XLA_FLAGS"] = flags


def pytest_collection_finish(session):
    gc.freeze()  # the modules the tests imported and what collecting built: never walked again


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory):
    base = tmp_path_factory.getbasetemp()
    # under xdist each worker has its own basetemp (.../popen-gwN); their common parent is the session's
    folder = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "compile-cache"
    folder.mkdir(mode=0o700, exist_ok=True)
    mp = pytest.MonkeyPatch()
    mp.setenv("SKELARM_SYM_CACHE", str(folder))
    if not os.environ.get("SKELARM_SYM_OPT"):  # a run may ask for another level: SKELARM_SYM_OPT=2 pytest
        mp.setenv("SKELARM_SYM_OPT", "0")
    yield
    mp.undo()


# -- derivations memoised for the session (see the module docstring) --------------------------------------------

class _Derivations:
    """The memo of every registered kind's ``derive``: installed for the session, bypassed while ``fresh``."""

    def __init__(self) -> None:
        self.memo: dict = {}
        self.fresh = bool(os.environ.get("SKELARM_SYM_TEST_FRESH"))
        self.originals: list = []  # (kind, its own derive)

    def wrap(self, kind):
        real = kind.derive

        def derive(model, wanted):
            if self.fresh:
                return real(model, wanted)
            try:
                key = (kind.name, type(model), model, repr(model), None if wanted is None else frozenset(wanted))
                hit = self.memo.get(key)
            except TypeError:  # an unhashable model: nothing to key it by
                return real(model, wanted)
            if hit is None:
                hit = self.memo[key] = real(model, wanted)
            return hit

        return real, derive

    def install(self) -> None:
        from skelarm_sym.models.registry import kinds

        for kind in kinds():
            real, derive = self.wrap(kind)
            self.originals.append((kind, real))
            object.__setattr__(kind, "derive", derive)  # ModelKind is a frozen dataclass

    def uninstall(self) -> None:
        for kind, real in self.originals:
            object.__setattr__(kind, "derive", real)
        self.originals.clear()
        self.memo.clear()


_DERIVATIONS = _Derivations()


@pytest.fixture(autouse=True, scope="session")
def _memoised_derivations():
    _DERIVATIONS.install()
    yield
    _DERIVATIONS.uninstall()


@pytest.fixture(autouse=True)
def _fresh_derivation(request):
    if request.node.get_closest_marker("fresh_derivation") is None:
        yield
        return
    before, _DERIVATIONS.fresh = _DERIVATIONS.fresh, True
    try:
        yield
    finally:
        _DERIVATIONS.fresh = before


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


# -- scheduling the two xdist workers ------------------------------------------------------------------------

_SPLIT = {
    # file -> the work unit of one of its tests, from the test's name and parameter id ("" when it has none)
    "tests/test_closed_ik_families.py": lambda name, param: f"{name}[{param}]",  # each random arm alone
    # a backend and model per module-scoped case: each JAX case alone (tracing and XLA compiles, up to 90 s of
    # CPU), the other backends of one model together (one derivation of the model in the worker's memo)
    "tests/test_conformance.py": lambda name, param: param if param.startswith("jax-") else param.split("-", 1)[-1],
    # by arm (the first word of the parameter id): an arm's solver, derived once and cached, serves its tests
    "tests/test_closed_ik_arms.py": lambda name, param: param.split("-")[0],
    "tests/test_closed_ik_emitted.py": lambda name, param: param.split("-")[0],
}
"""Files cut into smaller work units than the whole file (the other files go to one worker whole: their module
fixtures, ``lru_cache`` s and the memo of derivations are built once)."""

_COST = {
    # measured: CPU (user + sys) of each test and the processes it ran, d2dba39 (quick XLA compiles), two workers
    # on a machine shared with other work, rounded; each unit of 2.5 s or more, or one the estimate below misses
    "tests/test_codegen.py": 55, "tests/test_example_robot_data.py": 50, "tests/test_chain.py": 38,
    "tests/test_conformance.py::jax-chain-ur5": 38, "tests/test_robot_cli.py": 40, "tests/test_docs.py": 29,
    "tests/test_torch_jax_backends.py": 22, "tests/test_cuda.py": 27, "tests/test_robustness_c.py": 26,
    "tests/test_autodiff.py": 20, "tests/test_conformance.py::chain-ur5": 18, "tests/test_sanitizers.py": 17,
    "tests/test_ik.py": 15, "tests/test_chain_inverse.py": 13, "tests/test_ik_batch.py": 11,
    "tests/test_foreign_text.py": 11, "tests/test_closed_ik_emitted.py::spherical_wrist": 11,
    "tests/test_closed_ik_emitted.py::": 11, "tests/test_examples.py": 10, "tests/test_closed_ik_postprocess.py": 9,
    "tests/test_cpython_solvers.py": 9, "tests/test_cli.py": 9, "tests/test_cpython_extension.py": 8,
    "tests/test_conformance.py::jax-chain-params": 7, "tests/test_closed_ik_emitted.py::puma560": 7,
    "tests/test_closed_ik_emitted.py::iiwa14_lock3": 7, "tests/test_check_explains.py": 7,
    "tests/test_chain_reference.py": 6, "tests/test_conformance.py::jax-chain-mimic": 6,
    "tests/test_conformance.py::jax-planar": 5, "tests/test_chain_ops.py": 5, "tests/test_cache.py": 5,
    "tests/test_closed_ik_emitted.py::ur5": 5, "tests/test_closed_ik_arms.py::iiwa14_lock3": 5,
    "tests/test_closed_ik_emitted.py::panda_lock7": 4, "tests/test_closed_ik_arms.py::puma560": 4,
    "tests/test_closed_ik_arms.py::panda_lock7": 4, "tests/test_closed_ik_arms.py::panda_urdf_lock7": 4,
    "tests/test_conformance.py::chain-params": 4, "tests/test_closed_ik_arms.py::kinova_j2s6": 4,
    "tests/test_closed_ik_subproblems.py": 4, "tests/test_closed_ik_arms.py::ur5": 4,
    "tests/test_closed_ik_emitted.py::panda_urdf_lock7": 4, "tests/test_derive.py": 4,
    "tests/test_closed_ik_arms.py::stanford": 3, "tests/test_closed_ik_emitted.py::ur5_urdf": 3,
    "tests/test_closed_ik_arms.py::abb_irb140": 3, "tests/test_closed_ik_arms.py::kuka_kr6": 3,
    "tests/test_conformance.py::chain-mimic": 3, "tests/test_closed_ik_emitted.py::abb_irb140": 3,
    "tests/test_closed_ik_arms.py::ur5_urdf": 3, "tests/test_closed_ik_arms.py::ur10_urdf": 3,
    "tests/test_closed_ik_emitted.py::kuka_kr6": 3, "tests/test_closed_ik_arms.py::puma560_modified": 3,
    "tests/test_closed_ik_emitted.py::three_parallel": 3, "tests/test_architecture.py": 3,
    "tests/test_conformance.py::jax-planar-fixed": 2, "tests/test_urdf.py": 2, "tests/test_inverse.py": 2,
    "tests/test_conformance.py::planar": 1, "tests/test_conformance.py::planar-fixed": 1,
    "tests/test_contracts.py": 1, "tests/test_robot_file.py": 0.7, "tests/test_robot_fixtures.py": 0.5,
    "tests/test_conformance.py::diffdrive": 0.5, "tests/test_names.py": 0.1, "tests/test_model.py": 0.0,
}
"""Seconds of CPU of the larger work units (a file, or a unit of :data:`_SPLIT`); only their order matters: units
start longest first so that neither worker is left with a long one at the end. A unit not listed counts 0.2 s a
test (a random arm of ``test_closed_ik_families.py``: 2 s, 6 s for the three of ``..._more``)."""


def _unit(nodeid: str) -> str:
    """The work unit of a test's node id: its file, or a part of it (:data:`_SPLIT`)."""
    file, _, test = nodeid.partition("::")
    split = _SPLIT.get(file)
    if split is None:
        return file
    name, _, param = test.partition("[")
    return f"{file}::{split(name, param[:-1])}"


def _cost(unit: str, tests: int) -> float:
    """:data:`_COST` of a work unit, or an estimate."""
    if unit in _COST:
        return _COST[unit]
    if unit.startswith("tests/test_closed_ik_families.py::test_random_arm"):
        return 6.0 if "_more[" in unit else 2.0
    return 0.2 * tests


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist: a run without it (-p no:xdist) ignores it
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` (pyproject.toml's default), refined: the files of :data:`_SPLIT` cut smaller, and the
    work units handed out longest first (:data:`_COST`). Any other ``--dist`` is left as pytest-xdist has it."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class Schedule(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return _unit(nodeid)

        def _assign_work_unit(self, node) -> None:
            # the costliest unit waiting goes first (the base class hands out the queue's first)
            unit = max(self.workqueue, key=lambda u: _cost(u, len(self.workqueue[u])))
            self.workqueue.move_to_end(unit, last=False)
            super()._assign_work_unit(node)

    return Schedule(config, log)
