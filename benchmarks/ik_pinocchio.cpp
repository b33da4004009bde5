// The IK loop of skelarm-sym's emitted X_ik_solve written with Pinocchio 4, timed in the same process
// as the emitted solver on the same targets. Usage:
//   ik_pinocchio CHAIN TARGETS LIBRARY PREFIX
// CHAIN: the chain file of benchmarks/robots.py (z motions after constant 3 x 4 placements, tool);
// TARGETS: "m n" then per line: target (16, row-major), q0 (n), lower, upper, draw low, draw span (n each), periodic (n: 0/1)
// (limits repeated per line for simplicity; only the first line's are used);
// LIBRARY: the emitted C compiled as a shared library with the same flags; PREFIX its function prefix.
// Both loops: Levenberg-Marquardt on e = [p_t - p; log3(R_t R^T)] (LOCAL_WORLD_ALIGNED J),
// dq = J^T (J J^T + mu2 I)^-1 e (Eigen LDLT here), mu2 = max(lambda^2, c |e|), the same step cap,
// clamping, blocked-column removal, 2 pi wraps, stationary-point test, geodesic acceleration, restarts from the best of
// CANDIDATES random configurations by tool position (forwardKinematics + updateFramePlacement each;
// same xorshift64* seed, same alternation of centred and whole-range draws) and constants.
// Prints per loop: successes, total iterations, mean microseconds per solve (median of 5 passes).
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/spatial.hpp>
#include <Eigen/Cholesky>
#include <dlfcn.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

static pinocchio::SE3 read_placement(std::ifstream &in) {
    Eigen::Matrix3d R; Eigen::Vector3d t;
    for (int i = 0; i < 3; ++i) { for (int j = 0; j < 3; ++j) in >> R(i, j); in >> t(i); }
    return pinocchio::SE3(R, t);
}

// constants of skelarm_sym.ik (checked by benchmarks/ik_success.py, which passes them on the command line)
static double C_START = 0.01, C_MIN = 1e-8, C_MAX = 1e8, C_UP = 4.0, C_DOWN = 0.5, STEP_MAX = 1.0, STALL = 1e-9, PROGRESS = 0.6;
static double STATIONARY = 0.02, SHRINK = 0.5, GEO_H = 0.1, GEO_ALPHA = 0.75, GEO_GATE = 0.5, GEO_ERROR = 0.05;
static int ATTEMPT = 25, WINDOW = 3, CANDIDATES = 8;
static unsigned long long SEED = 0x5EED5EEDULL;

static double uniform(unsigned long long *state) {
    unsigned long long s = *state;
    s ^= s >> 12; s ^= s << 25; s ^= s >> 27;
    *state = s;
    return (double)((s * 0x2545F4914F6CDD1DULL) >> 11) * (1.0 / 9007199254740992.0);
}

struct Pin {
    pinocchio::Model model;
    pinocchio::Data *data;
    pinocchio::FrameIndex tool;
    int n;
    Eigen::VectorXd lo, hi, draw_lo, draw_span, near_lo, near_span;
    std::vector<int> periodic, slide;
    pinocchio::Data::Matrix6x J, Jt, Jf;

    // e at q (forwardKinematics + frame placement), no Jacobian
    void error_at(const Eigen::VectorXd &q, const pinocchio::SE3 &target, Eigen::Matrix<double, 6, 1> &e) {
        pinocchio::forwardKinematics(model, *data, q);
        const pinocchio::SE3 &M = pinocchio::updateFramePlacement(model, *data, tool);
        e.head<3>() = target.translation() - M.translation();
        e.tail<3>() = pinocchio::log3(Eigen::Matrix3d(target.rotation() * M.rotation().transpose()));
    }

    // e, |dp|, |dr| and J at q
    void evaluate(const Eigen::VectorXd &q, const pinocchio::SE3 &target, Eigen::Matrix<double, 6, 1> &e, double &pe, double &re,
                  pinocchio::Data::Matrix6x &jac) {
        pinocchio::forwardKinematics(model, *data, q);
        const pinocchio::SE3 &M = pinocchio::updateFramePlacement(model, *data, tool);
        e.head<3>() = target.translation() - M.translation();
        e.tail<3>() = pinocchio::log3(Eigen::Matrix3d(target.rotation() * M.rotation().transpose()));
        pe = e.head<3>().norm();
        re = e.tail<3>().norm();
        jac.setZero();
        pinocchio::computeFrameJacobian(model, *data, q, tool, pinocchio::LOCAL_WORLD_ALIGNED, jac);
    }

