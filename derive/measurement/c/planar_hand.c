/* A hand-written planar double pendulum rhs: seed 000 (1.34)-(1.35), the
 * benchmark's peer for the generated planar_rhs.  Same state and parameter
 * order: y = (theta1, theta2, theta1_dot, theta2_dot), p = (m1, m2, l1, l2, g).
 */
#include <math.h>

#include "planar_hand.h"

void hand_planar_rhs(const double *restrict y, const double *restrict p, double *restrict ydot)
{
    const double m1 = p[0], m2 = p[1], l1 = p[2], l2 = p[3], g = p[4];
    const double mu = 1.0 + m1 / m2;
    const double d = y[0] - y[1];
    const double s = sin(d), c = cos(d);
    const double a = mu * l1 * l1, b = l1 * l2 * c, e = l2 * l2;
    const double f1 = -y[3] * y[3] * l1 * l2 * s - mu * g * l1 * sin(y[0]);
    const double f2 = y[2] * y[2] * l1 * l2 * s - g * l2 * sin(y[1]);
    const double det = a * e - b * b;
    ydot[0] = y[2];
    ydot[1] = y[3];
    ydot[2] = (e * f1 - b * f2) / det;
    ydot[3] = (a * f2 - b * f1) / det;
}
