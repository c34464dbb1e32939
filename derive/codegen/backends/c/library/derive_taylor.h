/* derive_taylor.h: the run time of derive's Taylor integrator, written once for every
 * model and every precision (derive/codegen/backends/c/library/).  What a model's
 * generated <model>_taylor.c keeps is its jet: the decomposition of its rhs into
 * elementary operations, one recurrence call each, order by order.
 *
 * Here: the coefficient recurrences of the operations (product, square, quotient, square
 * root, and the chain rule of sin and cos together and of exp), the series by Horner, the
 * order for a tolerance and the step for a jet (Jorba & Zou 2005, as heyoka), dense output
 * at the output times inside a step, the status of a run, and the entry points' bodies.
 * The functions of numbers the lanes share (sin/cos, the radius' root) are
 * derive_taylor_math.h's, included here.
 *
 * Standalone C99, only <math.h> (and what the precision's arithmetic needs: derive_dd.h,
 * <quadmath.h>); reentrant: no globals, no allocation.  Included once per precision, in
 * the one translation unit of the model's jet, so the jet is a direct call of a static
 * function the compiler sees (and may inline), as in a file written for the model.
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
 *   DERIVE_TAYLOR_INLINE_MAX    the largest fixed order at which the recurrences are inlined
 *                               (codegen/taylor.py INLINE_BUDGET; 0 or undefined: none)
 *   DERIVE_TAYLOR_USES_MUL, _SQUARE, _DIV, _SQRT, _SINCOS, _EXP   1 where the jet uses that
 *                               recurrence (the others are left out: functions never called)
 *   DERIVE_TAYLOR_TIMED         (defined or not) a time-dependent model's: its jet takes
 *                               the time at the step's start, jet(X, p, R t0, order,
 *                               sine_min) (t is a variable of the jet: t0, 1, 0, ...),
 *                               and derive_taylor_coefficients_T takes a pointer to it first
 *
 * Defined before each inclusion (the including file undefines them after its jet):
 *   R, S                        the coefficients' type and the native type the step-size
 *                               control runs in (R itself, double for double-double)
 *   T_ADD(a, b), T_SUB, T_MUL, T_DIV, T_NEG, T_MULI(a, i), T_DIVI(a, i) (by an int),
 *   T_INT(i), T_D(x) (an int, a double as R), T_SQRT, T_SIN, T_COS, T_EXP   R's arithmetic
 *   T_SINCOS(a, s, c)           s = sin a, c = cos a (derive_taylor_math.h's where it has R)
 *   T_S(a), T_ABS(a), T_FROMS(s), T_LE(a, b)   a in S, |a| in S, s as R, a <= b
 *   T_SEXP(x), T_SROOT(x, y)    exp and x^y in S (the root: derive_taylor_math.h's where it
 *                               has S); T_SNAN(x) whether x in S is a NaN; T_NAN a NaN of R
 *   T_INLINE_ALL                (defined or not) inline the recurrences at any fixed order
 *   DERIVE_TAYLOR_T(x)          the precision's name tag (x##_d, x##_dd, ...)
 *   DERIVE_TAYLOR_JET           the model's jet, defined after the inclusion:
 *                               int jet(R (*X)[DIM], const R *p, int order, S sine_min)
 *                               fills X[i][1..order] from X[i][0]; OK or a status
 *   DERIVE_TAYLOR_DOUBLE_DOUBLE (defined or not) the sums of products as Dot2 (derive_dd.h)
 *
 * It defines (static; T the tag) TAYLOR_MUL, TAYLOR_SQUARE, TAYLOR_DIV, TAYLOR_SQRT,
 * TAYLOR_SINCOS and TAYLOR_EXP for the jet (undefined at the next inclusion), and
 *   derive_taylor_coefficients_T (y, p, order, coef, sine_min); timed: (t, y, p, ...)
 *   derive_taylor_T (y0, p, nt, t_out, y_out, opt, info): a whole run
 *   derive_taylor_batch_T (n, y0, y0_stride, p, p_stride, nt, t, y_out, opt, info)
 */

