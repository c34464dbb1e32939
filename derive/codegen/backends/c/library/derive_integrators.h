/* derive_integrators.h: the method code of derive's integrators, written once for every
 * model and every real type (derive/codegen/backends/c/library/).  A model's generated
 * <model>_integrate.c defines the macros below, includes this file once per real type
 * (float, double, long double), and defines its public functions by calling the static
 * functions it gets; the coefficients come from derive_tableaus.h (generated from the
 * .toml tableaus in derive/codegen/tableaus, the literals of each type, zero coefficients
 * left out) and the stepping loop from derive_driver.h.
 *
 * Standalone C99, only <math.h>; reentrant: no globals, no allocation.  The state size
 * is a compile-time constant and the model's guarded evaluation a static function of the
 * including file, so the compiler sees the code a per-model rendering gave it (the
 * coefficients as literals, the zero ones absent), and the results are the same bits.
 *
 * Defined once per translation unit, before the first inclusion:
 *   DERIVE_N                   the state size (a constant expression)
 *   DERIVE_N_P                 the length of p (the parameters, then the inputs)
 *   DERIVE_OPTIONS, DERIVE_INFO  the model's options and info structs
 *   DERIVE_DEFAULTS(opt)       fills the options with their defaults
 *   DERIVE_MAX_STAGES          the rows of the stage array K
 *   DERIVE_METHOD_RK4 .. DERIVE_METHOD_GAUSS2   the method codes (RK4, RK8, ABM12, DOPRI5,
 *                              DOP853, MIDPOINT, GAUSS2)
 *   DERIVE_TIMED               (only for a time-dependent model: t in its forces,
 *                              dissipation or pivot) every evaluation takes the time first,
 *                              DERIVE_EVAL(t, y, p, f, opt, info) and the SYS_ ones alike,
 *                              each stage at its own time t + c_i h; the step functions
 *                              below then take the step's start time t before y.  Without
 *                              it the time is never formed: an autonomous model's code is
 *                              what it was before the time existed (DERIVE_WITH_T).
 *   DERIVE_OK, DERIVE_STEP_UNDERFLOW, DERIVE_MAX_STEPS, DERIVE_NEWTON, DERIVE_NONFINITE,
 *   DERIVE_CHART_SINGULAR, DERIVE_BAD_INPUT, DERIVE_CANCELLED, DERIVE_MULTISTEP_UNSTABLE
 *                              the status codes
 * Defined before each inclusion (this file undefines them at its end):
 *   DERIVE_REAL                the real type
 *   DERIVE_T(x)                the type's name tag: x##_d, x##_f or x##_l (names the
 *                              functions defined here and picks the tableau's literals)
 *   DERIVE_MATH(fn)            <math.h> for the type: fn, fn##f or fn##l
 *   DERIVE_EPS                 the type's machine epsilon (a literal of the type)
 *   DERIVE_EVAL(y, p, f, opt, info)       f = y', guarded and counted: 0 or a status
 *   DERIVE_SYS_EVAL(x, p, f, opt, info)   the implicit methods' system and
 *   DERIVE_SYS_JAC(x, p, J, opt, info)    its Jacobian (row-major N x N)
 *   DERIVE_GUARD(y, opt)                  the chart check: 0, CHART_SINGULAR or NONFINITE
 *                                         (only for a model with chart guards)
 *   DERIVE_TO_CANONICAL(y, p, x)          y = (q, q') -> x = (q, p) and back, 0 or a status
 *   DERIVE_FROM_CANONICAL(x, p, y)        (only for a model with a Hamiltonian form: its
 *                                         implicit methods then run on x)
 *
 * Functions (static; T = the type's tag; K: the stage rows, K[0] = f(y) on entry):
 *   derive_rk4_step_T, derive_dopri5_step_T, derive_dop853_step_T (y, h, p, K, y_new, err, opt, info)
 *   derive_dopri5_dense_T (y, h, K, theta, out)
 *   derive_dop853_dense_prepare_T (y, y_new, h, p, K, F, opt, info), derive_dop853_dense_T (y, F, theta, out)
 *   derive_midpoint_step_T, derive_gauss2_step_T (x, h, p, x_new, opt, info)
 *   derive_integrate_T (method, y0, p, nt, t, y_out, opt, info): a whole run
 *   derive_integrate_batch_T (n, method, y0, y0_stride, p, p_stride, nt, t, y_out, opt, info)
 */
#include "derive_tableaus.h"

#if defined(__cplusplus) && !defined(restrict)
#define restrict __restrict
#endif

#ifndef DERIVE_INTEGRATORS_SHARED
#define DERIVE_INTEGRATORS_SHARED
/* DERIVE_WITH_T(x): "x," in a time-dependent model's code, nothing in an autonomous
 * one's: the time as an argument or a parameter, so one text serves both kinds of model
 * (derive_driver.h defines it the same way). */
#ifndef DERIVE_WITH_T
#ifdef DERIVE_TIMED
#define DERIVE_WITH_T(x) x,
#else
#define DERIVE_WITH_T(x)
#endif
#endif
/* One explicit stage: ys = y + h * (combination of the stages before), K[i] = f(t + c h, ys)
 * (in a step function: its t, y, h, p, K, ys, k, st, opt and info). */
