/* Shared by the benchmark harnesses: a monotonic clock in ns and the median of REPEATS samples.
 * Define REPEATS before including. */
#ifndef SKELARM_BENCH_TIMING_H
#define SKELARM_BENCH_TIMING_H

#define _POSIX_C_SOURCE 199309L
#include <stdlib.h>
#include <time.h>

#define CAT2(a, b) a##b
#define CAT(a, b) CAT2(a, b)

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e9 + t.tv_nsec;
}

static int cmp(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

static double median(double *v) { qsort(v, REPEATS, sizeof *v, cmp); return v[REPEATS / 2]; }

#endif
