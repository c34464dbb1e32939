/* Copied by derive 0.2.0 from codegen/backends/c/library/derive_taylor_lanes.h for every model; do not edit. */
/* derive_taylor_lanes.h: the run time of derive's Taylor integrator in SIMD lanes
 * (heyoka's batch mode), written once for every model and every native precision
 * (derive/codegen/backends/c/library/).  What a model's generated <model>_taylor_lanes.c
 * keeps is its jet (one recurrence call per elementary operation, for L lanes at once),
 * its constants and the public entry points.
 *
 * L trajectories at once, lane index innermost: a row is DIM coefficients of L lanes
 * (coefficient k of lane l at [k * L + l]), so every recurrence is a loop over the L lanes
 * the compiler turns into vector instructions (plain C loops: no intrinsics).  Each lane
 * is a trajectory of its own (its constants, step, time, output rows, counters); a lane
 * whose trajectory ends takes the batch's next one.  Every lane does the arithmetic of
 * derive_taylor.h, operation by operation and in the same order, so built without
 * floating-point contraction (-ffp-contract=off) each trajectory is bit for bit the scalar
 * integrator's.
 *
 * Here: the recurrences for L lanes (sum, difference, scaling and shift by a constant,
 * a constant less a node, product, square, quotient, square root, sin and cos together,
 * exp, the solution's coefficient from the rhs', the chart guard), the advance and dense
 * output by Horner, the step for a jet (Jorba & Zou 2005, as the scalar: every lane's
 * radius in one loop), the lanes' bookkeeping and the batch's body.  sin/cos and the
 * radius' root are derive_taylor_math.h's, the scalar integrator's: branch-free, so that
 * their loops over the lanes vectorise.
 *
 * Standalone C99, only <math.h>; reentrant: no globals, no allocation (the jet of the L
 * lanes is on the stack).  Included once per precision (double, float, long double), in
 * the one translation unit of the model's jet.
 *
 * Defined once per translation unit, before the first inclusion:
 *   DERIVE_N, DERIVE_N_P        the state size (a constant) and the length of p
 *   DERIVE_OPTIONS, DERIVE_INFO the model's options and info structs
 *   DERIVE_TAYLOR_INFO_CLEAR(info)  zeroes info's counters and scalars
 *   DERIVE_OK, DERIVE_STEP_UNDERFLOW, DERIVE_MAX_STEPS, DERIVE_NONFINITE,
 *   DERIVE_CHART_SINGULAR, DERIVE_BAD_INPUT, DERIVE_CANCELLED   the status codes
 *   DERIVE_TAYLOR_ORDER         the order fixed at compile time, 0: from the tolerance
 *   DERIVE_TAYLOR_ORDER_MIN, DERIVE_TAYLOR_ORDER_MAX   the orders of the tolerance rule
 *   DERIVE_TAYLOR_ORDER_FOR(tol)  the rule's unclamped order for a tolerance (a double;
 *                               rendered from the Python rule, derive/codegen/contract.py)
 *   DERIVE_TAYLOR_DIM           coefficients per row: the largest order + 1
 *   DERIVE_TAYLOR_UNROLL        a pragma before the recurrences' loops (or nothing)
 *   L                           the lanes (1 to 64)
 *   DERIVE_LANES_NCONST         the jet's constants per lane (at least 1)
 *   DERIVE_LANES_RESTRICT       restrict (C++: __restrict): the lane loops' rows are disjoint
 *   DERIVE_LANES_INLINE         how the recurrences are declared (static inline, forced
 *                               where the compiler can: each is then a few vector instructions)
 *   DERIVE_LANES_USES_ADD, _SUB, _SCALE, _SHIFT, _CSUB, _MUL, _SQUARE, _DIV, _SQRT, _SINCOS,
 *   _EXP, _OUT, _OUTC, _GUARD   1 where the jet uses that recurrence (the others are left out)
 *   DERIVE_TAYLOR_TIMED         (defined or not) a time-dependent model's: its jet takes each
 *                               lane's time at the step's start, jet(X, C, const R *t0,
 *                               order, sine_min, bad), and LANES_TIME(u, t0, k) is defined
 *
 * Defined before each inclusion (the including file undefines them after its jet):
 *   R                           the coefficients' type (double, float or long double)
 *   DERIVE_LANES_M(fn)          <math.h>'s function fn for R: fn, fn##f or fn##l
 *   DERIVE_LANES_T(x)           the precision's name tag (x##_d, x##_f, x##_l)
 *   DERIVE_LANES_JET            the model's jet, defined after the inclusion:
 *                               void jet(R (*X)[DIM * L], R (*C)[L], int order, R sine_min,
 *                               int *bad) fills X[i][(1..order) * L + l] from X[i][l] in every
 *                               lane (C: the lanes' constants), bad[l] = 1 where a guard fails
 *   DERIVE_LANES_CONSTANTS      the model's constants, defined after the inclusion:
 *                               void constants(R (*C)[L], int l, const R *p) fills C[c][l]
 *                               from lane l's parameters p
 *
 * It defines (static; T the tag) for the jet LANES_ADD(u, a, b), LANES_SUB, LANES_SCALE(u,
 * c, a), LANES_SHIFT(u, a, c, k), LANES_CSUB(u, c, a, k), LANES_MUL(u, a, b, k),
 * LANES_SQUARE(u, a, k), LANES_DIV(u, ak, b, k),
 * LANES_SQRT(u, ak, k), LANES_SINCOS(s, c, a, k), LANES_EXP(u, a, k), LANES_OUT(x, f, k),
 * LANES_OUTC(x, c, k), LANES_GUARD(bad, g, sine_min) and, timed, LANES_TIME(u, t0, k)
 * (undefined at the next inclusion),
 * and derive_taylor_lanes_batch_T (n, y0, y0_stride, p, p_stride, nt, t, y_out, opt, info).
 */

