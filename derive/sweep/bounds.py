"""Events that energy forbids: no trajectory need be integrated to learn it never flips.

For a conservative model the energy E = T + V is constant and T >= 0, so a motion
can reach |q_k| = c only if E >= V_min(c) = min V over the configurations with
|q_k| = c (every rate zero).  The minimum is taken on a periodic grid of the other
coordinates (the charts' coordinates are angles: V repeats every 2 pi, checked
here, else no bound is used).  At the true minimiser the gradient vanishes, so
the grid minimum exceeds it by at most d max|V''| h^2 / 8 (h the spacing, d the
number of other coordinates); that, doubled, and a relative 1e-6 for the run's own
energy error are subtracted before a trajectory is declared unable to reach c.
For the planar double pendulum (m = l = 1) this is 2 cos(theta1) + cos(theta2) > 1
for a flip of link 2 from rest, derived here from the energy kernel alone.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..model import load_model
from .sweep_file import Sweep
from ..runtime.model_sizes import model_info
from ..runtime.loader import load

GRID_POINTS = 2 ** 16           # grid points over the other coordinates, at most
MAX_PARAMETER_SETS = 64         # distinct parameter rows in one chunk that get a bound
ENERGY_SLACK = 1e-6             # relative: the integrator's own energy error, with room


@lru_cache(maxsize=None)
def n_params(model: str) -> int:
    """The model's parameters (p holds its inputs after them)."""
    return model_info(model).n_params


def energy(model: str, y, p):
    """E(y; p) from the compiled energy kernel (leading axes broadcast)."""
    return load(model).energy(y, p)


def unreachable(model: str, sweep: Sweep, y0: np.ndarray, p: np.ndarray) -> np.ndarray:
    """True for the trajectories whose energy keeps them from every event of the sweep."""
    out = np.zeros(len(y0), bool)
    description = load_model(model)
    if not sweep.events or not description.is_conservative:
        return out
    params = p[:, :n_params(model)]
    E0 = energy(model, y0, params)
    rows, inverse = np.unique(params, axis=0, return_inverse=True)
    if len(rows) > MAX_PARAMETER_SETS:
        return out
    out[:] = True
    for e in sweep.events:
        floors = np.array([floor(model, e.index, e.level, tuple(r)) for r in rows])
        out &= E0 < floors[inverse.reshape(-1)]
    return out


@lru_cache(maxsize=256)
def floor(model: str, index: int, level: float, params: tuple[float, ...]) -> float:
    """A lower bound (less the slack) of V on {|q_index| = level}; -inf where none holds."""
    n = 2 * len(load_model(model).coordinate_names)
    others = [i for i in range(n // 2) if i != index]
    p = np.asarray(params, float)
    if not _periodic(model, p, n):
        return -np.inf
    per = max(4, int(round(GRID_POINTS ** (1 / max(len(others), 1)))))
    h = 2 * np.pi / per
    axis = -np.pi + h * np.arange(per)
    lows = []
    for sign in (1.0, -1.0):
        mesh = np.meshgrid(*([axis] * len(others)), indexing="ij") if others else []
        y = np.zeros(tuple(len(axis) for _ in others) + (n,))
        y[..., index] = sign * level
        for i, m in zip(others, mesh):
            y[..., i] = m
        V = energy(model, y, p)
        curvature = 0.0
        for d in range(len(others)):
            second = np.roll(V, 1, axis=d) + np.roll(V, -1, axis=d) - 2 * V
            curvature = max(curvature, float(np.max(np.abs(second))) / h ** 2)
        lows.append(float(np.min(V)) - 2 * len(others) * curvature * h ** 2 / 8)
    low = min(lows)
    return low - ENERGY_SLACK * max(abs(low), 1.0)


def _periodic(model: str, p: np.ndarray, n: int) -> bool:
    rng = np.random.default_rng(0)
    q = np.zeros((16, n))
    q[:, : n // 2] = rng.uniform(-np.pi, np.pi, (16, n // 2))
    base = energy(model, q, p)
    for i in range(n // 2):
        shifted = q.copy()
        shifted[:, i] += 2 * np.pi
        if not np.allclose(energy(model, shifted, p), base, rtol=1e-12, atol=1e-12):
            return False
    return True
