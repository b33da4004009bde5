"""Rewrite generated/ with what the generator emits now (symbolic n = 2..6, one float example, the diffdrive).

Run from the repository root: ``PYTHONPATH=. python scripts/regenerate.py``. The tests call
:func:`regenerate` into a temporary folder and compare byte for byte.
"""

from pathlib import Path

from skelarm_sym.generate import generate
from skelarm_sym.models.diffdrive import DiffDrive

OUT = Path(__file__).resolve().parents[1] / "generated"


def regenerate(out: Path = OUT) -> None:
    """Emit every committed example into ``out``."""
    for n in range(2, 7):
        generate(n, out=out)
    generate(3, lengths=(1.0, 0.8, 0.5), precision="float", prefix="arm3f", out=out)
    generate(DiffDrive(), out=out)


if __name__ == "__main__":
    regenerate()
    print(f"regenerated {OUT}")
