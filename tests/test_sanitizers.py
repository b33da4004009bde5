"""Every emitted C function under AddressSanitizer and UBSan: single calls and batches at the
sizes around each function's block (0, 1, B - 1, B, B + 1, 2B + 3), on heap buffers of the exact
size, so any read or write outside them, any undefined behaviour, any leak is a failure. The
driver also checks that each batch equals its single calls bit for bit."""

import os
import re
import shutil
import subprocess

import numpy as np
import pytest

from skelarm_sym.generate import generate
from skelarm_sym.models.diffdrive import DiffDrive

CC = shutil.which("gcc") or shutil.which("clang")
SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", "-g1"]
"""``-g1``: line tables, all a sanitizer's report needs for its stack (function, file, line); full ``-g`` at
``-O1`` also tracks every variable's location, 1.6 times the compile for nothing a report prints."""


@pytest.fixture(scope="module")
def sanitizers(tmp_path_factory):
    """Skip (with the reason) when the compiler or its runtime cannot build sanitized programs."""
    if CC is None:
        pytest.skip("no C compiler (gcc or clang) on PATH")
    folder = tmp_path_factory.mktemp("probe")
    (folder / "t.c").write_text("#include <stdlib.h>\nint main(void) { char *p = malloc(4); p[0] = 0; free(p); return 0; }\n")
    build = subprocess.run([CC, *SANITIZE, str(folder / "t.c"), "-o", str(folder / "t")], capture_output=True, text=True)
    if build.returncode != 0:
        pytest.skip(f"{CC} cannot build with {SANITIZE[0]}: {build.stderr.strip().splitlines()[-1:]}")
    run = subprocess.run([str(folder / "t")], capture_output=True, text=True)
    if run.returncode != 0:
        pytest.skip(f"sanitized programs do not run here: {run.stderr.strip()[:200]}")
    return CC


def _blocks(source: str) -> dict[str, int]:
    """Configurations per block of each batch function, read from the emitted loop."""
    out = {}
    for name, body in re.findall(r"\nvoid (\w+)_batch\(size_t m[^)]*\)\n\{\n(.*?)\n\}\n", source, flags=re.S):
        step = re.search(r"for \(i = 0; i < m; i \+= (\d+)\)", body)
        out[name] = int(step.group(1)) if step else 1
    return out