#include "derive_taylor_math.h"

#undef LANES_ADD
#undef LANES_SUB
#undef LANES_SCALE
#undef LANES_SHIFT
#undef LANES_CSUB
#undef LANES_SQUARE
#undef LANES_MUL
#undef LANES_DIV
#undef LANES_SQRT
#undef LANES_SINCOS
#undef LANES_EXP
#undef LANES_OUT
#undef LANES_OUTC
#undef LANES_GUARD
#undef LANES_TIME

#ifdef DERIVE_TAYLOR_TIMED
static void DERIVE_LANES_JET(R (*X)[DERIVE_TAYLOR_DIM * L], R (*C)[L], const R *t0, int order_wanted, R sine_min, int *bad);
#else
static void DERIVE_LANES_JET(R (*X)[DERIVE_TAYLOR_DIM * L], R (*C)[L], int order_wanted, R sine_min, int *bad);
#endif
static void DERIVE_LANES_CONSTANTS(R (*C)[L], int l, const R *p);

/* Each function below is derive_taylor.h's recurrence for every lane: the same operations
 * in the same order, so each lane's result is the scalar one.  A pointer to one order's
 * L lanes (a_k, u + k * L) is that order's coefficient. */
#if DERIVE_LANES_USES_ADD

DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_add)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT a, const R *DERIVE_LANES_RESTRICT b)
{
    int l;
    for (l = 0; l < L; ++l) {
        u[l] = a[l] + b[l];
    }
}
#endif
#if DERIVE_LANES_USES_SUB

DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_sub)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT a, const R *DERIVE_LANES_RESTRICT b)
{
    int l;
    for (l = 0; l < L; ++l) {
        u[l] = a[l] - b[l];
    }
}
#endif
#if DERIVE_LANES_USES_SCALE

/* u = c a, c the lane's constant */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_scale)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT c, const R *DERIVE_LANES_RESTRICT a)
{
    int l;
    for (l = 0; l < L; ++l) {
        u[l] = c[l] * a[l];
    }
}
#endif
#if DERIVE_LANES_USES_SHIFT

/* u = a + c at order 0, a above (a null: the constant alone) */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_shift)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT a, const R *DERIVE_LANES_RESTRICT c, int k)
{
    int l;
    for (l = 0; l < L; ++l) {
        u[l] = (a ? a[l] : (R)0) + (k == 0 ? c[l] : (R)0);
    }
}
#endif
#if DERIVE_LANES_USES_CSUB

/* u = c - a at order 0, -a above (c the lane's constant) */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_csub)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT c, const R *DERIVE_LANES_RESTRICT a, int k)
{
    int l;
    for (l = 0; l < L; ++l) {
        u[l] = k == 0 ? c[l] - a[l] : -a[l];
    }
}
#endif

/* The sums of products in derive_taylor.h's order: from the middle out (the terms of the
 * oldest coefficients first), each from -0. */
#if DERIVE_LANES_USES_MUL

/* coefficient k of a b: sum_{j=0..k} a_j b_{k-j}, the pairs (j, k - j) inward out */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_mul)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT a, const R *DERIVE_LANES_RESTRICT b, int k)
{
    R acc[L];
    int j, l;
    for (l = 0; l < L; ++l) {
        acc[l] = -(R)0;
    }
    if (k % 2 == 0) {
        for (l = 0; l < L; ++l) {
            acc[l] += a[k / 2 * L + l] * b[k / 2 * L + l];
        }
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 0; --j) {
        for (l = 0; l < L; ++l) {
            acc[l] += a[j * L + l] * b[(k - j) * L + l];
            acc[l] += a[(k - j) * L + l] * b[j * L + l];
        }
    }
    for (l = 0; l < L; ++l) {
        u[l] = acc[l];
    }
}
#endif
#if DERIVE_LANES_USES_SQUARE || DERIVE_LANES_USES_SQRT

