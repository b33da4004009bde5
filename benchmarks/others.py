"""Other tools' generated C for the same outputs (p, J, H, v, a), behind the harness's signature.

Each builder returns ``(c_file, operation counts)`` or ``None`` when the tool is not installed
(``pip install '.[bench]'`` installs them). The C file defines

    void <name>(const double *q, const double *dq, const double *ddq, const double *l,
                double *p, double *J, double *H, double *v, double *a);

Layouts may differ from skelarm-sym's (CasADi stores J and H column-major); the builders check
the tool's values against the recursive reference before anything is timed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from skelarm_sym import reference


def casadi_kinematics(n: int, folder: Path, name: str = "casadi_kinematics") -> tuple[Path, dict[str, int]] | None:
    """CasADi SX route: p from the chain, J = jacobian(p, q), H = jtimes(J, q, dq); cse on."""
    try:
        import casadi as ca
    except ImportError:
        return None
    q, dq, ddq, l = (ca.SX.sym(s, n) for s in ("q", "dq", "ddq", "l"))
    theta = ca.cumsum(q)
    p = ca.vertcat(ca.dot(l, ca.cos(theta)), ca.dot(l, ca.sin(theta)))
    J = ca.jacobian(p, q)
    H = ca.jtimes(J, q, dq)
    v = ca.mtimes(J, dq)
    a = ca.mtimes(J, ddq) + ca.mtimes(H, dq)
    fn = ca.Function("kin", [q, dq, ddq, l], [p, J, H, v, a], {"cse": True})

    rng = np.random.default_rng(n)
    qs, dqs, ddqs = rng.uniform(-np.pi, np.pi, (3, n))
    ls = rng.uniform(0.5, 1.5, n)
    got = [np.array(x) for x in fn(qs, dqs, ddqs, ls)]
    want = reference.kinematics(qs, dqs, ddqs, ls)
    for value, expected in zip(got, (want.p, want.J, want.H, want.v, want.a)):
        np.testing.assert_allclose(value.reshape(expected.shape), expected, atol=1e-9)

    folder.mkdir(parents=True, exist_ok=True)
    generator = ca.CodeGenerator("casadi_kin.c")
    generator.add(fn)
    generator.generate(str(folder) + "/")
    source = (folder / "casadi_kin.c").read_text()
    wrapper = f"""
void {name}(const double *q, const double *dq, const double *ddq, const double *l,
            double *p, double *J, double *H, double *v, double *a)
{{
    const casadi_real *arg[4];
    casadi_real *res[5];
    casadi_real w[{max(fn.sz_w(), 1)}];
    arg[0] = q; arg[1] = dq; arg[2] = ddq; arg[3] = l;
    res[0] = p; res[1] = J; res[2] = H; res[3] = v; res[4] = a;
    kin(arg, res, 0, w, 0);
}}
"""
    target = folder / f"{name}.c"
    target.write_text(source + wrapper)
    kinds = {ca.OP_ADD: "arith", ca.OP_SUB: "arith", ca.OP_MUL: "arith", ca.OP_NEG: "arith", ca.OP_SIN: "sin", ca.OP_COS: "cos"}
    counts = {"sin": 0, "cos": 0, "arith": 0}
    for k in range(fn.n_instructions()):
        kind = kinds.get(fn.instruction_id(k))
        if kind:
            counts[kind] += 1
    return target, counts
