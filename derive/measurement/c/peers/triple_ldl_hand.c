/* The triple planar pendulum, point mass m1, uniform rod m2 (centre at l2/2, inertia L2
 * about it), point mass m3, written by hand as one would: the mass matrix entries are
 * a_ij cos(theta_i - theta_j), the forcing -a_ij sin(theta_i - theta_j) w_j^2 - g b_i
 * sin(theta_i), the angle differences from the sines and cosines of the angles, and
 * M x = F solved by L D L^T (M is symmetric positive definite).
 */
#include <math.h>

#include "triple_ldl_hand.h"

int hand_triple_rhs(const double *y, const double *p, double *ydot)
{
    const double m1 = p[0], m2 = p[1], m3 = p[2], l1 = p[3], l2 = p[4], l3 = p[5], L2 = p[6], g = p[7];
    const double s1 = sin(y[0]), c1 = cos(y[0]), s2 = sin(y[1]), c2 = cos(y[1]);
    const double s3 = sin(y[2]), c3 = cos(y[2]);
    const double w1 = y[3], w2 = y[4], w3 = y[5];
    const double c12 = c1 * c2 + s1 * s2, s12 = s1 * c2 - c1 * s2;
    const double c13 = c1 * c3 + s1 * s3, s13 = s1 * c3 - c1 * s3;
    const double c23 = c2 * c3 + s2 * s3, s23 = s2 * c3 - c2 * s3;
    const double b1 = (m1 + m2 + m3) * l1, b2 = (0.5 * m2 + m3) * l2, b3 = m3 * l3;
    const double a12 = b2 * l1, a13 = m3 * l1 * l3, a23 = m3 * l2 * l3;
    const double M11 = b1 * l1, M22 = (0.25 * m2 + m3) * l2 * l2 + L2, M33 = b3 * l3;
    const double M12 = a12 * c12, M13 = a13 * c13, M23 = a23 * c23;
    const double F1 = -a12 * s12 * w2 * w2 - a13 * s13 * w3 * w3 - g * b1 * s1;
    const double F2 = a12 * s12 * w1 * w1 - a23 * s23 * w3 * w3 - g * b2 * s2;
    const double F3 = a13 * s13 * w1 * w1 + a23 * s23 * w2 * w2 - g * b3 * s3;
    /* M = L D L^T */
    const double rD1 = 1.0 / M11;
    const double L21 = M12 * rD1, L31 = M13 * rD1;
    const double D2 = M22 - L21 * M12, rD2 = 1.0 / D2;
    const double L32 = (M23 - L31 * M12) * rD2;
    const double D3 = M33 - L31 * M13 - L32 * L32 * D2;
    /* forward, diagonal, back */
    const double z2 = F2 - L21 * F1, z3 = F3 - L31 * F1 - L32 * z2;
    const double x3 = z3 / D3, x2 = z2 * rD2 - L32 * x3, x1 = F1 * rD1 - L21 * x2 - L31 * x3;
    ydot[0] = w1;
    ydot[1] = w2;
    ydot[2] = w3;
    ydot[3] = x1;
    ydot[4] = x2;
    ydot[5] = x3;
    return 0;
}