#define DERIVE_STAGE(combo, c, i)                               \
    for (k = 0; k < DERIVE_N; ++k) {                            \
        ys[k] = y[k] + h * (DERIVE_T(combo)(K, k));             \
    }                                                           \
    st = DERIVE_EVAL(DERIVE_WITH_T(t + DERIVE_T(c) * h) ys, p, K[i], opt, info); \
    if (st) {                                                   \
        return st;                                              \
    }
/* The error scale of component k: atol + rtol max(|y|, |y_new|). */
#define DERIVE_SCALE(k) ((DERIVE_REAL)opt->atol + (DERIVE_REAL)opt->rtol * (DERIVE_MATH(fabs)(y[k]) > DERIVE_MATH(fabs)(y_new[k]) ? DERIVE_MATH(fabs)(y[k]) : DERIVE_MATH(fabs)(y_new[k])))
#endif

/* Classical RK4 (seed 001). */
static inline int DERIVE_T(derive_rk4_step)(DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *restrict y, DERIVE_REAL h, const DERIVE_REAL *restrict p, DERIVE_REAL (*restrict K)[DERIVE_N], DERIVE_REAL *restrict y_new, DERIVE_REAL *restrict err, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    DERIVE_REAL ys[DERIVE_N];
    int st, k;
    (void)opt;
    DERIVE_STAGE(DERIVE_RK4_A1, DERIVE_RK4_C1, 1)
    DERIVE_STAGE(DERIVE_RK4_A2, DERIVE_RK4_C2, 2)
    DERIVE_STAGE(DERIVE_RK4_A3, DERIVE_RK4_C3, 3)
    for (k = 0; k < DERIVE_N; ++k) {
        y_new[k] = y[k] + h * (DERIVE_T(DERIVE_RK4_B)(K, k));
    }
    *err = 0;
    return DERIVE_OK;
}

/* Dormand-Prince 5(4): stages 1-5, y_new, FSAL stage 6, error. */
static inline int DERIVE_T(derive_dopri5_step)(DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *restrict y, DERIVE_REAL h, const DERIVE_REAL *restrict p, DERIVE_REAL (*restrict K)[DERIVE_N], DERIVE_REAL *restrict y_new, DERIVE_REAL *restrict err, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    DERIVE_REAL ys[DERIVE_N];
    DERIVE_REAL sum = 0, e;
    int st, k;
    DERIVE_STAGE(DERIVE_DOPRI5_A1, DERIVE_DOPRI5_C1, 1)
    DERIVE_STAGE(DERIVE_DOPRI5_A2, DERIVE_DOPRI5_C2, 2)
    DERIVE_STAGE(DERIVE_DOPRI5_A3, DERIVE_DOPRI5_C3, 3)
    DERIVE_STAGE(DERIVE_DOPRI5_A4, DERIVE_DOPRI5_C4, 4)
    DERIVE_STAGE(DERIVE_DOPRI5_A5, DERIVE_DOPRI5_C5, 5)
    for (k = 0; k < DERIVE_N; ++k) {
        y_new[k] = y[k] + h * (DERIVE_T(DERIVE_DOPRI5_B)(K, k));
    }
    st = DERIVE_EVAL(DERIVE_WITH_T(t + h) y_new, p, K[6], opt, info);
    if (st) {
        return st;
    }
    for (k = 0; k < DERIVE_N; ++k) {
        e = h * (DERIVE_T(DERIVE_DOPRI5_E)(K, k)) / DERIVE_SCALE(k);
        sum += e * e;
    }
    *err = DERIVE_MATH(sqrt)(sum / DERIVE_N);
    return DERIVE_OK;
}

