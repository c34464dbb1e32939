"""Energy, bob positions and bob velocities of a run's outputs, by the generated kernels
(C through derive.runtime.loader.load, NumPy through numpy_module): shared by
simulate (one model) and the atlas (row by row, each row in its chart)."""
from __future__ import annotations

import numpy as np

from functools import lru_cache

from .loader import load as _load, numpy_module
from ..model import load_model
from ..model.description import forget_on_model_change
from .build import SUFFIX, dtype_key

__all__ = ["numpy_module", "observables", "velocities"]


@forget_on_model_change
@lru_cache(maxsize=None)
def load(model: str):
    """The compiled kernels of `model`, opened once per process (the loader hashes the
    sources to find the library: too slow for every run)."""
    return _load(model)


def _observables(model: str, y: np.ndarray, p: np.ndarray, backend: str, dtype: np.dtype):
    if len(y) == 0:
        d = load_model(model)
        return np.zeros(0, dtype), np.zeros((0, d.bodies, d.dimension), dtype)
    if backend == "c":
        m = load(model)
        s = SUFFIX[dtype_key(dtype)]
        E = getattr(m, "energy" + s)(y, p.astype(dtype))
        pos = getattr(m, "positions" + s)(y, p.astype(dtype))
    else:
        m = numpy_module(model)
        with np.errstate(all="ignore"):
            E = m.energy(y, p.astype(dtype))
            pos = m.positions(y, p.astype(dtype))
    return np.asarray(E, dtype), np.asarray(pos, dtype)


def _velocities(model: str, y: np.ndarray, p: np.ndarray, backend: str, dtype: np.dtype) -> np.ndarray:
    """The bobs' Cartesian velocities (len(y), bobs, dim) by the generated kernel."""
    d = load_model(model)
    if len(y) == 0:
        return np.zeros((0, d.bodies, d.dimension), dtype)
    if backend == "c":
        vel = getattr(load(model), "velocities" + SUFFIX[dtype_key(dtype)])(y, p.astype(dtype))
    else:
        with np.errstate(all="ignore"):
            vel = numpy_module(model).velocities(y, p.astype(dtype))
    return np.asarray(vel, dtype)


observables, velocities = _observables, _velocities
