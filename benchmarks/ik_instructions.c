/* Calls PREFIX_ik_all or PREFIX_ik_nearest on M targets, for counting instructions under valgrind's callgrind
 * (benchmarks/ik_instructions.py). Compile: cc -O2 -std=c99 -DPREFIX=x -Idir ik_instructions.c dir/x.c -lm.
 * argv[1]: a file of M x (16 + 6) doubles (the target, then q_ref), argv[2]: M, argv[3]: 0 ik_all, 1 ik_nearest. */
#include <stdio.h>
#include <stdlib.h>

#define CAT2(a, b) a##b
#define CAT(a, b) CAT2(a, b)
#define STR2(x) #x
#define STR(x) STR2(x)
#include STR(PREFIX.h)

int main(int argc, char **argv)
{
    if (argc != 4) {
        return 2;
    }
    int m = atoi(argv[2]), which = atoi(argv[3]);
    double *data = malloc(sizeof(double) * 22 * (size_t)(m > 0 ? m : 1));
    double q[48], sum = 0.0;
    int count, flags[8];
    FILE *f = fopen(argv[1], "rb");
    if (!data || !f || fread(data, sizeof(double), 22 * (size_t)m, f) != 22 * (size_t)m) {
        return 1;
    }
    fclose(f);
    for (int i = 0; i < m; ++i) {
        if (which == 0) {
            CAT(PREFIX, _ik_all)(data + 22 * i, q, &count, flags);
        } else {
            CAT(PREFIX, _ik_nearest)(data + 22 * i + 16, data + 22 * i, q);
        }
        sum += q[0];
    }
    printf("%g\n", sum);
    free(data);
    return 0;
}