/* Dormand-Prince 8(5,3): stages 1-11, y_new, error as in Hairer's DOP853. */
static inline int DERIVE_T(derive_dop853_step)(DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *restrict y, DERIVE_REAL h, const DERIVE_REAL *restrict p, DERIVE_REAL (*restrict K)[DERIVE_N], DERIVE_REAL *restrict y_new, DERIVE_REAL *restrict err, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    DERIVE_REAL ys[DERIVE_N];
    DERIVE_REAL e3 = 0, e5 = 0, sk, e, deno;
    int st, k;
    DERIVE_STAGE(DERIVE_DOP853_A1, DERIVE_DOP853_C1, 1)
    DERIVE_STAGE(DERIVE_DOP853_A2, DERIVE_DOP853_C2, 2)
    DERIVE_STAGE(DERIVE_DOP853_A3, DERIVE_DOP853_C3, 3)
    DERIVE_STAGE(DERIVE_DOP853_A4, DERIVE_DOP853_C4, 4)
    DERIVE_STAGE(DERIVE_DOP853_A5, DERIVE_DOP853_C5, 5)
    DERIVE_STAGE(DERIVE_DOP853_A6, DERIVE_DOP853_C6, 6)
    DERIVE_STAGE(DERIVE_DOP853_A7, DERIVE_DOP853_C7, 7)
    DERIVE_STAGE(DERIVE_DOP853_A8, DERIVE_DOP853_C8, 8)
    DERIVE_STAGE(DERIVE_DOP853_A9, DERIVE_DOP853_C9, 9)
    DERIVE_STAGE(DERIVE_DOP853_A10, DERIVE_DOP853_C10, 10)
    DERIVE_STAGE(DERIVE_DOP853_A11, DERIVE_DOP853_C11, 11)
    for (k = 0; k < DERIVE_N; ++k) {
        y_new[k] = y[k] + h * (DERIVE_T(DERIVE_DOP853_B)(K, k));
    }
    /* Hairer's DOP853: err = |h| E5 / sqrt(N (E5 + E3/100)), E3, E5 sums of squares */
    for (k = 0; k < DERIVE_N; ++k) {
        sk = DERIVE_SCALE(k);
        e = (DERIVE_T(DERIVE_DOP853_E3)(K, k)) / sk;
        e3 += e * e;
        e = (DERIVE_T(DERIVE_DOP853_E5)(K, k)) / sk;
        e5 += e * e;
    }
    deno = e5 + (DERIVE_REAL)0.01 * e3;
    if (deno <= 0) {
        deno = 1;
    }
    *err = DERIVE_MATH(fabs)(h) * e5 * DERIVE_MATH(sqrt)(1 / (DERIVE_N * deno));
    return DERIVE_OK;
}

/* y(t + theta h) from a DOPRI5 step (0 <= theta <= 1): its continuous extension. */
static inline void DERIVE_T(derive_dopri5_dense)(const DERIVE_REAL *restrict y, DERIVE_REAL h, DERIVE_REAL (*restrict K)[DERIVE_N], DERIVE_REAL theta, DERIVE_REAL *restrict out)
{
    DERIVE_REAL b[7];
    int k;
    DERIVE_T(DERIVE_DOPRI5_DENSE_WEIGHTS)(b, theta);
    for (k = 0; k < DERIVE_N; ++k) {
        out[k] = y[k] + h * (DERIVE_T(DERIVE_DOPRI5_DENSE)(b, K, k));
    }
}

/* DOP853 dense output: from K[0..12] of an accepted step, K[13..15] and F[0..6]. */
static inline int DERIVE_T(derive_dop853_dense_prepare)(DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *restrict y, const DERIVE_REAL *restrict y_new, DERIVE_REAL h, const DERIVE_REAL *restrict p, DERIVE_REAL (*restrict K)[DERIVE_N], DERIVE_REAL (*restrict F)[DERIVE_N], const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    DERIVE_REAL ys[DERIVE_N];
    int st, k;
    DERIVE_STAGE(DERIVE_DOP853_A13, DERIVE_DOP853_C13, 13)
    DERIVE_STAGE(DERIVE_DOP853_A14, DERIVE_DOP853_C14, 14)
    DERIVE_STAGE(DERIVE_DOP853_A15, DERIVE_DOP853_C15, 15)
    for (k = 0; k < DERIVE_N; ++k) {
        F[0][k] = y_new[k] - y[k];
        F[1][k] = h * K[0][k] - F[0][k];
        F[2][k] = F[0][k] - h * K[12][k] - F[1][k];
        F[3][k] = h * (DERIVE_T(DERIVE_DOP853_D3)(K, k));
        F[4][k] = h * (DERIVE_T(DERIVE_DOP853_D4)(K, k));
        F[5][k] = h * (DERIVE_T(DERIVE_DOP853_D5)(K, k));
        F[6][k] = h * (DERIVE_T(DERIVE_DOP853_D6)(K, k));
    }
    return DERIVE_OK;
}

static inline void DERIVE_T(derive_dop853_dense)(const DERIVE_REAL *restrict y, DERIVE_REAL (*restrict F)[DERIVE_N], DERIVE_REAL theta, DERIVE_REAL *restrict out)
{
    const DERIVE_REAL s1 = 1 - theta;
    int k;
    for (k = 0; k < DERIVE_N; ++k) {
        out[k] = y[k] + theta * (F[0][k] + s1 * (F[1][k] + theta * (F[2][k] + s1 * (F[3][k] + theta * (F[4][k] + s1 * (F[5][k] + theta * F[6][k]))))));
    }
}

/* W = I - h (a_ij J_j) for an s-stage method (J_j: the Jacobian used for stage j),
 * LU-factored in place with partial pivoting: 0 or NEWTON (singular). */