/* sum_{j=1..k-1} a_j a_{k-j} (k >= 1) as 2 sum_{1<=j<k/2} a_j a_{k-j} (+ a_{k/2}^2, k even) */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_inner_square)(R *DERIVE_LANES_RESTRICT acc, const R *DERIVE_LANES_RESTRICT a, int k)
{
    int j, l;
    for (l = 0; l < L; ++l) {
        acc[l] = -(R)0;
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        for (l = 0; l < L; ++l) {
            acc[l] += a[j * L + l] * a[(k - j) * L + l];
        }
    }
    for (l = 0; l < L; ++l) {
        acc[l] += acc[l];
    }
    if (k % 2 == 0) {
        for (l = 0; l < L; ++l) {
            acc[l] += a[k / 2 * L + l] * a[k / 2 * L + l];
        }
    }
}
#endif
#if DERIVE_LANES_USES_SQUARE

/* coefficient k of a a: the inner products, then 2 a_0 a_k */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_square)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT a, int k)
{
    R acc[L];
    int l;
    if (k == 0) {
        for (l = 0; l < L; ++l) {
            u[l] = a[l] * a[l];
        }
        return;
    }
    DERIVE_LANES_T(derive_lanes_inner_square)(acc, a, k);
    for (l = 0; l < L; ++l) {
        u[l] = acc[l] + a[l] * (R)2 * a[k * L + l];
    }
}
#endif
#if DERIVE_LANES_USES_DIV

/* coefficient k of u = a / b, given a_k (ak null: u = 1 / b) and u_0..u_{k-1}:
 * (a_k - sum_{j=1..k} b_j u_{k-j}) / b_0, the pairs of 1 <= j < k inward out, then b_k u_0 */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_div)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT ak, const R *DERIVE_LANES_RESTRICT b, int k)
{
    R acc[L];
    int j, l;
    if (k == 0) {
        for (l = 0; l < L; ++l) {
            u[l] = (ak ? ak[l] : (R)1) / b[l];
        }
        return;
    }
    for (l = 0; l < L; ++l) {
        acc[l] = -(R)0;
    }
    if (k % 2 == 0) {
        for (l = 0; l < L; ++l) {
            acc[l] += b[k / 2 * L + l] * u[k / 2 * L + l];
        }
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        for (l = 0; l < L; ++l) {
            acc[l] += b[j * L + l] * u[(k - j) * L + l];
            acc[l] += b[(k - j) * L + l] * u[j * L + l];
        }
    }
    for (l = 0; l < L; ++l) {
        acc[l] += b[k * L + l] * u[l];
        u[k * L + l] = ((ak ? ak[l] : (R)0) - acc[l]) / b[l];
    }
}
#endif
#if DERIVE_LANES_USES_SQRT

/* coefficient k of u = sqrt(a), given a_k: (a_k - sum_{j=1..k-1} u_j u_{k-j}) / (2 u_0) */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_sqrt)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT ak, int k)
{
    R acc[L];
    int l;
    if (k == 0) {
        for (l = 0; l < L; ++l) {
            u[l] = DERIVE_LANES_M(sqrt)(ak[l]);
        }
        return;
    }
    DERIVE_LANES_T(derive_lanes_inner_square)(acc, u, k);
    for (l = 0; l < L; ++l) {
        u[k * L + l] = (ak[l] - acc[l]) / (u[l] * (R)2);
    }
}
#endif
#if DERIVE_LANES_USES_SINCOS || DERIVE_LANES_USES_EXP

/* acc = sum_{j=1..k} j a_j w_{k-j} (k >= 1), the pairs of 1 <= j < k inward out, then
 * k a_k w_0; with v (not null) also vacc = sum_{j=1..k} j a_j v_{k-j}, each j a_j once */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_chain)(R *DERIVE_LANES_RESTRICT acc, R *DERIVE_LANES_RESTRICT vacc, const R *DERIVE_LANES_RESTRICT a, const R *w, const R *v, int k)
{
    R ja;
    int j, l;
    for (l = 0; l < L; ++l) {
        acc[l] = -(R)0;
        vacc[l] = -(R)0;
    }
    if (k % 2 == 0) {
        for (l = 0; l < L; ++l) {
            ja = a[k / 2 * L + l] * (R)(k / 2);
            acc[l] += ja * w[k / 2 * L + l];
            vacc[l] += v ? ja * v[k / 2 * L + l] : (R)0;
        }
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        for (l = 0; l < L; ++l) {
            ja = a[j * L + l] * (R)j;
            acc[l] += ja * w[(k - j) * L + l];
            vacc[l] += v ? ja * v[(k - j) * L + l] : (R)0;
            ja = a[(k - j) * L + l] * (R)(k - j);
            acc[l] += ja * w[j * L + l];
            vacc[l] += v ? ja * v[j * L + l] : (R)0;
        }
    }
    for (l = 0; l < L; ++l) {
        ja = a[k * L + l] * (R)k;
        acc[l] += ja * w[l];
        vacc[l] += v ? ja * v[l] : (R)0;
    }
}
#endif
#if DERIVE_LANES_USES_SINCOS

