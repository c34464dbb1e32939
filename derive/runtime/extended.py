"""The top of the precision ladder: Taylor's method in double-double and IEEE binary128.

float, double and long double are C types NumPy has; the two rungs above them are not:
    double-double  a value is the unevaluated sum hi + lo of two doubles (about 106
                   bits, 32 digits), its arithmetic emitted in <model>_taylor.c;
    quad           IEEE binary128 (113 bits, 34 digits): GCC's __float128 with
                   libquadmath, in <model>_taylor_quad.c.
Both run the generated Taylor integrator (derive/codegen/taylor.py), the
method that makes high precision cheap: its order grows with the digits asked
(p = ceil(-ln(tol)/2 + 1), 36 at tol 1e-30) while its cost per step grows as p^2.

The values cross into and out of C exactly: an input is taken as the exact number it
writes (a float as its binary value; a string, Fraction, Decimal or mpmath number as the
decimal it is, rounded once to the precision), and a result's values are given exactly
as mpmath numbers (`r.y_exact`, an object array) beside `r.y`, rounded to long double.
"""
from __future__ import annotations

import ctypes
import shutil
import subprocess
import sys
from decimal import Decimal
from fractions import Fraction
from functools import lru_cache

import mpmath
import numpy as np

from .loader import PORTABLE_FLAGS, build_library, default_compiler
from ..codegen.sources import c_source, kernels
from ..errors import BuildError, SimulationInputError
from ..model.description import forget_on_model_change
from .build import address, info_struct
from .shared_library import TAYLOR_BATCH, TAYLOR_COEFFICIENTS, TAYLOR_COEFFICIENTS_TIMED, SharedLibrary
from .model_sizes import model_info
from ..codegen.taylor import taylor_problem, taylor_skip_flags
from .taylor_library import form_flag, jet_form
from ..codegen.contract import EXTENDED, PRECISION, PRECISION_NAMES

# The rungs above long double (the contract's precision table): unit roundoff, default
# tolerance, every name of each, the suffix of their entry points.
UNIT_ROUNDOFF = {k: PRECISION[k].eps for k in EXTENDED}
DEFAULT_RTOL = {k: PRECISION[k].default_rtol for k in EXTENDED}
NAMES = {name: key for name, key in PRECISION_NAMES.items() if key in EXTENDED}
_SUFFIX = {k: PRECISION[k].suffix for k in EXTENDED}
_BITS = 256                        # mpmath's working precision for the conversions


def precision_of(dtype) -> str | None:
    """'double-double' or 'quad' for a dtype argument naming one, else None."""
    return NAMES.get(dtype) if isinstance(dtype, str) else None


# -- exact values in and out ------------------------------------------------------------

def exact(value, what: str) -> mpmath.mpf:
    """A number as the exact value it writes (an mpf at 256 bits)."""
    with mpmath.workprec(_BITS):
        try:
            if isinstance(value, (bool, np.bool_)):
                raise TypeError
            if isinstance(value, (int, np.integer)):
                x = mpmath.mpf(int(value))
            elif isinstance(value, (float, np.floating)):
                num, den = value.as_integer_ratio()        # the binary value, exactly
                x = mpmath.mpf(num) / den
            elif isinstance(value, Fraction):
                x = mpmath.mpf(value.numerator) / value.denominator
            elif isinstance(value, (str, Decimal)):
                x = mpmath.mpf(str(value).strip())
            elif isinstance(value, mpmath.mpf):
                x = +value
            else:
                raise TypeError
        except (TypeError, ValueError):
            raise SimulationInputError(f"{what} must be numbers (float, int, str, Fraction, Decimal or "
                                       f"mpmath.mpf), got {value!r}") from None
    if not mpmath.isfinite(x):
        raise SimulationInputError(f"{what} contains NaN or infinity: {value!r}")
    return x


def to_dd(values) -> np.ndarray:
    """(..., 2) float64: each exact value as hi + lo, the nearest double-double."""
    flat = list(values)
    out = np.empty((len(flat), 2))
    with mpmath.workprec(_BITS):
        for i, x in enumerate(flat):
            hi = float(x)
            out[i] = hi, float(x - hi)
    return out


