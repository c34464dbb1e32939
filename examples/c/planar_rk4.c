/* A standalone user of the generated C: integrates a planar double pendulum
 * with the classical fourth-order Runge-Kutta method and prints the final
 * state and energy.  It needs only planar.h and planar.c from generated/c.
 *
 * Usage: planar_rk4 [theta1 theta2 theta1_dot theta2_dot [t_end [steps [m1 m2 l1 l2 g]]]]
 * The defaults are the scene in scenes/default.toml: y0 = (2.5, 2.0, 0, 0),
 * m1 = m2 = l1 = l2 = 1, g = 9.81, integrated to t = 5 in 5000 steps.
 */
#include <stdio.h>
#include <stdlib.h>

#include "planar.h"

enum { N = PLANAR_N_STATES };

/* One RK4 step of size h from y (in place).  Returns the OR of the rhs statuses. */
static int rk4_step(double *y, const double *p, double h)
{
    double k1[N], k2[N], k3[N], k4[N], tmp[N];
    int i, status = 0;
    status |= planar_rhs(y, p, k1);
    for (i = 0; i < N; ++i) tmp[i] = y[i] + 0.5 * h * k1[i];
    status |= planar_rhs(tmp, p, k2);
    for (i = 0; i < N; ++i) tmp[i] = y[i] + 0.5 * h * k2[i];
    status |= planar_rhs(tmp, p, k3);
    for (i = 0; i < N; ++i) tmp[i] = y[i] + h * k3[i];
    status |= planar_rhs(tmp, p, k4);
    for (i = 0; i < N; ++i) y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    return status;
}

int main(int argc, char **argv)
{
    double y[N] = {2.5, 2.0, 0.0, 0.0};
    double p[PLANAR_N_PARAMS] = {1.0, 1.0, 1.0, 1.0, 9.81};
    double t_end = 5.0, e0, e1, h;
    long steps = 5000, s;
    int i, status = 0;

    for (i = 0; i < N && i + 1 < argc; ++i) y[i] = atof(argv[i + 1]);
    if (argc > N + 1) t_end = atof(argv[N + 1]);
    if (argc > N + 2) steps = atol(argv[N + 2]);
    for (i = 0; i < PLANAR_N_PARAMS && N + 3 + i < argc; ++i) p[i] = atof(argv[N + 3 + i]);
    if (steps <= 0) {
        fprintf(stderr, "steps must be positive\n");
        return 2;
    }

    status |= planar_energy(y, p, &e0);
    h = t_end / (double)steps;
    for (s = 0; s < steps; ++s) status |= rk4_step(y, p, h);
    status |= planar_energy(y, p, &e1);

    printf("t %.17g\n", t_end);
    for (i = 0; i < N; ++i) printf("%s %.17g\n", planar_state_names[i], y[i]);
    printf("energy_initial %.17g\n", e0);
    printf("energy_final %.17g\n", e1);
    printf("energy_relative_drift %.3e\n", (e1 - e0) / (e0 != 0.0 ? e0 : 1.0));
    printf("status %d\n", status);
    return status == PLANAR_STATUS_OK ? 0 : 1;
}
