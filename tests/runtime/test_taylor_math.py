"""derive_taylor_math.h: the sin/cos pair and the radius' root of the Taylor integrators (scalar
and SIMD lanes), against mpmath, and their lane loops (vector instructions) against their
scalar calls, bit for bit."""
from __future__ import annotations

import ctypes
import math
import subprocess

import mpmath
import numpy as np
import pytest

from derive.runtime.loader import default_compiler
from derive.runtime.vector_build import EXACT_FLAGS, simd_build
from tests.codegen.test_generate_and_compile import GEN_C

# the scalar call, and the lanes' loop as derive_taylor_lanes.h writes it (the polynomial
# for every lane, vectorised; libm's sin and cos past its range, lane by lane)
SOURCE = r"""
#include "derive_taylor_math.h"
#define LANES 8
void scalar(long n, const double *x, double *s, double *c)
{
    long i;
    for (i = 0; i < n; ++i) {
        derive_sincos(x[i], &s[i], &c[i]);
    }
}
static void lanes8(const double *restrict a, double *restrict s, double *restrict c)
{
    int l;
    for (l = 0; l < LANES; ++l) {
        derive_sincos_reduced(a[l], &s[l], &c[l]);
    }
    for (l = 0; l < LANES; ++l) {
        if (derive_sincos_outside(a[l])) {
            s[l] = sin(a[l]);
            c[l] = cos(a[l]);
        }
    }
}
void lanes(long n, const double *x, double *s, double *c)       /* n a multiple of LANES */
{
    long i;
    for (i = 0; i < n; i += LANES) {
        lanes8(x + i, s + i, c + i);
    }
}
void root(long n, const double *x, double *y, double *out)
{
    long i;
    for (i = 0; i < n; ++i) {
        out[i] = derive_root(x[i], y[i]);
    }
}
static void root8(const double *restrict x, const double *restrict y, double *restrict out)
{
    int l;
    for (l = 0; l < LANES; ++l) {
        out[l] = derive_root_reduced(x[l], y[l]);
    }
    for (l = 0; l < LANES; ++l) {
        if (derive_root_outside(x[l])) {
            out[l] = pow(x[l], y[l]);
        }
    }
}
void root_lanes(long n, const double *x, double *y, double *out)
{
    long i;
    for (i = 0; i < n; i += LANES) {
        root8(x + i, y + i, out + i);
    }
}
void root_l(long n, const long double *x, const long double *y, long double *out)
{
    long i;
    for (i = 0; i < n; ++i) {
        out[i] = derive_rootl(x[i], y[i]);
    }
}
void scalar_f(long n, const float *x, float *s, float *c)
{
    long i;
    for (i = 0; i < n; ++i) {
        derive_sincosf(x[i], &s[i], &c[i]);
    }
}
"""


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sincos")
    (folder / "sincos.c").write_text(SOURCE)
    path = folder / "libsincos.so"
    cmd = [default_compiler(), "-std=c99", "-O2", "-fPIC", "-shared", "-fpeel-loops", *EXACT_FLAGS,
           *simd_build("float64")[0], "-I", str(GEN_C), "sincos.c", "-o", str(path), "-lm"]
    proc = subprocess.run(cmd, cwd=folder, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return ctypes.CDLL(str(path))


def _call(lib, name, x, dtype=np.float64):
    x = np.ascontiguousarray(x, dtype)
    s, c = np.empty_like(x), np.empty_like(x)
    ptr = ctypes.POINTER(ctypes.c_double if dtype == np.float64 else ctypes.c_float)
    getattr(lib, name)(ctypes.c_long(len(x)), *(a.ctypes.data_as(ptr) for a in (x, s, c)))
    return s, c


def _arguments() -> np.ndarray:
    """Random arguments over the polynomial's range and past it, tiny ones, and the doubles
    nearest multiples of pi/2 (the hardest: r = x - n pi/2 is smallest there, 2^-60.5 at
    n = 29), a multiple of 8 in all."""
    rng = np.random.default_rng(25)
    near = []
    with mpmath.workprec(200):
        for n in [*range(1, 400), 29, 58, 116, 232, 464, 928, 1856, 3712, 7424, 20000]:
            v = float(n * mpmath.pi / 2)
            near += [v, np.nextafter(v, 0.0), np.nextafter(v, 1e9)]
    near = np.array(near)
    x = np.concatenate([rng.uniform(-4, 4, 3000), rng.uniform(-200, 200, 3000),
                        rng.uniform(-32768, 32768, 2000), rng.uniform(-1e6, 1e6, 200),
                        10.0 ** rng.uniform(-300, 0, 600) * rng.choice([-1.0, 1.0], 600), near, -near])
    return np.concatenate([x, np.zeros((-len(x)) % 8)])


def _ulps(got: float, x: float, f) -> float:
    with mpmath.workprec(200):
        exact = f(mpmath.mpf(x))
        return float(abs(mpmath.mpf(got) - exact) / math.ulp(float(exact)))


def test_within_one_ulp_of_mpmath(library):
    x = _arguments()
    s, c = _call(library, "scalar", x)
    worst_sin = max(_ulps(a, v, mpmath.sin) for a, v in zip(s, x))
    worst_cos = max(_ulps(a, v, mpmath.cos) for a, v in zip(c, x))
    assert worst_sin < 1.0 and worst_cos < 1.0, (worst_sin, worst_cos)


def test_the_lanes_loop_is_the_scalar_call_bit_for_bit(library):
    x = _arguments()
    assert np.array_equal(_call(library, "lanes", x), _call(library, "scalar", x))


def test_special_values(library):
    x = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 1e300, -5e-324, 32768.0])
    s, c = _call(library, "scalar", x)
    assert s[0] == 0.0 and not np.signbit(s[0]) and np.signbit(s[1]) and c[0] == c[1] == 1.0
    assert np.all(np.isnan(s[2:5])) and np.all(np.isnan(c[2:5]))
    assert (s[5], c[5]) == (math.sin(1e300), math.cos(1e300))      # past the range: libm's
    assert s[6] == -5e-324


