/* Copied by derive 0.2.0 from codegen/backends/c/library/derive_taylor_math.h for every model; do not edit. */
/* derive_taylor_math.h: the functions derive's Taylor integrators take of their numbers,
 * sin and cos of one argument together and the root x^y of the series' radius, written
 * as straight-line arithmetic that a compiler turns into vector instructions over SIMD
 * lanes (derive/codegen/backends/c/library/).  The scalar integrator (derive_taylor.h)
 * and the lanes (derive_taylor_lanes.h) call the same functions, so that every lane is
 * bit for bit the scalar run: IEEE arithmetic rounds the same in a vector register as in
 * a scalar one (built without contraction: -ffp-contract=off, as derive builds them; C99
 * mode in GCC implies it).
 *
 * derive_sincos(x, &s, &c) (double), derive_sincosf (float) and derive_sincosl (long
 * double: libm's sinl and cosl).  For |x| <= DERIVE_SINCOS_MAX (2^15) the double one is
 *   x = n pi/2 + r, n the integer nearest 2x/pi, |r| <= pi/4 (a little more by rounding),
 *   r from pi/2 in three parts (33, 33 and 53 bits: n times the first two is exact), the
 *   rounding of r - n pi/2 carried as r = y0 + y1 (two-sums),
 *   sin r = r + r^3 S(r^2), cos r = 1 - r^2/2 + r^4 C(r^2), S and C of degree 5: minimax
 *   on [0, (pi/4)^2] (Remez, 60 digits in mpmath; |error| < 2.1e-17 in S, 1.3e-18 in C),
 *   with the tail: sin(y0 + y1) = sin y0 + y1 (1 - y0^2/2), cos(y0 + y1) = cos y0 - y0 y1,
 *   then the quadrant of n.
 * Error: below 1 ulp against the exact values (tests/runtime/test_taylor_sincos.py compares
 * with mpmath on random arguments and on the doubles nearest multiples of pi/2, the
 * hardest: r as small as 2^-60.5 (n = 29); 3 pi/2 parts leave |r| wrong by about n 2^-121,
 * which up to 2^15 stays below a quarter ulp of the smallest r of each binade).  Past
 * 2^15, and for infinities and NaN, libm's sin and cos.  float: the double function, rounded.
 *
 * derive_root(x, y) = x^y (double; derive_rootf and derive_rootl: the double one,
 * converted) for the radius of the series, x = |y|_inf / |y^[p]|_inf > 0 and y = 1/p: for
 * 2^-1000 <= x <= 2^1000,
 *   x = 2^e m (the bits of x), m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh t = 2 (t + t^3/3
 *   + ... + t^19/19), t = (m - 1)/(m + 1) (|t| <= 0.172: the rest below 5e-18 relative),
 *   z = y (e + ln m / ln 2) = k + f (k the nearest integer, |f| <= 1/2), 2^f = exp(f ln 2)
 *   by its series to degree 13 (the rest below 5e-18), 2^k from its bits; both series by
 *   Estrin's scheme (a short chain of operations: the root is on the step's critical path);
 * relative error below 1e-13 (the rounding of e + log2 m, times y; tested against
 * mpmath), ample for a step size.  Past that range (or not a number), libm's pow.
 *
 * Standalone C99, only <math.h>; no globals.  Included by derive_taylor.h and
 * derive_taylor_lanes.h (once: guarded).
 */
#ifndef DERIVE_TAYLOR_MATH_H
#define DERIVE_TAYLOR_MATH_H

#include <math.h>

#define DERIVE_SINCOS_MAX 32768.0

/* inlined where called (forced where the compiler can: a lane loop vectorises only then) */
#if defined(__GNUC__)
#define DERIVE_MATH_INLINE static inline __attribute__((always_inline))
#else
#define DERIVE_MATH_INLINE static inline
#endif

/* Whether x is past the polynomial's range (or not a number): then libm's sin and cos. */
static inline int derive_sincos_outside(double x)
{
    return !(fabs(x) <= DERIVE_SINCOS_MAX);
}

/* sin x and cos x for |x| <= DERIVE_SINCOS_MAX (else the values of 0: the caller takes
 * libm's), without branches: a loop over lanes of it vectorises. */
