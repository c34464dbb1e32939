"""A run's relative energy error: max |E(t) - E0| / max(|E0|, m g l).

The scale is derive.model.energy_scale's (its docstring says why |E0| alone will not
do): it cannot vanish.  The same figure is SimulationResult.energy_error, a scene's
relative energy error and a sweep's `energy_error`.  A run above long double (y_exact:
double-double, quad) has its energy evaluated exactly from its exact states (mpmath,
from the derivation's T + V): its long double energies would show only their own
rounding, about 1e-19, not the run's error.
"""
from __future__ import annotations

import math
from functools import lru_cache

import mpmath
import numpy as np
import sympy as sp

from ..derivation import derive
from ..model import load_model
from ..model.atlas import standard_member
from ..model.description import forget_on_model_change
from ..model.energy_scale import SCALE_TEXT, energy_scale      # noqa: F401  (SCALE_TEXT re-exported)
from .extended import exact

DIGITS = 50          # mpmath's working precision for an exact energy


def scale_of(model: str, params, e0):
    """The scale max(|E0|, m g l) of a run's relative energy error.

    Parameters
    ----------
    model : str
        A model's name (an atlas: its standard chart's).
    params : array_like
        The parameters in the model's order, (np,) or (B, np) for a batch.
    e0 : float or ndarray
        The energy at the start ((B,) for a batch).

    Returns
    -------
    float or ndarray
    """
    description = load_model(standard_member(model))
    p = np.asarray(params, np.float64)
    values = {n: p[..., i] for i, n in enumerate(description.parameters)}
    return energy_scale(description, values, e0)


def relative_change(energy, e0, scale):
    """|E - E0| / scale: the one division behind every relative energy error (a run's, a
    scene's plot, a sweep's, the benchmark's), by a scale of scale_of, never by |E0|.

    Parameters
    ----------
    energy : array_like
        Energies, in their own precision (NaN stays NaN).
    e0 : float or ndarray
        The energy at the start (broadcast against `energy`: one per row for a batch).
    scale : float or ndarray
        scale_of's scale (broadcast as e0).

    Returns
    -------
    ndarray
        The relative change of each energy.
    """
    with np.errstate(invalid="ignore"):
        return np.abs(np.asarray(energy) - e0) / scale


def relative_energy_error(energy, model: str, params) -> tuple[float, float]:
    """The relative energy error of a run's energies.

    Parameters
    ----------
    energy : array_like
        The energies at the outputs (a stopped run's are NaN after its stop).
    model : str
    params : array_like
        As for scale_of.

    Returns
    -------
    (float, float)
        max |E - E0| / scale over the finite energies, in their own precision (NaN when
        none is finite; inf where an energy overflowed, which no figure of the others may
        hide), and the scale.
    """
    e = np.asarray(energy)
    finite = e[np.isfinite(e)]
    scale = scale_of(model, params, float(e[0]) if e.size and np.isfinite(e[0]) else 0.0)
    if finite.size == 0 or not np.isfinite(e[0]):
        return math.nan, scale
    if np.isinf(e).any():
        return math.inf, scale
    return float(np.max(relative_change(finite, e[0], scale))), scale


@forget_on_model_change
@lru_cache(maxsize=None)
def _exact_energy(model: str):
    """E(state, params) in mpmath, from the derivation of `model`."""
    d = derive(model)
    return sp.lambdify(list(d.symbols.state) + list(d.symbols.params), d.energy, "mpmath")


def exact_energy_error(result) -> tuple[float, float]:
    """relative_energy_error of a run with exact states, each energy evaluated from them.

    Parameters
    ----------
    result : SimulationResult
        A run above long double (result.y_exact: its states as mpmath numbers).

    Returns
    -------
    (float, float)
        The relative energy error (the energies in DIGITS digits) and its scale.
    """
    energy = _exact_energy(result.model)
    params = [exact(v, "params") for v in np.asarray(result.params)]
    with mpmath.workdps(DIGITS):
        rows = [row for row in result.y_exact if all(mpmath.isfinite(v) for v in row)]
        if not rows:
            return math.nan, scale_of(result.model, np.asarray(result.params, np.float64), 0.0)
        E = np.array([energy(*row, *params) for row in rows], dtype=object)     # mpmath numbers
        scale = scale_of(result.model, np.asarray(result.params, np.float64), float(E[0]))
        return float(max(relative_change(E, E[0], scale))), scale