#include "derive_taylor_math.h"

#undef TAYLOR_MUL
#undef TAYLOR_SQUARE
#undef TAYLOR_DIV
#undef TAYLOR_SQRT
#undef TAYLOR_SINCOS
#undef TAYLOR_EXP

#undef DERIVE_TAYLOR_JET_AT
#ifdef DERIVE_TAYLOR_TIMED
static int DERIVE_TAYLOR_JET(R (*X)[DERIVE_TAYLOR_DIM], const R *p, R t0, int order_wanted, S sine_min);
#define DERIVE_TAYLOR_JET_AT(X, p, t0, order, sine_min) DERIVE_TAYLOR_JET(X, p, t0, order, sine_min)
#else
static int DERIVE_TAYLOR_JET(R (*X)[DERIVE_TAYLOR_DIM], const R *p, int order_wanted, S sine_min);
/* an autonomous jet: the time of the step is not its argument */
#define DERIVE_TAYLOR_JET_AT(X, p, t0, order, sine_min) DERIVE_TAYLOR_JET(X, p, order, sine_min)
#endif

/* Every sum of products below runs from the middle out: the terms of the oldest
 * coefficients first, those of the coefficient being computed (order k of an argument)
 * last.  The partial sum of the older terms then waits on nothing of this order, so a
 * recurrence adds one or two operations to the jet's critical path, not k (a sum from
 * j = 0 up would start with a_0 b_k and wait on b_k).  The sums start at -0: x + -0 is x
 * for every x, which the compiler drops where the order is fixed. */
#define DERIVE_TAYLOR_ZERO T_NEG(T_INT(0))

/* With the order fixed and at most DERIVE_TAYLOR_INLINE_MAX (the unrolled jet within the
 * instruction cache: codegen/taylor.py INLINE_BUDGET), each recurrence is inlined where the
 * jet calls it, its k known: its loops unroll into straight arithmetic (forced, where the
 * compiler can: GCC leaves the longer ones as calls otherwise).  Double-double's stay
 * calls: unrolled, their every operation a dozen, they would outgrow the cache.  With
 * T_INLINE_ALL (long double: x87 arithmetic, bound by its operations, not their fetching)
 * at every fixed order. */
#ifndef DERIVE_TAYLOR_INLINE_MAX
#define DERIVE_TAYLOR_INLINE_MAX 0
#endif
#undef DERIVE_TAYLOR_INLINE
#if DERIVE_TAYLOR_ORDER && (DERIVE_TAYLOR_ORDER <= DERIVE_TAYLOR_INLINE_MAX || defined(T_INLINE_ALL)) && \
    defined(__GNUC__) && !defined(DERIVE_TAYLOR_DOUBLE_DOUBLE)
#define DERIVE_TAYLOR_INLINE static inline __attribute__((always_inline))
#else
#define DERIVE_TAYLOR_INLINE static
#endif

#if DERIVE_TAYLOR_USES_MUL
/* coefficient k of a b: sum_{j=0..k} a_j b_{k-j}, the pairs (j, k - j) inward out */
DERIVE_TAYLOR_INLINE R DERIVE_TAYLOR_T(derive_taylor_mul)(const R *a, const R *b, int k)
{
    int j;
#ifdef DERIVE_TAYLOR_DOUBLE_DOUBLE
    double s_ = 0, c_ = 0;
    if (k % 2 == 0) {
        DD_DOT_STEP(a[k / 2], b[k / 2]);
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 0; --j) {
        DD_DOT_STEP(a[j], b[k - j]);
        DD_DOT_STEP(a[k - j], b[j]);
    }
    return dd_quick(s_, c_);
#else
    R acc = DERIVE_TAYLOR_ZERO;
    if (k % 2 == 0) {
        acc = T_ADD(acc, T_MUL(a[k / 2], b[k / 2]));
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 0; --j) {
        acc = T_ADD(acc, T_MUL(a[j], b[k - j]));
        acc = T_ADD(acc, T_MUL(a[k - j], b[j]));
    }
    return acc;
#endif
}
#endif

