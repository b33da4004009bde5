"""``check``: emitted code against the independent references.

:mod:`.compare` runs every straight-line function on each model's scenarios and tabulates the errors;
:mod:`.ik` runs the solvers; :mod:`.load` reads files written earlier (``check --from``); :mod:`.scenario`
and :mod:`.solver_rows` are what the models' own ``check.py`` build their scenarios and rows from. The
names below load their module on first use, so a model's check imports nothing it does not need.
"""

from __future__ import annotations

import importlib

_WHERE = {
    "EPSILONS": "scenario", "TOLERANCES": "scenario", "Scenario": "scenario", "solve_cutoff": "scenario",
    "tolerance": "scenario", "TABLE_NOTE": "comparison", "OutputError": "comparison", "compare": "comparison",
    "load_implementations": "comparison", "run_check": "comparison", "table": "comparison", "IKCheck": "solver_rows",
    "check_solvers": "ik", "LoadedFiles": "load", "load_generated": "load",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module 'skelarm_sym.check' has no attribute {name!r}")
    return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
