"""Rewrite generated/ with what the generator emits now (symbolic n = 2..6, one float example)."""

from pathlib import Path

from skelarm_sym.generate import generate

OUT = Path(__file__).resolve().parents[1] / "generated"

if __name__ == "__main__":
    for n in range(2, 7):
        generate(n, out=OUT)
    generate(3, lengths=(1.0, 0.8, 0.5), precision="float", prefix="arm3f", out=OUT)
    print(f"regenerated {OUT}")
