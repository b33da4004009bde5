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


def symforce_kinematics(n: int, folder: Path, cxx: str = "c++", flags: tuple[str, ...] = ("-O2",),
                        name: str = "symforce_kinematics") -> tuple[Path, dict[str, int]] | None:
    """SymForce route: p from the chain, J = p.jacobian(q), H = sum_k dJ/dq_k dq_k, emitted as C++
    (Eigen) and wrapped in an ``extern "C"`` function; returns the compiled object file.
    Needs symforce and Eigen's headers (Debian: libeigen3-dev)."""
    import ctypes
    import re
    import shutil
    import subprocess

    try:
        import symforce

        symforce.set_log_level("error")
        import symforce.symbolic as sf
        from symforce import codegen
    except ImportError:
        return None
    eigen = next((p for p in ("/usr/include/eigen3", "/usr/local/include/eigen3") if Path(p, "Eigen").is_dir()), None)
    if eigen is None or shutil.which(cxx) is None:
        return None
    vec = sf.Matrix.zeros(n, 1).__class__  # Matrix of shape (n, 1)

    def kin(q, dq, ddq, l):
        theta = [q[0]]
        for i in range(1, n):
            theta.append(theta[-1] + q[i])
        p = sf.V2(sum(l[i] * sf.cos(theta[i]) for i in range(n)), sum(l[i] * sf.sin(theta[i]) for i in range(n)))
        J = p.jacobian(q)
        H = sf.Matrix(2, n, [sum(J[r, c].diff(q[k]) * dq[k] for k in range(n)) for r in range(2) for c in range(n)])
        return p, J, H, J * dq, J * ddq + H * dq

    kin.__annotations__ = {"q": vec, "dq": vec, "ddq": vec, "l": vec}  # SymForce reads the argument types here
    folder.mkdir(parents=True, exist_ok=True)
    data = codegen.Codegen.function(func=kin, config=codegen.CppConfig()).generate_function(
        output_dir=folder, skip_directory_nesting=True
    )
    header = data.generated_files[0]
    ops = int(re.search(r"Total ops: (\d+)", header.read_text()).group(1))
    wrapper = folder / f"{name}.cpp"
    wrapper.write_text(f"""#include "{header.name}"
#include <Eigen/Core>

extern "C" void {name}(const double *q, const double *dq, const double *ddq, const double *l,
                       double *p, double *J, double *H, double *v, double *a)
{{
    typedef Eigen::Matrix<double, {n}, 1> Vec;
    Eigen::Matrix<double, 2, 1> P, V, A;
    Eigen::Matrix<double, 2, {n}> JJ, HH;
    sym::Kin<double>(Eigen::Map<const Vec>(q), Eigen::Map<const Vec>(dq), Eigen::Map<const Vec>(ddq),
                     Eigen::Map<const Vec>(l), &P, &JJ, &HH, &V, &A);
    Eigen::Map<Eigen::Matrix<double, 2, 1>> out_p(p), out_v(v), out_a(a);
    Eigen::Map<Eigen::Matrix<double, 2, {n}, Eigen::RowMajor>> out_J(J), out_H(H);
    out_p = P;
    out_J = JJ;
    out_H = HH;
    out_v = V;
    out_a = A;
}}
""")
    base = [cxx, *flags, f"-I{eigen}", f"-I{folder}", "-DNDEBUG"]
    obj = folder / f"{name}.o"
    subprocess.run([*base, "-c", str(wrapper), "-o", str(obj)], check=True)
    library = folder / f"lib{name}.so"
    subprocess.run([*base, "-fPIC", "-shared", str(wrapper), "-o", str(library)], check=True)

    fn = getattr(ctypes.CDLL(str(library)), name)
    rng = np.random.default_rng(n)
    qs, dqs, ddqs = rng.uniform(-np.pi, np.pi, (3, n))
    ls = rng.uniform(0.5, 1.5, n)
    out = [np.zeros(2), np.zeros((2, n)), np.zeros((2, n)), np.zeros(2), np.zeros(2)]
    pointer = ctypes.POINTER(ctypes.c_double)
    fn(*[np.ascontiguousarray(x).ctypes.data_as(pointer) for x in (qs, dqs, ddqs, ls)], *[o.ctypes.data_as(pointer) for o in out])
    want = reference.kinematics(qs, dqs, ddqs, ls)
    for value, expected in zip(out, (want.p, want.J, want.H, want.v, want.a)):
        np.testing.assert_allclose(value, expected, atol=1e-9)
    return obj, {"ops": ops}
