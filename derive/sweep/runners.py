"""How a sweep runs a batch of trajectories: the model a worker loads (a model file's
text registered in this machine's cache) and one batch call of an integrator at given
settings (chunk.py's first pass, verify.py's runs again, mirror.py's check).
"""
from __future__ import annotations

import hashlib
from functools import lru_cache

import numpy as np

from ..codegen.contract import METHODS, TAYLOR
from ..model import load_model_file
from ..model.description import _from_files
from ..paths import cache_dir, replace_file
from ..runtime.build import integrator_library
from ..runtime.taylor_lanes_library import taylor_ensemble_library
from ..codegen.contract import taylor_order
from .sweep_file import Sweep

TAYLOR_HMAX = 1e300             # no cap on a Taylor step but the run's end (runner)


def model_name(sweep: Sweep) -> str:
    """The model's name here; a model file's description is written into this machine's
    cache and read from there (a worker needs no copy of the sweep's files)."""
    if sweep.model_text is None:
        return sweep.scene.model
    return _register(sweep.model_text)


@lru_cache(maxsize=None)
def _register(text: str) -> str:
    for name, model in _from_files.items():         # read already (the process that parsed the sweep)
        if model.text == text:
            return name
    path = cache_dir() / "sweep-models" / f"{hashlib.sha256(text.encode()).hexdigest()[:24]}.toml"
    if not path.is_file():
        replace_file(path, lambda tmp: tmp.write_text(text))
    return load_model_file(path).name


def runner(model: str, method: str, rtol: float | None, atol: float | None, step: float | None = None,
           build: type | None = None):
    """run(y0, p, t) -> (y, status): one batch call of `method` (DOP853, Taylor, ...) at these
    settings, in the dtype of y0 (double, or long double for the verification); `build`, a
    dtype: compile (or load) its Taylor integrator now rather than at the first call."""
    lib = integrator_library(model)
    opt = lib.defaults()
    for name, value in (("rtol", rtol), ("atol", atol), ("h", step)):
        if value is not None:
            setattr(opt, name, value)
    if method == TAYLOR:
        order = taylor_order(opt.rtol)
        # the generated Taylor integrator caps its step's radius at hmax (the run's span when
        # hmax is 0) before it applies the step factor (e^-2 ...): a run shorter than a few
        # steps would take ~8 steps of an eighth of the span.  An hmax past any span leaves
        # Jorba and Zou's step as it is (the last step still ends on the run's end).
        opt.hmax = TAYLOR_HMAX

        def call(y0, p, t):
            # derive.ensemble's integrator: SIMD lanes in double (bit for bit the scalar
            # integrator's numbers, tests/test_taylor_lanes.py), the scalar one in long double
            return taylor_ensemble_library(model, order, _dtype_name(y0.dtype)).run(y0, p, t, opt)
        if build is not None:
            taylor_ensemble_library(model, order, _dtype_name(np.dtype(build)))
    else:
        index = METHODS.index(method)

        def call(y0, p, t):
            return lib.run(index, y0, p, t, opt)

    def run(y0, p, t):
        y, infos = call(np.ascontiguousarray(y0), p, np.asarray(t, y0.dtype))
        return y, status_of(infos)
    return run


def scene_runner(sweep: Sweep, model: str):
    """The runner of the sweep's own method and tolerance (the first pass)."""
    scene = sweep.scene
    return runner(model, scene.method, scene.rtol, scene.atol, scene.step)


def _dtype_name(dtype: np.dtype) -> str:
    return "longdouble" if dtype == np.longdouble else "float64"


def status_of(infos) -> np.ndarray:
    return np.fromiter((i.status for i in infos), np.int8, len(infos))
