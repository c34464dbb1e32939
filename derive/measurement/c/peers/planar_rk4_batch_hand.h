#ifndef PLANAR_RK4_BATCH_HAND_H
#define PLANAR_RK4_BATCH_HAND_H
void hand_planar_rk4_batch(long count, double *restrict y, const double *restrict p, double h, long n);
#endif