static int DERIVE_T(derive_gauss_factor)(int ns, const DERIVE_REAL *A, DERIVE_REAL h, const DERIVE_REAL *J, DERIVE_REAL *W, int *piv)
{
    const int n = ns * DERIVE_N;
    DERIVE_REAL big, tmp;
    int i, j, k, l;
    for (i = 0; i < ns; ++i) {
        for (j = 0; j < ns; ++j) {
            for (k = 0; k < DERIVE_N; ++k) {
                for (l = 0; l < DERIVE_N; ++l) {
                    W[(i * DERIVE_N + k) * n + j * DERIVE_N + l] = (i == j && k == l ? 1 : 0) - h * A[i * ns + j] * J[j * DERIVE_N * DERIVE_N + k * DERIVE_N + l];
                }
            }
        }
    }
    for (k = 0; k < n; ++k) {
        big = 0;
        piv[k] = k;
        for (i = k; i < n; ++i) {
            if (DERIVE_MATH(fabs)(W[i * n + k]) > big) {
                big = DERIVE_MATH(fabs)(W[i * n + k]);
                piv[k] = i;
            }
        }
        if (!(big > 0)) {
            return DERIVE_NEWTON;
        }
        if (piv[k] != k) {
            for (j = 0; j < n; ++j) {
                tmp = W[k * n + j];
                W[k * n + j] = W[piv[k] * n + j];
                W[piv[k] * n + j] = tmp;
            }
        }
        for (i = k + 1; i < n; ++i) {
            W[i * n + k] /= W[k * n + k];
            for (j = k + 1; j < n; ++j) {
                W[i * n + j] -= W[i * n + k] * W[k * n + j];
            }
        }
    }
    return DERIVE_OK;
}

/* The Jacobian at each stage value x + Z_j (ns evaluations, counted in njev). */
static int DERIVE_T(derive_gauss_stage_jac)(int ns, DERIVE_WITH_T(const DERIVE_REAL *c) DERIVE_WITH_T(DERIVE_REAL t) DERIVE_WITH_T(DERIVE_REAL h) const DERIVE_REAL *restrict x, DERIVE_REAL (*Z)[DERIVE_N], const DERIVE_REAL *restrict p, DERIVE_REAL *J, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    DERIVE_REAL xs[DERIVE_N];
    int st, j, k;
    for (j = 0; j < ns; ++j) {
        for (k = 0; k < DERIVE_N; ++k) {
            xs[k] = x[k] + Z[j][k];
        }
        st = DERIVE_SYS_JAC(DERIVE_WITH_T(t + c[j] * h) xs, p, J + j * DERIVE_N * DERIVE_N, opt, info);
        if (st) {
            return st;
        }
    }
    return DERIVE_OK;
}

/* One step of an s-stage Gauss-Legendre method on the stage increments
 * Z_i = h sum_j a_ij f(x + Z_j), then x_new = x + sum_i d_i Z_i (d = b^T A^-1).
 * Simplified Newton with the Jacobian at x.  With the contraction rate
 * theta_k = |dZ_k| / |dZ_k-1|: an increment that shrinks slowly (DERIVE_THETA_MAX < theta
 * < 1) re-evaluates the Jacobian at the current stage values x + Z_j (one per stage,
 * W = I - h (a_ij J_j)) and restarts the rate estimate; one that grows (1 <= theta <
 * DERIVE_THETA_DIVERGE) does the same at the iterate before it, once per step.  NEWTON,
 * the last resort, when an increment grows again, grows by DERIVE_THETA_DIVERGE or more,
 * is not finite, or no convergence in opt->newton_max iterations: a step is never taken
 * from an unconverged iteration, nor from a far-off root the iteration wandered to. */
