"""Print a TOML robot file of N revolute joints (default 64) for generation-time measurements:
modified DH rows alternating alpha = -pi/2, pi/2, 0 with nonzero a and d, so no two
consecutive axes are parallel for long and every joint has offsets.

    python benchmarks/long_chain.py 64 > /tmp/chain64.toml
    skelarm-sym generate --robot /tmp/chain64.toml --out /tmp/chain64
"""

import sys


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 64
    print(f'name = "chain{n}"')
    print('convention = "modified"')
    print(f'description = "{n} revolute joints, alternating twists (generation benchmark)"')
    alphas = ("0", "-pi/2", "pi/2")
    for k in range(n):
        print()
        print("[[joints]]")
        print(f'name = "j{k + 1}"')
        print('type = "revolute"')
        print(f"a = {0.0 if k == 0 else 0.05 + 0.01 * (k % 5)}")
        print(f'alpha = "{alphas[k % 3] if k else "0"}"')
        print(f"d = {0.1 + 0.02 * (k % 3)}")


if __name__ == "__main__":
    main()
