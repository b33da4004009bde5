"""skelarm-sym against CasADi on the same chains: operations counted the same way, and time per call.

    python benchmarks/casadi_compare.py                    # UR5, Panda, xArm7 (example-robot-data) + examples/robots/*.toml
    python benchmarks/casadi_compare.py --no-time          # operation counts only
    python benchmarks/casadi_compare.py examples/robots/ur5.toml path/to/panda.urdf:panda_hand_tcp
    python benchmarks/casadi_compare.py --no-time --example-robot-data   # every example-robot-data chain (66: one chain per URDF, none with named parameters)

Needs ``pip install casadi example-robot-data`` (the URDFs are read from example-robot-data's
``cmeel.prefix/share/example-robot-data/robots``) and a C compiler.

For each robot, from the same :class:`~skelarm_sym.models.chain.model.Chain`:

* **CasADi**: SX expressions written the way a CasADi user would: the tool pose as the product of
  the chain's constant 4 x 4 transforms and its joint motions (rotation about the joint's axis, or
  translation along it; SX folds the products with structural zeros and ones), the geometric
  Jacobian's columns ``[z_k x (p - o_k); z_k]`` (``[z_k; 0]`` for a prismatic joint) with ``z_k`` the joint's
  axis in base axes (``R_k axis_k``) and ``o_k`` its origin, a mimic joint's column added with its multiplier, ``J_tool = blockdiag(R^T, R^T) J``, ``dJ = jtimes(J, q, dq)``,
  ``twist = J dq``, ``acc = J ddq + dJ dq``; one ``casadi.Function`` per emitted function with
  ``cse`` on, printed by ``casadi.CodeGenerator``. Its values are checked against
  :func:`skelarm_sym.reference.chain_kinematics` before anything is counted or timed.
* **skelarm-sym**: ``generate(chain, langs="c", functions=...)``.

Operations are counted by one small counter over the C text of each function's body (and the
helpers it calls): binary ``+ -`` (add), ``*`` (mul), ``/`` (div), unary minus (neg; a minus
sign written on a number literal is part of the literal), and ``sin``/``cos``/``sqrt`` calls
(``casadi_sq(x)`` is one multiplication). skelarm-sym evaluates its sines and cosines in a loop
over the angles, so its calls are counted as the number of angles that loop is given.
``arith`` = add + mul + div + neg.

Time: one C program (``casadi_harness.c``, ``gcc -O2``) calls ours built with vector math, ours
built with ``-DSKELARM_NO_SIMD`` and CasADi's on the same random configurations; the three are
interleaved and the medians of 31 passes reported (the machine is shared). It first prints every
variant's outputs at one configuration, and those are compared with the reference too.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np

from skelarm_sym import reference
from skelarm_sym.build import find_compiler
from skelarm_sym.generate import generate
from skelarm_sym.models.chain.loader import load_robot

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FUNCTIONS = ("pose", "jacobian", "jacobian_tool", "jacobian_dot", "kinematics")
OUTPUTS = {
    "pose": ("T",), "jacobian": ("J",), "jacobian_tool": ("J_tool",), "jacobian_dot": ("dJ",),
    "kinematics": ("T", "J", "dJ", "twist", "acc"),
}
INPUTS = {"pose": 1, "jacobian": 1, "jacobian_tool": 1, "jacobian_dot": 2, "kinematics": 3}
FLAGS = ["-O2", "-std=c99"]
CONFIGS = 2000


def robots_folder() -> Path:
    return Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"


def default_robots() -> list[tuple[Path, str | None]]:
    erd = robots_folder()
    out = [
        (erd / "ur_description/urdf/ur5_robot.urdf", "tool0"),
        (erd / "panda_description/urdf/panda.urdf", "panda_hand_tcp"),
        (erd / "xarm_description/urdf/xarm7.urdf", "link_eef"),
    ]
    out = [(p, t) for p, t in out if p.exists()]
    return out + [(p, None) for p in sorted((ROOT / "examples" / "robots").glob("*.toml"))]


def example_robots() -> list[tuple[Path, str | None]]:
    """Every example-robot-data URDF with a chain without named parameters, and its tip (see ``urdf_ops.py``)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from urdf_ops import example_chains

    root = robots_folder()
    if not root.is_dir():
        raise SystemExit(f"example-robot-data's robots are not at {root}: pip install example-robot-data")
    return [(root / rel, tip) for rel, (chain, tip) in example_chains(root).items() if not chain.parameters]


# -- CasADi -------------------------------------------------------------------------------------

