"""One test body over every registered backend and every model kind (issue 17): a new backend is checked
by adding it to the registry. Each pair is generated in memory, loaded through the backend's own
``load``, and must (1) have every public function, (2) match the model's independent reference on the
check's scenarios, its solvers converging on reachable targets, (3) give the same numbers for a batch
as for its configurations one at a time, and (4) refuse bad input with a clear error. A backend that
cannot print a kind of function says so in its ``SUPPORTS``: the test then reports it as a skip with
that reason, never silently."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from skelarm_sym.backends import BACKENDS
from skelarm_sym.check import check_solvers, compare
from skelarm_sym.generate import generate
from skelarm_sym.models import DiffDrive, PlanarArm
from skelarm_sym.models.chain.dh_file import chain_from_table
from skelarm_sym.models.chain.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]

PARAMETRISED = {  # a chain with named parameters: the emitted functions take params
    "name": "param2", "convention": "standard",
    "joints": [{"type": "revolute", "a": "upper", "alpha": "pi/2", "d": 0.2},
               {"type": "revolute", "a": "forearm"}, {"type": "prismatic", "alpha": "-pi/2", "theta": "pi/2"}],
}

MODELS = {
    "planar": lambda: PlanarArm(3),
    "planar-fixed": lambda: PlanarArm(4, (1.0, 0.8, 0.5, 0.3)),
    "diffdrive": lambda: DiffDrive(None),
    "chain-ur5": lambda: load_robot(ROOT / "examples" / "robots" / "ur5.toml"),
    "chain-params": lambda: chain_from_table(PARAMETRISED),
    "chain-mimic": lambda: load_robot(ROOT / "tests" / "fixtures" / "robots" / "gantry_gripper.urdf"),
}


# JAX traces and compiles every function of a case (a minute for the UR5 on two cores): its cases are in the
# slow set; the other backends print the same IR and stay in the quick one
@pytest.fixture(scope="module", params=[pytest.param((lang, model), marks=pytest.mark.slow if lang == "jax" else ())
                                        for lang in BACKENDS for model in MODELS], ids=lambda p: f"{p[0]}-{p[1]}")
def case(request):
    lang, model_name = request.param
    backend = BACKENDS[lang]
    model = MODELS[model_name]()
    generated = generate(model, langs=lang, out=None, prefix=f"conf_{model_name.replace('-', '_')}")
    return backend, generated, backend.load(generated)


def _supported(backend, function) -> None:
    if function.kind not in backend.SUPPORTS:
        pytest.skip(f"backend {backend.LANGUAGE} does not print {function.kind} functions ({function.name}): SUPPORTS = {backend.SUPPORTS}")


def test_every_public_function_is_there(case):
    backend, generated, impl = case
    missing = [f.name for f in generated.functions if f.kind in backend.SUPPORTS and not callable(getattr(impl, f.name, None))]
    assert missing == [], f"backend {backend.LANGUAGE} lacks {missing}"
    unsupported = [f.name for f in generated.functions if f.kind not in backend.SUPPORTS]
    if unsupported:
        pytest.skip(f"backend {backend.LANGUAGE} prints no {sorted({f.kind for f in generated.functions if f.name in unsupported})}: {unsupported}")


def test_every_file_says_what_wrote_it_and_how_to_write_it_again(case):
    """What check --from and generate read back from a set's files: the mark of skelarm-sym (else generate refuses to
    overwrite the file, and check --from finds no set), the command that regenerates it, and the set's stamp."""
    from skelarm_sym.check.load import _MARK
    from skelarm_sym.generate import file_stamp

    backend, generated, _ = case
    stamps = set()
    for name, text in generated.sources.items():
        assert _MARK in text, f"{name}: no '{_MARK}' mark"
        assert "regenerate with (in this folder): skelarm-sym generate " in text, f"{name}: no regenerate line"
        stamps.add(file_stamp(text))
    assert len(stamps) == 1 and None not in stamps, stamps


