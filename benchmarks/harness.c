/* Times PREFIX_kinematics, its _batch variant, recursive_kinematics and (with -DOTHER=name)
 * another tool's code on the same inputs.
 * Prints: single_ns recursive_ns batch_ns other_ns (medians over repeats, per configuration;
 * other_ns is -1 without OTHER). */
#define REPEATS 21
#include "timing.h"
#include <stdio.h>
#include HEADER

#define KIN CAT(PREFIX, _kinematics)
#define KIN_BATCH CAT(PREFIX, _kinematics_batch)

void recursive_kinematics(const double *q, const double *dq, const double *ddq, const double *l,
                          double *p, double *J, double *H, double *v, double *a);
#ifdef OTHER
/* Another tool's generated code behind the same signature (see benchmarks/others.py). */
void OTHER(const double *q, const double *dq, const double *ddq, const double *l,
           double *p, double *J, double *H, double *v, double *a);
#endif

#define CONFIGS 256


int main(int argc, char **argv)
{
    const long batch_m = argc > 1 ? atol(argv[1]) : 100000;
    static double q[CONFIGS][N], dq[CONFIGS][N], ddq[CONFIGS][N], l[N];
    static double p[2], J[2 * N], H[2 * N], v[2], a[2];
    double *bq = malloc(sizeof(double) * N * batch_m), *bdq = malloc(sizeof(double) * N * batch_m);
    double *bddq = malloc(sizeof(double) * N * batch_m), *bp = malloc(sizeof(double) * 2 * batch_m);
    double *bJ = malloc(sizeof(double) * 2 * N * batch_m), *bH = malloc(sizeof(double) * 2 * N * batch_m);
    double *bv = malloc(sizeof(double) * 2 * batch_m), *ba = malloc(sizeof(double) * 2 * batch_m);
    double single[REPEATS], rec[REPEATS], bat[REPEATS], other[REPEATS], sink = 0.0;
    long i, r, k, loops;
    srand(12345);
#define UNIFORM (-3.141592653589793 + 6.283185307179586 * (rand() / (double)RAND_MAX))
    for (i = 0; i < CONFIGS; ++i)
        for (k = 0; k < N; ++k) { q[i][k] = UNIFORM; dq[i][k] = UNIFORM; ddq[i][k] = UNIFORM; }
    for (k = 0; k < N; ++k) l[k] = 0.5 + (rand() / (double)RAND_MAX);
    for (i = 0; i < N * batch_m; ++i) { bq[i] = UNIFORM; bdq[i] = UNIFORM; bddq[i] = UNIFORM; }
    loops = 8000000 / N / 8 + 1;
    for (r = 0; r < REPEATS; ++r) {
        double t0 = now();
        for (i = 0; i < loops; ++i) {
            KIN(q[i % CONFIGS], dq[i % CONFIGS], ddq[i % CONFIGS], LARG p, J, H, v, a);
            sink += a[0];
        }
        single[r] = (now() - t0) / loops;
        t0 = now();
        for (i = 0; i < loops; ++i) {
            recursive_kinematics(q[i % CONFIGS], dq[i % CONFIGS], ddq[i % CONFIGS], l, p, J, H, v, a);
            sink += a[0];
        }
        rec[r] = (now() - t0) / loops;
#ifdef OTHER
        t0 = now();
        for (i = 0; i < loops; ++i) {
            OTHER(q[i % CONFIGS], dq[i % CONFIGS], ddq[i % CONFIGS], l, p, J, H, v, a);
            sink += a[0];
        }
        other[r] = (now() - t0) / loops;
#else
        other[r] = -1.0;
#endif
        t0 = now();
        KIN_BATCH(batch_m, bq, bdq, bddq, LARG bp, bJ, bH, bv, ba);
        bat[r] = (now() - t0) / batch_m;
        sink += ba[0];
    }
    printf("%.2f %.2f %.2f %.2f %g\n", median(single), median(rec), median(bat), median(other), sink * 0.0);
    return 0;
}
