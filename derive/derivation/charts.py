"""Changing charts (seed 000 §5.2): coordinates and rates of one model's chart
expressed through another's, for models that share links and differ in charts.

Coordinates go through the Cartesian unit vector and the target chart's robust
inverse (charts.toml, the forms of (5.2)-(5.5) that keep the quadrant).  Rates
follow (5.11)-(5.14): the link velocity is the same in both charts,
    e' = J_a a' = J_b b',
and the columns of a spherical chart's Jacobian are orthogonal, so
    b'_k = (e' . de/db_k) / |de/db_k|^2        (|de/dphi|^2 = sin^2 theta).
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import sympy as sp

from .. import cachefile
from ..model import Model, load_model
from ..paths import cache_dir
from .derivation import cache_key
from .symbols import ModelSymbols, model_symbols, per_shape


@cachefile.register
@dataclass
class ChartChange:
    source: str
    target: str
    source_symbols: ModelSymbols
    target_symbols: ModelSymbols
    coordinates: list[sp.Expr]   # target q in terms of source q
    target_q: list[sp.Symbol]    # stand-ins for the target q inside `rates`
    rates: list[sp.Expr]         # target q' in terms of source (q, q') and target_q


def _link_slices(model: Model):
    k = 0
    for link in model.links:
        n = len(link.chart.coordinates)
        yield link, slice(k, k + n)
        k += n


def cache_path(source: Model, target: Model) -> Path:
    """Where the chart change from `source` to `target` is (or will be) cached: keyed by
    both models' derivation keys (their descriptions, the SymPy version, this code)."""
    key = hashlib.sha256(f"{cache_key(source)} {cache_key(target)}".encode()).hexdigest()[:24]
    return cache_dir() / "chart-changes" / f"{source.name}-{target.name}-{key}.json"


# Kept per pair of models (a Model is a frozen value: an edited model is another key), in
# memory and on disk: the physics checks ask for the same pair in both directions and
# again for the round trip, and the atlas's conversion kernels for the same pairs, in
# this process or in a worker of the same run; every change costs trigsimp calls.
# Do not modify the returned ChartChange: it is shared.
@lru_cache(maxsize=64)
def chart_change(source: Model, target: Model) -> ChartChange:
    """The coordinates and rates of `target`'s charts in terms of `source`'s (seed 000 §5.2),
    from the disk cache or computed now (and stored there).

    Parameters
    ----------
    source, target : Model
        Two models of the same links in other charts.

    Returns
    -------
    ChartChange
        The target coordinates as expressions of the source coordinates, and the target
        rates of the source state (and the target coordinates).
    """
    path = cache_path(source, target)
    change = cachefile.load(path) if path.is_file() else cachefile.MISSING
    if isinstance(change, ChartChange) and (change.source, change.target) == (source.name, target.name):
        return change
    change = _computed(source, target)
    cachefile.store(path, change)
    return change


def store_chart_change(source: str, target: str) -> None:
    """Compute the chart change between two catalogue models into the disk cache (what a
    worker process of a command does, so that the command and its other workers read it).

    Parameters
    ----------
    source, target : str
        Catalogue model names.
    """
    chart_change(load_model(source), load_model(target))


def is_chart_change_cached(source: str, target: str) -> bool:
    """Whether :func:`chart_change` of these two catalogue models reads the disk cache.

    Parameters
    ----------
    source, target : str
        Catalogue model names.

    Returns
    -------
    bool
    """
    return cache_path(load_model(source), load_model(target)).is_file()


def _computed(source: Model, target: Model) -> ChartChange:
    """The coordinates and rates of `target`'s charts in terms of `source`'s (seed 000 §5.2).

    Parameters
    ----------
    source, target : Model
        Two models of the same links in other charts.

    Returns
    -------
    ChartChange
        The target coordinates as expressions of the source coordinates, and the target
        rates of the source state (and the target coordinates).
    """
    if [len(l.chart.coordinates) for l in source.links] != [len(l.chart.coordinates) for l in target.links]:
        raise ValueError(f"'{source.name}' and '{target.name}' do not have the same links")
    a, b = model_symbols(source), model_symbols(target)
    # Two models may share coordinate names (second and rotated chart), so the
    # target coordinates inside the rate formulas get names of their own.
    target_q = [sp.Symbol(f"{s.name}_new", real=True) for s in b.q]
    coords, rates = [], []
    for (la, sa), (lb, sb) in zip(_link_slices(source), _link_slices(target)):
        qa, qb = list(a.q[sa]), target_q[sb]
        e_a = la.chart.unit_vector(qa)
        coords += lb.chart.coordinates_of(list(e_a))
        velocity = e_a.jacobian(qa) * sp.Matrix(a.qd[sa])
        J_b = lb.chart.unit_vector(qb).jacobian(qb)
        gram = (J_b.T * J_b).applyfunc(lambda x: per_shape(sp.trigsimp, x))
        if not gram.is_diagonal():
            raise ValueError(f"chart '{lb.chart.name}' is not orthogonal; (5.11)-(5.14) do not apply")
        for k in range(len(qb)):
            # factor_terms exposes the sin u inside de/dv, so one power of the
            # Gram entry sin^2 u cancels: the code divides by sin u, not sin^2 u.
            # trigsimp once per shape: the second link's rates are the first's in other angles
            rates.append(sp.factor_terms(per_shape(sp.trigsimp, velocity.dot(J_b[:, k]))) / gram[k, k])
    return ChartChange(source.name, target.name, a, b, coords, target_q, rates)