/* coefficient k of s = sin a and c = cos a together; at order 0 derive_taylor_math.h's
 * function, the scalar integrator's (its polynomial in vector instructions, libm's sin
 * and cos past its range, lane by lane) */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_sincos)(R *DERIVE_LANES_RESTRICT s, R *DERIVE_LANES_RESTRICT c, const R *DERIVE_LANES_RESTRICT a, int k)
{
    R ssum[L], csum[L];
    int l;
    if (k == 0) {
        for (l = 0; l < L; ++l) {
            DERIVE_LANES_M(derive_sincos_reduced)(a[l], &s[l], &c[l]);
        }
        for (l = 0; l < L; ++l) {
            if (DERIVE_LANES_M(derive_sincos_outside)(a[l])) {
                s[l] = DERIVE_LANES_M(sin)(a[l]);
                c[l] = DERIVE_LANES_M(cos)(a[l]);
            }
        }
        return;
    }
    DERIVE_LANES_T(derive_lanes_chain)(ssum, csum, a, c, s, k);
    for (l = 0; l < L; ++l) {
        s[k * L + l] = ssum[l] / (R)k;
        c[k * L + l] = -(csum[l] / (R)k);
    }
}
#endif
#if DERIVE_LANES_USES_EXP

/* coefficient k of u = exp a */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_exp)(R *u, const R *DERIVE_LANES_RESTRICT a, int k)
{
    R acc[L], unused[L];
    int l;
    if (k == 0) {
        for (l = 0; l < L; ++l) {
            u[l] = DERIVE_LANES_M(exp)(a[l]);
        }
        return;
    }
    DERIVE_LANES_T(derive_lanes_chain)(acc, unused, a, u, 0, k);
    for (l = 0; l < L; ++l) {
        u[k * L + l] = acc[l] / (R)k;
    }
}
#endif
#if DERIVE_LANES_USES_OUT

/* x_{k+1} = f_k / (k + 1): the solution's coefficient from the rhs' */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_out)(R *DERIVE_LANES_RESTRICT x, const R *DERIVE_LANES_RESTRICT f, int k)
{
    int l;
    for (l = 0; l < L; ++l) {
        x[l] = f[l] / (R)(k + 1);
    }
}
#endif
#if DERIVE_LANES_USES_OUTC

/* the same for a constant rhs component */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_outc)(R *DERIVE_LANES_RESTRICT x, const R *DERIVE_LANES_RESTRICT c, int k)
{
    int l;
    for (l = 0; l < L; ++l) {
        x[l] = (k == 0 ? c[l] : (R)0) / (R)(k + 1);
    }
}
#endif
#if DERIVE_LANES_USES_GUARD

/* the chart guard: bad[l] where |g| < sine_min (the scalar jet's CHART_SINGULAR) */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_guard)(int *DERIVE_LANES_RESTRICT bad, const R *DERIVE_LANES_RESTRICT g, R sine_min)
{
    int l;
    for (l = 0; l < L; ++l) {
        if (!(DERIVE_LANES_M(fabs)(g[l]) >= sine_min)) {
            bad[l] = 1;
        }
    }
}
#endif

#define LANES_ADD DERIVE_LANES_T(derive_lanes_add)
#define LANES_SUB DERIVE_LANES_T(derive_lanes_sub)
#define LANES_SCALE DERIVE_LANES_T(derive_lanes_scale)
#define LANES_SHIFT DERIVE_LANES_T(derive_lanes_shift)
#define LANES_CSUB DERIVE_LANES_T(derive_lanes_csub)
#define LANES_SQUARE DERIVE_LANES_T(derive_lanes_square)
#define LANES_MUL DERIVE_LANES_T(derive_lanes_mul)
#define LANES_DIV DERIVE_LANES_T(derive_lanes_div)
#define LANES_SQRT DERIVE_LANES_T(derive_lanes_sqrt)
#define LANES_SINCOS DERIVE_LANES_T(derive_lanes_sincos)
#define LANES_EXP DERIVE_LANES_T(derive_lanes_exp)
#define LANES_OUT DERIVE_LANES_T(derive_lanes_out)
#define LANES_OUTC DERIVE_LANES_T(derive_lanes_outc)
#define LANES_GUARD DERIVE_LANES_T(derive_lanes_guard)
#ifdef DERIVE_TAYLOR_TIMED

