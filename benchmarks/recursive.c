/* Hand-written O(n) recursive kinematics (seed 000), the baseline skelarm-sym must beat.
 * The obvious loop: one sincos per link forward, suffix sums backward. N is a compile-time
 * constant (-DN=...), as it is for the emitted code. */
#define _GNU_SOURCE
#include <math.h>

void recursive_kinematics(const double q[N], const double dq[N], const double ddq[N], const double l[N],
                          double p[2], double J[2 * N], double H[2 * N], double v[2], double a[2])
{
    double X[N], Y[N], W[N];
    double th = 0.0, w = 0.0;
    int i;
    for (i = 0; i < N; ++i) {
        double s, c;
        th += q[i];
        w += dq[i];
        sincos(th, &s, &c);
        X[i] = l[i] * c;
        Y[i] = l[i] * s;
        W[i] = w;
    }
    {
        double jx = 0.0, jy = 0.0, hx = 0.0, hy = 0.0, ax = 0.0, ay = 0.0;
        for (i = N - 1; i >= 0; --i) {
            jx -= Y[i];
            jy += X[i];
            hx -= X[i] * W[i];
            hy -= Y[i] * W[i];
            J[i] = jx;
            J[N + i] = jy;
            H[i] = hx;
            H[N + i] = hy;
            ax += jx * ddq[i] + hx * dq[i];
            ay += jy * ddq[i] + hy * dq[i];
        }
        p[0] = jy;
        p[1] = -jx;
        v[0] = hy;
        v[1] = -hx;
        a[0] = ax;
        a[1] = ay;
    }
}
