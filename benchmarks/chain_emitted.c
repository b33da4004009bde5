/* Times the emitted {prefix}_kinematics on configurations read from argv[1] (the benchmark
 * compiles it with -DPREFIX=name -DHEADER='"name.h"'); prints the first outputs and median ns/call. */
#define REPEATS 15
#include "timing.h"
#include <stdio.h>
#include HEADER

#define KIN CAT(PREFIX, _kinematics)
#define INVERSE CAT(PREFIX, _inverse_velocity)
#define GRADIENT CAT(PREFIX, _manipulability_gradient)

int main(int argc, char **argv)
{
    static double q[4096][N], dq[4096][N < 6 ? 6 : N], ddq[4096][N];
    double T[16], J[6 * N], dJ[6 * N], twist[6], acc[6], samples[REPEATS], inverse[REPEATS], gradient[REPEATS], sink = 0;
    double dq_out[N], grad[N];
    FILE *fq;
    int m, repeats, i, k, r;
    if (argc < 2 || !(fq = fopen(argv[1], "r")) || fscanf(fq, "%d %d", &m, &repeats) != 2 || m > 4096) return 2;
    for (i = 0; i < m; ++i)
        for (k = 0; k < N; ++k)
            if (fscanf(fq, "%lf %lf %lf", &q[i][k], &dq[i][k], &ddq[i][k]) != 3) return 2;
    KIN(q[0], dq[0], ddq[0], T, J, dJ, twist, acc);
    for (i = 0; i < 16; ++i) printf("%.17g ", T[i]);
    for (i = 0; i < 6 * N; ++i) printf("%.17g ", J[i]);
    for (i = 0; i < 6 * N; ++i) printf("%.17g ", dJ[i]);
    for (i = 0; i < 6; ++i) printf("%.17g ", twist[i]);
    for (i = 0; i < 6; ++i) printf("%.17g ", acc[i]);
    printf("\n");
    for (r = 0; r < REPEATS; ++r) {
        const double start = now();
        for (i = 0; i < m; ++i) {
            KIN(q[i], dq[i], ddq[i], T, J, dJ, twist, acc);
            sink += T[3] + acc[0];
        }
        samples[r] = (now() - start) / m;
    }
    for (r = 0; r < REPEATS; ++r) {
        double start = now();
        for (i = 0; i < m; ++i) {
            INVERSE(q[i], dq[i], 1e-3, dq_out); /* the rates as a stand-in twist: any 6 numbers */
            sink += dq_out[0];
        }
        inverse[r] = (now() - start) / m;
        start = now();
        for (i = 0; i < m; ++i) {
            GRADIENT(q[i], grad);
            sink += grad[0];
        }
        gradient[r] = (now() - start) / m;
    }
    printf("%.2f %g %.2f %.2f\n", median(samples), sink, median(inverse), median(gradient));
    (void)repeats;
    return 0;
}