#if DERIVE_TAYLOR_USES_SQUARE || DERIVE_TAYLOR_USES_SQRT
/* sum_{j=1..k-1} a_j a_{k-j} (k >= 1) as 2 sum_{1<=j<k/2} a_j a_{k-j} (+ a_{k/2}^2, k
 * even): the products strictly inside, with half a product's multiplications */
DERIVE_TAYLOR_INLINE R DERIVE_TAYLOR_T(derive_taylor_inner_square)(const R *a, int k)
{
    int j;
#ifdef DERIVE_TAYLOR_DOUBLE_DOUBLE
    double s_ = 0, c_ = 0;
    R twice;
    if (k % 2 == 0) {
        DD_DOT_STEP(a[k / 2], a[k / 2]);
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        twice = T_MULI(a[j], 2);
        DD_DOT_STEP(twice, a[k - j]);
    }
    return dd_quick(s_, c_);
#else
    R acc = DERIVE_TAYLOR_ZERO;
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        acc = T_ADD(acc, T_MUL(a[j], a[k - j]));
    }
    acc = T_ADD(acc, acc);
    if (k % 2 == 0) {
        acc = T_ADD(acc, T_MUL(a[k / 2], a[k / 2]));
    }
    return acc;
#endif
}
#endif

#if DERIVE_TAYLOR_USES_SQUARE
/* coefficient k of a a: the inner products, then 2 a_0 a_k */
DERIVE_TAYLOR_INLINE R DERIVE_TAYLOR_T(derive_taylor_square)(const R *a, int k)
{
    if (k == 0) {
        return T_MUL(a[0], a[0]);
    }
    return T_ADD(DERIVE_TAYLOR_T(derive_taylor_inner_square)(a, k), T_MUL(T_MULI(a[0], 2), a[k]));
}
#endif

#if DERIVE_TAYLOR_USES_DIV
/* coefficient k of u = a / b, given a_k and u_0..u_{k-1}: (a_k - sum_{j=1..k} b_j u_{k-j}) / b_0,
 * the pairs (j, k - j) of 1 <= j < k inward out, then b_k u_0 */
DERIVE_TAYLOR_INLINE R DERIVE_TAYLOR_T(derive_taylor_div)(R ak, const R *b, const R *u, int k)
{
    int j;
#ifdef DERIVE_TAYLOR_DOUBLE_DOUBLE
    double s_ = 0, c_ = 0;
    if (k == 0) {
        return T_DIV(ak, b[0]);
    }
    if (k % 2 == 0) {
        DD_DOT_STEP(b[k / 2], u[k / 2]);
    }
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        DD_DOT_STEP(b[j], u[k - j]);
        DD_DOT_STEP(b[k - j], u[j]);
    }
    DD_DOT_STEP(b[k], u[0]);
    return T_DIV(T_SUB(ak, dd_quick(s_, c_)), b[0]);
#else
    R acc = DERIVE_TAYLOR_ZERO;
    if (k == 0) {
        return T_DIV(ak, b[0]);
    }
    if (k % 2 == 0) {
        acc = T_ADD(acc, T_MUL(b[k / 2], u[k / 2]));
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        acc = T_ADD(acc, T_MUL(b[j], u[k - j]));
        acc = T_ADD(acc, T_MUL(b[k - j], u[j]));
    }
    acc = T_ADD(acc, T_MUL(b[k], u[0]));
    return T_DIV(T_SUB(ak, acc), b[0]);
#endif
}
#endif

#if DERIVE_TAYLOR_USES_SQRT
/* coefficient k of u = sqrt(a): (a_k - sum_{j=1..k-1} u_j u_{k-j}) / (2 u_0) */
DERIVE_TAYLOR_INLINE R DERIVE_TAYLOR_T(derive_taylor_sqrt)(const R *a, const R *u, int k)
{
    if (k == 0) {
        return T_SQRT(a[0]);
    }
    return T_DIV(T_SUB(a[k], DERIVE_TAYLOR_T(derive_taylor_inner_square)(u, k)), T_MULI(u[0], 2));
}
#endif

