/* Times PREFIX_ik_all (every closed-form solution) and PREFIX_ik_solve (the iterative pose IK) from one
 * generated file, on the same targets. Compile: cc -O2 -std=c99 -DPREFIX=x -DN=6 [-DLOCKED] -Idir
 * ik_all_harness.c dir/x.c -lm. Reads targets (M x 16 doubles), locks (M) and starts (M x N) from
 * argv[1] (raw doubles, in that order), M = argv[2].
 * Prints: ik_all_cpu_ns ik_all_wall_ns ik_solve_cpu_ns ik_solve_wall_ns (medians over REPEATS sweeps of
 * all targets, per call; cpu: this thread's CPU time, which other processes on a shared machine do not
 * inflate; wall: CLOCK_MONOTONIC) and the mean number of solutions. */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define REPEATS 15
#define CAT2(a, b) a##b
#define CAT(a, b) CAT2(a, b)
#define STR2(x) #x
#define STR(x) STR2(x)
#include STR(PREFIX.h)

#define ALL CAT(PREFIX, _ik_all)
#define SOLVE CAT(PREFIX, _ik_solve)
#ifdef LOCKED
#define LOCK_ARG(i) , locks[i]
#else
#define LOCK_ARG(i)
#endif

static double clock_ns(clockid_t id)
{
    struct timespec t;
    clock_gettime(id, &t);
    return t.tv_sec * 1e9 + t.tv_nsec;
}

static int cmp(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

static double median(double *v)
{
    qsort(v, REPEATS, sizeof *v, cmp);
    return v[REPEATS / 2];
}

int main(int argc, char **argv)
{
    long m, i, r;
    double *targets, *locks, *starts, q[8 * N], qs[N], err[2], sink = 0.0, solutions = 0.0;
    double all_cpu[REPEATS], all_wall[REPEATS], solve_cpu[REPEATS], solve_wall[REPEATS];
    int count = 0, iterations = 0;
    FILE *f;
    if (argc < 3)
        return 2;
    m = atol(argv[2]);
    targets = malloc(sizeof(double) * 16 * m);
    locks = malloc(sizeof(double) * m);
    starts = malloc(sizeof(double) * N * m);
    f = fopen(argv[1], "rb");
    if (!f || fread(targets, sizeof(double), 16 * m, f) != (size_t)(16 * m) || fread(locks, sizeof(double), m, f) != (size_t)m
        || fread(starts, sizeof(double), N * m, f) != (size_t)(N * m))
        return 3;
    fclose(f);
    (void)locks;
    for (i = 0; i < m; ++i) {
        ALL(targets + 16 * i LOCK_ARG(i), q, &count, NULL);
        solutions += count;
    }
    for (r = 0; r < REPEATS; ++r) {
        double c0 = clock_ns(CLOCK_THREAD_CPUTIME_ID), w0 = clock_ns(CLOCK_MONOTONIC);
        for (i = 0; i < m; ++i) {
            ALL(targets + 16 * i LOCK_ARG(i), q, &count, NULL);
            sink += q[0] + count;
        }
        all_cpu[r] = (clock_ns(CLOCK_THREAD_CPUTIME_ID) - c0) / m;
        all_wall[r] = (clock_ns(CLOCK_MONOTONIC) - w0) / m;
    }
#ifndef LOCKED
    for (r = 0; r < REPEATS; ++r) {
        double c0 = clock_ns(CLOCK_THREAD_CPUTIME_ID), w0 = clock_ns(CLOCK_MONOTONIC);
        for (i = 0; i < m; ++i) {
            SOLVE(starts + N * i, targets + 16 * i, 0.0, 1e-10, 100, qs, err, &iterations);
            sink += qs[0];
        }
        solve_cpu[r] = (clock_ns(CLOCK_THREAD_CPUTIME_ID) - c0) / m;
        solve_wall[r] = (clock_ns(CLOCK_MONOTONIC) - w0) / m;
    }
#else
    for (r = 0; r < REPEATS; ++r)
        solve_cpu[r] = solve_wall[r] = -1.0; /* the 7-joint ik_solve moves the locked joint: not the same problem */
#endif
    printf("%.1f %.1f %.1f %.1f %.3f\n", median(all_cpu), median(all_wall), median(solve_cpu), median(solve_wall), solutions / m);
    return sink == 12345.678 ? 1 : 0;
}
