"""How a sweep runs a batch of trajectories: the model a worker loads (a model file's
text registered in this machine's cache) and one batch call of an integrator at given
settings (chunk.py's first pass, verify.py's runs again, mirror.py's check).
"""
from __future__ import annotations

import hashlib
from functools import lru_cache

import numpy as np

from ..model import load_model_file
from ..model.description import _from_files
from ..paths import cache_dir, replace_file
from ..runtime.build import dtype_key
from ..runtime.runner import runner_for
from ..runtime.specialised import folded_model
from .sweep_file import Sweep


def model_name(sweep: Sweep) -> str:
    """The model's name here; a model file's description is written into this machine's
    cache and read from there (a worker needs no copy of the sweep's files).  With
    pendulum.specialise = true, the model with the parameters the sweep does not sweep
    folded in (each worker makes the same one: its name is the digest of the values)."""
    name = sweep.scene.model if sweep.model_text is None else _register(sweep.model_text)
    if not sweep.scene.specialise:
        return name
    # (sweep.swept, not the axes: a chunk's task carries the sweep without them)
    return _specialised(name, tuple((k, v) for k, v in sweep.scene.parameters.items() if k not in sweep.swept))


@lru_cache(maxsize=64)
def _specialised(name: str, fixed: tuple) -> str:
    values = dict(fixed)
    return folded_model(name, tuple(values), tuple(values.values()))


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
    settings, in the dtype of y0 (double, or long double for the verification), through the
    run time's runner (Taylor: its SIMD lanes in double, bit for bit the scalar integrator's
    numbers; its step not capped by hmax); `build`, a dtype: compile (or load) its
    integrator now rather than at the first call."""
    values = {name: value for name, value in (("rtol", rtol), ("atol", atol), ("h", step)) if value is not None}
    opt = runner_for(model, method).options(values, uncapped=True)     # builds the RK library now
    if build is not None:
        runner_for(model, method, dtype_key(np.dtype(build))).batch_library(opt.rtol)

    def run(y0, p, t):
        y, infos, _ = runner_for(model, method, dtype_key(y0.dtype)).batch(
            np.ascontiguousarray(y0), p, np.asarray(t, y0.dtype), opt)
        return y, status_of(infos)
    return run


def scene_runner(sweep: Sweep, model: str):
    """The runner of the sweep's own method and tolerance (the first pass)."""
    scene = sweep.scene
    rtol, atol = scene.guard if scene.guard is not None else (scene.rtol, scene.atol)    # abm12: its guard's
    return runner(model, scene.method, rtol, atol, scene.step)


def status_of(infos) -> np.ndarray:
    return np.fromiter((i.status for i in infos), np.int8, len(infos))