DERIVE_MATH_INLINE void derive_sincos_reduced(double x, double *s, double *c)
{
    const double shifter = 6755399441055744.0;                /* 1.5 2^52: adding it rounds to an integer */
    const double two_over_pi = 6.3661977236758138e-01;        /* 0x1.45f306dc9c883p-1 */
    const double p1 = 1.5707963267341256e+00;                 /* 0x1.921fb544p+0: pi/2 to 33 bits */
    const double p2 = 6.0771005063039660e-11;                 /* 0x1.0b4611a6p-34: the next 33 */
    const double p3 = 2.0222662487959506e-21;                 /* 0x1.3198a2e037073p-69: the rest */
    const double s1 = -1.6666666666666666e-01, s2 = 8.3333333333309500e-03,
                 s3 = -1.9841269836759208e-04, s4 = 2.7557316102723360e-06,
                 s5 = -2.5051131855020103e-08, s6 = 1.5918128540749538e-10;
    const double c1 = 4.1666666666666664e-02, c2 = -1.3888888888887398e-03,
                 c3 = 2.4801587298765916e-05, c4 = -2.7557317271759740e-07,
                 c5 = 2.0876146260409636e-09, c6 = -1.1382631029181099e-11;
    double xr = fabs(x) <= DERIVE_SINCOS_MAX ? x : 0.0;
    double n = (xr * two_over_pi + shifter) - shifter;
    double t = xr - n * p1;                 /* exact (n p1 exact, t near it) */
    double w = n * p2;                      /* exact */
    double r1 = t - w, b1 = r1 - t;         /* r1 + e1 = t - w exactly (two-sum) */
    double e1 = (t - (r1 - b1)) + (-w - b1);
    double minus_tail = n * p3 - e1;        /* subtracted, so that sin(-0) is -0 */
    double y0 = r1 - minus_tail, b2 = y0 - r1;      /* y0 + y1 = r1 - minus_tail (two-sum) */
    double y1 = (r1 - (y0 - b2)) + (-minus_tail - b2);
    double z = y0 * y0, v = z * y0, hz = 0.5 * z, one_minus = 1.0 - hz;
    double sp = s2 + z * (s3 + z * (s4 + z * (s5 + z * s6)));
    double cp = c1 + z * (c2 + z * (c3 + z * (c4 + z * (c5 + z * c6))));
    double sr = y0 - ((z * (0.5 * y1 - v * sp) - y1) - v * s1);
    double cr = one_minus + (((1.0 - one_minus) - hz) + (z * z * cp - y0 * y1));
    /* the quadrant: q = n - 4 round(n/4) in {-2, -1, 0, 1, 2} (2 and -2 alike); selects
     * and signs as products by +-1 (exact), which GCC's vectoriser takes (branches it
     * does not): n = 1, 3 (mod 4) swap sin and cos, n = 2, 3 negate sin, n = 1, 2 cos */
    double q = n - 4.0 * ((n * 0.25 + shifter) - shifter);
    double odd = fabs(fabs(q) - 1.0);      /* 0 for n odd, 1 for n even */
    double sv = odd < 0.5 ? cr : sr, cv = odd < 0.5 ? sr : cr;
    double sin_sign = q < -0.5 ? -1.0 : 1.0, cos_sign = q > 0.5 ? -1.0 : 1.0;
    sin_sign = q > 1.5 ? -1.0 : sin_sign;
    cos_sign = q < -1.5 ? -1.0 : cos_sign;
    *s = sin_sign * sv;
    *c = cos_sign * cv;
}

static inline void derive_sincos(double x, double *s, double *c)
{
    if (derive_sincos_outside(x)) {
        *s = sin(x);
        *c = cos(x);
    } else {
        derive_sincos_reduced(x, s, c);
    }
}

/* float: the double function, rounded (a lane loop of floats vectorises the same) */
static inline int derive_sincos_outsidef(float x)
{
    return derive_sincos_outside((double)x);
}

DERIVE_MATH_INLINE void derive_sincos_reducedf(float x, float *s, float *c)
{
    double sd, cd;
    derive_sincos_reduced((double)x, &sd, &cd);
    *s = (float)sd;
    *c = (float)cd;
}

static inline void derive_sincosf(float x, float *s, float *c)
{
    if (derive_sincos_outsidef(x)) {
        *s = sinf(x);
        *c = cosf(x);
    } else {
        derive_sincos_reducedf(x, s, c);
    }
}

/* long double: libm's (no vector unit runs it) */
static inline int derive_sincos_outsidel(long double x)
{
    (void)x;
    return 0;
}

static inline void derive_sincos_reducedl(long double x, long double *s, long double *c)
{
    *s = sinl(x);
    *c = cosl(x);
}

static inline void derive_sincosl(long double x, long double *s, long double *c)
{
    derive_sincos_reducedl(x, s, c);
}


/* -- the root of the radius ---------------------------------------------------------- */

#define DERIVE_ROOT_MIN 9.3326361850321888e-302     /* 2^-1000 */
#define DERIVE_ROOT_MAX 1.0715086071862673e+301     /* 2^1000 */

