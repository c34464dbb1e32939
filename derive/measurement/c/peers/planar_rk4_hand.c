/* The benchmark's hand-written peer: classical RK4 on the planar double
 * pendulum, written by hand as a user would without this toolkit.  The rhs is
 * derive/measurement/c/planar_hand.c (seed 000 (1.34)-(1.35)).  Fixed step, n steps, result
 * in y (in place).
 */
#include "planar_rk4_hand.h"

/* One translation unit, so the compiler may inline the rhs into the loop, as
 * it would in a user's own single-file program. */
#include "../planar_hand.c"

void hand_planar_rk4(double *restrict y, const double *restrict p, double h, long n)
{
    double k1[4], k2[4], k3[4], k4[4], tmp[4];
    long i;
    int j;
    for (i = 0; i < n; ++i) {
        hand_planar_rhs(y, p, k1);
        for (j = 0; j < 4; ++j) tmp[j] = y[j] + 0.5 * h * k1[j];
        hand_planar_rhs(tmp, p, k2);
        for (j = 0; j < 4; ++j) tmp[j] = y[j] + 0.5 * h * k2[j];
        hand_planar_rhs(tmp, p, k3);
        for (j = 0; j < 4; ++j) tmp[j] = y[j] + h * k3[j];
        hand_planar_rhs(tmp, p, k4);
        for (j = 0; j < 4; ++j) y[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
    }
}
