#ifndef PLANAR_RK4_HAND_H
#define PLANAR_RK4_HAND_H
void hand_planar_rk4(double *restrict y, const double *restrict p, double h, long n);
#endif
