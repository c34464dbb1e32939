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

The chart rule of seed 000 section 5.1 is here too (`choose_chart`); it reads the
standard chart's polar sine and azimuth from the data, and which atlas model uses the
standard, second and rotated chart from the model descriptions.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

import numpy as np
import sympy as sp

from ..model import load_chart, load_model
from .contract import ATLAS_CHARTS

CHARTS = ATLAS_CHARTS
RULE_CHARTS = ("standard", "second", "rotated")   # the charts seed 000 section 5.1 names
_XYZ = "xyz"


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


def _polar_index(chart) -> int:
    """The coordinate in the chart's polar sine (theta of sin(theta))."""
    q = [sp.Symbol(c, real=True) for c in chart.coordinates]
    ps = chart.polar_sine_of(q)
    return next(k for k, c in enumerate(q) if ps.has(c))


def _sines_of_unit(chart, X) -> tuple[sp.Expr, sp.Expr]:
    """The polar sine and |sin| of the azimuth (the other coordinate) of a spherical chart
    as functions of the unit vector X: sin(q(X)) through the chart's robust inverse,
    simplified (sqrt(x^2 + y^2)/|X| and |y|/sqrt(x^2 + y^2) for the standard chart)."""
    q = [sp.Symbol(c, real=True) for c in chart.coordinates]
    inv = chart.coordinates_of(X)
    polar = _polar_index(chart)
    st = sp.simplify(chart.polar_sine_of(q).subs(dict(zip(q, inv)), simultaneous=True))
    return st, sp.simplify(sp.Abs(sp.sin(inv[1 - polar])))


@lru_cache(maxsize=None)
def rule_sines() -> tuple[tuple[sp.Symbol, ...], sp.Expr, sp.Expr]:
    """The ingredients of the rule of section 5.1 as expressions of a link's unit vector
    (x, y, z), from the standard chart's data: |sin theta| (its polar sine) and |sin phi|
    (its azimuth); the atlas templates print the same expressions."""
    chart = load_chart("standard")
    X = tuple(sp.Symbol(c, real=True) for c in _XYZ[:chart.dimension])
    return (X,) + _sines_of_unit(chart, X)


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


def _units(c12, lengths, d: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Unit vector and rate of each link from (x_1 .. x_n, v_1 .. v_n)."""
    c12 = np.asarray(c12, float)
    n = len(lengths)
    x = [np.zeros(d)] + [c12[i * d:(i + 1) * d] for i in range(n)]
    v = [np.zeros(d)] + [c12[(n + i) * d:(n + i + 1) * d] for i in range(n)]
    return [((x[i + 1] - x[i]) / lengths[i], (v[i + 1] - v[i]) / lengths[i]) for i in range(n)]


def state_to_cartesian(chart: str, y, l1: float, l2: float) -> np.ndarray:
    """(x1, x2, v1, v2) of a chart state (coordinates, then rates), exact at the poles too."""
    y = np.asarray(y, float)
    pos, vel = [], []
    x, v = 0.0, 0.0
    for (c, sq, sr), length in zip(_links(chart), (l1, l2)):
        u, ud = c.to_unit(y[sq], y[sr])
        x, v = x + length * u, v + length * ud
        pos.append(x)
        vel.append(v)
    return np.concatenate(pos + vel)


def cartesian_to_state(chart: str, c12, l1: float, l2: float) -> np.ndarray:
    """The chart state of (x1, x2, v1, v2) (robust inverse; rates by (5.11)-(5.14))."""
    links = list(_links(chart))
    d = links[0][0].dimension
    y = np.empty(2 * sum(c.n for c, _, _ in links))
    for (c, sq, sr), (u, ud) in zip(links, _units(c12, (l1, l2), d)):
        y[sq], y[sr] = c.from_unit(u, ud)
    return y


def polar_sines(chart: str, c12, l1: float, l2: float) -> list[float]:
    """Each link's polar sine in the chart (its distance from the chart's singular axis)."""
    links = model_charts(chart)
    return [c.polar_sine(u) for c, (u, _) in zip(links, _units(c12, (l1, l2), links[0].dimension))]


@lru_cache(maxsize=None)
def rule_models() -> dict[str, str]:
    """Which atlas model uses each chart the rule names (from the model descriptions)."""
    out = {}
    for m in ATLAS_CHARTS:
        names = {link.chart.name for link in load_model(m).links}
        if len(names) == 1:
            out[names.pop()] = m
    missing = [c for c in RULE_CHARTS if c not in out]
    if missing:
        raise ValueError(f"no atlas model uses chart '{missing[0]}' on every link")
    return out


def std_sines(c12, l1: float, l2: float) -> tuple[list[float], list[float]]:
    """|sin theta_i| and |sin phi_i| of the standard chart (its polar sine and the sine of
    its azimuth, from the data: `rule_sines`), from a Cartesian state; |sin phi_i| = 0 on
    the axis."""
    f_st, f_az = _rule_functions()
    st, sp_ = [], []
    for u, _ in _units(c12, (l1, l2), len(rule_sines()[0])):
        s = float(f_st(*u))
        st.append(s)
        sp_.append(float(f_az(*u)) if s > 0 else 0.0)
    return st, sp_


def choose_chart(c12, l1: float, l2: float, small: float = 0.5) -> str:
    """Seed 000 section 5.1: the standard chart when both |sin theta_i| >= small; else
    the rotated chart when a link with |sin theta_i| >= small has |sin phi_i| < small;
    else the second chart.  Every polar sine of the chosen chart is then >= 0.5.
    Returns the atlas model using that chart."""
    models = rule_models()
    st, sp_ = std_sines(c12, l1, l2)
    if all(s >= small for s in st):
        return models["standard"]
    if any(st[i] >= small and sp_[i] < small for i in range(len(st))):
        return models["rotated"]
    return models["second"]