/* coefficient k of u = t over a step from t0: t0, 1, 0, ... (each lane its own t0) */
DERIVE_LANES_INLINE void DERIVE_LANES_T(derive_lanes_time)(R *DERIVE_LANES_RESTRICT u, const R *DERIVE_LANES_RESTRICT t0, int k)
{
    int l;
    for (l = 0; l < L; ++l) {
        u[l] = k == 0 ? t0[l] : (R)(k == 1);
    }
}
#define LANES_TIME DERIVE_LANES_T(derive_lanes_time)
#endif

/* X[i][0] = the series at tau[l] in every lane (tau 0: unchanged), by Horner as the
 * scalar integrator advances; the states side by side (independent chains of
 * multiply-adds, where one state after another would wait on each) */
static void DERIVE_LANES_T(derive_lanes_advance)(R (*X)[DERIVE_TAYLOR_DIM * L], const R *tau, int order)
{
    R acc[DERIVE_N][L];
    int i, k, l;
    for (i = 0; i < DERIVE_N; ++i) {
        for (l = 0; l < L; ++l) {
            acc[i][l] = X[i][order * L + l];
        }
    }
    for (k = order - 1; k >= 0; --k) {
        for (i = 0; i < DERIVE_N; ++i) {
            for (l = 0; l < L; ++l) {
                acc[i][l] = acc[i][l] * tau[l] + X[i][k * L + l];
            }
        }
    }
    for (i = 0; i < DERIVE_N; ++i) {
        for (l = 0; l < L; ++l) {
            X[i][l] = acc[i][l];
        }
    }
}

/* lane l's series of state i at tau (dense output) */
static R DERIVE_LANES_T(derive_lanes_horner)(const R *x, int order, R tau, int l)
{
    R acc = x[order * L + l];
    int k;
    for (k = order - 1; k >= 0; --k) {
        acc = acc * tau + x[k * L + l];
    }
    return acc;
}

/* 1 if every z[k] is finite: z - z is 0 for a number, NaN for an infinity or a NaN */
static int DERIVE_LANES_T(derive_lanes_finite)(const R *z, long n)
{
    R check = 0;
    long k;
    for (k = 0; k < n; ++k) {
        check += z[k] - z[k];
    }
    return !isnan(check);
}

/* One lane's trajectory. */
typedef struct {
    long traj;                  /* its index in the batch; -1: the lane is idle */
    long iout, steps;
    R t, tend, dir, hmax, h;
    R rho, n2;                  /* this step's radius and largest last coefficient */
    int last;                   /* this step ends at tend */
    R *y;                       /* its output rows */
    DERIVE_INFO *info, local;
} DERIVE_LANES_T(derive_lane);

/* A batch call: its arguments, the jet of every lane and the lanes. */
typedef struct {
    long n, nt, y0_stride, p_stride, next, failed;
    const R *y0, *p, *t;
    R *y_out;
    const DERIVE_OPTIONS *opt;
    DERIVE_INFO *info;
    int order, shared_ok;       /* shared_ok: t and the options are valid */
    R safety;
    R X[DERIVE_N][DERIVE_TAYLOR_DIM * L];
    R C[DERIVE_LANES_NCONST][L];
    R tau[L];
    R rho[L], n1[L], n2[L];     /* each lane's radius and norms of its last two orders */
#ifdef DERIVE_TAYLOR_TIMED
    R t0[L];                    /* each lane's time at the step's start (the jet's t) */
#endif
    int bad[L];
    DERIVE_LANES_T(derive_lane) lane[L];
} DERIVE_LANES_T(derive_lanes_run);

/* Lane l's trajectory ends with status st (rows not reached are NaN, as the scalar). */
static void DERIVE_LANES_T(derive_lanes_finish)(DERIVE_LANES_T(derive_lanes_run) *r, int l, int st)
{
    DERIVE_LANES_T(derive_lane) *ln = &r->lane[l];
    long row;
    int i;
    ln->info->nsteps = ln->steps;
    ln->info->status = st;
    if (st) {
        for (row = ln->info->nout > 0 ? ln->info->nout : 0; row < r->nt; ++row) {
            for (i = 0; i < DERIVE_N; ++i) {
                ln->y[row * DERIVE_N + i] = DERIVE_LANES_M(nan)("");
            }
        }
        r->failed += 1;
    }
    ln->traj = -1;
}

/* The scalar loop's test before a step: -1 to take it, else the final status. */
static int DERIVE_LANES_T(derive_lanes_next)(const DERIVE_LANES_T(derive_lanes_run) *r, int l)
{
    const DERIVE_LANES_T(derive_lane) *ln = &r->lane[l];
    if (ln->iout >= r->nt) {
        return DERIVE_OK;
    }
    if (ln->steps >= r->opt->max_steps) {
        return DERIVE_MAX_STEPS;
    }
    if (r->opt->cancel && *r->opt->cancel) {
        return DERIVE_CANCELLED;
    }
    return -1;
}

