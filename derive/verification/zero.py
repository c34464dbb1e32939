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
from sympy.polys.domains import QQ
from sympy.polys.orderings import lex
from sympy.polys.rings import ring

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


def _matrix(x) -> sp.Matrix:
    """An expression as a 1x1 matrix; a matrix (or nested list) as a matrix."""
    return sp.Matrix(x) if not isinstance(x, sp.Expr) else sp.Matrix([x])


def matrix_is_zero(m, angles) -> bool:
    return all(trig_is_zero(e, angles) for e in _matrix(m))


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
    m = _matrix(expr)
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


# -- a faster exact test for rational trigonometric expressions ---------------
#
# trig_is_zero's tangent half-angle substitution doubles every degree and then
# needs ``together`` on a large nested rational expression, which is slow for
# expressions with inverses in them (the block inverse of (3.39), Hamilton's
# equations).  The same decision can be made in the polynomial ring
#     Q[R_k, s_x, c_x, other symbols] / (R_k^2 - f_k, s_x^2 + c_x^2 - 1):
# replace sin x -> s_x, cos x -> c_x, bring the expression to one fraction
# without gcd computations, and reduce the numerator modulo the relations.
# The leading monomials R_k^2, s_x^2 are pairwise coprime, so the relations
# are a Groebner basis and the remainder is a normal form: it is 0 exactly when
# the expression vanishes identically.  (The circle s^2 + c^2 = 1 is Zariski
# dense in its complexification, and each R_k = sqrt(f_k) is assumed not to be
# a rational function of the sines and cosines, which holds for the polar
# sines used here, so a + b R_k = 0 forces a = b = 0.)

def _trig_symbols(angles):
    subs, pairs = {}, []
    for x in angles:
        s, c = sp.Symbol(f"_s_{x.name}"), sp.Symbol(f"_c_{x.name}")
        subs[sp.sin(x)], subs[sp.cos(x)] = s, c
        pairs.append((s, c))
    return subs, pairs


class _Fractions:
    """Convert a SymPy expression to a ring numerator over a factored denominator.

    The denominator is kept as {factor: power} with the factors as they come
    (no gcds): sums take the least common multiple of the factor sets, so
    repeated denominators such as det(D1) or m2 do not pile up.
    """

    def __init__(self, ring_, gens):
        self.ring = ring_
        self.gens = dict(zip(gens, ring_.gens))
        self.memo: dict = {}

    def __call__(self, e):
        if e not in self.memo:
            self.memo[e] = self._convert(e)
        return self.memo[e]

    def _scaled(self, num, den: dict, target: dict):
        for f, k in target.items():
            if k > den.get(f, 0):
                num = num * f ** (k - den.get(f, 0))
        return num

    def _convert(self, e):
        if e in self.gens:
            return self.gens[e], {}
        if e.is_Rational:
            return self.ring(QQ(int(e.p), int(e.q))), {}
        if e.is_Add:
            parts = [self(a) for a in e.args]
            den: dict = {}
            for _, d in parts:
                for f, k in d.items():
                    den[f] = max(den.get(f, 0), k)
            return sum((self._scaled(n, d, den) for n, d in parts), self.ring.zero), den
        if e.is_Mul:
            num, den = self.ring.one, {}
            for a in e.args:
                n, d = self(a)
                num = num * n
                for f, k in d.items():
                    den[f] = den.get(f, 0) + k
            return num, den
        if e.is_Pow and e.exp.is_Integer:
            n, d = self(e.base)
            k = int(e.exp)
            if k >= 0:
                return n**k, {f: j * k for f, j in d.items()}
            num = self.ring.one
            for f, j in d.items():
                num = num * f ** (-j * k)
            return num, ({n: -k} if n != self.ring.one else {})
        raise ValueError(f"not rational in the ring's generators: {e}")


def circle_is_zero(expr, angles: Iterable[sp.Symbol], roots=()) -> bool:
    """True iff ``expr`` vanishes identically (same decision as :func:`trig_is_zero`).

    ``expr`` is rational in the sines and cosines of ``angles``, in other
    symbols, and in root symbols R with R**2 = f (``roots`` = [(R, f), ...],
    f rational in the sines and cosines; R is the positive root).
    """
    angles = list(angles)
    subs, pairs = _trig_symbols(angles)
    expr = sp.expand_trig(sp.sympify(expr)).xreplace(subs)
    leftover = [f for f in expr.atoms(sp.Function) if f.free_symbols & set(angles)]
    if leftover:
        raise ValueError(f"not rational in sin/cos of the angles: {leftover[0]}")
    root_syms = [r for r, _ in roots]
    trig_gens = [g for pair in pairs for g in pair]
    known = set(root_syms) | set(trig_gens)
    others = sorted(expr.free_symbols - known, key=lambda s: s.name)
    gens = root_syms + trig_gens + others
    ring_, *_ = ring(gens, QQ, lex)
    to_ring = _Fractions(ring_, gens)
    numerator, _ = to_ring(expr)
    if numerator == 0:
        return True
    relations = [ring_(to_ring(s**2 + c**2 - 1)[0]) for s, c in pairs]
    for r, f in roots:
        n, d = to_ring(sp.expand_trig(sp.sympify(f)).xreplace(subs))
        if d:   # R^2 - f must be monic in R for the division to be a normal form
            raise ValueError("root radicand must be a polynomial in the sines and cosines")
        relations.insert(0, to_ring(r)[0] ** 2 - n)
    return numerator.rem(relations) == 0