    int solve(const Eigen::VectorXd &q0, const pinocchio::SE3 &target, double lambda, double tol, int max_iter, Eigen::VectorXd &out,
              int &iterations) {
        Eigen::VectorXd q = q0.cwiseMax(lo).cwiseMin(hi), trial(n), dq(n), best_q(n), acc(n);
        Eigen::Matrix<double, 6, 1> e, et, r2;
        Eigen::Matrix<double, 6, 6> A, G, Gf;  // G = J J^T, kept while steps are rejected (as the emitted C)
        bool gram = false;
        Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt;
        std::vector<int> blocked(n);
        double pe, re, pet, ret;
        unsigned long long state = SEED ^ 0x9E3779B97F4A7C15ULL;
        evaluate(q, target, e, pe, re, J);
        double en = std::sqrt(pe * pe + re * re), best_en = en, c = C_START, checkpoint = en, window_start = en;
        int stationary = 0, curved = 0, damped = 1;  // damped: every step of the window accepted, c |e| above G's mean eigenvalue
        int best_stalled = 0, attempt = 0, it = 0, best_here = 1, restarts = 0;
        const double mu2_floor = lambda * lambda;
        best_q = q;
        for (;;) {
            if (pe <= tol && re <= tol) { out = q; iterations = it; return 0; }
            if (it == max_iter) {
                int steps = attempt % WINDOW;  /* the window's steps run so far, judged by their share of PROGRESS */
                double share = steps == 0 ? PROGRESS : std::pow(PROGRESS, (double)steps / WINDOW);
                if (best_here && attempt > 0 && !damped && (stationary || en > share * (steps == 0 ? window_start : checkpoint))) best_stalled = 1;
                break;
            }
            const double mu2 = std::max(c * en, mu2_floor);
            if (!gram) { G.noalias() = J * J.transpose(); gram = true; }
            A = G;
            A.diagonal().array() += mu2;
            ldlt.compute(A);
            dq.noalias() = J.transpose() * ldlt.solve(e);
            bool any = false;
            for (int k = 0; k < n; ++k) {
                blocked[k] = !periodic[k] && ((q[k] <= lo[k] && dq[k] < 0) || (q[k] >= hi[k] && dq[k] > 0));
                any = any || blocked[k];
            }
            const pinocchio::Data::Matrix6x *Jg = &J;
            if (any) {
                Jf = J;
                for (int k = 0; k < n; ++k) if (blocked[k]) Jf.col(k).setZero();
                Gf = G;
                for (int k = 0; k < n; ++k) if (blocked[k]) Gf.noalias() -= J.col(k) * J.col(k).transpose();
                A = Gf;
                A.diagonal().array() += mu2;
                ldlt.compute(A);
                dq.noalias() = Jf.transpose() * ldlt.solve(e);
                Jg = &Jf;
            }
            stationary = (Jg->transpose() * e).squaredNorm() <= STATIONARY * STATIONARY * Jg->squaredNorm() * en * en;
            if (stationary) {  // Gauss-Newton's step at a stationary point (the lightest damping), as the emitted solver
                A = any ? Gf : G;
                A.diagonal().array() += std::max(C_MIN * en, mu2_floor);
                ldlt.compute(A);
                dq.noalias() = Jg->transpose() * ldlt.solve(e);
            }
            damped = damped && c * en * 6.0 > Jg->squaredNorm();
            if (curved && en < GEO_ERROR) {  // geodesic acceleration, the factors reused
                error_at(q + GEO_H * dq, target, et);
                r2 = (et - e + GEO_H * (J * dq)) * (2.0 / (GEO_H * GEO_H));
                acc.noalias() = Jg->transpose() * ldlt.solve(r2);
                if (acc.squaredNorm() <= GEO_ALPHA * GEO_ALPHA * dq.squaredNorm()) dq += 0.5 * acc;
            }
            double big = 0.0;  // slides are not capped
            for (int k = 0; k < n; ++k) if (!slide[k]) big = std::max(big, std::abs(dq[k]));
            if (big > STEP_MAX) dq *= STEP_MAX / big;
            trial = q + dq;
            for (int k = 0; k < n; ++k) {
                if (periodic[k]) {
                    if (trial[k] > hi[k]) trial[k] -= 2 * M_PI;
                    else if (trial[k] < lo[k]) trial[k] += 2 * M_PI;
                }
            }
            trial = trial.cwiseMax(lo).cwiseMin(hi);
            evaluate(trial, target, et, pet, ret, Jt);
            const double ent = std::sqrt(pet * pet + ret * ret);
            ++it; ++attempt;
            int stalled;
            curved = ent > GEO_GATE * en;
            if (ent < en) {
                stalled = en - ent <= STALL * en;
                q = trial; e = et; J.swap(Jt); pe = pet; re = ret; en = ent; gram = false;
                c = std::max(c * C_DOWN, C_MIN);
            } else {
                c *= C_UP;
                stalled = c > C_MAX;
                damped = 0;
            }
            if (en < best_en || (stalled && en == best_en)) { best_en = en; best_q = q; best_stalled = stalled; best_here = 1; }
            if (pe <= tol && re <= tol) continue;
            int slow = stationary;
            if (attempt % WINDOW == 0) {
                slow = slow || (en > PROGRESS * checkpoint && !damped);
                damped = 1; window_start = checkpoint; checkpoint = en;
            }
            if ((stalled || slow || attempt >= ATTEMPT) && it < max_iter) {
                if ((stalled || slow) && best_here) best_stalled = 1;
                best_here = 0;
                const Eigen::VectorXd &low = restarts % 2 == 0 ? near_lo : draw_lo, &span = restarts % 2 == 0 ? near_span : draw_span;
                double nearest = 0;
                for (int m = 0; m < CANDIDATES; ++m) {
                    for (int k = 0; k < n; ++k) trial[k] = low[k] + span[k] * uniform(&state);
                    pinocchio::forwardKinematics(model, *data, trial);
                    const double d = (target.translation() - pinocchio::updateFramePlacement(model, *data, tool).translation()).norm();
                    if (m == 0 || d < nearest) { nearest = d; q = trial; }
                }
                ++restarts; gram = false;
                evaluate(q, target, e, pe, re, J);
                en = std::sqrt(pe * pe + re * re);
                c = C_START; curved = 0; damped = 1; attempt = 0; checkpoint = window_start = en;
                if (en < best_en) { best_en = en; best_q = q; best_stalled = 0; best_here = 1; }
            }
        }
        out = best_q; iterations = it;
        return best_stalled ? 1 : 2;
    }
};

