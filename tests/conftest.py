"""Shared fixtures: one private compile cache for the whole test session, compiles at -O0, derivations
memoised for the session, random generators.

Compile cache. It is keyed by content (sources, compiler, flags), so every test, and every pytest-xdist
worker, shares one folder: an arm compiled by one test is loaded by the next. Compiles that pass no flags
use ``-O0`` (``$SKELARM_SYM_OPT``, see :func:`skelarm_sym.build.default_flags`): the strict warning flags are
the same, and the tests that are about the optimised library (the vectorised batch paths, bit-equality of
batch and single calls, the SIMD trig helpers) pass their ``-O2`` explicitly.

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
"""

import os

import numpy as np
import pytest


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
