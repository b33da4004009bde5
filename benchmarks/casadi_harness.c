/* Times skelarm-sym's emitted functions (built with and without -DSKELARM_NO_SIMD) against CasADi's
 * generated C for the same outputs, in one program (see casadi_compare.py, which writes calls.h).
 *
 * calls.h defines N (coordinates), FUNCTIONS, OUTS (the largest output size), names[FUNCTIONS] and
 * table[FUNCTIONS][VARIANTS]: wrappers with one signature (q, dq, ddq, out); variant 0 is ours with
 * vector math, 1 ours with -DSKELARM_NO_SIMD, 2 CasADi's.
 *
 * Reads argv[1]: "m" then m lines of q (N), dq (N), ddq (N). Prints, per function, one line
 * "values <function> <variant> v..." of every variant's outputs at the first configuration, then
 * "time <function> ns0 ns1 ns2": medians over REPEATS passes of m calls, the variants interleaved
 * (their order rotates from pass to pass, so drifts of a shared machine hit all of them alike). */
#define REPEATS 31
#include "timing.h"
#include <stdio.h>

typedef void (*call)(const double *q, const double *dq, const double *ddq, double *out);
#define VARIANTS 3
#include "calls.h"

#define MAX_CONFIGS 4096

int main(int argc, char **argv)
{
    static double q[MAX_CONFIGS][N], dq[MAX_CONFIGS][N], ddq[MAX_CONFIGS][N];
    static double out[OUTS];
    double samples[VARIANTS][REPEATS], sink = 0;
    FILE *f;
    int m, i, k, r, fn, v;
    if (argc < 2 || !(f = fopen(argv[1], "r")) || fscanf(f, "%d", &m) != 1 || m < 1 || m > MAX_CONFIGS) return 2;
    for (i = 0; i < m; ++i) {
        for (k = 0; k < N; ++k) if (fscanf(f, "%lf", &q[i][k]) != 1) return 2;
        for (k = 0; k < N; ++k) if (fscanf(f, "%lf", &dq[i][k]) != 1) return 2;
        for (k = 0; k < N; ++k) if (fscanf(f, "%lf", &ddq[i][k]) != 1) return 2;
    }
    fclose(f);
    for (fn = 0; fn < FUNCTIONS; ++fn) {
        for (v = 0; v < VARIANTS; ++v) {
            for (k = 0; k < OUTS; ++k) out[k] = 0.0;
            table[fn][v](q[0], dq[0], ddq[0], out);
            printf("values %s %d", names[fn], v);
            for (k = 0; k < OUTS; ++k) printf(" %.17g", out[k]);
            printf("\n");
        }
        for (r = 0; r < REPEATS; ++r) {
            for (k = 0; k < VARIANTS; ++k) {
                call c;
                double start;
                v = (k + r) % VARIANTS;
                c = table[fn][v];
                start = now();
                for (i = 0; i < m; ++i) {
                    c(q[i], dq[i], ddq[i], out);
                    sink += out[0];
                }
                samples[v][r] = (now() - start) / m;
            }
        }
        printf("time %s", names[fn]);
        for (v = 0; v < VARIANTS; ++v) printf(" %.3f", median(samples[v]));
        printf("\n");
    }
    fprintf(stderr, "sink %g\n", sink);
    return 0;
}
