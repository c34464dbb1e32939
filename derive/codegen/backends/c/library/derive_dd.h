/* derive_dd.h: double-double arithmetic, written once for every model
 * (derive/codegen/backends/c/library/).
 *
 * A value is hi + lo with |lo| <= ulp(hi)/2 (about 106 bits), from error-free
 * transformations (Knuth's two-sum, fma for the product: C99's fma is exact whether or
 * not the machine has the instruction).  As the QD library (Hida, Li & Bailey 2001) does
 * it, written here so that a generated file needs no library.
 *
 * Standalone C99, only <math.h>; every function static inline and pure (reentrant: no
 * globals).  The Taylor integrator's double-double variant uses it through its
 * arithmetic macros (T_ADD -> dd_add, ...; derive_taylor.h).
 */
#ifndef DERIVE_DD_H
#define DERIVE_DD_H

#include <math.h>

#ifndef DERIVE_DOUBLE_DOUBLE
#define DERIVE_DOUBLE_DOUBLE
/* a double-double value: hi + lo, |lo| <= ulp(hi)/2 */
typedef struct {
    double hi, lo;
} derive_dd;
#endif

static inline derive_dd dd_d(double x)
{
    derive_dd r;
    r.hi = x;
    r.lo = 0;
    return r;
}

static inline derive_dd dd_quick(double s, double e)      /* |s| >= |e| */
{
    derive_dd r;
    r.hi = s + e;
    r.lo = e - (r.hi - s);
    return r;
}

static inline derive_dd dd_two_sum(double a, double b)
{
    derive_dd r;
    double v;
    r.hi = a + b;
    v = r.hi - a;
    r.lo = (a - (r.hi - v)) + (b - v);
    return r;
}

/* a + b with an absolute error below about 2^-105 (|a| + |b|): the lower parts added in
 * double ("sloppy" addition, QD's default), about half the work of the addition whose
 * relative error stays bounded under cancellation.  The bound in |a| + |b| is what every
 * sum here needs (a series' terms, a step added to a time). */
static inline derive_dd dd_add(derive_dd a, derive_dd b)
{
    derive_dd s = dd_two_sum(a.hi, b.hi);
    s.lo += a.lo + b.lo;
    return dd_quick(s.hi, s.lo);
}

static inline derive_dd dd_neg(derive_dd a)
{
    a.hi = -a.hi;
    a.lo = -a.lo;
    return a;
}

static inline derive_dd dd_sub(derive_dd a, derive_dd b)
{
    return dd_add(a, dd_neg(b));
}

static inline derive_dd dd_mul(derive_dd a, derive_dd b)
{
    double p = a.hi * b.hi;
    double e = fma(a.hi, b.hi, -p);
    e += a.hi * b.lo + a.lo * b.hi;
    return dd_quick(p, e);
}

static inline derive_dd dd_mul_d(derive_dd a, double b)
{
    double p = a.hi * b;
    double e = fma(a.hi, b, -p);
    e += a.lo * b;
    return dd_quick(p, e);
}

static inline derive_dd dd_div(derive_dd a, derive_dd b)
{
    double q1 = a.hi / b.hi, q2, q3;
    derive_dd r = dd_sub(a, dd_mul_d(b, q1));
    q2 = r.hi / b.hi;
    r = dd_sub(r, dd_mul_d(b, q2));
    q3 = r.hi / b.hi;
    r = dd_quick(q1, q2);
    return dd_add(r, dd_d(q3));
}

static inline derive_dd dd_div_d(derive_dd a, double b)
{
    return dd_div(a, dd_d(b));
}

static inline int dd_le(derive_dd a, derive_dd b)
{
    return a.hi < b.hi || (a.hi <= b.hi && a.lo <= b.lo);      /* after <, <= is == */
}

/* sqrt(a) = x + (a - x^2)/(2x) from the double x = sqrt(a.hi) (one Newton step, Karp & Markstein) */
static inline derive_dd dd_sqrt(derive_dd a)
{
    double x;
    derive_dd x2;
    if (!(a.hi > 0)) {
        return dd_d(a.hi >= 0 ? 0.0 : sqrt(a.hi));      /* here a.hi >= 0 is a.hi == 0: 0, or NaN below 0 */
    }
    x = sqrt(a.hi);
    x2 = dd_mul(dd_d(x), dd_d(x));
    return dd_add(dd_d(x), dd_div_d(dd_sub(a, x2), 2 * x));
}

/* pi/2 as three doubles (to about 2^-160): the reduction a - k pi/2 stays accurate for
 * the angles of a motion (|k| up to about 2^50) */