static int DERIVE_T(derive_gauss)(int ns, const DERIVE_REAL *A, const DERIVE_REAL *c, const DERIVE_REAL *d, DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *restrict x, DERIVE_REAL h, const DERIVE_REAL *restrict p, DERIVE_REAL *restrict x_new, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    DERIVE_REAL J[2 * DERIVE_N * DERIVE_N], W[4 * DERIVE_N * DERIVE_N], G[2 * DERIVE_N], Z[2][DERIVE_N], Zold[2][DERIVE_N], Fv[2][DERIVE_N], xs[DERIVE_N];
    DERIVE_REAL nrm, prev = 0, theta, tmp;
    const DERIVE_REAL tol = opt->newton_tol > 0 ? (DERIVE_REAL)opt->newton_tol : 10 * DERIVE_EPS;
    const DERIVE_REAL rounding = 1000 * DERIVE_EPS;
    const int n = ns * DERIVE_N;
    int piv[2 * DERIVE_N];
    int st, i, j, k, it, conv = 0, bad, grown = 0;

    st = DERIVE_SYS_JAC(DERIVE_WITH_T(t) x, p, J, opt, info);
    if (st) {
        return st;
    }
    for (k = DERIVE_N * DERIVE_N; k < ns * DERIVE_N * DERIVE_N; ++k) {
        J[k] = J[k - DERIVE_N * DERIVE_N];
    }
    st = DERIVE_SYS_EVAL(DERIVE_WITH_T(t) x, p, Fv[0], opt, info);
    if (st) {
        return st;
    }
    for (i = ns - 1; i >= 0; --i) {
        for (k = 0; k < DERIVE_N; ++k) {
            Z[i][k] = c[i] * h * Fv[0][k];
        }
    }
    st = DERIVE_T(derive_gauss_factor)(ns, A, h, J, W, piv);
    if (st) {
        return st;
    }
    for (it = 0; it < opt->newton_max; ++it) {
        for (i = 0; i < ns; ++i) {
            for (k = 0; k < DERIVE_N; ++k) {
                Zold[i][k] = Z[i][k];
                xs[k] = x[k] + Z[i][k];
            }
            st = DERIVE_SYS_EVAL(DERIVE_WITH_T(t + c[i] * h) xs, p, Fv[i], opt, info);
            if (st) {
                return st;
            }
        }
        for (i = 0; i < ns; ++i) {
            for (k = 0; k < DERIVE_N; ++k) {
                tmp = Z[i][k];
                for (j = 0; j < ns; ++j) {
                    tmp -= h * A[i * ns + j] * Fv[j][k];
                }
                G[i * DERIVE_N + k] = -tmp;
            }
        }
        for (k = 0; k < n; ++k) {
            if (piv[k] != k) {
                tmp = G[k];
                G[k] = G[piv[k]];
                G[piv[k]] = tmp;
            }
        }
        for (i = 1; i < n; ++i) {
            for (j = 0; j < i; ++j) {
                G[i] -= W[i * n + j] * G[j];
            }
        }
        for (i = n - 1; i >= 0; --i) {
            for (j = i + 1; j < n; ++j) {
                G[i] -= W[i * n + j] * G[j];
            }
            G[i] /= W[i * n + i];
        }
        nrm = 0;
        for (i = 0; i < ns; ++i) {
            for (k = 0; k < DERIVE_N; ++k) {
                Z[i][k] += G[i * DERIVE_N + k];
                tmp = DERIVE_MATH(fabs)(G[i * DERIVE_N + k]) / (1 + DERIVE_MATH(fabs)(x[k]));
                if (!(tmp <= nrm)) {
                    nrm = tmp;
                }
            }
        }
        info->nnewton += 1;
        bad = 0;                /* 1: slow, 2: growing */
        if (isnan(nrm) || nrm > (DERIVE_REAL)1e30) {
            return DERIVE_NEWTON;
        } else if (nrm <= tol) {
            conv = 1;
            break;
        } else if (prev > 0) {
            theta = nrm / prev;
            if (theta < 1 && theta / (1 - theta) * nrm <= tol) {
                conv = 1;
                break;
            }
            if (nrm <= rounding) {
                if (theta >= 1) {
                    conv = 1;   /* stagnation at rounding level */
                    break;
                }
            } else if (theta >= (DERIVE_REAL)DERIVE_THETA_DIVERGE) {
                return DERIVE_NEWTON;    /* diverges: the step is too large for the motion */
            } else if (theta >= 1) {
                bad = 2;
            } else if (theta > (DERIVE_REAL)DERIVE_THETA_MAX) {
                bad = 1;
            }
        }
        if (bad) {
            if (bad == 2) {
                if (grown) {
                    return DERIVE_NEWTON;    /* grows again after a re-evaluation */
                }
                grown = 1;
                for (i = 0; i < ns; ++i) {
                    for (k = 0; k < DERIVE_N; ++k) {
                        Z[i][k] = Zold[i][k];
                    }
                }
            }
            st = DERIVE_T(derive_gauss_stage_jac)(ns, DERIVE_WITH_T(c) DERIVE_WITH_T(t) DERIVE_WITH_T(h) x, Z, p, J, opt, info);
            if (st) {
                return st;
            }
            st = DERIVE_T(derive_gauss_factor)(ns, A, h, J, W, piv);
            if (st) {
                return st;
            }
            prev = 0;           /* restart: the rate is estimated anew */
            continue;
        }
        prev = nrm;
    }
    if (!conv) {
        return DERIVE_NEWTON;
    }
    for (k = 0; k < DERIVE_N; ++k) {
        tmp = 0;
        for (i = 0; i < ns; ++i) {
            tmp += d[i] * Z[i][k];
        }
        x_new[k] = x[k] + tmp;
    }
    return DERIVE_OK;
}

/* The implicit midpoint rule (1-stage Gauss-Legendre, order 2). */
static inline int DERIVE_T(derive_midpoint_step)(DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *restrict x, DERIVE_REAL h, const DERIVE_REAL *restrict p, DERIVE_REAL *restrict x_new, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    const DERIVE_REAL A[1] = DERIVE_T(DERIVE_MIDPOINT_A);
    const DERIVE_REAL c[1] = DERIVE_T(DERIVE_MIDPOINT_C);
    const DERIVE_REAL d[1] = DERIVE_T(DERIVE_MIDPOINT_D);
    return DERIVE_T(derive_gauss)(1, A, c, d, DERIVE_WITH_T(t) x, h, p, x_new, opt, info);
}

/* 2-stage Gauss-Legendre (order 4). */
static inline int DERIVE_T(derive_gauss2_step)(DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *restrict x, DERIVE_REAL h, const DERIVE_REAL *restrict p, DERIVE_REAL *restrict x_new, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    const DERIVE_REAL A[4] = DERIVE_T(DERIVE_GAUSS2_A);
    const DERIVE_REAL c[2] = DERIVE_T(DERIVE_GAUSS2_C);
    const DERIVE_REAL d[2] = DERIVE_T(DERIVE_GAUSS2_D);
    return DERIVE_T(derive_gauss)(2, A, c, d, DERIVE_WITH_T(t) x, h, p, x_new, opt, info);
}