def from_dd(a: np.ndarray) -> list:
    with mpmath.workprec(_BITS):
        return [mpmath.mpf(float(hi)) + mpmath.mpf(float(lo)) for hi, lo in a.reshape(-1, 2)]


_Q_BIAS, _Q_FRAC = 16383, 112


def _quad_bits(x: mpmath.mpf) -> int:
    """The IEEE binary128 bit pattern nearest to x (round to nearest even)."""
    with mpmath.workprec(_Q_FRAC + 1):
        r = +x
    if r == 0:
        return 0
    sign, man, exp, bc = r._mpf_
    shift = _Q_FRAC + 1 - bc
    significand, e = man << shift, exp - shift          # x = significand 2^e, 2^112 <= significand < 2^113
    biased = e + _Q_FRAC + _Q_BIAS
    if not 0 < biased < 0x7FFF:
        raise SimulationInputError(f"{mpmath.nstr(x, 10)} is outside the normal range of binary128")
    return (sign << 127) | (biased << _Q_FRAC) | (significand - (1 << _Q_FRAC))


def _quad_value(bits: int) -> mpmath.mpf:
    sign, biased, frac = bits >> 127, (bits >> _Q_FRAC) & 0x7FFF, bits & ((1 << _Q_FRAC) - 1)
    if biased == 0x7FFF:
        return mpmath.mpf("nan") if frac else (-mpmath.inf if sign else mpmath.inf)
    significand, e = (frac, 1 - _Q_BIAS - _Q_FRAC) if biased == 0 else \
        (frac | (1 << _Q_FRAC), biased - _Q_BIAS - _Q_FRAC)
    with mpmath.workprec(_BITS):          # exact (negation too: mpmath rounds every result)
        v = mpmath.ldexp(mpmath.mpf(significand), e)
        return -v if sign else v


def to_quad(values) -> np.ndarray:
    """(k, 2) uint64: the binary128 words (low, high: a little-endian machine's layout)."""
    flat = list(values)
    out = _aligned((len(flat), 2), np.uint64)
    mask = (1 << 64) - 1
    for i, x in enumerate(flat):
        b = _quad_bits(x)
        out[i] = b & mask, b >> 64
    return out


def from_quad(a: np.ndarray) -> list:
    return [_quad_value(int(lo) | (int(hi) << 64)) for lo, hi in a.reshape(-1, 2)]


def _aligned(shape: tuple, dtype) -> np.ndarray:
    """An array whose data starts on a 16-byte boundary (__float128's alignment)."""
    count = int(np.prod(shape))
    raw = np.empty(count + 2, dtype)
    skip = (-address(raw) % 16) // raw.itemsize
    return raw[skip:skip + count].reshape(shape)


ENCODE = {"double-double": to_dd, "quad": to_quad}
DECODE = {"double-double": from_dd, "quad": from_quad}
_WORDS = {"double-double": np.float64, "quad": np.uint64}


def as_longdouble(values: list) -> np.ndarray:
    """Exact values rounded to long double (through a double pair: hi + lo)."""
    out = np.empty(len(values), np.longdouble)
    with mpmath.workprec(_BITS):
        for i, x in enumerate(values):
            if not mpmath.isfinite(x):
                out[i] = np.nan
                continue
            hi = float(x)
            out[i] = np.longdouble(hi) + np.longdouble(float(x - hi))
    return out


# -- the compiled integrators --------------------------------------------------------

