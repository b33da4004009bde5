/* Batch against single calls for one emitted function: -DJACOBIAN times PREFIX_jacobian,
 * otherwise PREFIX_kinematics. Prints: single_ns batch_small_ns batch_large_ns
 * (per configuration; small = 1000 configurations, in cache; large = argv[1], default 100000).
 * Medians over repeats; the configurations of the single calls cycle through 256 in cache. */
#define REPEATS 15
#include "timing.h"
#include <stdio.h>
#include HEADER

#define CONFIGS 256


static double *filled(long count)
{
    double *x = malloc(sizeof(double) * count);
    long i;
    for (i = 0; i < count; ++i) x[i] = -3.141592653589793 + 6.283185307179586 * (rand() / (double)RAND_MAX);
    return x;
}

int main(int argc, char **argv)
{
    const long large = argc > 1 ? atol(argv[1]) : 100000, small = 1000;
    double l[N], single[REPEATS], bsmall[REPEATS], blarge[REPEATS], sink = 0.0;
    double *q = filled(N * large), *dq = filled(N * large), *ddq = filled(N * large);
    double *out = filled(2 * N * large + 8), *out2 = filled(2 * N * large + 8);
    double *p = filled(2 * large), *v = filled(2 * large), *a = filled(2 * large);
    long i, r, loops = 4000000 / N / 8 + 1;
    (void)dq; (void)ddq; (void)out2; (void)p; (void)v; (void)a;
    for (i = 0; i < N; ++i) l[i] = 0.5 + rand() / (double)RAND_MAX;
    for (r = 0; r < REPEATS; ++r) {
        double t0 = now();
        for (i = 0; i < loops; ++i) {
            const long k = i % CONFIGS;
#ifdef JACOBIAN
            CAT(PREFIX, _jacobian)(q + k * N, l, out + k * 2 * N);
#else
            CAT(PREFIX, _kinematics)(q + k * N, dq + k * N, ddq + k * N, l, p + 2 * k, out + k * 2 * N, out2 + k * 2 * N, v + 2 * k, a + 2 * k);
#endif
            sink += out[k * 2 * N];
        }
        single[r] = (now() - t0) / loops;
        t0 = now();
        for (i = 0; i < 100; ++i) {
#ifdef JACOBIAN
            CAT(PREFIX, _jacobian_batch)(small, q, l, out);
#else
            CAT(PREFIX, _kinematics_batch)(small, q, dq, ddq, l, p, out, out2, v, a);
#endif
        }
        bsmall[r] = (now() - t0) / (100 * small);
        t0 = now();
#ifdef JACOBIAN
        CAT(PREFIX, _jacobian_batch)(large, q, l, out);
#else
        CAT(PREFIX, _kinematics_batch)(large, q, dq, ddq, l, p, out, out2, v, a);
#endif
        blarge[r] = (now() - t0) / large;
        sink += out[0];
    }
    printf("%.2f %.2f %.2f %g\n", median(single), median(bsmall), median(blarge), sink * 0.0);
    return 0;
}