#if DERIVE_TAYLOR_USES_SINCOS || DERIVE_TAYLOR_USES_EXP
/* sum_{j=1..k} j a_j w_{k-j} (k >= 1): the pairs (j, k - j) of 1 <= j < k inward out,
 * then k a_k w_0; with v (not null) also sum_{j=1..k} j a_j v_{k-j} into *vsum, each
 * j a_j computed once for both (sin's sum and cos') */
DERIVE_TAYLOR_INLINE R DERIVE_TAYLOR_T(derive_taylor_chain)(const R *a, const R *w, const R *v, R *vsum, int k)
{
    R ja;
    int j;
#ifdef DERIVE_TAYLOR_DOUBLE_DOUBLE
    double s_ = 0, c_ = 0, sv_ = 0, cv_ = 0;
    /* one term into (s_, c_) and, with v, into (sv_, cv_) */
#define DERIVE_TAYLOR_TERM(i, m) do { \
        double ws_ = s_, wc_ = c_; \
        ja = T_MULI(a[i], i); \
        DD_DOT_STEP(ja, w[m]); \
        if (v) { \
            ws_ = s_; wc_ = c_; s_ = sv_; c_ = cv_; \
            DD_DOT_STEP(ja, v[m]); \
            sv_ = s_; cv_ = c_; s_ = ws_; c_ = wc_; \
        } \
    } while (0)
    if (k % 2 == 0) {
        DERIVE_TAYLOR_TERM(k / 2, k / 2);
    }
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        DERIVE_TAYLOR_TERM(j, k - j);
        DERIVE_TAYLOR_TERM(k - j, j);
    }
    DERIVE_TAYLOR_TERM(k, 0);
#undef DERIVE_TAYLOR_TERM
    if (v) {
        *vsum = dd_quick(sv_, cv_);
    }
    return dd_quick(s_, c_);
#else
    R acc = DERIVE_TAYLOR_ZERO, vacc = DERIVE_TAYLOR_ZERO;
    if (k % 2 == 0) {
        ja = T_MULI(a[k / 2], k / 2);
        acc = T_ADD(acc, T_MUL(ja, w[k / 2]));
        vacc = v ? T_ADD(vacc, T_MUL(ja, v[k / 2])) : vacc;
    }
    DERIVE_TAYLOR_UNROLL
    for (j = (k + 1) / 2 - 1; j >= 1; --j) {
        ja = T_MULI(a[j], j);
        acc = T_ADD(acc, T_MUL(ja, w[k - j]));
        vacc = v ? T_ADD(vacc, T_MUL(ja, v[k - j])) : vacc;
        ja = T_MULI(a[k - j], k - j);
        acc = T_ADD(acc, T_MUL(ja, w[j]));
        vacc = v ? T_ADD(vacc, T_MUL(ja, v[j])) : vacc;
    }
    ja = T_MULI(a[k], k);
    acc = T_ADD(acc, T_MUL(ja, w[0]));
    if (v) {
        *vsum = T_ADD(vacc, T_MUL(ja, v[0]));
    }
    return acc;
#endif
}
#endif

#if DERIVE_TAYLOR_USES_SINCOS
/* coefficient k of s = sin a and c = cos a together: s_k = (1/k) sum_{j=1..k} j a_j c_{k-j},
 * c_k = -(1/k) sum_{j=1..k} j a_j s_{k-j}; order 0: T_SINCOS of a_0 */
DERIVE_TAYLOR_INLINE void DERIVE_TAYLOR_T(derive_taylor_sincos)(R *s, R *c, const R *a, int k)
{
    R ssum, csum;
    if (k == 0) {
        T_SINCOS(a[0], s[0], c[0]);
        return;
    }
    ssum = DERIVE_TAYLOR_T(derive_taylor_chain)(a, c, s, &csum, k);
    s[k] = T_DIVI(ssum, k);
    c[k] = T_NEG(T_DIVI(csum, k));
}
#endif

