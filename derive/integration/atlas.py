"""The chart atlas of the double spherical pendulum (seed 000 section 5), from Python.

Charts: spherical_std (theta, phi), spherical_alt (vartheta, varphi), spherical_rot
(the second chart with x and y swapped).  Thresholds (the same in C and NumPy):

* SINE_SWITCH = 0.3: after each accepted step (before each fixed step) the run
  switches when a polar sine of its chart is below this;
* SINE_RULE = 0.5: the rule of section 5.1 ("not small" is >= 0.5) picks the
  chart; every polar sine of the chart it picks is >= 0.5 (checked in
  tests/test_atlas.py), so hysteresis holds: a fresh chart is never left at once;
* SINE_MIN = 0.1: no kernel is ever evaluated where a polar sine of its chart is
  below this (adaptive steps shrink, fixed steps switch and redo, or stop with
  status 'chart singular').

The switch converts the state exactly with the generated <chart>_to_<chart>
kernels (robust atan2 forms, rates through the chart Jacobians); the integrator
then continues in the new chart (FSAL stage re-evaluated).
"""
from __future__ import annotations

import ctypes
from functools import lru_cache

import numpy as np

from ..codegen.sources import ATLAS, c_source
from . import contract
from .build import CTYPES, SUFFIX, build_fastest, dtype_key, info_struct, options_struct
from .contract import ATLAS_CHARTS, COUNTERS, METHODS, SINE_MIN, SINE_RULE, SINE_SWITCH, STATUS_NAMES
from .observables import _observables, _velocities, numpy_module
from .result import SimulationResult

__all__ = ["ATLAS_CHARTS", "SINE_MIN", "SINE_RULE", "SINE_SWITCH", "atlas_library", "run_atlas"]


class AtlasLibrary:
    def __init__(self):
        sources = [c_source(ATLAS, "spherical_atlas.c")]       # the charts' files are beside it
        for ch in ATLAS_CHARTS:
            sources += [c_source(ATLAS, f"{ch}_integrate.c"), c_source(ATLAS, f"{ch}.c")]
        self.path, self.flags = build_fastest("spherical_atlas", sources)
        self.lib = ctypes.CDLL(str(self.path))
        self.Options = options_struct(contract.ATLAS_OPTIONS)
        self.Info = info_struct(8, contract.ATLAS_INFO)
        self.lib.spherical_atlas_defaults.argtypes = [ctypes.POINTER(self.Options)]
        self.fns = {}
        for dt, suffix in SUFFIX.items():
            ptr = ctypes.POINTER(CTYPES[dt])
            ip = ctypes.POINTER(ctypes.c_int)
            fn = self.lib[f"spherical_atlas_integrate_batch{suffix}"]
            fn.restype = ctypes.c_long
            fn.argtypes = [ctypes.c_long, ctypes.c_int, ip, ptr, ctypes.c_long, ptr, ctypes.c_long,
                           ctypes.c_long, ptr, ptr, ip, ctypes.POINTER(self.Options),
                           ctypes.POINTER(self.Info)]
            self.fns[dt] = fn

    def defaults(self):
        o = self.Options()
        self.lib.spherical_atlas_defaults(ctypes.byref(o))
        return o

    def run(self, method: int, charts0, y0: np.ndarray, p: np.ndarray, t: np.ndarray, opt):
        """y0 (B, 8) in charts0 (B,) (-1: standard chart, rule picks) -> y, charts, infos."""
        dt = dtype_key(y0.dtype)
        ptr = ctypes.POINTER(CTYPES[dt])
        y0 = np.ascontiguousarray(y0)
        B = y0.shape[0]
        c0 = np.ascontiguousarray(np.broadcast_to(np.asarray(charts0, np.intc), (B,)))
        p = np.ascontiguousarray(p, dtype=y0.dtype)
        pstride = 0 if p.ndim == 1 else 5
        t = np.ascontiguousarray(t, dtype=y0.dtype)
        out = np.empty((B, len(t), 8), y0.dtype)
        charts = np.empty((B, len(t)), np.intc)
        infos = (self.Info * B)()
        ip = ctypes.POINTER(ctypes.c_int)
        self.fns[dt](B, method, c0.ctypes.data_as(ip), y0.ctypes.data_as(ptr), 8,
                     p.ctypes.data_as(ptr), pstride, len(t), t.ctypes.data_as(ptr),
                     out.ctypes.data_as(ptr), charts.ctypes.data_as(ip), ctypes.byref(opt), infos)
        return out, charts, infos


@lru_cache(maxsize=None)
def atlas_library() -> AtlasLibrary:
    return AtlasLibrary()


@lru_cache(maxsize=None)
def numpy_atlas():
    return numpy_module("spherical_atlas")


def observables(y: np.ndarray, charts: np.ndarray, p: np.ndarray, backend: str, dtype) -> tuple:
    """Energy, positions and velocities row by row, each row in its own chart."""
    n = len(y)
    E = np.full(n, np.nan, dtype)
    pos = np.full((n, 2, 3), np.nan, dtype)
    vel = np.full((n, 2, 3), np.nan, dtype)
    for k, ch in enumerate(ATLAS_CHARTS):
        rows = np.flatnonzero(charts == k)
        if rows.size:
            E[rows], pos[rows] = _observables(ch, y[rows], p, backend, dtype)
            vel[rows] = _velocities(ch, y[rows], p, backend, dtype)
    return E, pos, vel


def run_atlas(method: str, y0, chart: str, ts, p, opt: dict, dt, backend: str):
    y0 = np.asarray(y0, dt)
    pd = np.asarray(p, dt)
    tsd = np.asarray(ts, dt)
    chart0 = ATLAS_CHARTS.index(chart)
    if backend == "c":
        lib = atlas_library()
        o = lib.defaults()
        for k, v in opt.items():
            setattr(o, k, v)
        y, charts, infos = lib.run(METHODS.index(method), [chart0], y0[None, :], pd, tsd, o)
        y, charts, inf = y[0], charts[0], infos[0]
        counters = {k: int(getattr(inf, k)) for k in COUNTERS}
        status, t_stop, y_stop = int(inf.status), float(inf.t), np.array(inf.y[:])
        switches, chart_stop = int(inf.nswitches), int(inf.chart)
    else:
        mod = numpy_atlas()
        status, y, charts, inf = mod.integrate(method, chart0, y0, pd, tsd, dt, **opt)
        counters = {k: int(inf[k]) for k in COUNTERS}
        t_stop, y_stop = float(inf["t"]), np.asarray(inf["y"], float)
        switches, chart_stop = int(inf["nswitches"]), int(inf["chart"])
    ok_rows = charts >= 0
    E, pos, vel = observables(y, np.where(ok_rows, charts, -1), pd, backend, dt)
    names = np.array([ATLAS_CHARTS[c] if c >= 0 else None for c in charts], dtype=object)
    return SimulationResult(
        model="spherical", method=method, backend=backend, dtype=dtype_key(dt), t=np.asarray(ts, dt), y=y,
        energy=E, positions=pos, status=status, status_name=STATUS_NAMES[status], t_stop=t_stop,
        y_stop=y_stop, chart=names, switches=switches,
        chart_stop=ATLAS_CHARTS[chart_stop] if 0 <= chart_stop < 3 else None, params=pd,
        velocities=vel, **counters)