def casadi_functions(chain):
    """``{name: casadi.Function}`` for the chain (see the module docstring)."""
    import casadi as ca

    if chain.parameters:
        raise SystemExit(f"{chain.name}: named parameters are not supported by this comparison")
    num = chain.numeric()
    n = chain.n
    q, dq, ddq = ca.SX.sym("q", n), ca.SX.sym("dq", n), ca.SX.sym("ddq", n)

    def const(m):
        return ca.sparsify(ca.DM(np.asarray(m, dtype=float)))

    def motion(kind, axis, theta):
        M = ca.SX.eye(4)
        if kind == "prismatic":
            for i in range(3):
                if axis[i] != 0:
                    M[i, 3] = float(axis[i]) * theta
            return M
        c, s = ca.cos(theta), ca.sin(theta)
        exact = [i for i in range(3) if abs(axis[i]) == 1.0]
        if exact:  # rotation about a base axis, as written by hand
            i = exact[0]
            j, k = (i + 1) % 3, (i + 2) % 3
            sign = float(axis[i])
            M[j, j] = c
            M[k, k] = c
            M[k, j] = sign * s
            M[j, k] = -sign * s
            return M
        K = ca.DM([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        M[:3, :3] = ca.DM.eye(3) + s * K + (1 - c) * ca.mtimes(K, K)  # Rodrigues
        return M

    T = const(num.base)
    frames = []  # (kind, coordinate, multiplier, axis z and origin o in base axes)
    for j in num.joints:
        T = ca.mtimes(T, const(j.before))
        theta = j.multiplier * q[j.coordinate] + j.offset
        frames.append((j.kind, j.coordinate, j.multiplier, ca.mtimes(T[:3, :3], const(j.axis)), T[:3, 3]))
        T = ca.mtimes(ca.mtimes(T, motion(j.kind, j.axis, theta)), const(j.after))
    T = ca.mtimes(T, const(num.tool))
    R, p = T[:3, :3], T[:3, 3]
    J = ca.SX(6, n)
    for kind, c, m, z, o in frames:  # geometric columns [z x (p - o); z] (revolute), [z; 0] (prismatic)
        if kind == "revolute":
            J[:3, c] += m * ca.cross(z, p - o)
            J[3:, c] += m * z
        else:
            J[:3, c] += m * z
    J_tool = ca.vertcat(ca.mtimes(R.T, J[:3, :]), ca.mtimes(R.T, J[3:, :]))
    dJ = ca.jtimes(J, q, dq)
    twist = ca.mtimes(J, dq)
    acc = ca.mtimes(J, ddq) + ca.mtimes(dJ, dq)
    values = {"T": T, "J": J, "J_tool": J_tool, "dJ": dJ, "twist": twist, "acc": acc}
    args = [q, dq, ddq]
    return {
        name: ca.Function(f"ca_{name}", args[: INPUTS[name]], [ca.densify(values[o]) for o in OUTPUTS[name]], {"cse": True})
        for name in FUNCTIONS
    }


def check_casadi(chain, functions, rng) -> None:
    """CasADi's values against the reference at a few random configurations (SystemExit when they differ)."""
    n = chain.n
    num = chain.numeric()
    for _ in range(3):
        q, dq, ddq = rng.uniform(-np.pi, np.pi, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
        ref = reference.chain_kinematics(num, q, dq, ddq)
        for name, fn in functions.items():
            got = fn(*[q, dq, ddq][: INPUTS[name]])
            got = got if isinstance(got, (list, tuple)) else [got]
            for o, value in zip(OUTPUTS[name], got):
                want = getattr(ref, o)
                value = np.array(value).reshape(want.shape) if want.ndim == 1 else np.array(value)
                if not np.allclose(value, want, atol=1e-10, rtol=1e-10):
                    raise SystemExit(f"{chain.name}: CasADi's {name} {o} differs from the reference")


# -- counting operations in C text ----------------------------------------------------------------

_NUMBER = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[fFlL]?")
_IDENT = re.compile(r"[A-Za-z_]\w*")
_CALLS = {"sin": "sin", "cos": "cos", "sqrt": "sqrt", "sinf": "sin", "cosf": "cos", "sqrtf": "sqrt"}


def function_body(source: str, name: str) -> str | None:
    """The text between the braces of the definition of ``name`` in ``source`` (None if not defined)."""
    match = re.search(rf"^[^\n;]*\b{re.escape(name)}\s*\([^;{{]*\)\s*\{{", source, re.M)
    if not match:
        return None
    depth, start = 1, match.end()
    for i in range(start, len(source)):
        if source[i] == "{":
            depth += 1
        elif source[i] == "}":
            depth -= 1
            if depth == 0:
                return source[start:i]
    raise ValueError(f"unbalanced braces in {name}")


def count_expression(text: str, counts: dict[str, int], source: str, seen: set[str]) -> None:
    """Add the operations of one right-hand side (see the module docstring)."""
    previous = None  # None, "operand" or "operator"
    i = 0
    while i < len(text):
        ch = text[i]
        if ch.isspace():
            i += 1
            continue
        number = _NUMBER.match(text, i)
        if number and (ch.isdigit() or ch == "."):
            i, previous = number.end(), "operand"
            continue
        ident = _IDENT.match(text, i)
        if ident:
            word = ident.group()
            i = ident.end()
            rest = text[i:].lstrip()
            if rest.startswith("("):
                if word in _CALLS:
                    counts[_CALLS[word]] += 1
                elif word == "casadi_sq":
                    counts["mul"] += 1
                elif function_body(source, word) is not None and word not in seen:
                    count_function(source, word, counts, seen)
            previous = "operand"
            continue
        if ch == "-" and text[i:i + 2] not in ("->", "--", "-="):
            if previous != "operand":
                following = text[i + 1:].lstrip()
                if not (following[:1].isdigit() or following[:1] == "."):
                    counts["neg"] += 1
            else:
                counts["add"] += 1
            previous = "operator"
        elif ch == "+" and text[i:i + 2] not in ("++", "+="):
            if previous == "operand":
                counts["add"] += 1
            previous = "operator"
        elif ch == "*" and previous == "operand":
            counts["mul"] += 1
            previous = "operator"
        elif ch == "/":
            counts["div"] += 1
            previous = "operator"
        elif ch == ")" or ch == "]":
            previous = "operand"
        else:
            previous = "operator"
        i += 1


def count_function(source: str, name: str, counts: dict[str, int] | None = None, seen: set[str] | None = None) -> dict[str, int]:
    """Operations in the body of ``name`` and of the functions it calls (loop control and array
    indices are not arithmetic; a ``*_trigN(ang, cs, sn, used)`` call counts ``used`` sines and cosines)."""
    counts = counts if counts is not None else {k: 0 for k in ("add", "mul", "div", "neg", "sin", "cos", "sqrt")}
    seen = seen if seen is not None else set()
    seen.add(name)
    body = function_body(source, name)
    if body is None:
        raise ValueError(f"no function {name}")
    body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
    body = re.sub(r"^\s*#.*$", "", body, flags=re.M)
    for statement in body.split(";"):
        statement = statement.strip()
        trig = re.search(r"\b\w+_trig\d+\s*\(\s*\w+\s*,\s*\w+\s*,\s*\w+\s*,\s*(\d+)\s*\)", statement)
        if trig:
            counts["sin"] += int(trig.group(1))
            counts["cos"] += int(trig.group(1))
            continue
        if re.match(r"(for|while)\s*\(", statement) or statement.startswith("return 0") or statement.startswith("(void)"):
            continue
        while True:  # drop array indices (they are addresses, not arithmetic)
            stripped = re.sub(r"\[[^\[\]]*\]", "", statement)
            if stripped == statement:
                break
            statement = stripped
        assign = re.search(r"(?<![=!<>+\-*/])=(?!=)", statement)
        if assign:
            statement = statement[assign.end():]
        elif not re.search(r"\w+\s*\(", statement):
            continue
        count_expression(statement, counts, source, seen)
    return counts


def arithmetic(counts: dict[str, int]) -> int:
    return counts["add"] + counts["mul"] + counts["div"] + counts["neg"]


def ratio(ours: int, theirs: int) -> str:
    """``ours / theirs`` to two decimals; ``-`` where CasADi needs no arithmetic (a constant output)."""
    return f"{ours / theirs:.2f}" if theirs else ("1.00" if not ours else "-")


# -- building and timing --------------------------------------------------------------------------

def check_ours(chain, rng) -> None:
    """Our NumPy module's values against the reference at random configurations (the C is checked when timed)."""
    from skelarm_sym.build import load_python

    g = generate(chain, langs="python", out=None, prefix="ours", functions=",".join(FUNCTIONS))
    module = load_python(g.sources["ours.py"], "ours")
    n = chain.n
    q, dq, ddq = rng.uniform(-np.pi, np.pi, (5, n)), rng.uniform(-1, 1, (5, n)), rng.uniform(-1, 1, (5, n))
    ref = reference.chain_kinematics(chain.numeric(), q, dq, ddq)
    got = {"T": module.pose(q), "J": module.jacobian(q), "J_tool": module.jacobian_tool(q), "dJ": module.jacobian_dot(q, dq)}
    for name, value in got.items():
        if not np.allclose(value, getattr(ref, name), atol=1e-10, rtol=1e-10):
            raise SystemExit(f"{chain.name}: our {name} differs from the reference")


def ours_sources(chain, work: Path) -> tuple[str, float]:
    """Generate our C (prefix ``ours``) into ``work``; returns its text and the generation time."""
    start = time.perf_counter()
    g = generate(chain, langs="c", out=None, prefix="ours", functions=",".join(FUNCTIONS))
    seconds = time.perf_counter() - start
    for name, text in g.sources.items():
        (work / name).write_text(text)
    header = g.sources["ours.h"]
    exported = sorted(set(re.findall(r"\b(ours_\w+)\s*\(", header)))
    for tag, defines in (("s", ""), ("n", "#define SKELARM_NO_SIMD 1\n")):
        renames = "".join(f"#define {name} {tag}_{name[5:]}\n" for name in exported)
        (work / f"ours_{tag}.c").write_text(defines + renames + '#include "ours.c"\n')
    return g.sources["ours.c"], seconds


def casadi_sources(functions, work: Path) -> str:
    import casadi as ca

    generator = ca.CodeGenerator("ca.c", {"with_header": False})
    for name in FUNCTIONS:
        generator.add(functions[name])
    generator.generate(str(work) + "/")
    return (work / "ca.c").read_text()


def sizes(n: int) -> dict[str, int]:
    return {"T": 16, "J": 6 * n, "J_tool": 6 * n, "dJ": 6 * n, "twist": 6, "acc": 6}


def calls_header(n: int, functions) -> str:
    size = sizes(n)
    lines = [f"#define N {n}", f"#define FUNCTIONS {len(FUNCTIONS)}"]
    lines.append(f"#define OUTS {max(sum(size[o] for o in OUTPUTS[f]) for f in FUNCTIONS)}")
    lines.append("static const char *names[FUNCTIONS] = {" + ", ".join(f'"{f}"' for f in FUNCTIONS) + "};")
    for name in FUNCTIONS:
        inputs = ("q", "dq", "ddq")[: INPUTS[name]]
        offsets, at = [], 0
        for o in OUTPUTS[name]:
            offsets.append(f"out + {at}")
            at += size[o]
        unused = "".join(f"(void){x}; " for x in ("q", "dq", "ddq")[INPUTS[name]:])
        for tag in ("s", "n"):
            params = ", ".join([f"const double *{x}" for x in inputs] + [f"double *{o}" for o in OUTPUTS[name]])
            lines.append(f"void {tag}_{name}({params});")
            lines.append(f"static void w{tag}_{name}(const double *q, const double *dq, const double *ddq, double *out)")
            lines.append(f"{{ {unused}{tag}_{name}({', '.join(inputs)}, {', '.join(offsets)}); }}")
        fn = functions[name]
        lines.append(f"int ca_{name}(const double **arg, double **res, long long *iw, double *w, int mem);")
        lines.append(f"static void wc_{name}(const double *q, const double *dq, const double *ddq, double *out)")
        lines.append(f"{{ const double *arg[3]; double *res[{len(OUTPUTS[name])}]; double w[{max(fn.sz_w(), 1)}]; {unused}"
                     f"arg[0] = q; arg[1] = dq; arg[2] = ddq; "
                     + " ".join(f"res[{k}] = {off};" for k, off in enumerate(offsets))
                     + f" ca_{name}(arg, res, 0, w, 0); }}")
    table = ", ".join(f"{{ws_{f}, wn_{f}, wc_{f}}}" for f in FUNCTIONS)
    lines.append(f"static call table[FUNCTIONS][VARIANTS] = {{{table}}};")
    return "\n".join(lines) + "\n"


def compare_values(chain, name: str, variant: int, values: np.ndarray, ref) -> None:
    """One variant's C outputs at the first configuration against the reference (CasADi's are column-major)."""
    at = 0
    size = sizes(chain.n)
    for o in OUTPUTS[name]:
        want = getattr(ref, o)
        got = values[at:at + size[o]]
        at += size[o]
        got = got.reshape(want.shape[::-1]).T if (variant == 2 and want.ndim == 2) else got.reshape(want.shape)
        if not np.allclose(got, want, atol=1e-10, rtol=1e-10):
            who = ("ours", "ours (NO_SIMD)", "CasADi")[variant]
            raise SystemExit(f"{chain.name}: {who} C {name} {o} differs from the reference by {np.abs(got - want).max():.3g}")


def time_robot(chain, functions, work: Path, cc: str) -> dict[str, list[float]]:
    """``{function: [ns ours, ns ours NO_SIMD, ns CasADi]}``, after checking the C outputs."""
    (work / "calls.h").write_text(calls_header(chain.n, functions))
    exe = work / "harness"
    subprocess.run([cc, *FLAGS, f"-I{work}", f"-I{HERE}", str(HERE / "casadi_harness.c"), str(work / "ours_s.c"),
                    str(work / "ours_n.c"), str(work / "ca.c"), "-o", str(exe), "-lm"], check=True)
    rng = np.random.default_rng(1)
    n = chain.n
    q, dq, ddq = rng.uniform(-np.pi, np.pi, (CONFIGS, n)), rng.uniform(-1, 1, (CONFIGS, n)), rng.uniform(-1, 1, (CONFIGS, n))
    lines = [str(CONFIGS)] + [" ".join(repr(float(x)) for x in np.concatenate([q[i], dq[i], ddq[i]])) for i in range(CONFIGS)]
    (work / "configs.txt").write_text("\n".join(lines) + "\n")
    out = subprocess.run([str(exe), str(work / "configs.txt")], capture_output=True, text=True, check=True).stdout
    ref = reference.chain_kinematics(chain.numeric(), q[0], dq[0], ddq[0])
    times = {}
    for line in out.splitlines():
        parts = line.split()
        if parts[0] == "values":
            compare_values(chain, parts[1], int(parts[2]), np.array([float(x) for x in parts[3:]]), ref)
        elif parts[0] == "time":
            times[parts[1]] = [float(x) for x in parts[2:]]
    return times


def parse_robot(text: str) -> tuple[Path, str | None]:
    head, _, tip = text.rpartition(":")
    if head.endswith(".urdf"):
        return Path(head), tip
    return Path(text), None


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("robots", nargs="*", help="robot files (a URDF as PATH:TIP); default: see the module docstring")
    parser.add_argument("--no-time", action="store_true", help="count operations only")
    parser.add_argument("--example-robot-data", action="store_true",
                        help="every example-robot-data URDF instead: its default chain, else the first of its longest "
                             "(the tip in parentheses), as benchmarks/urdf_ops.py takes it")
    args = parser.parse_args(argv)
    robots = [parse_robot(r) for r in args.robots] or (example_robots() if args.example_robot_data else default_robots())
    cc = find_compiler()
    if not args.no_time:
        version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
        print(f"compiler: {version}; flags: {' '.join(FLAGS)}; times: medians of 31 interleaved passes of {CONFIGS} calls")
    print("arith: additions, multiplications, divisions and negations in the C text of each function; ratio: ours / "
          "CasADi's (lower is fewer operations); sin+cos: sines + cosines evaluated"
          + ("" if args.no_time else "; ns: time per call, medians"))
    print()
    print("| robot | n | function | arith ours | arith CasADi | ratio | sin+cos ours | sin+cos CasADi "
          + ("| ns ours | ns ours NO_SIMD | ns CasADi | ours / CasADi | NO_SIMD / CasADi " if not args.no_time else "") + "|")
    print("|---|---|---|---|---|---|---|---" + ("|---|---|---|---|---" if not args.no_time else "") + "|")
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        for path, tip in robots:
            path = path if path.is_absolute() else ROOT / path
            chain = load_robot(path, tip=tip)
            work = Path(tmp) / f"{len(list(Path(tmp).iterdir()))}_{path.stem}"
            work.mkdir()
            functions = casadi_functions(chain)
            check_casadi(chain, functions, rng)
            check_ours(chain, rng)
            ours_c, gen_seconds = ours_sources(chain, work)
            casadi_c = casadi_sources(functions, work)
            times = {} if args.no_time else time_robot(chain, functions, work, cc)
            label = f"{path.stem}" + (f" ({tip})" if tip else "")
            for name in FUNCTIONS:
                a = count_function(ours_c, f"ours_{name}")
                b = count_function(casadi_c, f"ca_{name}")
                row = (f"| {label} | {chain.n} | {name} | {arithmetic(a)} | {arithmetic(b)} | {ratio(arithmetic(a), arithmetic(b))} "
                       f"| {a['sin']}+{a['cos']} | {b['sin']}+{b['cos']} ")
                if name in times:
                    s, ns, c = times[name]
                    row += f"| {s:.1f} | {ns:.1f} | {c:.1f} | {s / c:.2f} | {ns / c:.2f} "
                print(row + "|", flush=True)
            print(f"<!-- {label}: generate (these 5 functions, C) {gen_seconds:.2f} s -->", file=sys.stderr)


if __name__ == "__main__":
    main()