typedef int (*solve_fn)(const double *, const double *, double, double, int, double *, double *, int *);

int main(int argc, char **argv) {
    if (argc < 5) { std::fprintf(stderr, "usage: ik_pinocchio CHAIN TARGETS LIBRARY PREFIX [constants...]\n"); return 2; }
    if (argc >= 23) {
        C_START = atof(argv[5]); C_MIN = atof(argv[6]); C_MAX = atof(argv[7]); C_UP = atof(argv[8]); C_DOWN = atof(argv[9]);
        STEP_MAX = atof(argv[10]); STALL = atof(argv[11]); PROGRESS = atof(argv[12]); ATTEMPT = atoi(argv[13]); WINDOW = atoi(argv[14]);
        SEED = std::stoull(argv[15]); STATIONARY = atof(argv[16]); CANDIDATES = atoi(argv[17]); SHRINK = atof(argv[18]);
        GEO_H = atof(argv[19]); GEO_ALPHA = atof(argv[20]); GEO_GATE = atof(argv[21]); GEO_ERROR = atof(argv[22]);
    } else if (argc > 5) { std::fprintf(stderr, "expected 18 constants after PREFIX\n"); return 2; }
    std::ifstream chain(argv[1]), targets(argv[2]);
    int joints; chain >> joints;
    Pin pin;
    pinocchio::JointIndex parent = 0;
    for (int k = 0; k < joints; ++k) {
        int prismatic; chain >> prismatic;
        pin.slide.push_back(prismatic);
        pinocchio::SE3 M = read_placement(chain);
        if (prismatic) parent = pin.model.addJoint(parent, pinocchio::JointModelPZ(), M, "j" + std::to_string(k));
        else parent = pin.model.addJoint(parent, pinocchio::JointModelRZ(), M, "j" + std::to_string(k));
    }
    pin.tool = pin.model.addFrame(pinocchio::Frame("tool", parent, 0, read_placement(chain), pinocchio::OP_FRAME));
    pinocchio::Data data(pin.model);
    pin.data = &data;
    const int n = pin.model.nq;
    pin.n = n;
    pin.J.resize(6, n); pin.Jt.resize(6, n); pin.Jf.resize(6, n);
    int m, nn; targets >> m >> nn;
    if (nn != n) { std::fprintf(stderr, "joint count mismatch\n"); return 2; }
    std::vector<Eigen::Matrix<double, 16, 1>> T(m);
    std::vector<Eigen::VectorXd> q0(m, Eigen::VectorXd(n));
    pin.lo.resize(n); pin.hi.resize(n); pin.draw_lo.resize(n); pin.draw_span.resize(n); pin.periodic.assign(n, 0);
    for (int i = 0; i < m; ++i) {
        for (int k = 0; k < 16; ++k) targets >> T[i](k);
        for (int k = 0; k < n; ++k) targets >> q0[i](k);
        for (int k = 0; k < n; ++k) targets >> pin.lo[k];
        for (int k = 0; k < n; ++k) targets >> pin.hi[k];
        for (int k = 0; k < n; ++k) targets >> pin.draw_lo[k];
        for (int k = 0; k < n; ++k) targets >> pin.draw_span[k];
        for (int k = 0; k < n; ++k) targets >> pin.periodic[k];
    }
    pin.near_lo.resize(n); pin.near_span.resize(n);
    for (int k = 0; k < n; ++k) {  // even restarts: SHRINK times the range around its centre (periodic: all of it)
        pin.near_lo[k] = pin.periodic[k] ? pin.draw_lo[k] : pin.draw_lo[k] + pin.draw_span[k] * ((1.0 - SHRINK) / 2.0);
        pin.near_span[k] = pin.periodic[k] ? pin.draw_span[k] : pin.draw_span[k] * SHRINK;
    }
    std::vector<pinocchio::SE3> poses(m);
    for (int i = 0; i < m; ++i) {
        Eigen::Matrix4d H;
        for (int k = 0; k < 16; ++k) H(k / 4, k % 4) = T[i](k);
        poses[i] = pinocchio::SE3(H);
    }
    void *lib = dlopen(argv[3], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { std::fprintf(stderr, "dlopen: %s\n", dlerror()); return 2; }
    solve_fn emitted = (solve_fn)dlsym(lib, (std::string(argv[4]) + "_ik_solve").c_str());
    if (!emitted) { std::fprintf(stderr, "dlsym: %s\n", dlerror()); return 2; }

    const double tol = 1e-10, lambda = 0.0;
    const int max_iter = 100;
    std::vector<double> t_pin, t_c;
    long it_pin = 0, it_c = 0; int ok_pin = 0, ok_c = 0, agree = 0;
    Eigen::VectorXd out(n), qc(n);
    double err[2];
    std::vector<int> status_pin(m), status_c(m);
    double sink = 0;
    for (int pass = 0; pass < 5; ++pass) {
        auto start = std::chrono::steady_clock::now();
        for (int i = 0; i < m; ++i) {
            int its;
            status_pin[i] = pin.solve(q0[i], poses[i], lambda, tol, max_iter, out, its);
            if (pass == 0) { it_pin += its; ok_pin += status_pin[i] == 0; }
            sink += out[0];
        }
        auto mid = std::chrono::steady_clock::now();
        for (int i = 0; i < m; ++i) {
            int its;
            status_c[i] = emitted(q0[i].data(), T[i].data(), lambda, tol, max_iter, qc.data(), err, &its);
            if (pass == 0) { it_c += its; ok_c += status_c[i] == 0; }
            sink += qc[0];
        }
        auto stop = std::chrono::steady_clock::now();
        t_pin.push_back(std::chrono::duration<double, std::micro>(mid - start).count() / m);
        t_c.push_back(std::chrono::duration<double, std::micro>(stop - mid).count() / m);
    }
    for (int i = 0; i < m; ++i) agree += status_pin[i] == status_c[i];
    std::sort(t_pin.begin(), t_pin.end());
    std::sort(t_c.begin(), t_c.end());
    std::printf("pinocchio %d %ld %.3f\n", ok_pin, it_pin, t_pin[2]);
    std::printf("emitted %d %ld %.3f\n", ok_c, it_c, t_c[2]);
    std::printf("agree %d %g\n", agree, sink);
    return 0;
}
