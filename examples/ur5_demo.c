/* UR5 from C: tool position and twist at one configuration, with the committed generated/ur5.c.
 *   cc -std=c99 -O2 -Igenerated examples/ur5_demo.c generated/ur5.c -o ur5_demo -lm && ./ur5_demo */
#include <stdio.h>
#include "ur5.h"

int main(void)
{
    const double q[6] = {0.1, -1.2, 1.5, -1.9, -1.4, 0.3};    /* rad, base to tip */
    const double dq[6] = {0.2, 0.1, -0.3, 0.4, 0.0, 0.5};     /* rad/s */
    double T[16], J[36], twist[6];
    int i;
    ur5_pose(q, T);                      /* 4 x 4 row-major: the position is T[3], T[7], T[11] */
    ur5_jacobian(q, J);                  /* 6 x 6 row-major: rows vx vy vz wx wy wz, base axes */
    ur5_twist(q, dq, twist);             /* J dq */
    printf("%.17g %.17g %.17g", T[3], T[7], T[11]);
    for (i = 0; i < 6; ++i) {
        printf(" %.17g", twist[i]);
    }
    printf("\n");
    return J[0] == J[0] ? 0 : 1;
}
