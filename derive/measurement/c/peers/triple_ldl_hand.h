/* A hand-written rhs of the triple planar pendulum (point, rod, point): the peer that
 * the generated L D L^T solve is measured against (bench/open_models.py). */
#ifndef TRIPLE_LDL_HAND_H
#define TRIPLE_LDL_HAND_H
/* y = (theta1, theta2, theta3, rates), p = (m1, m2, m3, l1, l2, l3, L2, g); returns 0. */
int hand_triple_rhs(const double *y, const double *p, double *ydot);
#endif