#define DD_PI2_A 1.5707963267948966
#define DD_PI2_B 6.123233995736766e-17
#define DD_PI2_C (-1.4973849048591698e-33)

/* sin and cos of |r| <= pi/4 by their series, to below 2^-106 */
static inline void dd_sincos_small(derive_dd r, derive_dd *s, derive_dd *c)
{
    derive_dd r2 = dd_mul(r, r), term = r, sum = r;
    int k;
    for (k = 2; k < 60 && fabs(term.hi) > 1e-36 * fabs(sum.hi); k += 2) {
        term = dd_div_d(dd_mul(term, dd_neg(r2)), (double)(k * (k + 1)));
        sum = dd_add(sum, term);
    }
    *s = sum;
    term = dd_d(1.0);
    sum = term;
    for (k = 1; k < 60 && fabs(term.hi) > 1e-36; k += 2) {
        term = dd_div_d(dd_mul(term, dd_neg(r2)), (double)(k * (k + 1)));
        sum = dd_add(sum, term);
    }
    *c = sum;
}

static inline void dd_sincos(derive_dd a, derive_dd *s, derive_dd *c)
{
    double k = floor(a.hi / DD_PI2_A + 0.5);
    derive_dd r = a, ss, cc;
    int q;
    if (!(fabs(a.hi) < 1e15)) {             /* beyond the reduction (or NaN): libm's double */
        *s = dd_d(sin(a.hi));
        *c = dd_d(cos(a.hi));
        return;
    }
    r = dd_sub(r, dd_mul_d(dd_d(DD_PI2_A), k));
    r = dd_sub(r, dd_mul_d(dd_d(DD_PI2_B), k));
    r = dd_sub(r, dd_mul_d(dd_d(DD_PI2_C), k));
    dd_sincos_small(r, &ss, &cc);
    q = (int)fmod(k, 4.0);
    q = q < 0 ? q + 4 : q;
    *s = q == 0 ? ss : q == 1 ? cc : q == 2 ? dd_neg(ss) : dd_neg(cc);
    *c = q == 0 ? cc : q == 1 ? dd_neg(ss) : q == 2 ? dd_neg(cc) : ss;
}

static inline derive_dd dd_sin(derive_dd a)
{
    derive_dd s, c;
    dd_sincos(a, &s, &c);
    return s;
}

static inline derive_dd dd_cos(derive_dd a)
{
    derive_dd s, c;
    dd_sincos(a, &s, &c);
    return c;
}

/* exp(a) = 2^m exp(r)^(2^10), r = (a - m ln 2)/2^10, exp(r) by its series */
static inline derive_dd dd_exp(derive_dd a)
{
    const derive_dd ln2 = dd_quick(6.9314718055994529e-01, 2.3190468138462996e-17);
    double m;
    derive_dd r, term, sum;
    int k;
    if (!(fabs(a.hi) < 700)) {
        return dd_d(exp(a.hi));
    }
    m = floor(a.hi / ln2.hi + 0.5);
    r = dd_mul_d(dd_sub(a, dd_mul_d(ln2, m)), 1.0 / 1024);
    term = r;
    sum = dd_add(dd_d(1.0), r);
    for (k = 2; k < 40 && fabs(term.hi) > 1e-36; ++k) {
        term = dd_div_d(dd_mul(term, r), (double)k);
        sum = dd_add(sum, term);
    }
    for (k = 0; k < 10; ++k) {
        sum = dd_mul(sum, sum);
    }
    sum.hi = ldexp(sum.hi, (int)m);
    sum.lo = ldexp(sum.lo, (int)m);
    return sum;
}

/* sum_j a_j b_j of double-doubles as Ogita, Rump & Oishi's Dot2 does it (2005): the
 * products' leading parts summed with two-sum, every error term into one double c; as
 * accurate as the dd sum of dd products (about 2^-105 sum |a_j b_j|) with half the
 * dependent operations.  One term x y of the sum in the caller's doubles s_ (the sum so
 * far) and c_ (its errors); the result is dd_quick(s_, c_). */
#define DD_DOT_STEP(x, y) do { \
        double p_ = (x).hi * (y).hi, t_ = s_ + p_, z_ = t_ - s_; \
        c_ += ((s_ - (t_ - z_)) + (p_ - z_)) + fma((x).hi, (y).hi, -p_) + ((x).hi * (y).lo + (x).lo * (y).hi); \
        s_ = t_; \
    } while (0)

#endif /* DERIVE_DD_H */