/* -- the driver's view of a model: one chart, seven methods -- */
typedef struct DERIVE_T(derive_ctx) {
    const DERIVE_REAL *p;
    const DERIVE_OPTIONS *opt;
    DERIVE_INFO *info;
    int method;
    int canonical;      /* the implicit methods run on x = (q, p) */
    int nhist;          /* abm12: how many of hist are filled */
    DERIVE_REAL hist[DERIVE_ABM12_STEPS][DERIVE_N];    /* abm12: f at the last grid points, newest first */
} DERIVE_T(derive_ctx);

static int DERIVE_T(derive_ctx_eval)(DERIVE_T(derive_ctx) *c, DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *z, DERIVE_REAL *f)
{
    return DERIVE_EVAL(DERIVE_WITH_T(t) z, c->p, f, c->opt, c->info);
}

/* rk8: the 8th-order formula of DOP853 at a fixed step (its error estimate unused). */
static int DERIVE_T(derive_rk8_step)(DERIVE_T(derive_ctx) *c, DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *z, DERIVE_REAL h, DERIVE_REAL (*K)[DERIVE_N], DERIVE_REAL *zn)
{
    DERIVE_REAL unused;
    const int st = DERIVE_EVAL(DERIVE_WITH_T(t) z, c->p, K[0], c->opt, c->info);
    return st ? st : DERIVE_T(derive_dop853_step)(DERIVE_WITH_T(t) z, h, c->p, K, zn, &unused, c->opt, c->info);
}

/* abm12 on the grid: the 12-step Adams-Bashforth-Moulton pair in PECE mode (predict
 * with Adams-Bashforth, evaluate, correct with Adams-Moulton, evaluate; weights of
 * tableau.adams(12)), the first 11 steps with rk8 to fill the history.  Its stability
 * region is small: a step outside it grows the parasitic solutions, and the
 * predictor-corrector difference grows with them.  Milne's estimate of the local error,
 * DERIVE_ABM12_MILNE |y_c - y_p|_max (tableau.adams_milne), above atol + rtol |y|_max:
 * the step is not taken, MULTISTEP_UNSTABLE.  *err is that ratio. */
static int DERIVE_T(derive_abm12_step)(DERIVE_T(derive_ctx) *c, DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *z, DERIVE_REAL h, DERIVE_REAL (*K)[DERIVE_N], DERIVE_REAL *zn, DERIVE_REAL *err)
{
    const DERIVE_REAL ab[DERIVE_ABM12_STEPS] = DERIVE_T(DERIVE_ABM12_AB);
    const DERIVE_REAL am[DERIVE_ABM12_STEPS] = DERIVE_T(DERIVE_ABM12_AM);
    DERIVE_REAL yp[DERIVE_N], fp[DERIVE_N], diff = 0, size = 0, sum;
    int st, j, k;
    *err = 0;
    if (c->nhist == 0) {
        st = DERIVE_EVAL(DERIVE_WITH_T(t) z, c->p, c->hist[0], c->opt, c->info);
        if (st) {
            return st;
        }
        c->nhist = 1;
    }
    if (c->nhist < DERIVE_ABM12_STEPS) {
        st = DERIVE_T(derive_rk8_step)(c, DERIVE_WITH_T(t) z, h, K, zn);
    } else {
        for (k = 0; k < DERIVE_N; ++k) {
            sum = 0;
            for (j = DERIVE_ABM12_STEPS - 1; j >= 0; --j) {
                sum += ab[j] * c->hist[j][k];
            }
            yp[k] = z[k] + h * sum;
        }
        st = DERIVE_EVAL(DERIVE_WITH_T(t + h) yp, c->p, fp, c->opt, c->info);
        if (st) {
            return st;
        }
        for (k = 0; k < DERIVE_N; ++k) {
            sum = 0;
            for (j = DERIVE_ABM12_STEPS - 1; j >= 1; --j) {
                sum += am[j] * c->hist[j - 1][k];
            }
            zn[k] = z[k] + h * (sum + am[0] * fp[k]);
            if (!(DERIVE_MATH(fabs)(zn[k] - yp[k]) <= diff)) {
                diff = DERIVE_MATH(fabs)(zn[k] - yp[k]);
            }
            if (DERIVE_MATH(fabs)(z[k]) > size) {
                size = DERIVE_MATH(fabs)(z[k]);
            }
        }
        *err = DERIVE_T(DERIVE_ABM12_MILNE) * diff / ((DERIVE_REAL)c->opt->atol + (DERIVE_REAL)c->opt->rtol * size);
        if (!(*err <= 1)) {
            return DERIVE_MULTISTEP_UNSTABLE;
        }
    }
    if (st) {
        return st;
    }
    /* the history moves by one: f at the new grid point first */
    for (j = DERIVE_ABM12_STEPS - 1; j >= 1; --j) {
        for (k = 0; k < DERIVE_N; ++k) {
            c->hist[j][k] = c->hist[j - 1][k];
        }
    }
    st = DERIVE_EVAL(DERIVE_WITH_T(t + h) zn, c->p, c->hist[0], c->opt, c->info);
    if (c->nhist < DERIVE_ABM12_STEPS) {
        c->nhist += 1;
    }
    return st;
}

