"""The chart rule of seed 000 section 5.1, its symbolic side: which charts it names, which
member of an atlas uses each, and the polar sine and azimuth sine of a link as expressions
of its unit vector, from the chart data.  NumPy-free, so that the code generator (which
prints these expressions) does not import NumPy; derive.derivation.cartesian evaluates them.
"""
from __future__ import annotations

from functools import lru_cache

import sympy as sp

from ..model import load_chart, load_model
from ..model.atlas import ATLAS, load_atlas

RULE_CHARTS = ("standard", "second", "rotated")   # the charts seed 000 section 5.1 names
_XYZ = "xyz"


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
def rule_models(atlas: str = ATLAS) -> dict[str, str]:
    """Which member of `atlas` uses each chart the rule names (from the model descriptions)."""
    out = {}
    for m in load_atlas(atlas).charts:
        names = {link.chart.name for link in load_model(m).links}
        if len(names) == 1:
            out[names.pop()] = m
    missing = [c for c in RULE_CHARTS if c not in out]
    if missing:
        raise ValueError(f"no member of atlas '{atlas}' uses chart '{missing[0]}' on every link")
    return out
