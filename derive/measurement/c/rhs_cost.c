/* The cost of one generated rhs evaluation, timed in C (no Python, no allocation):
 * RHS (a generated <model>_rhs, chosen with -DRHS=<model>_rhs -include <model>.h)
 * over n given states, reps times.  Used by derive bench for the integrator
 * overhead check (time / (rhs evaluations x this cost)).
 *
 * independent (chained = 0): the evaluations do not depend on each other, so the CPU may
 * overlap one with the next -- a throughput figure.
 * chained (chained = 1): evaluation i reads state i + eps * (evaluation i-1's output), eps = 0
 * given at run time: the same states, but each evaluation waits for the one before, as every
 * evaluation of an integrator does (its latency, plus one multiply-add per component).
 */
#include "rhs_cost.h"

#define RHS_COST_MAX_DIM 16

double rhs_cost_loop(long n, long dim, const double *y, const double *p, double *out, long reps,
                     int chained, double eps)
{
    double acc = 0.0;
    double w[RHS_COST_MAX_DIM];
    long r, i, c;
    if (dim > RHS_COST_MAX_DIM) {
        return -1.0;
    }
    for (r = 0; r < reps; ++r) {
        for (i = 0; i < n; ++i) {
            const double *in = y + i * dim;
            if (chained && i > 0) {
                for (c = 0; c < dim; ++c) {
                    w[c] = in[c] + eps * out[(i - 1) * dim + c];
                }
                in = w;
            }
            (void)RHS(in, p, out + i * dim);
        }
        acc += out[dim - 1];
    }
    return acc;
}
