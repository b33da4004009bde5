"""The last per-function pass (skelarm_sym/ir/unread.py): no local of a straight-line function is left that
nothing reads. Judged with the IR's own walk of what each statement reads, and by clang, whose front end reports
an unused variable under the strict flags."""

from __future__ import annotations

import shutil

from skelarm_sym.build import compile_shared
from skelarm_sym.generate import generate
from skelarm_sym.ir.nodes import Add, Let, Mul, Store, TrigBlock, Var
from skelarm_sym.ir.unread import drop_unread
from skelarm_sym.ir.walk import statement_reads
from skelarm_sym.models.chain.loader import load_robot

from test_ir_signs import C, S, TRIG, X


def test_a_chain_of_unread_lets_goes_and_the_rest_stays():
    a, b, c, d = Var("t0"), Var("t1"), Var("t2"), Var("t3")
    body = (TRIG, Let(a, Mul((C[0], X[1]))), Let(b, Mul((a, S[0]))),  # b unread, so a (read only by b) too
            Let(c, Mul((C[1], S[1]))), Let(d, Add((c, X[0]))), Store("y", 0, d), Store("y", 1, c))
    after = drop_unread(body)
    assert after == (TRIG, body[3], body[4], body[5], body[6])
    assert drop_unread(after) == after  # nothing more to drop


def test_trigonometry_blocks_and_stores_stay_even_when_nothing_reads_them():
    unread = TrigBlock((X[0],), (Var("c9"),), (Var("s9"),))
    body = (unread, Store("y", 0, X[1]))
    assert drop_unread(body) == body


def _unread_lets(body) -> list[str]:
    read = set().union(*(statement_reads(s) for s in body))
    return [s.var.name for s in body if type(s) is Let and s.var.name not in read]


TWO_JOINTS = '[[joints]]\ntype = "revolute"\nalpha = "0.3"\na = 0.3\n\n[[joints]]\ntype = "revolute"\nalpha = "-pi/2"\na = 0.3\n'
"""The chain whose manipulability_gradient kept a local the products pass had stopped reading."""


def test_every_local_is_read_in_every_function_of_a_chain(tmp_path):
    robot = tmp_path / "two.toml"
    robot.write_text(TWO_JOINTS)
    g = generate(load_robot(robot), langs="c", out=None, functions="manipulability_gradient,manipulability,jacobian,kinematics")
    straight = [f for f in g.functions if f.kind == "straight"]
    assert straight
    for f in straight:
        assert _unread_lets(f.body) == [], f.name
    if shutil.which("clang"):  # clang's -Wunused-variable comes from its front end: -O0 is enough
        compile_shared(dict(g.sources), flags=("-O0",), compiler="clang")
