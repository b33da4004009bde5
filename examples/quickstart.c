/* Quick start: the emitted UR5 functions from C. Generate them, then build and run:
 *   skelarm-sym generate --robot examples/robots/ur5.urdf --tip tool0 --lang c --out build
 *   cc -std=c99 -O2 -Ibuild examples/quickstart.c build/ur5.c -o quickstart -lm && ./quickstart */
#include <stdio.h>
#include "ur5.h"

int main(void)
{
    const double q[6] = {0.1, -1.2, 1.5, -1.9, -1.4, 0.3};   /* rad, base to tip */
    const double dq[6] = {0.2, 0.1, -0.3, 0.4, 0.0, 0.5};    /* rad/s */
    const double ddq[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};    /* rad/s^2 */
    const double q0[6] = {0.0, -1.0, 1.0, -1.5, -1.5, 0.0};  /* where the IK starts */
    double T[16], J[36], dJ[36], twist[6], acc[6], q_ik[6], error[2];
    int iterations, status;

    /* pose (4 x 4 row-major), Jacobian (6 x 6: vx vy vz wx wy wz, base axes, tool origin), dJ/dt, J dq, J ddq + dJ dq */
    ur5_kinematics(q, dq, ddq, T, J, dJ, twist, acc);
    printf("tool at %.6f %.6f %.6f m, moving at %.6f %.6f %.6f m/s\n", T[3], T[7], T[11], twist[0], twist[1], twist[2]);

    /* back from the pose to joint angles (damped least squares with restarts; tol in m and rad) */
    status = ur5_ik_solve(q0, T, 0.0, 1e-10, 100, q_ik, error, &iterations);
    printf("ik_solve: status %d (%s) after %d steps, position error %.1e m, rotation error %.1e rad\n", status,
           status == UR5_IK_CONVERGED ? "converged" : "not converged", iterations, error[0], error[1]);
    return status == UR5_IK_CONVERGED ? 0 : 1;
}