/* Start the batch's next trajectory in lane l, as derive_taylor.h's run starts: 1 if it
 * runs, 0 if it ended at once (bad input, a single output time). */
static int DERIVE_LANES_T(derive_lanes_start)(DERIVE_LANES_T(derive_lanes_run) *r, int l)
{
    DERIVE_LANES_T(derive_lane) *ln = &r->lane[l];
    const long traj = r->next++;
    const R *y0 = r->y0 + traj * r->y0_stride;
    const R *p = r->p + traj * r->p_stride;
    DERIVE_INFO *info = r->info ? r->info + traj : &ln->local;
    R span;
    int i, st;
    ln->traj = traj;
    ln->info = info;
    ln->y = r->y_out + traj * r->nt * DERIVE_N;
    ln->iout = 1;
    ln->steps = 0;
    DERIVE_TAYLOR_INFO_CLEAR(info);
    info->t = r->nt > 0 ? (double)r->t[0] : 0;
    for (i = 0; i < DERIVE_N; ++i) {
        info->y[i] = r->nt > 0 ? (long double)y0[i] : 0;
    }
    if (!r->shared_ok || !DERIVE_LANES_T(derive_lanes_finite)(y0, DERIVE_N) || !DERIVE_LANES_T(derive_lanes_finite)(p, DERIVE_N_P)) {
        DERIVE_LANES_T(derive_lanes_finish)(r, l, DERIVE_BAD_INPUT);
        return 0;
    }
    for (i = 0; i < DERIVE_N; ++i) {
        r->X[i][l] = y0[i];
        ln->y[i] = y0[i];
    }
    info->nout = 1;
    ln->t = r->t[0];
    if (r->nt == 1) {
        DERIVE_LANES_T(derive_lanes_finish)(r, l, DERIVE_OK);
        return 0;
    }
    ln->tend = r->t[r->nt - 1];
    ln->dir = ln->tend - ln->t > 0 ? 1 : -1;
    span = (ln->tend - ln->t) * ln->dir;
    if (!(span > 0)) {
        DERIVE_LANES_T(derive_lanes_finish)(r, l, DERIVE_BAD_INPUT);
        return 0;
    }
    ln->hmax = r->opt->hmax > 0 ? (R)r->opt->hmax : span;
    DERIVE_LANES_CONSTANTS(r->C, l, p);
    st = DERIVE_LANES_T(derive_lanes_next)(r, l);
    if (st >= 0) {
        DERIVE_LANES_T(derive_lanes_finish)(r, l, st);
        return 0;
    }
    return 1;
}

/* x^n (n >= 1) by squaring, as derive_taylor.h's derive_taylor_powi */
static R DERIVE_LANES_T(derive_lanes_powi)(R x, int n)
{
    R result = 1, square = x;
    for (;;) {
        if (n & 1) {
            result *= square;
        }
        n >>= 1;
        if (!n) {
            return result;
        }
        square *= square;
    }
}

/* Every lane's series' radius after the jet, as the scalar computes it: the norms m =
 * max(1, |y|), n1 = |y^[p-1]|, n2 = |y^[p]| (max over the states), rho the smaller of
 * (m/n1)^(1/(p-1)) and (m/n2)^(1/p) (-1: no growth in the last coefficients), the roots
 * derive_taylor_math.h's in one loop over the lanes (vector instructions), libm's pow past
 * its range lane by lane.  An idle lane's numbers are a running lane's copy. */
