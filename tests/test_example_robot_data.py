"""Every URDF of example-robot-data (the ``oracle`` extra: ``pip install example-robot-data``) either
loads or fails with one line naming the file, and the code emitted for a chain of each one compiles
with the strict flags and computes what the NumPy reference does.

For each file: the default chain (base = root, tip = the only leaf) when there is one, else the chain
to every leaf; each loads or raises an InputError of one line that starts with the file's path. One
chain per file (the default one, else the one with the most coordinates) is generated (C and NumPy,
``pose`` and ``jacobian``), compiled by ``compile_shared`` (``-std=c99 -Wall -Wextra -Werror
-pedantic``), its C checked by clang with the same flags (``-fsyntax-only``: clang's diagnostics without
generating code) when clang is installed, and its NumPy module imported and run against ``chain_kinematics``. Set
``SKELARM_SYM_EVERY_CHAIN=1`` to generate every chain that loads (about 540, some 20 minutes).
"""

from __future__ import annotations

import functools
import importlib.metadata
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from skelarm_sym.errors import InputError
from skelarm_sym.models.chain.loader import load_robot, urdf_links
from skelarm_sym.models.chain.reference import chain_kinematics


def _robots() -> Path | None:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    path = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))
    return path if path.is_dir() else None


ROBOTS = _robots()
pytestmark = [pytest.mark.skipif(ROBOTS is None, reason="example-robot-data is not installed (pip install example-robot-data, or the oracle extra)"),
              pytest.mark.slow]  # a sweep over every URDF of the package: about 90 s of CPU
URDFS = sorted(str(p.relative_to(ROBOTS)) for p in ROBOTS.rglob("*.urdf")) if ROBOTS else []
EVERY_CHAIN = os.environ.get("SKELARM_SYM_EVERY_CHAIN") == "1"
needs_cc = pytest.mark.skipif(not any(shutil.which(c) for c in ("cc", "gcc", "clang")), reason="no C compiler on PATH")

NO_CHAIN = {  # files with no moving joint to make a chain of: each is refused with one line
    "ur_description/urdf/ur3.urdf": "a <robot> without links (its xacro left it empty)",
    "hector_description/robots/quadrotor_base.urdf": "one link, no joint",
    "iris_description/robots/iris_simple.urdf": "fixed joints only",
}


def _one_line(error: InputError, path: Path) -> None:
    message = str(error)
    assert message.startswith(f"{path}: ") and "\n" not in message and message.isprintable(), message
    assert len(message) < 1000, message


@functools.lru_cache(maxsize=None)  # both tests read every file: load each once
def _chains(path: Path) -> dict[str | None, object]:
    """The chains of ``path`` that load, by tip (None: the default chain); every refusal is one line."""
    try:
        links = urdf_links(path)
    except InputError as error:
        _one_line(error, path)
        return {}
    try:
        return {None: load_robot(path)}
    except InputError as error:
        _one_line(error, path)
    chains = {}
    for link in links:
        if link.leaf and link.depth:
            try:
                chains[link.name] = load_robot(path, tip=link.name)
            except InputError as error:
                _one_line(error, path)
    return chains


def test_the_package_has_its_robots():
    assert len(URDFS) >= 60
    assert "ur_description/urdf/ur5_robot.urdf" in URDFS and "panda_description/urdf/panda.urdf" in URDFS


@pytest.mark.parametrize("rel", URDFS)
def test_every_urdf_loads_or_fails_with_one_line(rel):
    chains = _chains(ROBOTS / rel)
    if rel in NO_CHAIN:
        assert chains == {}, NO_CHAIN[rel]
    else:
        assert chains, f"{rel}: no chain loads"
        for chain in chains.values():
            assert chain.n >= 1 and chain.default_prefix.isidentifier()


def _generated_chains(rel):
    chains = _chains(ROBOTS / rel)
    if not chains:
        pytest.skip(f"{rel}: no chain loads")
    if EVERY_CHAIN:
        return list(chains.items())
    tip = None if None in chains else max(chains, key=lambda t: chains[t].n)  # first of the longest
    return [(tip, chains[tip])]


@needs_cc
@pytest.mark.parametrize("rel", [r for r in URDFS if r not in NO_CHAIN])
def test_emitted_code_compiles_strictly_and_runs(rel, rng, tmp_path):
    from skelarm_sym.build import STRICT_FLAGS, compile_shared, load_python
    from skelarm_sym.generate import generate

    for tip, chain in _generated_chains(rel):
        generated = generate(chain, langs="c,python", out=None, functions="pose,jacobian")
        sources = {k: v for k, v in generated.sources.items() if k.endswith((".c", ".h"))}
        library = compile_shared(sources)
        assert library.is_file()
        if shutil.which("clang"):  # and clang's diagnostics (its front end's: no code generated), a warning an error
            for name, text in sources.items():
                (tmp_path / name).write_text(text, encoding="utf-8")
            c_file = next(name for name in sources if name.endswith(".c"))
            result = subprocess.run(["clang", *STRICT_FLAGS, "-fsyntax-only", str(tmp_path / c_file)],
                                    capture_output=True, text=True)
            assert result.returncode == 0 and result.stderr == "", f"{rel} tip {tip}: {result.stderr[-2000:]}"
        prefix = next(k for k in generated.sources if k.endswith(".py"))[:-3]
        module = load_python(generated.sources[f"{prefix}.py"], prefix)
        numeric = chain.numeric()
        for _ in range(2):
            q = rng.uniform(-1, 1, chain.n)
            expected = chain_kinematics(numeric, q)
            np.testing.assert_allclose(module.pose(q), expected.T, atol=1e-12, err_msg=f"{rel} tip {tip}")
            np.testing.assert_allclose(module.jacobian(q), expected.J, atol=1e-12, err_msg=f"{rel} tip {tip}")


def test_centauro_wheel_legs_closed_form_ik():
    """centauro's wheel legs are three-parallel arms whose parallel axes point opposite ways (``rpy="3.14159265359 0
    0"`` frames): every exact row reproduces its target and the configuration that made it is among the rows (every
    row's q4 was wrong, poses up to 2 m off, flagged exact). The whole collection: ``python
    benchmarks/closed_ik_sweep.py --urdfs``."""
    from closed_ik_support import pose_errors, random_configurations, wrapped_distance

    from skelarm_sym.closed_ik.evaluate import ClosedFormIK
    from skelarm_sym.models.chain import reference_ik_all as judge

    path = ROBOTS / "centauro_description" / "urdf" / "centauro.urdf"
    for tip in ("wheel_1", "wheel_4"):
        chain = load_robot(path, tip=tip)
        assert chain.n == 6
        num = chain.numeric()
        q = random_configurations(chain, 40, np.random.default_rng(5))
        T = chain_kinematics(num, q).T
        Q, flags = ClosedFormIK(chain).candidates(T.reshape(-1, 16))
        exact = (flags & 1) == 0
        pos, rot = pose_errors(num, Q, T)
        assert np.where(exact, np.maximum(pos, rot), 0.0).max() <= 1e-11
        near = np.where(exact, wrapped_distance(Q, q[:, None, :], judge.revolute_mask(num)), np.inf).min(axis=1)
        assert near.max() < 1e-6, (tip, near.max())
