"""Deciding whether a trigonometric expression is identically zero.

Simplification heuristics (``simplify``) can fail to find a zero and are slow.
A decision procedure is cheap for our expressions, which are rational in the
sines and cosines of the angles: expand multiple angles and angle sums
(``expand_trig``), substitute the tangent half-angle parametrisation
    sin x = 2t/(1+t^2),  cos x = (1-t^2)/(1+t^2)
for every angle, and the result is a rational function of the t's, which is
zero exactly when its numerator expands to 0.
"""
from __future__ import annotations

import random
from typing import Iterable

import mpmath
import sympy as sp

DIGITS = 40           # working precision of the numeric comparison
TOLERANCE_DIGITS = 30  # agreement demanded: relative 1e-30


def _half_angle(expr: sp.Expr, angles: Iterable[sp.Symbol]) -> sp.Expr:
    subs = {}
    for x in angles:
        t = sp.Dummy(f"t_{x.name}", real=True)
        subs[sp.sin(x)] = 2 * t / (1 + t**2)
        subs[sp.cos(x)] = (1 - t**2) / (1 + t**2)
    return expr.xreplace(subs)


def trig_is_zero(expr: sp.Expr, angles: Iterable[sp.Symbol]) -> bool:
    """True iff ``expr`` (rational in sin/cos of ``angles`` and other symbols) is 0."""
    expr = sp.expand_trig(sp.sympify(expr))
    if expr == 0:
        return True
    angles = list(angles)
    rational = _half_angle(expr, angles)
    leftover = [f for f in rational.atoms(sp.Function) if f.free_symbols & set(angles)]
    if leftover:
        raise ValueError(f"not rational in sin/cos of the angles: {leftover[0]}")
    numerator, _ = sp.fraction(sp.together(rational))
    return sp.expand(numerator) == 0


def matrix_is_zero(m, angles) -> bool:
    m = sp.Matrix(m) if not isinstance(m, sp.Expr) else sp.Matrix([m])
    return all(trig_is_zero(e, angles) for e in m)


def random_point(symbols: Iterable[sp.Symbol], rng: random.Random,
                 overrides: dict[str, tuple[float, float]] | None = None) -> dict:
    """A random point with 40-digit mpmath values.

    Angles anywhere on the circle, rates in [-3, 3], positive parameters in
    [0.3, 3]: every quadrant and sign is visited over a handful of points.
    """
    overrides = overrides or {}
    point = {}
    for s in symbols:
        lo, hi = overrides.get(s.name, (0.3, 3.0) if s.is_positive else (-3.0, 3.0)
                               if "_dot" in s.name or s.name.startswith("p_") else (-3.14159, 3.14159))
        with mpmath.workdps(DIGITS):
            point[s] = mpmath.mpf(lo) + (mpmath.mpf(hi) - mpmath.mpf(lo)) * mpmath.mpf(rng.random())
    return point


def evaluate(expr, point: dict) -> list:
    """Evaluate an expression or matrix at a point with DIGITS significant digits."""
    m = sp.Matrix(expr) if not isinstance(expr, sp.Expr) else sp.Matrix([expr])
    subs = {k: sp.Float(str(v), DIGITS + 5) for k, v in point.items()}
    return [sp.N(e.xreplace(subs), DIGITS) for e in m]


def numeric_max_error(a, b, symbols, n_points: int = 20, seed: int = 1,
                      overrides=None) -> float:
    """Largest relative difference of a and b over n random points (40 digits)."""
    rng = random.Random(seed)
    worst = 0.0
    for _ in range(n_points):
        point = random_point(symbols, rng, overrides)
        for x, y in zip(evaluate(a, point), evaluate(b, point)):
            scale = max(abs(x), abs(y), 1)
            worst = max(worst, float(abs(x - y) / scale))
    return worst