def circle_matrix_is_zero(m, angles, roots=()) -> bool:
    return all(circle_is_zero(e, angles, roots) for e in _matrix(m))


def trig_angles(*exprs) -> list[sp.Symbol]:
    """The symbols that occur inside a sine or cosine (the angles of a trig test)."""
    found: set = set()
    for e in exprs:
        for entry in _matrix(e):
            for f in entry.atoms(sp.sin, sp.cos):
                found |= f.free_symbols
    return sorted(found, key=lambda s: s.name)


# -- fast numeric evaluation --------------------------------------------------
#
# ``evaluate`` substitutes and calls N on every entry; compiling the
# expression once with lambdify(modules="mpmath") gives the same 40-digit
# values far faster when many points are needed.

def mp_function(expr, symbols=None):
    """Compile ``expr`` (expression or matrix) to point -> list of mpmath numbers.

    ``symbols`` defaults to the expression's free symbols (the point must give them all).
    """
    m = _matrix(expr)
    symbols = sorted(m.free_symbols, key=str) if symbols is None else list(symbols)
    f = sp.lambdify(symbols, list(m), modules="mpmath")

    def at(point: dict) -> list:
        with mpmath.workdps(DIGITS):
            return [mpmath.mpmathify(v) for v in f(*[point[s] for s in symbols])]
    return at


def relative_error(xs, ys) -> float:
    """max |x - y| / max(|x|, |y|, 1) over paired values."""
    with mpmath.workdps(DIGITS):
        return max((float(abs(x - y) / max(abs(x), abs(y), 1)) for x, y in zip(xs, ys)),
                   default=0.0)


# -- many points at once ------------------------------------------------------------
#
# lambdify prints and compiles every expression, and the compiled code recomputes each
# repeated subexpression; the claims' expressions are large trees with many shared
# subtrees (the derivation's M and F).  Walking the tree once, each distinct subtree
# evaluated once for all the points together, gives the same 40-digit values for less.

_MP_FUNCTIONS = {sp.sin: mpmath.sin, sp.cos: mpmath.cos, sp.tan: mpmath.tan,
                 sp.asin: mpmath.asin, sp.acos: mpmath.acos, sp.atan: mpmath.atan,
                 sp.atan2: mpmath.atan2, sp.exp: mpmath.exp, sp.log: mpmath.log,
                 sp.sinh: mpmath.sinh, sp.cosh: mpmath.cosh, sp.tanh: mpmath.tanh,
                 sp.Abs: abs, sp.sign: mpmath.sign}


class Unsupported(ValueError):
    """An expression :func:`mp_values` cannot walk (mp_function can: lambdify it)."""


class _PointValues:
    """The values of SymPy expressions at several points: expression -> one value a point,
    every distinct subexpression evaluated once (the memo)."""

    def __init__(self, points: list[dict]):
        self.n = len(points)
        self.memo: dict = {}
        self.points = points

    def __call__(self, e) -> list:
        values = self.memo.get(e)
        if values is None:
            values = self.memo[e] = self._evaluate(e)
        return values

    def _constant(self, value) -> list:
        return [value] * self.n

    def _evaluate(self, e) -> list:
        if e.is_Symbol:
            try:
                return [pt[e] for pt in self.points]
            except KeyError:
                raise Unsupported(f"no value for {e}") from None
        if e.is_Integer:
            return self._constant(mpmath.mpf(int(e)))
        if e.is_Rational:
            return self._constant(mpmath.mpf(int(e.p)) / int(e.q))
        if e.is_Float:
            return self._constant(mpmath.mpf(e))
        if e is sp.pi:
            return self._constant(+mpmath.pi)
        if e is sp.E:
            return self._constant(+mpmath.e)
        if e.is_Add or e.is_Mul:
            return self._fold(e)
        if e.is_Pow:
            return self._power(e)
        f = _MP_FUNCTIONS.get(type(e))
        if f is None:
            raise Unsupported(f"cannot evaluate {type(e).__name__}")
        args = [self(a) for a in e.args]
        return [f(*xs) for xs in zip(*args)]

    def _fold(self, e) -> list:
        first, *rest = [self(a) for a in e.args]
        out = list(first)
        for values in rest:
            if e.is_Add:
                out = [x + y for x, y in zip(out, values)]
            else:
                out = [x * y for x, y in zip(out, values)]
        return out

    def _power(self, e) -> list:
        base, k = self(e.base), e.exp
        if k.is_Integer:
            return [x ** int(k) for x in base]
        if k == sp.S.Half:
            return [mpmath.sqrt(x) for x in base]
        if k == -sp.S.Half:
            return [1 / mpmath.sqrt(x) for x in base]
        return [mpmath.power(x, y) for x, y in zip(base, self(k))]


def mp_values(expr, points: list[dict]) -> list[list]:
    """The values of `expr` (expression or matrix) at each point, 40 digits: what
    ``[mp_function(expr)(pt) for pt in points]`` gives, for a fraction of the work.

    Parameters
    ----------
    expr : sympy expression or matrix
    points : list of dict
        Symbol -> mpmath number; each point gives every free symbol of `expr`.

    Returns
    -------
    list of list
        One list a point, of the entries' values (a matrix row by row).

    Raises
    ------
    Unsupported
        For a node outside arithmetic and the elementary functions (use mp_function).
    """
    entries = list(_matrix(expr))
    with mpmath.workdps(DIGITS):
        values = _PointValues(points)
        columns = [[mpmath.mpmathify(v) for v in values(e)] for e in entries]
    return [[column[k] for column in columns] for k in range(len(points))]