def test_outputs_match_the_reference(case):
    backend, generated, impl = case
    results = compare(generated, cases=12, seed=5, implementations=[(backend.LABEL, impl)])
    assert results and all(r.ok for r in results), [r for r in results if not r.ok]
    names = {r.implementation.split(" [")[0].split(" ", 1)[1] for r in results}
    assert names == {f.name for f in generated.programs}  # every straight function judged
    if any(f.kind == "procedure" for f in generated.functions):
        if "procedure" not in backend.SUPPORTS:
            pytest.skip(f"backend {backend.LANGUAGE} prints no procedures: the solvers are not judged here")
        rows = check_solvers(generated, [(backend.LABEL, impl)], cases=4, seed=5)
        assert rows and all(r.ok for r in rows), [r.row() for r in rows]


def _inputs(function, rng, batch: tuple[int, ...]):
    """Random valid inputs of ``function``: batched arrays (..., size), shared ones (size,), scalars."""
    values = []
    for a in function.inputs:
        low, high = (0.5, 1.5) if a.domain == "positive" else (0.0, 0.2) if a.domain == "nonnegative" else (-1.0, 1.0)
        if a.is_scalar:
            values.append(float(rng.uniform(low, high)))
        elif a.batched:
            values.append(rng.uniform(low, high, batch + (a.size,)))
        else:
            values.append(rng.uniform(low, high, (a.size,)))
    return values


def test_a_batch_gives_the_numbers_of_its_configurations(case):
    backend, generated, impl = case
    rng = np.random.default_rng(9)
    for f in generated.programs:
        args = _inputs(f, rng, (2, 3))
        batched = getattr(impl, f.name)(*args)
        batched = batched if isinstance(batched, tuple) else (batched,)
        for i in range(2):
            for j in range(3):
                single_args = [x[i, j] if (a.batched and not a.is_scalar) else x for x, a in zip(args, f.inputs)]
                single = getattr(impl, f.name)(*single_args)
                single = single if isinstance(single, tuple) else (single,)
                for out, one in zip(batched, single):
                    np.testing.assert_allclose(np.asarray(out)[i, j], one, rtol=1e-14, atol=1e-14, err_msg=f.name)


def test_bad_input_is_refused(case):
    backend, generated, impl = case
    rng = np.random.default_rng(4)
    for f in generated.programs:
        method = getattr(impl, f.name)
        args = _inputs(f, rng, (2,))
        first = next(i for i, a in enumerate(f.inputs) if not a.is_scalar)
        bad = list(args)
        bad[first] = np.full_like(args[first], np.nan)
        with pytest.raises(ValueError, match=f.inputs[first].name):
            method(*bad)
        bad = list(args)
        bad[first] = np.zeros(args[first].shape[:-1] + (f.inputs[first].size + 1,))
        with pytest.raises(ValueError, match=f.inputs[first].name):
            method(*bad)
        bad = list(args)
        bad[first] = args[first].astype(complex)
        with pytest.raises(ValueError, match=f.inputs[first].name):
            method(*bad)
        with pytest.raises(TypeError, match=f.name):
            method(*args, 1.0)


def test_a_kind_of_function_a_backend_does_not_print_is_refused_not_dropped(monkeypatch, tmp_path):
    """generate wrote a backend's file without the functions of a kind its SUPPORTS leaves out, and said nothing
    (a contributor's probe: a straight-line-only backend given ik_solve). Now the set is refused, naming them, and
    nothing is written."""
    from skelarm_sym.errors import InputError

    monkeypatch.setattr(BACKENDS["python"], "SUPPORTS", ("straight",))
    chain = load_robot(ROOT / "examples" / "robots" / "ur5.toml")
    with pytest.raises(InputError, match=r"^--lang python does not print procedure functions \(ik_solve\): leave them out"):
        generate(chain, langs="python", out=tmp_path, functions="pose,ik_solve")
    assert list(tmp_path.iterdir()) == []
    assert set(generate(chain, langs="python", out=None, functions="pose").sources) == {"ur5.py"}
