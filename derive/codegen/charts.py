"""Conversions between spherical charts, seed 000 section 5.2, robust forms only.

Every spherical chart in the catalog writes the unit vector of a link as
    e = (+-cos u, +-sin u cos v, +-sin u sin v)
in some order of the axes.  Reading that pattern off the chart's own formula
gives the robust inverse (5.2)-(5.5), last forms:
    u = atan2(sqrt(e_c^2 + e_s^2), +-e_p),   v = atan2(+-e_s, +-e_c),
e.g. vartheta = atan2(sqrt(q^2 + r^2), p), theta = atan2(sqrt(p^2 + q^2), -r).
The rates follow (5.11)-(5.14) with l = 1: the velocity of the unit vector is
e' = (de/du) u' + (de/dv) v' in the source chart, and in the target chart
    u' = e' . de/du,   v' = e' . de/dv / sin^2 u,
where one factor sin u of de/dv cancels symbolically, leaving 1/sin u.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp


class ChartError(ValueError):
    pass


def is_spherical(chart) -> bool:
    return chart.dimension == 3 and len(chart.coordinates) == 2 and chart.polar_sine is not None


@dataclass(frozen=True)
class Pattern:
    polar: tuple[int, int]      # (axis, sign) with e[axis] = sign * cos u
    cos: tuple[int, int]        # e[axis] = sign * sin u cos v
    sin: tuple[int, int]        # e[axis] = sign * sin u sin v


def pattern(chart) -> Pattern:
    u, v = sp.symbols("u v", real=True)
    e = chart.unit_vector([u, v])
    forms = {"polar": sp.cos(u), "cos": sp.sin(u) * sp.cos(v), "sin": sp.sin(u) * sp.sin(v)}
    found = {}
    for axis, comp in enumerate(e):
        for key, form in forms.items():
            for sign in (1, -1):
                if sp.expand(comp - sign * form) == 0:
                    found[key] = (axis, sign)
    if sorted(found) != sorted(forms) or len({a for a, _ in found.values()}) != 3:
        raise ChartError(f"chart '{chart.name}': unit vector {list(chart.unit)} is not "
                         "(+-cos u, +-sin u cos v, +-sin u sin v) in some axis order; "
                         "no robust inverse is known for it")
    if sp.expand(chart.polar_sine_of([u, v]) - sp.sin(u)) != 0:
        raise ChartError(f"chart '{chart.name}': polar sine must be sin of the first coordinate")
    return Pattern(found["polar"], found["cos"], found["sin"])


@dataclass
class Conversion:
    exprs: list[sp.Expr]                     # target state, in the target's state order
    stages: list[tuple[sp.Symbol, sp.Expr]]
    guards: list[sp.Expr]                    # target polar sines


def _sym(name: str) -> sp.Symbol:
    return sp.Symbol(name, real=True)


def conversion(source, target, s) -> Conversion:
    """Kernel pieces converting a state of model `source` into one of model `target`."""
    stages, coords, rates, guards = [], [], [], []
    k = 0
    for i, (ls, lt) in enumerate(zip(source.links, target.links), 1):
        n = len(ls.chart.coordinates)
        u, v = s.q[k:k + n]
        du, dv = s.qd[k:k + n]
        k += n
        e = ls.chart.unit_vector([u, v])
        de = e.jacobian([u, v]) * sp.Matrix([du, dv])
        es = [_sym(f"e{i}_{c}") for c in range(3)]
        des = [_sym(f"de{i}_{c}") for c in range(3)]
        stages += list(zip(es, e)) + list(zip(des, de))
        pt = pattern(lt.chart)
        (ap, sp_), (ac, sc), (as_, ss) = pt.polar, pt.cos, pt.sin
        U = _sym(f"{target.name}_{lt.chart.coordinates[0]}{i}")
        V = _sym(f"{target.name}_{lt.chart.coordinates[1]}{i}")
        stages.append((U, sp.atan2(sp.sqrt(es[ac] ** 2 + es[as_] ** 2), sp_ * es[ap])))
        stages.append((V, sp.atan2(ss * es[as_], sc * es[ac])))
        f = lt.chart.unit_vector([U, V])
        sine = lt.chart.polar_sine_of([U, V])
        d_u = sum(des[c] * f[c].diff(U) for c in range(3))
        d_v = sp.factor_terms(sum(des[c] * f[c].diff(V) for c in range(3))) / sine ** 2
        coords += [U, V]
        rates += [sp.factor_terms(d_u), d_v]
        guards.append(sine)
    return Conversion(coords + rates, stages, guards)
