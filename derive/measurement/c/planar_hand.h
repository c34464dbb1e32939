#ifndef PLANAR_HAND_H
#define PLANAR_HAND_H
void hand_planar_rhs(const double *restrict y, const double *restrict p, double *restrict ydot);
#endif