static int DERIVE_T(derive_ctx_step)(DERIVE_T(derive_ctx) *c, DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *z, DERIVE_REAL h, DERIVE_REAL (*K)[DERIVE_N], DERIVE_REAL *zn, DERIVE_REAL *err)
{
    int st;
    switch (c->method) {
    case DERIVE_METHOD_RK4:
        st = DERIVE_EVAL(DERIVE_WITH_T(t) z, c->p, K[0], c->opt, c->info);
        return st ? st : DERIVE_T(derive_rk4_step)(DERIVE_WITH_T(t) z, h, c->p, K, zn, err, c->opt, c->info);
    case DERIVE_METHOD_RK8:
        *err = 0;
        return DERIVE_T(derive_rk8_step)(c, DERIVE_WITH_T(t) z, h, K, zn);
    case DERIVE_METHOD_ABM12:
        return DERIVE_T(derive_abm12_step)(c, DERIVE_WITH_T(t) z, h, K, zn, err);
    case DERIVE_METHOD_DOPRI5:
        return DERIVE_T(derive_dopri5_step)(DERIVE_WITH_T(t) z, h, c->p, K, zn, err, c->opt, c->info);
    case DERIVE_METHOD_DOP853:
        return DERIVE_T(derive_dop853_step)(DERIVE_WITH_T(t) z, h, c->p, K, zn, err, c->opt, c->info);
    case DERIVE_METHOD_MIDPOINT:
        *err = 0;
        return DERIVE_T(derive_midpoint_step)(DERIVE_WITH_T(t) z, h, c->p, zn, c->opt, c->info);
    default:
        *err = 0;
        return DERIVE_T(derive_gauss2_step)(DERIVE_WITH_T(t) z, h, c->p, zn, c->opt, c->info);
    }
}

/* A shortened step to an output time off the grid: the method's own step, but rk8 for
 * abm12 (its history belongs to the grid, and a multistep formula needs equal steps). */
static int DERIVE_T(derive_ctx_partial_step)(DERIVE_T(derive_ctx) *c, DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *z, DERIVE_REAL h, DERIVE_REAL (*K)[DERIVE_N], DERIVE_REAL *zn)
{
    DERIVE_REAL err;
    if (c->method == DERIVE_METHOD_ABM12) {
        return DERIVE_T(derive_rk8_step)(c, DERIVE_WITH_T(t) z, h, K, zn);
    }
    return DERIVE_T(derive_ctx_step)(c, DERIVE_WITH_T(t) z, h, K, zn, &err);
}

static int DERIVE_T(derive_ctx_dense_prepare)(DERIVE_T(derive_ctx) *c, DERIVE_WITH_T(DERIVE_REAL t) const DERIVE_REAL *z, const DERIVE_REAL *zn, DERIVE_REAL h, DERIVE_REAL (*K)[DERIVE_N], DERIVE_REAL (*F)[DERIVE_N])
{
    if (c->method == DERIVE_METHOD_DOP853) {
        return DERIVE_T(derive_dop853_dense_prepare)(DERIVE_WITH_T(t) z, zn, h, c->p, K, F, c->opt, c->info);
    }
    return DERIVE_OK;
}

static void DERIVE_T(derive_ctx_dense)(DERIVE_T(derive_ctx) *c, const DERIVE_REAL *z, const DERIVE_REAL *zn, DERIVE_REAL h, DERIVE_REAL (*K)[DERIVE_N], DERIVE_REAL (*F)[DERIVE_N], DERIVE_REAL theta, DERIVE_REAL *out)
{
    (void)zn;
    if (c->method == DERIVE_METHOD_DOP853) {
        DERIVE_T(derive_dop853_dense)(z, F, theta, out);
    } else {
        DERIVE_T(derive_dopri5_dense)(z, h, K, theta, out);
    }
}

/* The state y -> the integration variable z: y itself, checked against the chart, or
 * for the implicit methods of a model with a Hamiltonian form x = (q, p). */
static int DERIVE_T(derive_ctx_in)(DERIVE_T(derive_ctx) *c, const DERIVE_REAL *y, DERIVE_REAL *z)
{
    int k;
#ifdef DERIVE_TO_CANONICAL
    if (c->canonical) {
        return DERIVE_TO_CANONICAL(y, c->p, z);
    }
#endif
    for (k = 0; k < DERIVE_N; ++k) {
        z[k] = y[k];
    }
#ifdef DERIVE_GUARD
    return DERIVE_GUARD(z, c->opt);
#else
    (void)c;
    return DERIVE_OK;
#endif
}

