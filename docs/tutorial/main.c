/* The tutorial's C program: the generated DOP853 integrator of the damped pendulum
 * (derive generate pendulum.toml --out gen), embedded in a program of one's own.
 * It prints the state at t = 0, 1, ..., 10 and the integrator's counters. */
#include <stdio.h>

#include "damped_integrate.h"

int main(void)
{
    /* parameters in the model's order: m1, m2, l1, l2, L2, g, c (a model with inputs: then
     * its inputs; DAMPED_INTEGRATE_N_P counts what the integrators read) */
    const double p[DAMPED_INTEGRATE_N_P] = {1.0, 0.5, 1.0, 1.0, 0.0417, 9.81, 0.05};
    const double y0[DAMPED_N_STATES] = {2.0, 1.0, 0.0, 0.0};   /* theta1, theta2, their rates */
    double t[11], y[11][DAMPED_N_STATES];
    damped_integrate_options opt;
    damped_integrate_info info;
    int i, status;

    for (i = 0; i < 11; ++i) t[i] = i;
    damped_integrate_defaults(&opt);
    opt.rtol = 1e-10;
    opt.atol = 1e-12;
    status = damped_integrate(DAMPED_METHOD_DOP853, y0, p, 11, t, &y[0][0], &opt, &info);
    if (status != DAMPED_INTEGRATE_OK) {
        fprintf(stderr, "integration failed: %s\n", damped_integrate_status_name(status));
        return 1;
    }
    for (i = 0; i < 11; ++i)
        printf("t = %4.1f  theta1 = %+.9f  theta2 = %+.9f\n", t[i], y[i][0], y[i][1]);
    printf("%ld rhs evaluations, %ld steps accepted\n", info.nfev, info.naccepted);
    return 0;
}
