"""Cartesian states of the chained pendulums and their charts, from the chart data.

Nothing about a chart is typed here: each link's chart comes from
derive/model/catalog/charts.toml through derive.model (`Chart.unit_vector`,
`Chart.coordinates_of`, `Chart.polar_sine_of`), and the numeric conversions are
lambdified once per chart and cached:

* chart -> Cartesian: the unit vector e(q) and its rate e' = (de/dq) q';
* Cartesian -> chart: q = the chart's robust inverse of the unit vector (the atan2
  forms of seed 000 (5.2)-(5.5)), and the rates by (5.11)-(5.14): the columns of a
  chart's Jacobian are orthogonal, so q'_k = (e' . de/dq_k) / |de/dq_k|^2 (checked
  symbolically; |de/dphi|^2 = sin^2 theta, one power cancels);
* the polar sine (the chart-quality indicator) as a function of the unit vector,
  sin(q_polar(e)) simplified (sqrt(x^2 + y^2) / |e| for the standard chart): exactly 0
  on the singular axis.

Inside the rates the polar sine is a symbol S, evaluated from the unit vector by that
robust form.  A rate that divides by S is set to 0 when S is exactly 0 (a link exactly
on its chart's singular axis: the azimuth is atan2(0, 0) = 0 and its rate is
undefined; the atlas never converts to a chart there, and `state_to_cartesian` is
exact at the pole since it only evaluates e and de/dq).

The chart rule of seed 000 section 5.1 is here too (`choose_chart`, for N links); it
reads the standard chart's polar sine and azimuth from the data, and which member of an
atlas uses the standard, second and rotated chart from the model descriptions.  Cartesian
states are (x_1 .. x_N, v_1 .. v_N), 2 N d numbers; the lengths come from the description
(`link_lengths`).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

import numpy as np
import sympy as sp

from ..model import load_chart, load_model
from ..model.atlas import ATLAS, load_atlas
from ..model.description import forget_on_model_change
from ..model.expressions import parse_expression
# the rule's symbolic side (no NumPy: the code generator prints it), kept importable from here
from .chart_rule import RULE_CHARTS, _XYZ, _polar_index, _sines_of_unit, rule_models, rule_sines  # noqa: F401

CHARTS = load_atlas(ATLAS).charts     # the catalogue atlas's members


@dataclass(frozen=True)
class LinkChart:
    """The numeric conversions of one chart of charts.toml (one link)."""
    name: str
    dimension: int
    n: int                                    # number of coordinates
    polar: int | None                         # index of the polar coordinate (in the polar sine)
    unit: Callable                            # (*q, *qd) -> (e, e')
    inverse: Callable                         # (*e) -> q
    sine: Callable | None                     # (*e) -> polar sine (robust, 0 on the axis)
    rates: tuple[Callable, ...]               # per coordinate: (*q, S, *e') -> its rate
    singular: tuple[bool, ...]                # which rates divide by the polar sine S

    def to_unit(self, q, qd) -> tuple[np.ndarray, np.ndarray]:
        e, ed = self.unit(*q, *qd)
        return np.array(e, float), np.array(ed, float)

    def polar_sine(self, e) -> float | None:
        return None if self.sine is None else float(self.sine(*e))

    def from_unit(self, e, ed) -> tuple[np.ndarray, np.ndarray]:
        """(q, q') of a unit vector e and its rate e' (exact-pole rule in the module docstring)."""
        q = np.array(self.inverse(*e), float)
        s = 1.0 if self.sine is None else float(self.sine(*e))
        qd = [0.0 if s == 0.0 and sing else rate(*q, s, *ed)
              for rate, sing in zip(self.rates, self.singular)]
        return q, np.array(qd, float)


@lru_cache(maxsize=None)
def _rule_functions() -> tuple[Callable, Callable]:
    X, st, az = rule_sines()
    return sp.lambdify(X, st, "math"), sp.lambdify(X, az, "math")


@lru_cache(maxsize=None)
def link_chart(name: str) -> LinkChart:
    """The numeric conversions of chart `name` (a section of charts.toml), built once."""
    chart = load_chart(name)
    d = chart.dimension
    q = [sp.Symbol(c, real=True) for c in chart.coordinates]
    qd = [sp.Symbol(f"{c}_dot", real=True) for c in chart.coordinates]
    X = [sp.Symbol(c, real=True) for c in _XYZ[:d]]
    V = sp.Matrix([sp.Symbol(f"v{c}", real=True) for c in _XYZ[:d]])
    S = sp.Symbol("S", nonnegative=True)
    e = chart.unit_vector(q)
    J = e.jacobian(q)
    unit = sp.lambdify(q + qd, (list(e), list(J * sp.Matrix(qd))), "math")
    inverse = sp.lambdify(X, chart.coordinates_of(X), "math")
    gram = (J.T * J).applyfunc(sp.trigsimp)
    if not gram.is_diagonal():
        raise ValueError(f"chart '{name}' is not orthogonal; (5.11)-(5.14) do not apply")
    rates = [sp.factor_terms(sp.trigsimp(V.dot(J[:, k]))) / gram[k, k] for k in range(len(q))]
    polar, sine = None, None
    ps = chart.polar_sine_of(q)
    if ps is not None:
        polar = _polar_index(chart)
        rates = [r.subs(ps, S) for r in rates]
        sine = sp.lambdify(X, _sines_of_unit(chart, X)[0], "math")
    singular = tuple(bool(sp.fraction(sp.together(r))[1].has(S)) for r in rates)
    return LinkChart(name, d, len(q), polar, unit, inverse, sine,
                     tuple(sp.lambdify(q + [S] + list(V), r, "math") for r in rates), singular)


@forget_on_model_change
@lru_cache(maxsize=None)
def model_charts(model: str) -> tuple[LinkChart, ...]:
    """The chart of each link of a model (a model of derive/model/catalog)."""
    return tuple(link_chart(link.chart.name) for link in load_model(model).links)


def _links(model: str):
    """(chart, coordinate slice, rate slice) per link, in the model's state order."""
    charts = model_charts(model)
    nq = sum(c.n for c in charts)
    k = 0
    for c in charts:
        yield c, slice(k, k + c.n), slice(nq + k, nq + k + c.n)
        k += c.n


def unit_to_chart(chart: str, u, ud, link: int = 0) -> tuple[float, ...]:
    """(coordinates, rates) of a link's unit vector u and its rate ud in the chart of that
    link of model `chart`: (th, ph, th', ph') for a spherical chart."""
    q, qd = model_charts(chart)[link].from_unit(np.asarray(u, float), np.asarray(ud, float))
    return tuple(float(v) for v in q) + tuple(float(v) for v in qd)


def chart_to_unit(chart: str, *coords_and_rates, link: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The unit vector and its rate from a link's coordinates and rates (th, ph, th', ph')."""
    c = model_charts(chart)[link]
    return c.to_unit(coords_and_rates[:c.n], coords_and_rates[c.n:])


def _units(c, lengths, d: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Unit vector and rate of each link from (x_1 .. x_N, v_1 .. v_N)."""
    c = np.asarray(c, float)
    n = len(lengths)
    x = [np.zeros(d)] + [c[i * d:(i + 1) * d] for i in range(n)]
    v = [np.zeros(d)] + [c[(n + i) * d:(n + i + 1) * d] for i in range(n)]
    return [((x[i + 1] - x[i]) / lengths[i], (v[i + 1] - v[i]) / lengths[i]) for i in range(n)]


def link_lengths(model: str, p) -> tuple[float, ...]:
    """Each link's length for the parameter values p (in the model's order): from the
    description (a parameter, a number or an expression of parameters)."""
    m = load_model(model)
    values = dict(zip(m.parameters, (float(v) for v in np.asarray(p, float).reshape(-1))))
    return tuple(float(f(*[values[n] for n in names])) for names, f in _length_functions(model))


@forget_on_model_change
@lru_cache(maxsize=None)
def _length_functions(model: str) -> tuple[tuple[tuple[str, ...], Callable], ...]:
    m = load_model(model)
    symbols = {n: sp.Symbol(n) for n in m.parameters}
    out = []
    for i, link in enumerate(m.links, 1):
        expr = parse_expression(link.length, symbols, f"model '{model}': link {i} length")
        names = tuple(sorted(s.name for s in expr.free_symbols))
        out.append((names, sp.lambdify([symbols[n] for n in names], expr, "math")))
    return tuple(out)


def state_to_cartesian(chart: str, y, lengths) -> np.ndarray:
    """(x_1 .. x_N, v_1 .. v_N) of a chart state (coordinates, then rates), exact at the
    poles too; `lengths`: one per link."""
    y = np.asarray(y, float)
    pos, vel = [], []
    x, v = 0.0, 0.0
    for (c, sq, sr), length in zip(_links(chart), lengths, strict=True):
        u, ud = c.to_unit(y[sq], y[sr])
        x, v = x + length * u, v + length * ud
        pos.append(x)
        vel.append(v)
    return np.concatenate(pos + vel)


def cartesian_to_state(chart: str, c, lengths) -> np.ndarray:
    """The chart state of (x_1 .. x_N, v_1 .. v_N) (robust inverse; rates by (5.11)-(5.14))."""
    links = list(_links(chart))
    d = links[0][0].dimension
    y = np.empty(2 * sum(lc.n for lc, _, _ in links))
    for (lc, sq, sr), (u, ud) in zip(links, _units(c, lengths, d), strict=True):
        y[sq], y[sr] = lc.from_unit(u, ud)
    return y


def polar_sines(chart: str, c, lengths) -> list[float]:
    """Each link's polar sine in the chart (its distance from the chart's singular axis)."""
    links = model_charts(chart)
    return [lc.polar_sine(u) for lc, (u, _) in zip(links, _units(c, lengths, links[0].dimension), strict=True)]


def std_sines(c, lengths) -> tuple[list[float], list[float]]:
    """|sin theta_i| and |sin phi_i| of the standard chart (its polar sine and the sine of
    its azimuth, from the data: `rule_sines`), from a Cartesian state; |sin phi_i| = 0 on
    the axis."""
    f_st, f_az = _rule_functions()
    st, sp_ = [], []
    for u, _ in _units(c, lengths, len(rule_sines()[0])):
        s = float(f_st(*u))
        st.append(s)
        sp_.append(float(f_az(*u)) if s > 0 else 0.0)
    return st, sp_


def rule_chart(st, sp_, small: float) -> str:
    """Seed 000 section 5.1 on the standard chart's sines of every link: 'standard' when
    every |sin theta_i| >= small; else 'rotated' when a link with |sin theta_i| >= small has
    |sin phi_i| < small; else 'second'."""
    if all(s >= small for s in st):
        return "standard"
    if any(st[i] >= small and sp_[i] < small for i in range(len(st))):
        return "rotated"
    return "second"


def choose_chart(c, lengths, atlas: str = ATLAS, small: float | None = None) -> str:
    """The chart of `atlas` for the Cartesian state c (the member model using it).

    Seed 000 section 5.1, generalised to N links: `rule_chart` on the standard chart's
    sines of every link (small = the atlas's sine_rule, 0.5).  For N <= 2 every polar sine
    of the chart it picks is >= small (the hysteresis the switching relies on: a link near
    the z axis is far from the x and y axes, and a link with |sin theta| >= 0.5 is far
    from the axis the rule's chart is singular on).  For N >= 3 the rule cannot guarantee
    that, nor can any choice among the three charts: links along x, y and z put every
    chart's singular axis under one link.  So, the generalisation: for N >= 3, when the
    rule's chart has a polar sine below small, the chart whose smallest polar sine is
    largest (the first of standard, second, rotated on a tie) is used instead; the
    seed's remark after 5.1 (more charts, rotated by an angle alpha) is the way beyond.
    """
    a = load_atlas(atlas)
    small = float(a.sine_rule) if small is None else small
    pick = rule_chart(*std_sines(c, lengths), small)
    if len(lengths) > 2:
        units = [u for u, _ in _units(c, lengths, 3)]
        smallest = {ch: min(link_chart(ch).polar_sine(u) for u in units) for ch in RULE_CHARTS}
        if smallest[pick] < small:
            pick = max(RULE_CHARTS, key=smallest.__getitem__)
    return rule_models(atlas)[pick]
