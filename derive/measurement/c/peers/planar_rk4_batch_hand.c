/* The throughput peer written by hand: the hand-written RK4 loop
 * (planar_rk4_hand.c) over a batch of trajectories, one after the other, as a
 * user would write it in C (array of structures y[i*4 + k], scalar code, one core).
 */
#include "planar_rk4_batch_hand.h"

#include "planar_rk4_hand.c"

void hand_planar_rk4_batch(long count, double *restrict y, const double *restrict p, double h, long n)
{
    long i;
    for (i = 0; i < count; ++i) {
        hand_planar_rk4(y + 4 * i, p, h, n);
    }
}
