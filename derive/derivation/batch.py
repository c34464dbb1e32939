"""Many derivations at once: the models (and chart changes) a command needs that the disk
cache does not hold yet, computed side by side in worker processes (derive.workers), each
stored in the disk cache, from which the command then reads them as from a warm cache."""
from __future__ import annotations

from ..model import Model, load_model
from .workers import run_all
from .charts import is_chart_change_cached, store_chart_change
from .derivation import derive, is_cached


def _seconds_to_derive(names: list[str]) -> list[float]:
    """Derive catalogue models into the disk cache, one after another in this process
    (each reuses the trigsimp calls of the ones before: symbols.per_shape); the seconds
    each derivation took."""
    return [derive(name).seconds for name in names]


def _store_chart_changes(pairs: list[tuple[str, str]]) -> None:
    """Compute chart changes into the disk cache, one after another in this process (the
    pairs of one atlas meet the same trigsimp shapes)."""
    for source, target in pairs:
        store_chart_change(source, target)


def _expected_cost(model: Model) -> tuple:
    # the seed's paper forms (their trigsimp calls) dominate, then the number of coordinates
    return ("paper" in model.forms, sum(len(link.chart.coordinates) for link in model.links))


def _links(model: Model) -> tuple:
    """What the shapes of a model's expressions follow: its dimension and its links'
    coordinate counts (the catalogue's three double spherical pendulums in three charts
    share nearly every trigsimp shape)."""
    return (model.dimension, tuple(len(link.chart.coordinates) for link in model.links))


def derive_uncached(names: list[str], pairs: list[tuple[str, str]] = ()) -> dict[str, float]:
    """Compute, side by side, the derivations of `names` and the chart changes `pairs`
    that are not in the disk cache yet, into it.

    Models of the same links are derived one after another in one worker process, and so
    are the chart changes: the later ones reuse the earlier ones' trigsimp calls
    (symbols.per_shape), which costs less than deriving them apart on two cores.

    Parameters
    ----------
    names : list of str
        Catalogue model names.
    pairs : list of (str, str)
        (source, target) catalogue models whose chart change (charts.chart_change) a later
        step of the command needs.

    Returns
    -------
    dict
        Model name -> seconds its derivation took, for the models derived now.
    """
    cold = sorted((n for n in names if not is_cached(n)),
                  key=lambda n: _expected_cost(load_model(n)), reverse=True)
    groups: dict[tuple, list[str]] = {}
    for name in cold:                       # the costliest first within each group
        groups.setdefault(_links(load_model(name)), []).append(name)
    groups = sorted(groups.values(), key=lambda group: _expected_cost(load_model(group[0])), reverse=True)
    paper = [g for g in groups if "paper" in load_model(g[0]).forms]
    rest = [g for g in groups if g not in paper]
    # a chart change needs only the two models' symbols, not their derivations
    changes = [pair for pair in pairs if not is_chart_change_cached(*pair)]
    calls = [(_seconds_to_derive, (g,)) for g in paper]
    calls += [(_store_chart_changes, (changes,))] if changes else []
    calls += [(_seconds_to_derive, (g,)) for g in rest]
    done = run_all(calls)
    seconds = [s for (f, _), result in zip(calls, done) if f is _seconds_to_derive for s in result]
    return dict(zip([n for g in paper + rest for n in g], seconds))
