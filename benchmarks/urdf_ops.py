"""Operation counts of every example-robot-data chain, this checkout against another: what a change to the chain
derivation does beyond the robots ``casadi_compare.py`` counts.

    python benchmarks/urdf_ops.py --before OTHER_PYTHON               # the rows that differ, and the totals
    python benchmarks/urdf_ops.py --before OTHER_PYTHON --all         # every row
    python benchmarks/urdf_ops.py --functions pose,jacobian           # this checkout alone

Needs ``pip install example-robot-data``. The chain of each URDF is the one ``tests/test_example_robot_data.py``
compiles: the default chain, else the first of the longest (66 files). The counts are the IR's
(``Program.ops.arithmetic``: additions, multiplications, divisions and negations, as the C and the NumPy code
write them), one derivation per URDF and checkout; ``OTHER_PYTHON`` runs the other checkout's code
(``PYTHONSAFEPATH=1 PYTHONPATH=/path/to/checkout exec python "$@"``), as the other A/B benchmarks take it.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import sysconfig
from pathlib import Path

FUNCTIONS = "pose,jacobian,jacobian_dot,kinematics"

COUNT = r"""
import json, sys
from pathlib import Path
sys.path.insert(0, sys.argv[3])  # this folder: example_chains below, run by the other checkout's package
from skelarm_sym.generate import generate
from urdf_ops import example_chains

root, functions = Path(sys.argv[1]), sys.argv[2]
out = {}
for rel, (chain, _tip) in example_chains(root).items():
    g = generate(chain, langs="python", out=None, functions=functions)
    out[rel] = {p.name: p.ops.arithmetic for p in g.programs}
print(json.dumps(out))
"""


def example_chains(root: Path) -> dict:
    """``{urdf path relative to root: (chain, tip or None)}``, sorted: of every URDF under ``root`` the chain
    ``tests/test_example_robot_data.py`` compiles: the default chain, else the first of the longest (66 files of
    example-robot-data 6). Imports the ``skelarm_sym`` on the path (this checkout's or another's)."""
    from skelarm_sym.errors import InputError
    from skelarm_sym.models.chain.loader import load_robot
    from skelarm_sym.models.chain.urdf import urdf_links

    out = {}
    for path in sorted(root.rglob("*.urdf")):
        try:
            chain, tip = load_robot(path), None
        except InputError:
            chain, tip = None, None
            try:
                leaves = [link.name for link in urdf_links(path) if link.leaf and link.depth]
            except InputError:
                leaves = []
            for leaf in leaves:
                try:
                    found = load_robot(path, tip=leaf)
                except InputError:
                    continue
                if chain is None or found.n > chain.n:  # the first of the longest
                    chain, tip = found, leaf
        if chain is not None:
            out[str(path.relative_to(root))] = (chain, tip)
    return out


def robots_folder() -> Path:
    return Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"


def counts(python: str, root: Path, functions: str) -> dict[str, dict[str, int]]:
    """``{urdf: {function: operations}}`` from the checkout that ``python`` runs."""
    done = subprocess.run([python, "-c", COUNT, str(root), functions, str(Path(__file__).resolve().parent)],
                          check=True, capture_output=True, text=True)
    return json.loads(done.stdout)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", help="the Python of the other checkout (see the module docstring)")
    parser.add_argument("--functions", default=FUNCTIONS, help=f"comma-separated functions (default {FUNCTIONS})")
    parser.add_argument("--all", action="store_true", help="print every row, not only those that differ")
    args = parser.parse_args(argv)
    root = robots_folder()
    if not root.is_dir():
        raise SystemExit(f"example-robot-data's robots are not at {root}: pip install example-robot-data")
    functions = [f for f in args.functions.split(",") if f]
    after = counts(sys.executable, root, ",".join(functions))
    before = counts(args.before, root, ",".join(functions)) if args.before else after
    print(f"{len(after)} chains; operations (IR count), before -> after" if args.before else f"{len(after)} chains; operations (IR count)")
    print()
    print("| urdf | " + " | ".join(functions) + " |")
    print("|---|" + "---|" * len(functions))
    totals = {f: [0, 0] for f in functions}
    for urdf in sorted(after):
        a, b = after[urdf], before.get(urdf, {})
        for f in functions:
            totals[f][0] += b.get(f, 0)
            totals[f][1] += a.get(f, 0)
        if args.all or a != b:
            cells = [f"{b.get(f)} -> {a.get(f)}" if args.before else str(a.get(f)) for f in functions]
            print(f"| {urdf} | " + " | ".join(cells) + " |")
    cells = [f"{t[0]} -> {t[1]}" if args.before else str(t[1]) for t in totals.values()]
    print("| **total** | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
