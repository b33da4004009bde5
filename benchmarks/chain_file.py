"""Write a TOML robot file of an N-joint revolute chain (for timing generation on long chains).

    python benchmarks/chain_file.py 64 /tmp/chain64.toml

Standard DH; joint i has a = 0.1, 0.2, 0.3 and alpha = pi/2, 0, -pi/2 in turn, d = 0.05: no two
consecutive axes alike, so nothing folds away (the rows tests/test_chain_ops.py grows chains with).
"""

import sys
from pathlib import Path


def chain_toml(n: int) -> str:
    lines = [f'name = "chain{n}"', 'convention = "standard"']
    for i in range(n):
        lines += ["[[joints]]", 'type = "revolute"', f"a = {0.1 * (1 + i % 3):.1f}",
                  f'alpha = "{["pi/2", "0", "-pi/2"][i % 3]}"', "d = 0.05"]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    count, path = int(sys.argv[1]), Path(sys.argv[2])
    path.write_text(chain_toml(count))
