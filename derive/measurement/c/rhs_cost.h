#ifndef RHS_COST_H
#define RHS_COST_H
double rhs_cost_loop(long n, long dim, const double *y, const double *p, double *out, long reps,
                     int chained, double eps);
#endif
