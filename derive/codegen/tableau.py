"""Butcher tableaus as data (the .toml files beside this module) and their literals.

Every coefficient is read as text ("35/384", "1/4 - sqrt(3)/6", a 30-digit
decimal), evaluated once to 40 digits, and printed per target precision:
float literals end in ``f``, long double literals in ``L`` (36 digits),
double literals are the correctly rounded shortest form.  Templates only place
these strings.
"""
from __future__ import annotations

import tomllib
from fractions import Fraction
from dataclasses import dataclass, field
from functools import lru_cache

import math
import struct

import mpmath
import sympy as sp

from ..model.expressions import parse_expression
from ..paths import tableau_file

DIGITS = 40


def value(text: str) -> mpmath.mpf:
    """The exact value of a coefficient written as a decimal, a rational or an expression."""
    text = text.strip()
    with mpmath.workdps(DIGITS + 10):
        try:
            return mpmath.mpf(text)
        except (ValueError, TypeError):
            return mpmath.mpf(sp.N(parse_expression(text, {}, "tableau coefficient"), DIGITS + 10))


def _as_float32(x: float) -> float:
    """x rounded to the nearest float (IEEE single; beyond its range, +-inf), as NumPy's
    float32 rounds it: the generator does not import NumPy for one conversion."""
    try:
        return struct.unpack("f", struct.pack("f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)


def literal(x: mpmath.mpf, ctype: str) -> str:
    """A C literal of x for the C type (float, double, long double)."""
    if ctype == "float":
        s = repr(_as_float32(float(x)))
        suffix = "f"
    elif ctype == "double":
        s = repr(float(x))
        suffix = ""
    else:
        with mpmath.workdps(DIGITS):
            s = mpmath.nstr(x, 36, min_fixed=-4, max_fixed=5)
        suffix = "L"
    if "." not in s and "e" not in s and "inf" not in s:
        s += ".0"
    if s.startswith("-"):
        return f"({s}{suffix})"
    return s + suffix


def py_literal(x: mpmath.mpf) -> str:
    """A decimal string with 36 digits, parsed per dtype by the NumPy integrators."""
    with mpmath.workdps(DIGITS):
        return mpmath.nstr(x, 36, min_fixed=-4, max_fixed=5)


@dataclass
class Tableau:
    name: str
    order: int
    stages: int                                   # stages of one step (FSAL stage included)
    c: list[mpmath.mpf]
    a: dict[tuple[int, int], mpmath.mpf]          # (row, col) -> value, non-zero only
    b: list[mpmath.mpf]
    extra: dict = field(default_factory=dict)     # error estimator and dense output data

    def row(self, i: int) -> list[tuple[int, mpmath.mpf]]:
        return sorted((j, v) for (r, j), v in self.a.items() if r == i and v != 0)


def _entries_n(items: list[str], nidx: int) -> dict[tuple[int, ...], mpmath.mpf]:
    out = {}
    for item in items:
        words = item.split()
        out[tuple(int(w) for w in words[:nidx])] = value(" ".join(words[nidx:]))
    return out


@lru_cache(maxsize=None)
def load(name: str) -> Tableau:
    """One of: rk4, dopri5, dop853, midpoint, gauss2."""
    files = {"rk4": "rk4.toml", "dopri5": "dopri5.toml", "dop853": "dop853.toml",
             "midpoint": "gauss.toml", "gauss2": "gauss.toml"}
    if name not in files:
        raise ValueError(f"unknown tableau '{name}' (known: {', '.join(files)})")
    data = tomllib.loads(tableau_file(files[name]).read_text())[name]
    a = {k: v for k, v in _entries_n(data["a"], 2).items()}
    c = [value(x) for x in data["c"]]
    extra: dict = {}
    if name == "dopri5":
        s = data["stages"] + 1                     # the FSAL stage is part of the step
        b = [a.get((6, j), mpmath.mpf(0)) for j in range(s)]
        extra["e"] = {k[0]: v for k, v in _entries_n(data["e"], 1).items()}
        extra["p"] = _entries_n(data["p"], 2)
    elif name == "dop853":
        s = data["stages"]
        b = [a.get((12, j), mpmath.mpf(0)) for j in range(s)]
        extra["e3_minus"] = {k[0]: v for k, v in _entries_n(data["e3_minus"], 1).items()}
        extra["e5"] = {k[0]: v for k, v in _entries_n(data["e5"], 1).items()}
        extra["d"] = _entries_n(data["d"], 2)
        extra["stages_dense"] = data["stages_dense"]
    else:
        s = data["stages"]
        b = [value(x) for x in data["b"]]
    return Tableau(name, data["order"], s, c, a, b, extra)


def gauss_d(t: Tableau) -> list[mpmath.mpf]:
    """d = b^T A^-1: the update x1 = x0 + sum_i d_i Z_i from the stage increments Z."""
    with mpmath.workdps(DIGITS + 10):
        s = t.stages
        A = mpmath.matrix(s, s)
        for (i, j), v in t.a.items():
            A[i, j] = v
        b = mpmath.matrix([t.b])
        d = b * mpmath.inverse(A)
        return [d[0, j] for j in range(s)]


@lru_cache(maxsize=None)
def adams(k: int) -> tuple[list[sp.Rational], list[sp.Rational]]:
    """Exact weights of the k-step Adams pair, derived from their definition.

    Both integrate, over one step [t_n, t_n + h], the polynomial that interpolates the
    rhs at k equally spaced past times (s = (t - t_n)/h):
    - Adams-Bashforth (explicit, order k): nodes s = 0, -1, ..., -(k-1);
      y_{n+1} = y_n + h sum_j ab[j] f_{n-j};
    - Adams-Moulton (implicit, order k): nodes s = 1, 0, ..., -(k-2);
      y_{n+1} = y_n + h (am[0] f_{n+1} + sum_{j>=1} am[j] f_{n+1-j}).
    ab[j] is the integral over s in [0, 1] of the Lagrange basis polynomial of node j.
    """
    if k < 1:
        raise ValueError("an Adams method needs at least one step")

    def weights(nodes):
        # exact arithmetic over Q on coefficient lists (lowest power first): the same
        # rationals as SymPy's Poly over QQ, without its construction per factor
        out = []
        for j, nj in enumerate(nodes):
            basis = [Fraction(1)]
            for m, nm in enumerate(nodes):
                if m != j:              # times (s - nm) / (nj - nm)
                    scale = Fraction(1, nj - nm)
                    shifted = [Fraction(0)] + basis
                    basis = [hi * scale - nm * scale * lo
                             for hi, lo in zip(shifted, basis + [Fraction(0)])]
            integral = sum(c / (p + 1) for p, c in enumerate(basis))      # over s in [0, 1]
            out.append(sp.Rational(integral.numerator, integral.denominator))
        return out

    return weights([-j for j in range(k)]), weights([1 - j for j in range(k)])


@lru_cache(maxsize=None)
def adams_milne(k: int) -> sp.Rational:
    """Milne's factor of the k-step Adams pair: the corrector's local error is about
    C_AM / (C_AB - C_AM) (y_corrected - y_predicted), with C the error constants (the
    residual of each formula on y = s^(k+1)/(k+1)!, f = s^k/k!, over one unit step)."""
    ab, am = adams(k)
    exact = sp.Rational(1, sp.factorial(k + 1))
    c_ab = exact - sum(w * sp.Integer(-j) ** k for j, w in enumerate(ab)) / sp.factorial(k)
    c_am = exact - sum(w * sp.Integer(1 - j) ** k for j, w in enumerate(am)) / sp.factorial(k)
    return abs(c_am / (c_ab - c_am))
