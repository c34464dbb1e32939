"""Chart-change kernels: the symbolic chart change of derive.derivation.charts
(seed 000 §5.2, robust forms from charts.toml) laid out as kernel stages.

The target coordinates become stages (named <model>_<coordinate><link>), the
rates (5.11)-(5.14) are written in them, and the target chart's polar sines
are the kernel's guards.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..derivation.charts import chart_change
from .names import internal


def is_spherical(chart) -> bool:
    return chart.dimension == 3 and len(chart.coordinates) == 2 and chart.polar_sine is not None


@dataclass
class Conversion:
    exprs: list[sp.Expr]                     # target state, in the target's state order
    stages: list[tuple[sp.Symbol, sp.Expr]]
    guards: list[sp.Expr]                    # target polar sines


def conversion(source, target, s) -> Conversion:
    """Kernel pieces converting a state of model `source` into one of model `target`."""
    change = chart_change(source, target)
    if change.source_symbols.state != s.state:
        raise ValueError(f"conversion from '{source.name}' built for other symbols")
    names = [internal(f"{target.name}_{c}{i}")
             for i, link in enumerate(target.links, 1) for c in link.chart.coordinates]
    rename = dict(zip(change.target_q, names))
    rates = [r.xreplace(rename) for r in change.rates]
    guards, k = [], 0
    for link in target.links:
        n = len(link.chart.coordinates)
        guards.append(link.chart.polar_sine_of(names[k:k + n]))
        k += n
    return Conversion(names + rates, list(zip(names, change.coordinates)), guards)