def test_float_is_the_double_rounded(library):
    x = np.random.default_rng(3).uniform(-50, 50, 4000).astype(np.float32)
    s, c = _call(library, "scalar_f", x, np.float32)
    sd, cd = _call(library, "scalar", x.astype(np.float64))
    assert np.array_equal(s, sd.astype(np.float32)) and np.array_equal(c, cd.astype(np.float32))


def _roots(lib, name, x, y):
    x, y = np.ascontiguousarray(x, float), np.ascontiguousarray(y, float)
    out = np.empty_like(x)
    ptr = ctypes.POINTER(ctypes.c_double)
    getattr(lib, name)(ctypes.c_long(len(x)), *(a.ctypes.data_as(ptr) for a in (x, y, out)))
    return out


def test_the_root_of_the_radius(library):
    """x^y, y = 1/p for the orders p: within 1e-13 of mpmath over the polynomial's range
    (2^-1000 to 2^1000), pow's past it; the lanes' loop bit for bit the scalar call."""
    rng = np.random.default_rng(7)
    n = 4000
    x = np.concatenate([2.0 ** rng.uniform(-1000, 1000, n - 16), [2.0 ** -1000, 2.0 ** 1000, 1.0, 1.5, 0.75,
                                                                    1e-305, 1e305, np.inf, 5e-324, 2.0 ** 0.5,
                                                                    np.nextafter(2.0 ** 0.5, 2), 3.0, 7.0, 1e10,
                                                                    1e-10, 0.5]])
    y = 1.0 / rng.integers(1, 60, n)
    got = _roots(library, "root", x, y)
    assert np.array_equal(got, _roots(library, "root_lanes", x, y))
    inside = (x >= 2.0 ** -1000) & (x <= 2.0 ** 1000)
    with mpmath.workprec(120):
        worst = max(float(abs(mpmath.mpf(g) / mpmath.power(mpmath.mpf(a), mpmath.mpf(b)) - 1))
                    for g, a, b in zip(got[inside], x[inside], y[inside]))
    assert worst < 1e-13, worst
    assert np.array_equal(got[~inside], x[~inside] ** y[~inside])          # numpy's pow is libm's


def test_the_long_double_root_is_the_double_one(library):
    """derive_rootl, the step size's root in long double: the double root of the arguments
    rounded to double, inside its range (a step size needs no more digits; x87's powl cost
    a tenth of a step), powl past it (beyond double's range too)."""
    rng = np.random.default_rng(11)
    x = np.concatenate([2.0 ** rng.uniform(-900, 900, 200), [1.0, 0.75, 3.0]]).astype(np.longdouble)
    x[0] = np.longdouble(2) ** 1100                       # past double's range: powl's
    x[1] = np.longdouble(1) + np.longdouble(2) ** -60     # below double's resolution: its rounding
    y = (1.0 / rng.integers(2, 40, len(x))).astype(np.longdouble)
    out = np.empty_like(x)
    ptr = ctypes.POINTER(ctypes.c_longdouble)
    library.root_l(ctypes.c_long(len(x)), *(a.ctypes.data_as(ptr) for a in (x, y, out)))
    double = _roots(library, "root", x[1:].astype(np.float64), y[1:].astype(np.float64))
    assert np.array_equal(out[1:], double.astype(np.longdouble))
    assert out[0] == x[0] ** y[0]                    # numpy's long double power is powl