static void DERIVE_LANES_T(derive_lanes_radius)(DERIVE_LANES_T(derive_lanes_run) *r)
{
    const int order = r->order;
    const R y1 = (R)1 / (R)(order - 1), y2 = (R)1 / (R)order;
    R m[L], x1[L], x2[L], q1[L], q2[L], a;
    int i, l;
    for (l = 0; l < L; ++l) {
        m[l] = 1;
        r->n1[l] = 0;
        r->n2[l] = 0;
    }
    for (i = 0; i < DERIVE_N; ++i) {
        for (l = 0; l < L; ++l) {
            a = DERIVE_LANES_M(fabs)(r->X[i][l]);
            m[l] = a > m[l] ? a : m[l];
            a = DERIVE_LANES_M(fabs)(r->X[i][(order - 1) * L + l]);
            r->n1[l] = a > r->n1[l] ? a : r->n1[l];
            a = DERIVE_LANES_M(fabs)(r->X[i][order * L + l]);
            r->n2[l] = a > r->n2[l] ? a : r->n2[l];
        }
    }
    for (l = 0; l < L; ++l) {
        x1[l] = r->n1[l] > 0 ? m[l] / r->n1[l] : (R)1;
        x2[l] = r->n2[l] > 0 ? m[l] / r->n2[l] : (R)1;
        q1[l] = DERIVE_LANES_M(derive_root_reduced)(x1[l], y1);
        q2[l] = DERIVE_LANES_M(derive_root_reduced)(x2[l], y2);
    }
    for (l = 0; l < L; ++l) {
        if (DERIVE_LANES_M(derive_root_outside)(x1[l])) {
            q1[l] = DERIVE_LANES_M(pow)(x1[l], y1);
        }
        if (DERIVE_LANES_M(derive_root_outside)(x2[l])) {
            q2[l] = DERIVE_LANES_M(pow)(x2[l], y2);
        }
    }
    for (l = 0; l < L; ++l) {
        r->rho[l] = r->n1[l] > 0 ? q1[l] : (R)-1;
        r->rho[l] = r->n2[l] > 0 && (r->rho[l] < 0 || q2[l] < r->rho[l]) ? q2[l] : r->rho[l];
    }
}

/* Lane l after the jet: its step (Jorba & Zou, as the scalar) and the output times inside
 * it; r->tau[l] the step.  Returns a status (OK: advance). */
static int DERIVE_LANES_T(derive_lanes_step)(DERIVE_LANES_T(derive_lanes_run) *r, int l)
{
    DERIVE_LANES_T(derive_lane) *ln = &r->lane[l];
    const int order = r->order;
    R rho = r->rho[l], h, tau;
    long row;
    int i;
    ln->info->nfev += 1;
    if (r->bad[l]) {
        return DERIVE_CHART_SINGULAR;
    }
    if (!DERIVE_LANES_T(derive_lanes_finite)(&r->n1[l], 1) || !DERIVE_LANES_T(derive_lanes_finite)(&r->n2[l], 1)) {
        return DERIVE_NONFINITE;
    }
    /* the step rho times the safety factor, capped by hmax (never the cap shrunk), the
     * last one exactly to tend */
    h = rho > 0 ? rho * r->safety : ln->hmax;
    if (!(h <= ln->hmax)) {
        h = ln->hmax;
    }
    if (!(h > 0)) {
        return DERIVE_STEP_UNDERFLOW;
    }
    ln->last = h >= (ln->tend - ln->t) * ln->dir;
    if (ln->last) {
        h = (ln->tend - ln->t) * ln->dir;
    }
    while (ln->iout < r->nt && (ln->last || (r->t[ln->iout] - ln->t) * ln->dir <= h)) {
        tau = r->t[ln->iout] - ln->t;
        row = ln->iout * DERIVE_N;
        for (i = 0; i < DERIVE_N; ++i) {
            ln->y[row + i] = DERIVE_LANES_T(derive_lanes_horner)(r->X[i], order, tau, l);
        }
        if (!DERIVE_LANES_T(derive_lanes_finite)(ln->y + row, DERIVE_N)) {
            return DERIVE_NONFINITE;
        }
        ln->iout += 1;
        ln->info->nout = ln->iout;
    }
    ln->h = h;
    ln->rho = rho;
    ln->n2 = r->n2[l];
    r->tau[l] = h * ln->dir;
    return DERIVE_OK;
}

/* Lane l after the advance: its time and counters; -1 to go on, else the final status. */
static int DERIVE_LANES_T(derive_lanes_advanced)(DERIVE_LANES_T(derive_lanes_run) *r, int l)
{
    DERIVE_LANES_T(derive_lane) *ln = &r->lane[l];
    int i;
    /* the truncation error, as the scalar estimates it: the first term left out,
     * |x_p| h^p (h / rho) */
    ln->info->local_error += ln->rho > 0 ? (double)(ln->n2 * DERIVE_LANES_T(derive_lanes_powi)(ln->h, r->order) * (ln->h / ln->rho)) : 0;
    ln->t = ln->last ? ln->tend : ln->t + ln->h * ln->dir;
    ln->steps += 1;
    ln->info->naccepted += 1;
    ln->info->t = (double)ln->t;
    ln->info->h = (double)(ln->h * ln->dir);
    for (i = 0; i < DERIVE_N; ++i) {
        ln->info->y[i] = (long double)r->X[i][l];
    }
    if (!DERIVE_LANES_T(derive_lanes_finite)(&r->X[0][l], 1)) {
        return DERIVE_NONFINITE;
    }
    return DERIVE_LANES_T(derive_lanes_next)(r, l);
}

/* An idle lane computes a copy of a running one (never read), so that its arithmetic
 * stays on ordinary numbers. */