/* ... and back. */
static int DERIVE_T(derive_ctx_out)(DERIVE_T(derive_ctx) *c, const DERIVE_REAL *z, DERIVE_REAL *y)
{
    int k;
#ifdef DERIVE_FROM_CANONICAL
    if (c->canonical) {
        return DERIVE_FROM_CANONICAL(z, c->p, y);
    }
#endif
    (void)c;
    for (k = 0; k < DERIVE_N; ++k) {
        y[k] = z[k];
    }
    return DERIVE_OK;
}

static int DERIVE_T(derive_ctx_switch)(DERIVE_T(derive_ctx) *c, DERIVE_REAL *z, int force)
{
    (void)c;
    (void)z;
    (void)force;
    return 0;   /* one chart: never switches */
}

static void DERIVE_T(derive_ctx_set_y)(DERIVE_T(derive_ctx) *c, const DERIVE_REAL *z)
{
    DERIVE_REAL y[DERIVE_N];
    int k;
    if (DERIVE_T(derive_ctx_out)(c, z, y) != 0) {
        for (k = 0; k < DERIVE_N; ++k) {
            y[k] = z[k];
        }
    }
    for (k = 0; k < DERIVE_N; ++k) {
        c->info->y[k] = (long double)y[k];
    }
}

#define DERIVE_METHOD_LAST DERIVE_METHOD_ABM12
#define DERIVE_DRIVER_CTX DERIVE_T(derive_ctx)
#define DERIVE_DRIVER_EVAL DERIVE_T(derive_ctx_eval)
#define DERIVE_DRIVER_STEP DERIVE_T(derive_ctx_step)
#define DERIVE_DRIVER_PARTIAL_STEP DERIVE_T(derive_ctx_partial_step)
#define DERIVE_DRIVER_DENSE_PREPARE DERIVE_T(derive_ctx_dense_prepare)
#define DERIVE_DRIVER_DENSE DERIVE_T(derive_ctx_dense)
#define DERIVE_DRIVER_IN DERIVE_T(derive_ctx_in)
#define DERIVE_DRIVER_OUT DERIVE_T(derive_ctx_out)
#define DERIVE_DRIVER_SWITCH DERIVE_T(derive_ctx_switch)
#define DERIVE_DRIVER_SET_Y DERIVE_T(derive_ctx_set_y)
#include "derive_driver.h"
#undef DERIVE_METHOD_LAST

/* A whole run: y0 at t[0] to the output times t[0..nt-1] (see <model>_integrate.h). */
static int DERIVE_T(derive_integrate)(int method, const DERIVE_REAL *restrict y0, const DERIVE_REAL *restrict p, long nt, const DERIVE_REAL *restrict t, DERIVE_REAL *restrict y_out, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    DERIVE_OPTIONS defaults;
    DERIVE_INFO local;
    DERIVE_T(derive_ctx) c;
    long i;
    int k;
    if (!opt) {
        DERIVE_DEFAULTS(&defaults);
        opt = &defaults;
    }
    if (!info) {
        info = &local;
    }
    info->status = 0;
    info->nfev = info->njev = info->nsteps = info->naccepted = info->nrejected = info->nnewton = info->nout = 0;
    info->t = nt > 0 && t ? (double)t[0] : 0;
    info->h = info->h_end = info->local_error = 0;
    for (k = 0; k < DERIVE_N; ++k) {
        info->y[k] = y0 ? (long double)y0[k] : 0;
    }
    info->status = DERIVE_T(derive_check)(method, y0, DERIVE_N, p, DERIVE_N_P, nt, t, opt);
    if (info->status) {
        for (i = 0; i < nt * DERIVE_N; ++i) {
            y_out[i] = DERIVE_MATH(nan)("");
        }
        return info->status;
    }
    c.p = p;
    c.opt = opt;
    c.info = info;
    c.method = method;
#ifdef DERIVE_TO_CANONICAL
    c.canonical = method == DERIVE_METHOD_MIDPOINT || method == DERIVE_METHOD_GAUSS2;
#else
    c.canonical = 0;
#endif
    c.nhist = 0;
    return DERIVE_T(derive_drive)(&c, y0, nt, t, y_out);
}

/* n trajectories: y0 + i*y0_stride, p + i*p_stride (0 broadcasts), one shared t. */
static long DERIVE_T(derive_integrate_batch)(long n, int method, const DERIVE_REAL *restrict y0, long y0_stride, const DERIVE_REAL *restrict p, long p_stride, long nt, const DERIVE_REAL *restrict t, DERIVE_REAL *restrict y_out, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    long i, failed = 0;
    for (i = 0; i < n; ++i) {
        if (DERIVE_T(derive_integrate)(method, y0 + i * y0_stride, p + i * p_stride, nt, t, y_out + i * nt * DERIVE_N, opt, info ? info + i : 0) != 0) {
            failed += 1;
        }
    }
    return failed;
}

#undef DERIVE_REAL
#undef DERIVE_T
#undef DERIVE_MATH
#undef DERIVE_EPS
#undef DERIVE_EVAL
#undef DERIVE_SYS_EVAL
#undef DERIVE_SYS_JAC
#undef DERIVE_GUARD
#undef DERIVE_TO_CANONICAL
#undef DERIVE_FROM_CANONICAL
