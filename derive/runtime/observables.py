"""Energy, bob positions and bob velocities of a run's outputs, by the generated kernels
(C through derive.runtime.loader.load, NumPy through numpy_module): shared by
simulate (one model) and the atlas (row by row, each row in its chart)."""
from __future__ import annotations

import inspect
from functools import lru_cache

import numpy as np

from .loader import load as _load, numpy_module
from ..model import load_model
from ..model.description import forget_on_model_change
from .build import SUFFIX, dtype_key

__all__ = ["numpy_module", "observables", "velocities", "takes_time", "call_kernel"]


@forget_on_model_change
@lru_cache(maxsize=None)
def load(model: str):
    """The compiled kernels of `model`, opened once per process (the loader hashes the
    sources to find the library: too slow for every run)."""
    return _load(model)


def takes_time(kernel) -> bool:
    """Whether a generated kernel (a C kernel of the loader or a NumPy function) takes the
    time t first: a time-dependent model's kernels whose expressions use t do."""
    if hasattr(kernel, "inputs"):                      # a CKernel: its arrays, in order
        return bool(kernel.inputs) and kernel.inputs[0][0] == "t"
    return next(iter(inspect.signature(kernel).parameters), None) == "t"


def call_kernel(kernel, t, *arrays):
    """kernel(t, *arrays) where it takes the time (t: one per row, shaped (..., 1)), else
    kernel(*arrays); t may be None only for a kernel without it."""
    if not takes_time(kernel):
        return kernel(*arrays)
    if t is None:
        raise TypeError(f"{getattr(kernel, 'name', kernel)} takes the time t: give the times of the rows")
    return kernel(np.asarray(t, np.asarray(arrays[0]).dtype)[..., None], *arrays)


def _observables(model: str, y: np.ndarray, p: np.ndarray, backend: str, dtype: np.dtype, t=None):
    """(E, positions) of the rows y by the generated kernels; t: the rows' times (needed
    by a time-dependent model whose kernels take it: a moving pivot's)."""
    if len(y) == 0:
        d = load_model(model)
        return np.zeros(0, dtype), np.zeros((0, d.bodies, d.dimension), dtype)
    if backend == "c":
        m = load(model)
        s = SUFFIX[dtype_key(dtype)]
        E = call_kernel(getattr(m, "energy" + s), t, y, p.astype(dtype))
        pos = call_kernel(getattr(m, "positions" + s), t, y, p.astype(dtype))
    else:
        m = numpy_module(model)
        with np.errstate(all="ignore"):
            E = call_kernel(m.energy, t, y, p.astype(dtype))
            pos = call_kernel(m.positions, t, y, p.astype(dtype))
    return np.asarray(E, dtype), np.asarray(pos, dtype)


def _velocities(model: str, y: np.ndarray, p: np.ndarray, backend: str, dtype: np.dtype, t=None) -> np.ndarray:
    """The bobs' Cartesian velocities (len(y), bobs, dim) by the generated kernel (t: as
    for _observables)."""
    d = load_model(model)
    if len(y) == 0:
        return np.zeros((0, d.bodies, d.dimension), dtype)
    if backend == "c":
        vel = call_kernel(getattr(load(model), "velocities" + SUFFIX[dtype_key(dtype)]), t, y, p.astype(dtype))
    else:
        with np.errstate(all="ignore"):
            vel = call_kernel(numpy_module(model).velocities, t, y, p.astype(dtype))
    return np.asarray(vel, dtype)


observables, velocities = _observables, _velocities