#if DERIVE_TAYLOR_USES_EXP
/* coefficient k of u = exp a: (1/k) sum_{j=1..k} j a_j u_{k-j} */
DERIVE_TAYLOR_INLINE R DERIVE_TAYLOR_T(derive_taylor_exp)(const R *a, const R *u, int k)
{
    if (k == 0) {
        return T_EXP(a[0]);
    }
    return T_DIVI(DERIVE_TAYLOR_T(derive_taylor_chain)(a, u, 0, 0, k), k);
}
#endif

#define TAYLOR_MUL DERIVE_TAYLOR_T(derive_taylor_mul)
#define TAYLOR_SQUARE DERIVE_TAYLOR_T(derive_taylor_square)
/* u_0 = a_0 / b_0 reads no coefficient of u: at order 0 the quotient is handed b in its
 * place, so an unrolled jet never passes the function a row it has not written yet (GCC's
 * -Wmaybe-uninitialized, in the double-double jet at a fixed order) */
#define TAYLOR_DIV(ak, b, u, k) DERIVE_TAYLOR_T(derive_taylor_div)(ak, b, (k) ? (u) : (b), k)
/* the same for u_0 = sqrt(a_0) and u_0 = exp(a_0), handed a in u's place */
#define TAYLOR_SQRT(a, u, k) DERIVE_TAYLOR_T(derive_taylor_sqrt)(a, (k) ? (u) : (a), k)
#define TAYLOR_SINCOS DERIVE_TAYLOR_T(derive_taylor_sincos)
#define TAYLOR_EXP(a, u, k) DERIVE_TAYLOR_T(derive_taylor_exp)(a, (k) ? (u) : (a), k)

/* the series x_0 + x_1 tau + ... + x_order tau^order by Horner */
static R DERIVE_TAYLOR_T(derive_taylor_horner)(const R *x, int order, R tau)
{
    R acc = x[order];
    int k;
    for (k = order - 1; k >= 0; --k) {
        acc = T_ADD(T_MUL(acc, tau), x[k]);
    }
    return acc;
}

/* 1 if every z[k] is finite: z - z is 0 for a number, NaN for an infinity or a NaN */
static int DERIVE_TAYLOR_T(derive_taylor_finite)(const R *z, long n)
{
    S check = 0;
    long k;
    for (k = 0; k < n; ++k) {
        check += T_S(z[k]) - T_S(z[k]);
    }
    return !T_SNAN(check);
}

