"""Stage 3: the kinds of claim a seed prints, and the comparison of one with the derivation.

The transcriptions live in :mod:`seed_formulas` (one :class:`Claim` each), the
recorded errata in :mod:`errata`, and :mod:`judge` runs them all.  This module holds
the machinery:

* :class:`Context` -- what a printed or a derived formula may use for one
  model: symbols by name, mu, the link vectors and their chart derivatives,
  the model's Lagrangian in the seed's Cartesian link components, the
  derivation's M, F, the reduced matrices obtained from them, chart inversion.
* :func:`compare` -- the verdict machinery.  An algebraic identity holds when
  printed - derived is exactly zero (:func:`zero.circle_is_zero`, a decision
  procedure) AND numerically below 1e-30 relative at >= 20 random states
  computed with 40 digits.  atan2 forms are checked geometrically at states in
  every quadrant plus an exact direction check.
* :func:`run_all` -- every claim against the derivation and the errata.

A claim's verdict is "match", "erratum" (a recorded erratum whose pinned
discrepancy and correction both hold exactly), or "FAIL" (anything else: a
printed formula differing from the derivation without a recorded erratum, or
a recorded erratum that no longer reproduces).
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass
from functools import cache, cached_property
from typing import Any, Callable

import mpmath
import sympy as sp

from .. import cachefile
from ..derivation import derive
from ..derivation.lagrange import link_directions, link_vectors
from ..derivation.symbols import parse_quantity
from . import zero

SEED0 = "000_22f1304773697fe8.txt"
SEED1 = "001_025e500cdf7d3415.txt"
N_POINTS = 24                 # random states per numeric check (>= 20)
TOLERANCE = 1e-30             # relative agreement demanded, 40-digit arithmetic


# -- the objects a claim's two sides may be -----------------------------------

@dataclass(frozen=True)
class Solve:
    """The x with P x = r, P invertible: names A^-1 r without inverting A.

    Exact comparisons premultiply by P (x - y = 0 iff P x - r = 0); numeric
    ones solve the linear system at each point.
    """
    P: sp.Matrix
    r: sp.Matrix


@dataclass(frozen=True)
class IllFormed:
    """A printed expression that cannot be evaluated, e.g. a product of matrices
    whose shapes do not fit (a dimension mismatch on the page)."""
    operands: tuple
    reason: str


@dataclass(frozen=True)
class ShapeMismatch:
    """The discrepancy of a dimension mismatch.

    ``printed`` is the printed object's shape, or the operand shapes of an
    ill-formed product; ``missing`` lists (index, entry) of the derived vector
    that the printed one lacks, when the printed vector is the derived one with
    entries left out.
    """
    printed: tuple
    derived: tuple
    missing: tuple = ()


@dataclass(frozen=True)
class AtanForm:
    """Printed angle formulas of a chart change (5.2)-(5.5).

    ``values`` maps target-chart angles to printed atan2 expressions in the
    source chart's variables (and possibly other target angles, which are then
    taken at their true values).  The claim holds when the target chart's link
    vector at these angles is the source point.
    """
    target: str
    values: dict


@dataclass(frozen=True)
class QuadrantError:
    """Discrepancy of an atan2 form: atan2(Y, X) points along the right direction
    (Y cos x - X sin x = 0 exactly) but X cos x + Y sin x = rho changes sign,
    so where rho < 0 the printed angle is the true one +- pi."""
    angle: sp.Symbol
    rho: sp.Expr


@dataclass(frozen=True)
class ChartRule:
    """A printed rule choosing a chart from a standard-chart state (5.1)."""
    choose: Callable
    bound: float


@dataclass(frozen=True)
class Claim:
    seed: str
    equation: str
    what: str
    model: str
    printed: Callable[["Context"], Any]
    derived: Callable[["Context"], Any]
    kind: str = "identity"            # "identity", "angle" or "rule"
    # For claims relating two charts at one point: expressions of the target
    # chart's trig functions in the source chart's (exact test, with roots) and
    # of the target angles (numeric test).  Both come from Context.
    point_map: Callable[["Context"], "PointMap"] | None = None

    @property
    def key(self) -> tuple[str, str, str]:
        return (self.seed, self.equation, self.what)


@dataclass
class Comparison:
    holds: bool
    exact: bool | None            # the exact test (None: no exact test possible)
    numeric_error: float          # worst relative error over the points
    discrepancy: Any              # printed - derived: expression, matrix, ShapeMismatch, ...
    note: str = ""


@cachefile.register
@dataclass
class Result:
    seed: str
    equation: str
    what: str
    model: str
    verdict: str                  # "match", "erratum" or "FAIL"
    summary: str
    seconds: float = 0.0

    @property
    def key(self) -> tuple[str, str, str]:
        return (self.seed, self.equation, self.what)


# -- the context: everything the formulas of one model may use ---------------

@dataclass(frozen=True)
class PointMap:
    """One point seen from two charts: trig of ``angles`` in terms of the others."""
    trig: dict                    # sin/cos of the mapped angles -> expressions
    roots: tuple                  # ((R, R^2), ...) root symbols used in ``trig``
    angles: dict                  # mapped angle -> exact expression (acos/atan2)


class Context:
    """Symbols and derived quantities of one model, for the two sides of claims.

    Attribute access by name gives the model's symbols: coordinates
    (``c.theta1``), rates (``c.theta1_dot``), accelerations
    (``c.theta1_ddot``), parameters (``c.m1``), the seed's Cartesian link
    components (``c.p1``, ``c.q1``, ``c.r1`` and their ``_dot``/``_ddot``).
    """

    def __init__(self, model: str):
        self.model = model
        self.d = derive(model)
        s = self.d.symbols
        self.q, self.qd = s.q, s.qd
        self.qdd = tuple(sp.Symbol(f"{x.name}_ddot", real=True) for x in s.q)
        self.mu = sp.Symbol("mu", positive=True)
        self.n_links = len(self.d.model.links)
        axes = "pqr"[:self.d.model.dimension]
        self._cart = [[[sp.Symbol(f"{a}{i}{suffix}", real=True) for a in axes]
                       for i in range(1, self.n_links + 1)]
                      for suffix in ("", "_dot", "_ddot")]
        names = list(self.q) + list(self.qd) + list(self.qdd) + list(s.p) + list(s.params)
        names += [x for level in self._cart for link in level for x in link]
        self._by_name = {x.name: x for x in names}

    def __getattr__(self, name):
        by_name = self.__dict__.get("_by_name", {})
        if name in by_name:
            return by_name[name]
        raise AttributeError(name)

    # parameters and mu
    @property
    def mu_value(self) -> sp.Expr:
        return 1 + self.m1 / self.m2

    def with_mu(self, x):
        """mu = 1 + m1/m2 substituted (the seed writes mu; the derivation has masses)."""
        return _map(x, lambda e: e.xreplace({self.mu: self.mu_value}))

    def length(self, i: int) -> sp.Expr:
        return parse_quantity(self.d.model.links[i - 1].length, self.d.symbols)

    # coordinates of link i (1-based, as on the page)
    def _slice(self, seq, i):
        k = sum(len(l.chart.coordinates) for l in self.d.model.links[:i - 1])
        return tuple(seq[k:k + len(self.d.model.links[i - 1].chart.coordinates)])

    def coords(self, i):
        return self._slice(self.q, i)

    def rates(self, i):
        return self._slice(self.qd, i)

    def accels(self, i):
        return self._slice(self.qdd, i)

    # link vectors q_i in the chart and their derivatives
    @cached_property
    def _qvecs(self):
        return link_vectors(self.d.model, self.d.symbols)

    @cached_property
    def _units(self):
        return link_directions(self.d.model, self.d.symbols)

    def qvec(self, i: int) -> sp.Matrix:
        return self._qvecs[i - 1]

    def unit(self, i: int) -> sp.Matrix:
        return self._units[i - 1]

    def dq(self, i: int, *wrt) -> sp.Matrix:
        """Partial derivative(s) of q_i with respect to chart coordinates."""
        return self.qvec(i).diff(*wrt)

    # time derivatives by the chain rule along (x, x', x'') chains
    @cached_property
    def _chains(self):
        chains = list(zip(self.q, self.qd, self.qdd))
        pos, vel, acc = self._cart
        for i in range(self.n_links):
            chains += list(zip(pos[i], vel[i], acc[i]))
        return chains

    def ddt(self, x):
        """d/dt of an expression or matrix in positions and rates (accelerations appear)."""
        return _map(x, lambda e: sum((e.diff(a) * ad + e.diff(ad) * add
                                      for a, ad, add in self._chains), sp.S.Zero))

    def qdot(self, i):
        return self.ddt(self.qvec(i))

    def qddot(self, i):
        return self.ddt(self.qdot(i))

    # the seed's Cartesian link components q_i = (p_i, q_i[, r_i])
    def cart(self, i):
        return sp.Matrix(self._cart[0][i - 1])

    def cart_dot(self, i):
        return sp.Matrix(self._cart[1][i - 1])

    def cart_ddot(self, i):
        return sp.Matrix(self._cart[2][i - 1])

    @cached_property
    def _to_chart(self):
        m = {}
        for i in range(1, self.n_links + 1):
            for level, vec in zip(self._cart, (self.qvec(i), self.qdot(i), self.qddot(i))):
                m.update(zip(level[i - 1], vec))
        return m

    def to_chart(self, x):
        """Replace the Cartesian link components by their chart expressions."""
        return _map(x, lambda e: e.xreplace(self._to_chart))

    @cached_property
    def L_cart(self) -> sp.Expr:
        """The model's Lagrangian written in the link components q_i, q_i'.

        Built from the model description exactly as the derivation builds its
        positions (mass centre = previous links + com * q_i; rod rotation
        energy 1/2 I |q_i'|^2 / l_i^2); claim (1.13) checks it equals d.L.
        """
        g, T, V = self.g, sp.S.Zero, sp.S.Zero
        base = sp.zeros(self.d.model.dimension, 1)
        base_dot = base
        for i, link in enumerate(self.d.model.links, 1):
            s = self.d.symbols
            m, com = parse_quantity(link.body.mass, s), parse_quantity(link.body.com, s)
            inertia = parse_quantity(link.body.inertia, s)
            c, c_dot = base + com * self.cart(i), base_dot + com * self.cart_dot(i)
            spin = self.cart_dot(i).dot(self.cart_dot(i)) / self.length(i)**2   # |e_i'|^2
            T += m * c_dot.dot(c_dot) / 2 + inertia * spin / 2
            V += m * g * c[-1]
            base, base_dot = base + self.cart(i), base_dot + self.cart_dot(i)
        return sp.expand(T - V)

    def dL_dcart(self, i):
        """dL/dq_i, the gradient in the Cartesian components (1.5), (2.5)."""
        return sp.Matrix([self.L_cart.diff(x) for x in self.cart(i)])

    def dL_dcart_dot(self, i):
        """dL/dq_i'."""
        return sp.Matrix([self.L_cart.diff(x) for x in self.cart_dot(i)])

    def lagrange_lhs(self, coordinate):
        """d/dt dL/dx' - dL/dx of the model's own L, for a coordinate x."""
        x_dot = self.qd[self.q.index(coordinate)]
        L = self.d.L
        return sp.expand(self.ddt(L.diff(x_dot)) - L.diff(coordinate))

    # the derivation's equations, divided by m2 where the seed does
    @property
    def qdd_vec(self):
        return sp.Matrix(self.qdd)

    @cached_property
    def lagrange_per_m2(self) -> sp.Matrix:
        """(M q'' - F) / m2: Lagrange's equations in the mu-form of (2.20)."""
        return (self.d.M * self.qdd_vec - self.d.F) / self.m2

    @cached_property
    def S(self) -> sp.Matrix:
        """diag(1, polar sine 1, 1, polar sine 2): the reduction of (3.27), (4.8)."""
        s1, s2 = self.d.polar_sines
        return sp.diag(1, s1, 1, s2)

    @cached_property
    def S_inv(self) -> sp.Matrix:
        s1, s2 = self.d.polar_sines
        return sp.diag(1, 1 / s1, 1, 1 / s2)

    @cached_property
    def A_lagrange(self) -> sp.Matrix:
        """A of (2.20) from the Lagrangian route: M / m2."""
        return self.d.M / self.m2

    @cached_property
    def rate_vector(self) -> sp.Matrix:
        """w of (2.20): (u1'^2, 2u1'v1', v1'^2, u2'^2, 2u2'v2', v2'^2), from the rates."""
        w = []
        for i in (1, 2):
            u, v = self.rates(i)
            w += [u**2, 2 * u * v, v**2]
        return sp.Matrix(w)

    @cached_property
    def G_lagrange(self) -> sp.Matrix:
        """Gravity vector of (2.20) from the Lagrangian route: -F/m2 at rest."""
        return (-self.d.F / self.m2).xreplace({r: 0 for r in self.qd}).applyfunc(sp.expand)

    @cached_property
    def B_lagrange(self) -> sp.Matrix:
        """B of (2.20) from the Lagrangian route: -F/m2 = B w + G, read off the
        coefficients of the rate monomials (2u'v' carries the factor 2).

        Claim (2.20) checks that B w + G reproduces -F/m2 exactly, i.e. that F
        has no other rate monomials."""
        monomials, weights = [], []
        for i in (1, 2):
            u, v = self.rates(i)
            monomials += [u**2, u * v, v**2]
            weights += [1, sp.Rational(1, 2), 1]
        rows = []
        for Fj in self.d.F:
            poly = sp.Poly(sp.expand(-Fj / self.m2), *self.qd)
            rows.append([wt * poly.coeff_monomial(mo) for mo, wt in zip(monomials, weights)])
        return sp.Matrix(rows)

    @cached_property
    def A_red_lagrange(self) -> sp.Matrix:
        """A-tilde = S^-1 A S^-1 (3.27)-(3.28), A from the Lagrangian route."""
        return self.S_inv * self.A_lagrange * self.S_inv

    @cached_property
    def B_red_lagrange(self) -> sp.Matrix:
        return self.S_inv * self.B_lagrange

    @cached_property
    def G_red_lagrange(self) -> sp.Matrix:
        return self.S_inv * self.G_lagrange

    @cached_property
    def reduced_lagrange(self) -> sp.Matrix:
        """S^-1 (M q'' - F)/m2: the reduced equations (3.27), (4.8), from the Lagrangian."""
        return self.S_inv * self.lagrange_per_m2

    def other(self, model: str) -> "Context":
        return context(model)

    # one point in two charts (section 5): chart inversion from the chart's own formula
    def chart_parts(self, i: int = 1):
        """Which component of link i's unit vector is +-cos u, +-sin u cos v, +-sin u sin v."""
        u, v = self.coords(i)
        e = self.unit(i)
        shapes = {"cos": sp.cos(u), "sincos": sp.sin(u) * sp.cos(v), "sinsin": sp.sin(u) * sp.sin(v)}
        parts = {}
        for k, comp in enumerate(e):
            for name, shape in shapes.items():
                for sign in (1, -1):
                    if sp.expand(comp - sign * shape) == 0:
                        parts[name] = (k, sign)
        if len(parts) != 3:
            raise ValueError(f"{self.model}: link {i} is not a spherical chart")
        return parts

    def point_map(self, e: sp.Matrix, root: sp.Symbol, i: int = 1) -> PointMap:
        """This chart's link-i angles at the unit vector ``e`` (u in (0, pi)).

        cos u = +-e_k, sin u = R = sqrt(e_a^2 + e_b^2) > 0, cos v = +-e_a / R,
        sin v = +-e_b / R -- read off the chart's own unit vector.
        """
        u, v = self.coords(i)
        parts = self.chart_parts(i)
        (k, sk), (a, sa), (b, sb) = parts["cos"], parts["sincos"], parts["sinsin"]
        trig = {sp.cos(u): sk * e[k], sp.sin(u): root,
                sp.cos(v): sa * e[a] / root, sp.sin(v): sb * e[b] / root}
        radicand = sp.expand(e[a]**2 + e[b]**2)
        angles = {u: sp.acos(sk * e[k]), v: sp.atan2(sb * e[b], sa * e[a])}
        return PointMap(trig, ((root, radicand),), angles)


@cache
def context(model: str) -> Context:
    return Context(model)


def _map(x, f):
    if isinstance(x, sp.MatrixBase):
        return x.applyfunc(f)
    return f(sp.sympify(x))


# -- comparison ----------------------------------------------------------------

def _as_matrix(x) -> sp.Matrix:
    return sp.Matrix(x) if isinstance(x, sp.MatrixBase) else sp.Matrix([sp.sympify(x)])


def _domain(symbols) -> dict:
    """Random ranges: polar angles in (0, pi) (the charts' domain), rest as zero.random_point."""
    return {s.name: (0.0, math.pi) for s in symbols
            if s.name.rstrip("0123456789") in ("theta", "vartheta")}


def sample(symbols, n: int = N_POINTS, seed: int = 1) -> list[dict]:
    """`n` random points of `symbols` (40 digits; the same points for the same symbols).
    Do not modify them: they are shared."""
    return _sample(tuple(sorted(symbols, key=lambda s: s.name)), n, seed)


@cache
def _sample(symbols: tuple, n: int, seed: int) -> list[dict]:
    rng = random.Random(seed)
    return [zero.random_point(symbols, rng, _domain(symbols)) for _ in range(n)]


def _free(*xs) -> set:
    out: set = set()
    for x in xs:
        if isinstance(x, Solve):
            out |= x.P.free_symbols | x.r.free_symbols
        else:
            out |= _as_matrix(x).free_symbols
    return out


def _mp_matrix(values, shape):
    m = mpmath.matrix(*shape)
    for k, v in enumerate(values):
        m[k // shape[1], k % shape[1]] = v
    return m


def _values(x, points) -> list[list]:
    """Values of an expression or matrix at each point (40 digits)."""
    try:
        return zero.mp_values(x, points)
    except zero.Unsupported:          # a node the walk does not know: lambdify it
        f = zero.mp_function(x, sorted(_free(x), key=lambda s: s.name))
        return [f(pt) for pt in points]


def _numeric(x, points) -> list[list]:
    """Values of an expression, matrix or Solve at each point (40 digits)."""
    if not isinstance(x, Solve):
        return _values(x, points)
    out = []
    for P, r in zip(_values(x.P, points), _values(x.r, points)):
        with mpmath.workdps(zero.DIGITS):
            sol = mpmath.inverse(_mp_matrix(P, x.P.shape)) * _mp_matrix(r, x.r.shape)
            out.append([sol[k // x.r.shape[1], k % x.r.shape[1]] for k in range(len(x.r))])
    return out


def _shape(x):
    return x.P.shape[:1] + x.r.shape[1:] if isinstance(x, Solve) else _as_matrix(x).shape


def _exact_zero(x, roots=()) -> bool:
    m = _as_matrix(x)
    angles = zero.trig_angles(m)
    return zero.circle_matrix_is_zero(m, angles, roots)


def _shape_mismatch(printed, derived) -> ShapeMismatch:
    if isinstance(printed, IllFormed):
        return ShapeMismatch(printed.operands, _shape(derived))
    p, dm = _as_matrix(printed), _as_matrix(derived)
    missing, k = [], 0
    if p.shape[1] == dm.shape[1] == 1:
        # the printed vector as the derived one with entries left out?
        for idx, entry in enumerate(dm):
            if k < len(p) and _exact_zero(p[k] - entry):
                k += 1
            else:
                missing.append((idx, entry))
    if k != len(p):
        missing = []
    return ShapeMismatch(p.shape, dm.shape, tuple(missing))


def compare(claim: Claim, printed=None, offset=None) -> Comparison:
    """Does ``printed`` (default: the claim's) minus ``offset`` equal the derived side?

    With no offset this is the claim's verdict; errata pass their pinned
    discrepancy as ``offset`` and their corrected formula as ``printed``.
    """
    c = context(claim.model)
    printed = claim.printed(c) if printed is None else printed
    if claim.kind == "angle":
        return _compare_angles(claim, c, printed, offset)
    if claim.kind == "rule":
        return _compare_rule(claim, c, printed)
    derived = claim.derived(c)
    if isinstance(printed, IllFormed) or _as_matrix(printed).shape != _shape(derived):
        found = _shape_mismatch(printed, derived)
        return Comparison(offset is not None and _same_mismatch(found, offset), None,
                          math.inf, found, "dimension mismatch")
    printed = c.with_mu(_as_matrix(printed))
    if offset is not None:
        printed = printed - c.with_mu(_as_matrix(offset))
    pm = claim.point_map(c) if claim.point_map else None
    exact = _exact_identity(printed, derived, pm)
    err = _numeric_identity(printed, derived, pm)
    holds = exact and err < TOLERANCE
    disc = None   # printed - derived, kept only to report a difference
    if not holds and not isinstance(derived, Solve):
        disc = (printed - _as_matrix(derived)).applyfunc(lambda e: sp.expand(sp.expand_trig(e)))
    return Comparison(holds, exact, err, disc)


def _exact_identity(printed: sp.Matrix, derived, pm: PointMap | None) -> bool:
    if isinstance(derived, Solve):      # x = P^-1 r  <=>  P x - r = 0 (P invertible)
        diff = derived.P * printed - derived.r
    else:
        diff = printed - _as_matrix(derived)
    roots = ()
    if pm is not None:
        diff = sp.expand_trig(diff).xreplace(pm.trig)
        roots = pm.roots
    return _exact_zero(diff, roots)


def _numeric_identity(printed: sp.Matrix, derived, pm: PointMap | None) -> float:
    if pm is not None:   # the mapped angles are functions of the others at the point
        printed = printed.xreplace(pm.angles)
        derived = (Solve(derived.P.xreplace(pm.angles), derived.r.xreplace(pm.angles))
                   if isinstance(derived, Solve) else _as_matrix(derived).xreplace(pm.angles))
    points = sample(_free(printed, derived))
    return max(zero.relative_error(a, b)
               for a, b in zip(_numeric(printed, points), _numeric(derived, points)))


def _same_mismatch(found: ShapeMismatch, pinned) -> bool:
    if not isinstance(pinned, ShapeMismatch):
        return False
    if (found.printed, found.derived) != (pinned.printed, pinned.derived):
        return False
    if len(found.missing) != len(pinned.missing):
        return False
    return all(i == j and _exact_zero(sp.sympify(a) - sp.sympify(b))
               for (i, a), (j, b) in zip(found.missing, pinned.missing))


# -- atan2 forms (5.2)-(5.5) ---------------------------------------------------

def _angle_points(c: Context, n: int = N_POINTS, seed: int = 2) -> list[dict]:
    """States of link 1 in its chart: polar angle in (0, pi), azimuth in
    (-pi, pi], cycling through both halves and all four quadrants."""
    rng = random.Random(seed)
    u, v = c.coords(1)
    points = []
    for k in range(n):
        half, quadrant = (k // 4) % 2, k % 4
        with mpmath.workdps(zero.DIGITS):
            pt = {u: (half + mpmath.mpf(rng.random())) * mpmath.pi / 2,
                  v: (quadrant - 2 + mpmath.mpf(rng.random())) * mpmath.pi / 2,
                  c.l1: mpmath.mpf(0.3) + 2 * mpmath.mpf(rng.random())}
        points.append(pt)
    return points


def _angle_difference(a, b):
    """a - b wrapped into (-pi, pi], in 40-digit arithmetic."""
    with mpmath.workdps(zero.DIGITS):
        x = a - b
        y = x - 2 * mpmath.pi * mpmath.floor((x + mpmath.pi) / (2 * mpmath.pi))
        return y if y > -mpmath.pi else y + 2 * mpmath.pi


def angle_values(claim: Claim, printed: AtanForm | None = None):
    """At each test state: (point, printed angles, true angles) for an atan2 claim."""
    c = context(claim.model)
    printed = claim.printed(c) if printed is None else printed
    t = c.other(printed.target)
    compiled = lambda exprs: {x: zero.mp_function(e) for x, e in exprs.items()}
    true = compiled(t.point_map(c.unit(1), sp.Dummy("R", positive=True)).angles)
    got = compiled(printed.values)
    rows = []
    for pt in _angle_points(c):
        truth = {x: f(pt)[0] for x, f in true.items()}
        env = dict(pt) | truth
        rows.append((pt, {x: f(env)[0] for x, f in got.items()}, truth))
    return rows


def _compare_angles(claim: Claim, c: Context, printed: AtanForm, offset) -> Comparison:
    t = c.other(printed.target)
    # numeric: the target chart's link vector at the printed angles is the point
    target_vec, source_vec = t.qvec(1), claim.derived(c)
    f_t, f_s = zero.mp_function(target_vec), zero.mp_function(source_vec)
    err, rows = 0.0, angle_values(claim, printed)
    for pt, got, truth in rows:
        env = {x: got.get(x, truth[x]) for x in truth} | {t.l1: pt[c.l1]}
        err = max(err, zero.relative_error(f_t(env), f_s(pt)))
    # exact: each atan2(Y, X) points along the true angle x; the source chart's
    # trig functions are expressed through the target chart's angles
    pm = c.point_map(t.unit(1), sp.Dummy("R", positive=True))
    exact, rhos = True, {}
    for x, form in printed.values.items():
        Y, X = form.args
        Y, X = [sp.expand_trig(e).xreplace(pm.trig) for e in (Y, X)]
        if isinstance(Y, sp.Pow) and Y.exp == sp.S.Half:       # sqrt form: squared check
            direction = Y.base * sp.cos(x)**2 - X**2 * sp.sin(x)**2
            rhos[x] = None
        else:
            direction = Y * sp.cos(x) - X * sp.sin(x)
            rhos[x] = X * sp.cos(x) + Y * sp.sin(x)
        exact = exact and _exact_zero(direction, pm.roots)
    if offset is None:
        disc = [QuadrantError(x, r) for x, r in rhos.items()]
        return Comparison(exact and err < TOLERANCE, exact, err, disc[0] if len(disc) == 1 else disc)
    return Comparison(_quadrant_matches(rows, pm, rhos, offset), exact, err, offset)


def _quadrant_matches(rows, pm, rhos, pinned) -> bool:
    """The pinned QuadrantError holds: same exact rho, and the printed angle is
    off by pi exactly where rho < 0 (and nowhere else) at every test state
    (``rows`` as from :func:`angle_values`)."""
    if not isinstance(pinned, QuadrantError) or rhos.get(pinned.angle) is None:
        return False
    if not _exact_zero(sp.sympify(rhos[pinned.angle]) - pinned.rho, pm.roots):
        return False
    f_rho = zero.mp_function(pinned.rho)
    seen_jump = False
    for pt, got, truth in rows:
        env = dict(pt) | truth
        negative = f_rho(env)[0] < 0
        with mpmath.workdps(zero.DIGITS):
            jump = abs(_angle_difference(got[pinned.angle], truth[pinned.angle]))
            if abs(jump - (mpmath.pi if negative else 0)) > TOLERANCE:
                return False
        seen_jump = seen_jump or negative
    return seen_jump


# -- the chart rule of 5.1 -------------------------------------------------------

def rule_states(n_random: int = 2000, seed: int = 3) -> list[tuple[float, ...]]:
    """Standard-chart states (theta1, phi1, theta2, phi2): random, near the poles,
    near the x and y axes, and on the 0.5 thresholds."""
    rng = random.Random(seed)
    th = lambda: rng.uniform(0, math.pi)
    ph = lambda: rng.uniform(-math.pi, math.pi)
    pole = lambda: rng.choice([rng.uniform(0, 1e-3), math.pi - rng.uniform(0, 1e-3)])
    edge = lambda: rng.choice([math.pi / 6, 5 * math.pi / 6]) + rng.uniform(-1e-9, 1e-9)
    axis = lambda: rng.choice([0.0, math.pi, math.pi / 2, -math.pi / 2]) + rng.uniform(-1e-3, 1e-3)
    states = [(th(), ph(), th(), ph()) for _ in range(n_random)]
    for _ in range(200):
        states += [(pole(), ph(), th(), ph()), (th(), ph(), pole(), ph()),
                   (pole(), ph(), math.pi / 2, axis()), (math.pi / 2, axis(), pole(), ph()),
                   (pole(), ph(), pole(), ph()), (edge(), ph(), edge(), axis()),
                   (edge(), axis(), th(), ph())]
    return states


def _compare_rule(claim: Claim, c: Context, rule: ChartRule) -> Comparison:
    polar_sine = claim.derived(c)       # (chart model, state) -> polar sines there
    worst, where = math.inf, None
    for state in rule_states():
        chosen = rule.choose(*state)
        m = min(polar_sine(chosen, state))
        if m < worst:
            worst, where = m, (chosen, state)
    holds = worst >= rule.bound - 1e-12
    note = f"smallest polar sine of the chosen chart {worst:.6f} (>= {rule.bound})"
    return Comparison(holds, None, 0.0 if holds else rule.bound - worst,
                      None if holds else where, note)
