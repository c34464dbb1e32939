"""The scale a relative energy error is measured against: it cannot vanish.

The energy E = T + V of a pendulum has no natural zero (V is measured from the
pivot's height), so |E0| can be near 0 for a motion like any other (a chain released
at rest near the horizontal), and |E - E0| / |E0| then says nothing.  The scale is

    max(|E0|, W),   W = |g| sum_k m_k d_k,

d_k the depth of body k's centre of mass below the pivot with the chain hanging
straight down (the lengths of the links before it plus its centre of mass along its
own): the potential energy lies in [-W, W], so W is the size of the energy a motion
can exchange (W = |g| (m1 l1 + m2 (l1 + l2)) = 29.43 for the planar double pendulum
with unit masses and lengths).  In a tree, the links before body k are those on its
path to the pivot; offsets and sliders add no depth (W is then a scale, not a bound).  It is 0 only without gravity and at rest (then the
error is absolute).
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .description import Model
from .expressions import parse_expression

SCALE_TEXT = "max(|E0|, m g l)"     # how reports name the scale (m g l: W above)

_depths: dict[str, object] = {}


def well_depth(model: Model, values: dict):
    """W = |g| sum_k m_k d_k (module docstring): the potential energy lies in [-W, W].

    Parameters
    ----------
    model : Model
    values : dict
        Parameter name -> value: numbers, or NumPy arrays (broadcast: one W per row).

    Returns
    -------
    float or ndarray
        W at those values; 0 only without gravity (g = 0).
    """
    if model.content_hash not in _depths:
        params = {n: sp.Symbol(n) for n in model.parameters}
        depths, W = [], sp.S.Zero      # the depth of each link's tip, hanging straight down
        for i, link in enumerate(model.links, 1):
            length = parse_expression(link.length, params, f"link {i} length")
            depth = depths[link.parent] if link.parent >= 0 else sp.S.Zero
            if link.body is not None:
                mass = parse_expression(link.body.mass, params, f"link {i} body mass")
                com = parse_expression(link.body.com, params, f"link {i} body com")
                W += mass * (depth + com * length)
            depths.append(depth + length)
        W = sp.Abs(params["g"]) * W
        _depths[model.content_hash] = sp.lambdify([params[n] for n in model.parameters], W, "numpy")
    out = _depths[model.content_hash](*[values[n] for n in model.parameters])
    return float(out) if np.ndim(out) == 0 else np.asarray(out, np.float64)


def energy_scale(model: Model, values: dict, e0):
    """max(|E0|, W): the scale of a relative energy error (module docstring).

    Parameters
    ----------
    model : Model
    values : dict
        Parameter name -> value (numbers or arrays, as for well_depth).
    e0 : float or ndarray
        The energy at the start (one per row for arrays).

    Returns
    -------
    float or ndarray
        The scale; 1 where it would be 0 (no gravity, at rest: the error is then absolute).
    """
    scale = np.maximum(np.abs(np.asarray(e0, np.float64)), well_depth(model, values))
    scale = np.where(scale > 0, scale, 1.0)
    return float(scale) if np.ndim(scale) == 0 else scale
