"""Many derivations at once: the models (and chart changes) a command needs that the disk
cache does not hold yet, computed side by side in worker processes (derive.workers), each
stored in the disk cache, from which the command then reads them as from a warm cache."""
from __future__ import annotations

from ..model import Model, load_model
from .workers import run_all
from .charts import is_chart_change_cached, store_chart_change
from .derivation import derive, is_cached


def _seconds_to_derive(name: str) -> float:
    """Derive a catalogue model into the disk cache; the seconds its derivation took."""
    return derive(name).seconds


def _expected_cost(model: Model) -> tuple:
    # the seed's paper forms (their trigsimp calls) dominate, then the number of coordinates
    return ("paper" in model.forms, sum(len(link.chart.coordinates) for link in model.links))


def derive_uncached(names: list[str], pairs: list[tuple[str, str]] = ()) -> dict[str, float]:
    """Compute, side by side, the derivations of `names` and the chart changes `pairs`
    that are not in the disk cache yet, into it.

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
    calls = [(_seconds_to_derive, (n,)) for n in cold]
    # a chart change needs only the two models' symbols, not their derivations
    calls += [(store_chart_change, pair) for pair in pairs if not is_chart_change_cached(*pair)]
    done = run_all(calls)
    return dict(zip(cold, done))
