/* The cost of one generated rhs evaluation, timed in C (no Python, no allocation):
 * RHS (a generated <model>_rhs, chosen with -DRHS=<model>_rhs -include <model>.h)
 * over n given states, reps times.  Used by derive bench for the integrator
 * overhead check (time / (rhs evaluations x this cost)).
 */
#include "rhs_cost.h"

double rhs_cost_loop(long n, long dim, const double *y, const double *p, double *out, long reps)
{
    double acc = 0.0;
    long r, i;
    for (r = 0; r < reps; ++r) {
        for (i = 0; i < n; ++i) {
            (void)RHS(y + i * dim, p, out + i * dim);
        }
        acc += out[dim - 1];
    }
    return acc;
}
