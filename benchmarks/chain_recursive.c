/* A plain hand-written O(n) recursion for a serial chain, for the benchmark: the same outputs as
 * the emitted {prefix}_kinematics (T, J and dJ/dt in base axes at the tool origin, twist, classical
 * acceleration), one sin and one cos per revolute joint. Reads the chain (each joint a z motion
 * after a constant placement, then a tool placement) from argv[1] and configurations from argv[2];
 * prints the outputs of the first configuration and the median ns/call. */
#define REPEATS 15
#include "timing.h"
#include <math.h>
#include <stdio.h>

#define MAXJ 64
typedef struct { int n, prismatic[MAXJ]; double C[MAXJ][12], tool[12]; } Chain;

static void cross(const double *a, const double *b, double *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static void kinematics(const Chain *ch, const double *q, const double *dq, const double *ddq,
                       double *T, double *J, double *dJ, double *twist, double *acc)
{
    const int n = ch->n;
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, p[3] = {0, 0, 0};
    double z[MAXJ][3], o[MAXJ][3], jv[MAXJ][3], w[MAXJ + 1][3], u[3] = {0, 0, 0}, pe[3];
    int k, i, j;
    w[0][0] = w[0][1] = w[0][2] = 0;
    for (k = 0; k < n; ++k) {
        const double *C = ch->C[k];
        double Rb[9];
        for (i = 0; i < 3; ++i) {
            o[k][i] = p[i] + R[3 * i] * C[3] + R[3 * i + 1] * C[7] + R[3 * i + 2] * C[11];
            for (j = 0; j < 3; ++j)
                Rb[3 * i + j] = R[3 * i] * C[j] + R[3 * i + 1] * C[4 + j] + R[3 * i + 2] * C[8 + j];
            z[k][i] = Rb[3 * i + 2];
        }
        if (ch->prismatic[k]) {
            for (i = 0; i < 9; ++i) R[i] = Rb[i];
            for (i = 0; i < 3; ++i) p[i] = o[k][i] + z[k][i] * q[k];
            for (i = 0; i < 3; ++i) w[k + 1][i] = w[k][i];
        } else {
            const double c = cos(q[k]), s = sin(q[k]);
            for (i = 0; i < 3; ++i) {
                R[3 * i] = c * Rb[3 * i] + s * Rb[3 * i + 1];
                R[3 * i + 1] = c * Rb[3 * i + 1] - s * Rb[3 * i];
                R[3 * i + 2] = Rb[3 * i + 2];
                p[i] = o[k][i];
                w[k + 1][i] = w[k][i] + z[k][i] * dq[k];
            }
        }
    }
    for (i = 0; i < 3; ++i) {
        pe[i] = p[i] + R[3 * i] * ch->tool[3] + R[3 * i + 1] * ch->tool[7] + R[3 * i + 2] * ch->tool[11];
        for (j = 0; j < 3; ++j)
            T[4 * i + j] = R[3 * i] * ch->tool[j] + R[3 * i + 1] * ch->tool[4 + j] + R[3 * i + 2] * ch->tool[8 + j];
        T[4 * i + 3] = pe[i];
        T[12 + i] = 0;
    }
    T[15] = 1;
    for (k = 0; k < n; ++k) {
        if (ch->prismatic[k]) {
            for (i = 0; i < 3; ++i) { jv[k][i] = z[k][i]; J[(3 + i) * n + k] = 0; }
        } else {
            double r[3];
            for (i = 0; i < 3; ++i) { r[i] = pe[i] - o[k][i]; J[(3 + i) * n + k] = z[k][i]; }
            cross(z[k], r, jv[k]);
        }
        for (i = 0; i < 3; ++i) J[i * n + k] = jv[k][i];
    }
    for (i = 0; i < 6; ++i) acc[i] = 0;
    for (k = n - 1; k >= 0; --k) {
        double a[3], b[3], dz[3];
        cross(w[k], z[k], dz);
        if (ch->prismatic[k]) {
            for (i = 0; i < 3; ++i) { dJ[i * n + k] = dz[i]; dJ[(3 + i) * n + k] = 0; }
        } else {
            cross(w[k + 1], jv[k], a);
            cross(z[k], u, b);
            for (i = 0; i < 3; ++i) { dJ[i * n + k] = a[i] + b[i]; dJ[(3 + i) * n + k] = dz[i]; }
        }
        for (i = 0; i < 3; ++i) u[i] += jv[k][i] * dq[k];
        for (i = 0; i < 6; ++i) acc[i] += J[i * n + k] * ddq[k] + dJ[i * n + k] * dq[k];
    }
    for (i = 0; i < 3; ++i) { twist[i] = u[i]; twist[3 + i] = w[n][i]; }
}

int main(int argc, char **argv)
{
    static Chain ch;
    static double q[4096][MAXJ], dq[4096][MAXJ], ddq[4096][MAXJ];
    double T[16], J[6 * MAXJ], dJ[6 * MAXJ], twist[6], acc[6], samples[REPEATS], sink = 0;
    FILE *fc, *fq;
    int m, repeats, i, k, r;
    if (argc < 3 || !(fc = fopen(argv[1], "r")) || !(fq = fopen(argv[2], "r"))) return 2;
    if (fscanf(fc, "%d", &ch.n) != 1) return 2;
    for (k = 0; k < ch.n; ++k) {
        if (fscanf(fc, "%d", &ch.prismatic[k]) != 1) return 2;
        for (i = 0; i < 12; ++i) if (fscanf(fc, "%lf", &ch.C[k][i]) != 1) return 2;
    }
    for (i = 0; i < 12; ++i) if (fscanf(fc, "%lf", &ch.tool[i]) != 1) return 2;
    if (fscanf(fq, "%d %d", &m, &repeats) != 2 || m > 4096) return 2;
    for (i = 0; i < m; ++i)
        for (k = 0; k < ch.n; ++k)
            if (fscanf(fq, "%lf %lf %lf", &q[i][k], &dq[i][k], &ddq[i][k]) != 3) return 2;
    kinematics(&ch, q[0], dq[0], ddq[0], T, J, dJ, twist, acc);
    for (i = 0; i < 16; ++i) printf("%.17g ", T[i]);
    for (i = 0; i < 6 * ch.n; ++i) printf("%.17g ", J[i]);
    for (i = 0; i < 6 * ch.n; ++i) printf("%.17g ", dJ[i]);
    for (i = 0; i < 6; ++i) printf("%.17g ", twist[i]);
    for (i = 0; i < 6; ++i) printf("%.17g ", acc[i]);
    printf("\n");
    for (r = 0; r < REPEATS; ++r) {
        const double start = now();
        for (i = 0; i < m; ++i) {
            kinematics(&ch, q[i], dq[i], ddq[i], T, J, dJ, twist, acc);
            sink += T[3] + acc[0];
        }
        samples[r] = (now() - start) / m;
    }
    printf("%.2f %g\n", median(samples), sink);
    (void)repeats;
    return 0;
}