static void DERIVE_LANES_T(derive_lanes_idle)(DERIVE_LANES_T(derive_lanes_run) *r)
{
    int l, from = 0, i;
    while (from < L && r->lane[from].traj < 0) {
        from += 1;
    }
    for (l = 0; l < L && from < L; ++l) {
        if (r->lane[l].traj >= 0) {
            continue;
        }
        for (i = 0; i < DERIVE_N; ++i) {
            r->X[i][l] = r->X[i][from];
        }
        for (i = 0; i < DERIVE_LANES_NCONST; ++i) {
            r->C[i][l] = r->C[i][from];
        }
    }
}

/* Fill lane l with the batch's next trajectory that runs (those that end at once are
 * done here); 1 if the lane runs one. */
static int DERIVE_LANES_T(derive_lanes_fill)(DERIVE_LANES_T(derive_lanes_run) *r, int l)
{
    while (r->next < r->n) {
        if (DERIVE_LANES_T(derive_lanes_start)(r, l)) {
            return 1;
        }
    }
    return 0;
}

static long DERIVE_LANES_T(derive_taylor_lanes_batch)(long n, const R *y0, long y0_stride, const R *p, long p_stride, long nt, const R *t, R *y_out, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    DERIVE_LANES_T(derive_lanes_run) run;
    DERIVE_LANES_T(derive_lanes_run) *r = &run;
    const R tol = (R)opt->rtol;
    const R sine_min = (R)opt->sine_min;
    double order_guess;
    long j;
    int l, st, live = 0;
    r->n = n;
    r->nt = nt;
    r->y0 = y0;
    r->y0_stride = y0_stride;
    r->p = p;
    r->p_stride = p_stride;
    r->t = t;
    r->y_out = y_out;
    r->opt = opt;
    r->info = info;
    r->next = 0;
    r->failed = 0;
    r->shared_ok = nt >= 1 && DERIVE_LANES_T(derive_lanes_finite)(t, nt) && tol > 0 && opt->hmax >= 0 && opt->max_steps >= 1;
    for (j = 2; j < nt; ++j) {
        if (!((t[j] - t[j - 1]) * (t[1] - t[0]) > 0)) {
            r->shared_ok = 0;
        }
    }
    /* the order for the tolerance, clamped to [ORDER_MIN, ORDER_MAX], as the scalar */
    order_guess = DERIVE_TAYLOR_ORDER_FOR((double)tol);
    r->order = DERIVE_TAYLOR_ORDER ? DERIVE_TAYLOR_ORDER
             : !(order_guess >= DERIVE_TAYLOR_ORDER_MIN) ? DERIVE_TAYLOR_ORDER_MIN
             : order_guess > DERIVE_TAYLOR_ORDER_MAX ? DERIVE_TAYLOR_ORDER_MAX : (int)order_guess;
    /* Jorba & Zou's step factor: e^-2 exp(-0.7/(p-1)) */
    r->safety = DERIVE_LANES_M(exp)((R)-2 - (R)0.7 / (R)(r->order - 1));
    for (l = 0; l < L; ++l) {
        r->lane[l].traj = -1;
        r->tau[l] = 0;
        live += DERIVE_LANES_T(derive_lanes_fill)(r, l);
    }
    while (live > 0) {
        if (live < L) {
            DERIVE_LANES_T(derive_lanes_idle)(r);
        }
        for (l = 0; l < L; ++l) {
            r->bad[l] = 0;
        }
#ifdef DERIVE_TAYLOR_TIMED
        for (l = 0; l < L; ++l) {      /* an idle lane's (never read): 0 */
            r->t0[l] = r->lane[l].traj >= 0 ? r->lane[l].t : 0;
        }
        DERIVE_LANES_JET(r->X, r->C, r->t0, r->order, sine_min, r->bad);
#else
        DERIVE_LANES_JET(r->X, r->C, r->order, sine_min, r->bad);
#endif
        DERIVE_LANES_T(derive_lanes_radius)(r);
        for (l = 0; l < L; ++l) {
            r->tau[l] = 0;
            if (r->lane[l].traj >= 0) {
                st = DERIVE_LANES_T(derive_lanes_step)(r, l);
                if (st) {
                    DERIVE_LANES_T(derive_lanes_finish)(r, l, st);
                }
            }
        }
        DERIVE_LANES_T(derive_lanes_advance)(r->X, r->tau, r->order);
        live = 0;
        for (l = 0; l < L; ++l) {
            if (r->lane[l].traj >= 0) {
                st = DERIVE_LANES_T(derive_lanes_advanced)(r, l);
                if (st >= 0) {
                    DERIVE_LANES_T(derive_lanes_finish)(r, l, st);
                }
            }
            if (r->lane[l].traj >= 0 || DERIVE_LANES_T(derive_lanes_fill)(r, l)) {
                live += 1;
            }
        }
    }
    return r->failed;
}