def _driver(g, prefix: str, ctype: str) -> str:
    """C statements that call every function of ``g`` single and batched on exact-size heap buffers."""
    shared = set(g.derivation.parameters)
    blocks = _blocks(g.sources[f"{prefix}.c"])
    lines = []
    for program in g.programs:
        name = f"{prefix}_{program.name}"
        block = blocks[name]
        sizes = sorted({0, 1, 2, max(block - 1, 0), block, block + 1, 2 * block + 3})
        lines.append(f"    /* {name}: block {block} */")
        lines.append(f"    {{ static const size_t ms[] = {{{', '.join(map(str, sizes))}}}; size_t mi;")
        lines.append(f"    for (mi = 0; mi < {len(sizes)}; ++mi) {{")
        lines.append("        const size_t m = ms[mi]; size_t j, k;")
        args_batch, args_single = [], []
        for a in program.inputs:
            if a.is_scalar:
                value = "0.5" if a.name != "lambda" else "(m % 2 ? 0.1 : 0.0)"
                lines.append(f"        const {ctype} {a.name} = ({ctype}){value};")
                args_batch.append(a.name)
                args_single.append(a.name)
                continue
            count = f"{a.size}" if a.name in shared else f"m * {a.size}"
            positive = g.derivation.domains.get(a.name) == "positive"
            lines.append(f"        {ctype} *{a.name} = ({ctype} *)malloc(sizeof({ctype}) * ({count} ? {count} : 1));")
            fill = "0.5 + 0.001 * (double)k" if positive else "-3.0 + 6.0 * (double)((k * 7919u) % 1000u) / 1000.0"
            lines.append(f"        for (k = 0; k < {count}; ++k) {a.name}[k] = ({ctype})({fill});")
            args_batch.append(a.name)
            args_single.append(a.name if a.name in shared else f"{a.name} + j * {a.size}")
        for o in program.outputs:
            size = o.size
            lines.append(f"        {ctype} *{o.name} = ({ctype} *)malloc(sizeof({ctype}) * (m * {size} ? m * {size} : 1));")
            lines.append(f"        {ctype} *{o.name}_1 = ({ctype} *)malloc(sizeof({ctype}) * {size});")
            args_batch.append(o.name)
        lines.append(f"        {name}_batch(m, {', '.join(args_batch)});")
        lines.append("        for (j = 0; j < m; ++j) {")
        lines.append(f"            {name}({', '.join(args_single + [o.name + '_1' for o in program.outputs])});")
        for o in program.outputs:
            size = o.size
            lines.append(f"            if (memcmp({o.name}_1, {o.name} + j * {size}, sizeof({ctype}) * {size}) != 0) ++mismatches;")
        lines.append("        }")
        for a in program.inputs:
            if not a.is_scalar:
                lines.append(f"        free({a.name});")
        for o in program.outputs:
            lines.append(f"        free({o.name}); free({o.name}_1);")
        lines.append("    } }")
    if any(p.name == "ik_step" for p in g.programs):
        step = next(p for p in g.programs if p.name == "ik_step")
        n = next(a.size for a in step.inputs if a.name == "q")
        has_l = any(a.name == "l" for a in step.inputs)
        lines.append("    {")
        lines.append(f"        {ctype} *q0 = ({ctype} *)calloc({n}, sizeof({ctype})), *q = ({ctype} *)malloc(sizeof({ctype}) * {n});")
        lines.append(f"        {ctype} *target = ({ctype} *)malloc(sizeof({ctype}) * 2), err; int it;")
        if has_l:
            lines.append(f"        {ctype} *l = ({ctype} *)malloc(sizeof({ctype}) * {n}); size_t k;")
            lines.append(f"        for (k = 0; k < {n}; ++k) l[k] = ({ctype})1.0;")
        lines.append(f"        target[0] = ({ctype})-0.5; target[1] = ({ctype})0.0;")
        l_arg = "l, " if has_l else ""
        lines.append(f"        if ({prefix}_ik_solve(q0, target, {l_arg}0, ({ctype})1e-3, 100, q, NULL, NULL) > 2) ++mismatches;")
        lines.append(f"        if ({prefix}_ik_solve(q0, target, {l_arg}({ctype})0.01, ({ctype})1e-3, 100, q, &err, &it) > 2) ++mismatches;")
        lines.append(f"        if ({prefix}_ik_solve(q0, target, {l_arg}({ctype})0.01, ({ctype})1e-3, 100, q0, &err, &it) > 2) ++mismatches;  /* q = q0 */")
        if has_l:
            lines.append("        free(l);")
        lines.append("        free(q0); free(q); free(target);")
        lines.append("    }")
    body = "\n".join(lines)
    return (
        "#include <stdio.h>\n#include <stdlib.h>\n#include <string.h>\n"
        f'#include "{prefix}.h"\n\nint main(void)\n{{\n    long mismatches = 0;\n{body}\n'
        '    printf("mismatches %ld\\n", mismatches);\n    return mismatches != 0;\n}\n'
    )


CASES = [
    ("planar", 1, None, "double"),
    ("planar", 3, None, "float"),
    ("planar", 3, (1.0, 0.8, 0.5), "double"),
    pytest.param("planar", 7, None, "double", marks=pytest.mark.slow),  # the 7-link arms: the slow set
    pytest.param("planar", 7, (1.0, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4), "float", marks=pytest.mark.slow),
    ("diffdrive", None, None, "double"),
]


@pytest.mark.parametrize("model, n, lengths, precision", CASES, ids=lambda v: str(v) if not isinstance(v, tuple) else "fixed")
def test_every_function_is_clean_under_asan_and_ubsan(sanitizers, tmp_path, model, n, lengths, precision):
    if model == "diffdrive":
        g = generate(DiffDrive(), out=tmp_path, langs="c", precision=precision)
        prefix = "diffdrive"
    else:
        prefix = "arm"
        g = generate(n, out=tmp_path, langs="c", precision=precision, lengths=lengths, prefix=prefix)
    ctype = "double" if precision == "double" else "float"
    (tmp_path / "main.c").write_text(_driver(g, prefix, ctype))
    exe = tmp_path / "main"
    cmd = [sanitizers, "-std=c99", "-O1", *SANITIZE, "-o", str(exe), str(tmp_path / "main.c"), str(tmp_path / f"{prefix}.c"), "-lm"]
    build = subprocess.run(cmd, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    env = {**os.environ, "ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0", "UBSAN_OPTIONS": "print_stacktrace=1"}
    run = subprocess.run([str(exe)], capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0 and "runtime error" not in run.stderr, run.stdout + run.stderr[-4000:]
    assert run.stdout.strip() == "mismatches 0"
    # the driver did call the batches around the block sizes
    blocks = _blocks(g.sources[f"{prefix}.c"])
    assert blocks and all(b >= 1 for b in blocks.values())
    if model == "planar" and n == 3:
        assert max(blocks.values()) >= 8  # the vectorised path (blocks of SOA configurations) is exercised
    assert np.all(np.fromiter(blocks.values(), int) > 0)
