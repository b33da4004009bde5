"""The argument-order rule, checked on the emitted prototypes and the Python signatures."""

import inspect
import re
from pathlib import Path

import pytest

from skelarm_sym.build import load_python
from skelarm_sym.derive.core import ARGUMENT_ROLES, FunctionSpec
from skelarm_sym.generate import generate
from skelarm_sym.models.diffdrive import DiffDrive

GENERATED = Path(__file__).resolve().parents[1] / "generated"
OUTPUT_ROLE = 4
PROTOTYPE = re.compile(r"^(?:void|int)\s+\w+\((.*?)\);", re.M | re.S)


def _roles(params: list[str]) -> list[int]:
    roles = []
    for text in params:
        text = text.strip()
        if text == "size_t m":
            continue
        name = re.sub(r"\[.*\]", "", text.split()[-1]).lstrip("*")
        is_output = not text.startswith("const ") and ("[" in text or "*" in text)
        roles.append(OUTPUT_ROLE if is_output else ARGUMENT_ROLES[name])
    return roles


@pytest.mark.parametrize("header", sorted(GENERATED.glob("*.h")), ids=lambda p: p.name)
def test_emitted_prototypes_follow_the_argument_order(header):
    text = header.read_text()
    assert "Arguments, in every function: the state (" in text
    prototypes = PROTOTYPE.findall(text)
    assert prototypes
    for params in prototypes:
        roles = _roles(params.split(","))
        assert roles == sorted(roles), params


def test_a_wrong_order_is_refused_at_derivation_time():
    with pytest.raises(ValueError, match="argument order"):
        FunctionSpec("bad", ("q", "l", "v", "lambda"), ("dq",), "")


@pytest.mark.parametrize("model", [3, DiffDrive()], ids=["arm3", "diffdrive"])
def test_python_signatures_follow_the_argument_order(model):
    generated = generate(model, langs="python", out=None)
    module = load_python(next(iter(generated.sources.values())), "m")
    for program in generated.programs:
        names = [p.rstrip("_") for p in inspect.signature(getattr(module, program.name)).parameters]
        roles = [ARGUMENT_ROLES[n] for n in names]
        assert roles == sorted(roles), (program.name, names)


def test_the_argument_rule_names_the_models_own_arguments():
    """The drive's header listed an arm's arguments (q, q0, twist, lambda, tol, max_iter, lock), none of which it
    takes (a new user's probe)."""
    drive = (GENERATED / "diffdrive.h").read_text()
    assert "the state (pose), the call's other data (wheels, rates), the\n * mechanism's parameters (track)" in drive
    assert "lambda" not in drive.split("Precision:")[0]
    arm = (GENERATED / "ur5.h").read_text()
    assert "scalars (lambda, tol, max_iter)" in arm.replace("\n * ", " ")


def test_arguments_of_the_wrong_type_are_a_value_error():
    """A security review: ``load_robot(..., tip=5)`` raised AttributeError, ``generate(out=123)`` and
    ``generate(functions=5)`` TypeError; bad input from Python is a ValueError that names the argument."""
    from pathlib import Path

    from skelarm_sym.generate import generate
    from skelarm_sym.models.chain import load_robot

    from skelarm_sym.build import compile_arm

    urdf = Path(__file__).parent.parent / "examples" / "robots" / "ur5.urdf"
    generated = generate(2, out=None, langs="c", functions="position")
    for call, message in ((lambda: load_robot(urdf, tip=5), "tip must be a link's name"),
                          (lambda: load_robot(urdf, base=b"base"), "base must be a link's name"),
                          (lambda: generate(2, out=123), "out must be a folder's path"),
                          (lambda: generate(2, out=None, functions=5), "functions must be a comma-separated string"),
                          (lambda: generate(2, out=None, functions=["position", 3]), "functions must be"),
                          # a second review: force="no" is true, and replaced a user's file
                          (lambda: generate(2, out=None, force="no"), "force must be True or False"),
                          (lambda: generate(2, out=None, cmake="false", langs="c"), "cmake must be True or False"),
                          (lambda: generate(2, out=None, before_writing=3), "before_writing must be a function"),
                          (lambda: compile_arm(None), "compile_arm takes what generate"),
                          (lambda: compile_arm(generated, compiler=5), "compiler must be a command"),
                          (lambda: compile_arm(generated, flags="-O2"), "flags must be a sequence of strings"),
                          (lambda: compile_arm(generated, flags=[1]), "flags must be a sequence of strings"),
                          # a probe: extension="yes" was taken as true; an empty path was "a folder", a NUL one a bare
                          # "embedded null byte"
                          (lambda: compile_arm(generated, extension="yes"), "extension must be True, False or None"),
                          (lambda: load_robot(""), "load_robot: the robot file's path is empty"),
                          (lambda: load_robot("/tmp/a\0b.urdf"), r"the robot file's path '/tmp/a\\x00b\.urdf' holds a NUL")):
        with pytest.raises(ValueError, match=message):
            call()


def test_none_for_a_solver_number_is_refused_alike_by_every_module():
    """A probe: the compiled wrapper (ctypes and extension) took ``ik_solve(q0, target, l, None)`` as the default lambda,
    where the emitted NumPy module (and PyTorch, JAX) refuse None; the README promises the same signatures. A None is
    now taken only where the signature's default is None (a default computed from the other arguments: a planar arm's
    tol), and refused with the same message elsewhere."""
    import numpy as np

    from skelarm_sym.build import compile_arm, load_python
    from skelarm_sym.generate import generate

    generated = generate(2, out=None, langs="c,python", functions="ik_solve")
    modules = (compile_arm(generated), load_python(generated.sources["arm2.py"], "arm2"))
    q0, target, l = np.array([0.3, 0.4]), np.array([1.2, 0.6]), np.ones(2)
    for module in modules:
        for args, message in (((None,), "lambda must hold real numbers, got object"),
                              ((0.0, 1e-9, None), "max_iter must be a whole number")):
            with pytest.raises(ValueError, match=message):
                module.ik_solve(q0, target, l, *args)
        assert module.ik_solve(q0, target, l, 0.0, None).status == "converged"