class ExtendedTaylor(SharedLibrary):
    """ctypes access to <model>_taylor_batch_dd (in <model>_taylor.c) or _q (in
    <model>_taylor_quad.c, with libquadmath) at `order`.

    One library serves every order: it is compiled without -D<M>_TAYLOR_ORDER, so it takes
    the order from options.rtol by the same rule as contract.taylor_order.  Unrolled at a
    fixed order the extended arithmetic runs no faster and gives the same bits, while each
    new tolerance would cost a compile of its own.  The jet's form (`form`: compact or
    unrolled, taylor_library.JET_FORMS) is compact by default: without a fixed order the
    statements are not unrolled, and the compact loops ran as fast in both rungs."""

    def __init__(self, model: str, precision: str, order: int, form: str = "compact"):
        info = model_info(model)
        self.model, self.precision, self.order, self.n, self.form = model, precision, order, info.n, form
        self.n_params = info.n_params + info.n_inputs
        stem = f"{model}_taylor_quad" if precision == "quad" else f"{model}_taylor"
        source = c_source(model, f"{stem}.c")
        if not source.is_file():
            raise SimulationInputError(f"model '{model}' has no Taylor integrator: {taylor_problem(model)}")
        flags = (*PORTABLE_FLAGS, "-O3", *_fma_flags(), form_flag(model, form))     # no fixed order: see above
        if precision == "double-double":          # only the variant that runs (compile time)
            flags += taylor_skip_flags(model, PRECISION[precision].ctype)
        libs = ()
        if precision == "quad":
            cc = default_compiler()
            flags += _quadmath_include(cc)
            libs = ("-lquadmath",)
        try:
            path = build_library(f"{stem}{_SUFFIX[precision]}", [source], flags=flags, libs=libs)
        except BuildError as exc:
            if precision == "quad":
                raise BuildError(f"binary128 (dtype='quad') needs GCC's __float128 and libquadmath, and "
                                 f"building with them failed: {str(exc).splitlines()[0]}") from None
            raise
        super().__init__(path)
        self.Info = info_struct(self.n)
        self.batch = self.bind(TAYLOR_BATCH, model=model, suffix=_SUFFIX[precision])
        self.timed = kernels(model)[0].is_time_dependent
        self.coefficients_fn = self.bind(TAYLOR_COEFFICIENTS_TIMED if self.timed else TAYLOR_COEFFICIENTS,
                                         model=model, suffix=_SUFFIX[precision])

    def run(self, y0: list, p: list, t: list, opt) -> tuple[list, object]:
        """One trajectory from exact values -> (the outputs as exact values, row-major
        (len(t), n), and the info struct)."""
        enc = ENCODE[self.precision]
        y0w, pw, tw = enc(y0), enc(p) if p else enc([0]), enc(t)
        out = _aligned((len(t) * self.n, 2), _WORDS[self.precision])
        infos = (self.Info * 1)()
        self.batch(1, address(y0w), self.n, address(pw), 0, len(t), address(tw), address(out),
                   ctypes.addressof(opt), ctypes.addressof(infos))
        return DECODE[self.precision](out), infos[0]

    def coefficients(self, y: list, p: list, sine_min: float = 0.0, t=0) -> tuple[int, list]:
        """(status, the normalised Taylor coefficients, row-major (n, order + 1), exact) of
        the solution through y (at the time t, an exact value: a time-dependent model's)."""
        enc = ENCODE[self.precision]
        yw, pw = enc(y), enc(p) if p else enc([0])
        tw = enc([exact(t, "t")])
        out = _aligned((self.n * (self.order + 1), 2), _WORDS[self.precision])
        at = (address(tw),) if self.timed else ()
        st = self.coefficients_fn(*at, address(yw), address(pw), self.order, address(out), float(sine_min))
        return int(st), DECODE[self.precision](out)


@lru_cache(maxsize=None)
def _fma_flags() -> tuple[str, ...]:
    """-mfma where this machine's processor has the instruction: double-double's products
    use C99's fma, a slow library call without it.  The flag is part of the
    build key, so a machine without FMA builds its own library."""
    try:
        with open("/proc/cpuinfo") as f:
            flags = next((line.split(":", 1)[1].split() for line in f if line.startswith("flags")), [])
    except OSError:
        return ()
    return ("-mfma",) if "fma" in flags else ()


@lru_cache(maxsize=None)
def _quadmath_include(cc: str) -> tuple[str, ...]:
    """clang has __float128 but not GCC's <quadmath.h>: point it at GCC's headers."""
    if "clang" not in cc or shutil.which("gcc") is None:
        return ()
    proc = subprocess.run(["gcc", "-print-file-name=include"], capture_output=True, text=True)
    return ("-idirafter", proc.stdout.strip()) if proc.returncode == 0 and proc.stdout.strip() else ()


@forget_on_model_change
@lru_cache(maxsize=None)
def extended_taylor(model: str, precision: str, order: int) -> ExtendedTaylor:
    if sys.byteorder != "little":
        raise SimulationInputError(f"dtype '{precision}' runs on little-endian machines only")
    return ExtendedTaylor(model, precision, order, jet_form(model, None))
