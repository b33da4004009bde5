"""Rewrite generated/ with what the generator emits now (symbolic n = 2..6, one float example, the diffdrive, UR5 and Panda).

Run from the repository root: ``PYTHONPATH=. python scripts/regenerate.py``. The tests call
:func:`regenerate` into a temporary folder and compare byte for byte.
"""

from pathlib import Path

from skelarm_sym.generate import generate
from skelarm_sym.models.diffdrive import DiffDrive
from skelarm_sym.models.chain.dh_file import load_robot_file

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "generated"
ROBOTS = ("ur5", "panda")
"""Example robots kept in generated/ (from examples/robots/, named by their path from the repository root)."""


def regenerate(out: Path = OUT) -> None:
    """Emit every committed example into ``out``."""
    for n in range(2, 7):
        generate(n, out=out, force=True)
    generate(3, lengths=(1.0, 0.8, 0.5), precision="float", prefix="arm3f", out=out, force=True)
    generate(DiffDrive(), out=out, force=True)
    for name in ROBOTS:
        generate(load_robot_file(ROOT / f"examples/robots/{name}.toml"), out=out, force=True, recorded_folder=OUT)


if __name__ == "__main__":
    regenerate()
    print(f"regenerated {OUT}")