/* x^n (n >= 1) by squaring: the truncation error's h^p without a pow */
static S DERIVE_TAYLOR_T(derive_taylor_powi)(S x, int n)
{
    S result = 1, square = x;
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

/* The order for a tolerance, clamped to [ORDER_MIN, ORDER_MAX] (a NaN: ORDER_MIN). */
static int DERIVE_TAYLOR_T(derive_taylor_order)(S tol)
{
    double p = DERIVE_TAYLOR_ORDER_FOR((double)tol);
    if (DERIVE_TAYLOR_ORDER) {
        return DERIVE_TAYLOR_ORDER;
    }
    if (!(p >= DERIVE_TAYLOR_ORDER_MIN)) {
        return DERIVE_TAYLOR_ORDER_MIN;
    }
    return p > DERIVE_TAYLOR_ORDER_MAX ? DERIVE_TAYLOR_ORDER_MAX : (int)p;
}

#ifdef DERIVE_TAYLOR_TIMED
static int DERIVE_TAYLOR_T(derive_taylor_coefficients)(const R *t, const R *y, const R *p, int order, R *coef, double sine_min)
#else
static int DERIVE_TAYLOR_T(derive_taylor_coefficients)(const R *y, const R *p, int order, R *coef, double sine_min)
#endif
{
    R X[DERIVE_N][DERIVE_TAYLOR_DIM];
    int i, k, st;
#ifndef DERIVE_TAYLOR_TIMED
    const R *t = 0;      /* not read: the jet of an autonomous model takes no time */
#endif
    if (order < 1 || order > DERIVE_TAYLOR_DIM - 1 || (DERIVE_TAYLOR_ORDER && order != DERIVE_TAYLOR_ORDER)) {
        return DERIVE_BAD_INPUT;
    }
    for (i = 0; i < DERIVE_N; ++i) {
        X[i][0] = y[i];
    }
    (void)t;
    st = DERIVE_TAYLOR_JET_AT(X, p, *t, order, (S)sine_min);
    for (i = 0; i < DERIVE_N; ++i) {
        for (k = 0; k <= order; ++k) {
            coef[i * (order + 1) + k] = X[i][k];
        }
    }
    return st;
}

static int DERIVE_TAYLOR_T(derive_taylor)(const R *y0, const R *p, long nt, const R *t_out, R *y_out, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    R X[DERIVE_N][DERIVE_TAYLOR_DIM];
    R t, h = T_INT(0), tend, tau, span;
    S hs, tol, m, n1, n2, rho, r, hmax, safety, y1, y2;
    long iout = 1, steps = 0, row, j;
    int i, order, dir, st = DERIVE_OK, last;
    DERIVE_INFO local;

    if (!info) {
        info = &local;
    }
    DERIVE_TAYLOR_INFO_CLEAR(info);
    info->t = nt > 0 ? (double)T_S(t_out[0]) : 0;
    for (i = 0; i < DERIVE_N; ++i) {
        info->y[i] = nt > 0 ? (long double)T_S(y0[i]) : 0;
    }
    tol = (S)opt->rtol;
    if (nt < 1 || !DERIVE_TAYLOR_T(derive_taylor_finite)(y0, DERIVE_N) || !DERIVE_TAYLOR_T(derive_taylor_finite)(p, DERIVE_N_P) ||
        !DERIVE_TAYLOR_T(derive_taylor_finite)(t_out, nt) || !(tol > 0) || !(opt->hmax >= 0) || opt->max_steps < 1) {
        st = DERIVE_BAD_INPUT;
        goto done;
    }
    for (j = 2; j < nt; ++j) {
        if (!(T_S(T_SUB(t_out[j], t_out[j - 1])) * T_S(T_SUB(t_out[1], t_out[0])) > 0)) {
            st = DERIVE_BAD_INPUT;
            goto done;
        }
    }
    order = DERIVE_TAYLOR_T(derive_taylor_order)(tol);
    /* Jorba & Zou's step factor: e^-2 exp(-0.7/(p-1)) */
    safety = T_SEXP((S)-2 - (S)0.7 / (S)(order - 1));
    y1 = (S)1 / (S)(order - 1);          /* the radius' exponents at orders p - 1 and p */
    y2 = (S)1 / (S)order;
    for (i = 0; i < DERIVE_N; ++i) {
        X[i][0] = y0[i];
        y_out[i] = y0[i];
    }
    info->nout = 1;
    t = t_out[0];
    if (nt == 1) {
        goto done;
    }
    tend = t_out[nt - 1];
    dir = T_S(T_SUB(tend, t)) > 0 ? 1 : -1;
    span = T_MULI(T_SUB(tend, t), dir);
    if (!(T_S(span) > 0)) {
        st = DERIVE_BAD_INPUT;
        goto done;
    }
    hmax = opt->hmax > 0 ? (S)opt->hmax : T_S(span);
    while (iout < nt) {
        if (steps >= opt->max_steps) {
            st = DERIVE_MAX_STEPS;
            break;
        }
        if (opt->cancel && *opt->cancel) {
            st = DERIVE_CANCELLED;
            break;
        }
        st = DERIVE_TAYLOR_JET_AT(X, p, t, order, (S)opt->sine_min);     /* t: the step's start */
        info->nfev += 1;
        if (st) {
            break;
        }
        m = 1;
        n1 = 0;
        n2 = 0;
        for (i = 0; i < DERIVE_N; ++i) {
            m = T_ABS(X[i][0]) > m ? T_ABS(X[i][0]) : m;
            n1 = T_ABS(X[i][order - 1]) > n1 ? T_ABS(X[i][order - 1]) : n1;
            n2 = T_ABS(X[i][order]) > n2 ? T_ABS(X[i][order]) : n2;
        }
        if (T_SNAN(n1 - n1) || T_SNAN(n2 - n2)) {      /* an infinity or a NaN */
            st = DERIVE_NONFINITE;
            break;
        }
        /* the series' radius rho from the last two coefficients (-1: no growth in them), the
         * step rho times the safety factor, then capped by hmax (never the cap shrunk) */
        rho = -1;
        if (n1 > 0) {
            rho = T_SROOT(m / n1, y1);
        }
        if (n2 > 0) {
            r = T_SROOT(m / n2, y2);
            rho = rho < 0 || r < rho ? r : rho;
        }
        hs = rho > 0 ? rho * safety : hmax;
        if (!(hs <= hmax)) {
            hs = hmax;
        }
        if (!(hs > 0)) {
            st = DERIVE_STEP_UNDERFLOW;
            break;
        }
        /* the step in R: the last one exactly to tend */
        last = hs >= T_S(T_MULI(T_SUB(tend, t), dir));
        h = last ? T_MULI(T_SUB(tend, t), dir) : T_FROMS(hs);
        /* dense output: every output time inside this step from the series */
        while (iout < nt && (last || T_LE(T_MULI(T_SUB(t_out[iout], t), dir), h))) {
            tau = T_SUB(t_out[iout], t);
            row = iout * DERIVE_N;
            for (i = 0; i < DERIVE_N; ++i) {
                y_out[row + i] = DERIVE_TAYLOR_T(derive_taylor_horner)(X[i], order, tau);
            }
            if (!DERIVE_TAYLOR_T(derive_taylor_finite)(y_out + row, DERIVE_N)) {
                st = DERIVE_NONFINITE;
                break;
            }
            iout += 1;
            info->nout = iout;
        }
        if (st) {
            break;
        }
        for (i = 0; i < DERIVE_N; ++i) {
            X[i][0] = DERIVE_TAYLOR_T(derive_taylor_horner)(X[i], order, T_MULI(h, dir));
        }
        /* the truncation error: the first term left out, |x_p| h^p (h / rho) from the last
         * (the coefficients fall off as rho^-k) */
        info->local_error += rho > 0 ? (double)(n2 * DERIVE_TAYLOR_T(derive_taylor_powi)(T_S(h), order) * (T_S(h) / rho)) : 0;
        t = last ? tend : T_ADD(t, T_MULI(h, dir));
        steps += 1;
        info->naccepted += 1;
        info->t = (double)T_S(t);
        info->h = (double)T_S(T_MULI(h, dir));
        for (i = 0; i < DERIVE_N; ++i) {
            info->y[i] = (long double)T_S(X[i][0]);
        }
        if (!DERIVE_TAYLOR_T(derive_taylor_finite)(&X[0][0], 1)) {
            st = DERIVE_NONFINITE;
            break;
        }
    }
done:
    info->nsteps = steps;
    info->status = st;
    if (st) {
        for (row = info->nout > 0 ? info->nout : 0; row < nt; ++row) {
            for (i = 0; i < DERIVE_N; ++i) {
                y_out[row * DERIVE_N + i] = T_NAN;
            }
        }
    }
    return st;
}

static long DERIVE_TAYLOR_T(derive_taylor_batch)(long n, const R *y0, long y0_stride, const R *p, long p_stride, long nt, const R *t, R *y_out, const DERIVE_OPTIONS *opt, DERIVE_INFO *info)
{
    long i, failed = 0;
    for (i = 0; i < n; ++i) {
        if (DERIVE_TAYLOR_T(derive_taylor)(y0 + i * y0_stride, p + i * p_stride, nt, t, y_out + i * nt * DERIVE_N, opt, info ? info + i : 0) != 0) {
            failed += 1;
        }
    }
    return failed;
}