/* a double's bits (C99: reading the member not last written gives them) */
typedef union {
    double d;
    unsigned long long u;
} derive_bits;

/* Whether x is past derive_root_reduced's range (or not a number): then libm's pow. */
static inline int derive_root_outside(double x)
{
    return !(x >= DERIVE_ROOT_MIN && x <= DERIVE_ROOT_MAX);
}

/* x^y for 2^-1000 <= x <= 2^1000 and 0 < y <= 1 (else a number of no meaning: the caller
 * takes pow's), without branches: a loop over lanes of it vectorises. */
DERIVE_MATH_INLINE double derive_root_reduced(double x, double y)
{
    const double shifter = 6755399441055744.0;                /* 1.5 2^52 */
    const double two52 = 4503599627370496.0;                  /* 2^52 */
    const double ln2 = 6.9314718055994529e-01, inv_ln2 = 1.4426950408889634e+00;
    const double sqrt2 = 1.4142135623730951e+00;
    derive_bits b, e_bits, scale;
    double e, m, t, t2, t4, t8, ln_m, z, k, w, w2, w4, w8, p;
    b.d = derive_root_outside(x) ? 1.0 : x;
    /* x = 2^e m: the exponent field as a double (2^52 + field, less 2^52), m in [1, 2) */
    e_bits.u = (b.u >> 52) | 0x4330000000000000ULL;
    e = (e_bits.d - two52) - 1023.0;
    b.u = (b.u & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL;
    m = b.d > sqrt2 ? 0.5 * b.d : b.d;
    e = b.d > sqrt2 ? e + 1.0 : e;
    t = (m - 1.0) / (m + 1.0);
    /* the series by Estrin's scheme (powers t^2, t^4, t^8, t^16 side by side): it sits on
     * the step's critical path, where Horner's rule would chain ten multiply-adds */
    t2 = t * t;
    t4 = t2 * t2;
    t8 = t4 * t4;
    ln_m = 2.0 * t * (((1.0 + t2 * (1.0 / 3)) + t4 * (1.0 / 5 + t2 * (1.0 / 7)))
                      + t8 * ((1.0 / 9 + t2 * (1.0 / 11)) + t4 * (1.0 / 13 + t2 * (1.0 / 15)))
                      + t8 * t8 * (1.0 / 17 + t2 * (1.0 / 19)));
    z = y * (e + ln_m * inv_ln2);
    b.d = z + shifter;                       /* its low bits: k, the integer nearest z */
    k = b.d - shifter;
    w = (z - k) * ln2;
    w2 = w * w;
    w4 = w2 * w2;
    w8 = w4 * w4;
    p = ((1.0 + w) + w2 * (1.0 / 2 + w * (1.0 / 6))) + w4 * ((1.0 / 24 + w * (1.0 / 120))
        + w2 * (1.0 / 720 + w * (1.0 / 5040)))
        + w8 * (((1.0 / 40320 + w * (1.0 / 362880)) + w2 * (1.0 / 3628800 + w * (1.0 / 39916800)))
                + w4 * (1.0 / 479001600 + w * (1.0 / 6227020800.0)));
    scale.u = (b.u - 0x4338000000000000ULL + 1023ULL) << 52;      /* 2^k (|k| <= 1000) */
    return p * scale.d;
}

static inline double derive_root(double x, double y)
{
    return derive_root_outside(x) ? pow(x, y) : derive_root_reduced(x, y);
}

/* float: the double function, rounded */
static inline int derive_root_outsidef(float x)
{
    return derive_root_outside((double)x);
}

DERIVE_MATH_INLINE float derive_root_reducedf(float x, float y)
{
    return (float)derive_root_reduced((double)x, (double)y);
}

static inline float derive_rootf(float x, float y)
{
    return derive_root_outsidef(x) ? powf(x, y) : derive_root_reducedf(x, y);
}

/* long double: the double function too.  The root sets the step size, a heuristic whose
 * value needs no more digits than double's (double-double's takes the double one as
 * well); x87's powl costs about as much as a tenth of a long double step. */
static inline int derive_root_outsidel(long double x)
{
    return derive_root_outside((double)x);
}

DERIVE_MATH_INLINE long double derive_root_reducedl(long double x, long double y)
{
    return (long double)derive_root_reduced((double)x, (double)y);
}

static inline long double derive_rootl(long double x, long double y)
{
    return derive_root_outsidel(x) ? powl(x, y) : derive_root_reducedl(x, y);
}

#endif /* DERIVE_TAYLOR_MATH_H */
