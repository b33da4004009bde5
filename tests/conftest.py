"""Shared fixtures: one private compile cache for the whole test session, compiles at -O0, random generators.

The cache is keyed by content (sources, compiler, flags), so every test, and every pytest-xdist worker, shares
one folder: an arm compiled by one test is loaded by the next. Compiles that pass no flags use ``-O0``
(``$SKELARM_SYM_OPT``, see :func:`skelarm_sym.build.default_flags`): the strict warning flags are the same, and
the tests that are about the optimised library (the vectorised batch paths, bit-equality of batch and single
calls, the SIMD trig helpers) pass their ``-O2`` explicitly."""

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


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
