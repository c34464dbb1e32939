"""Chart atlases (seed 000 section 5), from Python: the catalogue's ("spherical", the
double spherical pendulum) and the atlas of any chain of spherical links
(derive/model/atlas.py; key "<model>_atlas").

Charts: standard (theta, phi), second (vartheta, varphi), rotated (the second chart
with x and y swapped), one member model each.  Thresholds (the same in C and NumPy):

* SINE_SWITCH = 0.3: after each accepted step (before each fixed step) the run
  switches when a polar sine of its chart is below this;
* SINE_RULE = 0.5: the rule of section 5.1 ("not small" is >= 0.5) picks the
  chart; for one or two links every polar sine of the chart it picks is >= 0.5
  (checked in tests/test_atlas.py), so hysteresis holds: a fresh chart is never left
  at once; for three links or more see cartesian.choose_chart (the generalisation);
* SINE_MIN = 0.1: no kernel is ever evaluated where a polar sine of its chart is
  below this (adaptive steps shrink, fixed steps switch and redo, or stop with
  status 'chart singular').

The switch converts the state exactly with the generated <chart>_to_<chart>
kernels (robust atan2 forms, rates through the chart Jacobians); the integrator
then continues in the new chart (FSAL stage re-evaluated).
"""
from __future__ import annotations

import numpy as np

from ..model import load_model
from ..model.atlas import ATLAS, load_atlas
from .build import dtype_key
from .atlas_library import AtlasLibrary, atlas_library, numpy_atlas  # noqa: F401  (re-exported)
from .runner import runner_for
from .shared_library import info_state, stop_state
from ..codegen.contract import (ATLAS_CHARTS, COUNTERS, LOCAL_ERROR_METHODS, SINE_MIN, SINE_RULE, SINE_SWITCH,
                                STATUS_NAMES)
from ..codegen.contract import METHODS  # noqa: F401  (re-exported: the contract's table)
from .observables import _observables, _velocities
from .result import LOCAL_SUM, SimulationResult

__all__ = ["ATLAS_CHARTS", "SINE_MIN", "SINE_RULE", "SINE_SWITCH", "atlas_library", "run_atlas"]


def observables(charts_of: tuple[str, ...], y: np.ndarray, charts: np.ndarray, p: np.ndarray,
                backend: str, dtype) -> tuple:
    """Energy, positions and velocities row by row, each row in its own chart."""
    n = len(y)
    first = load_model(charts_of[0])
    shape = (n, first.bodies, first.dimension)
    E = np.full(n, np.nan, dtype)
    pos, vel = np.full(shape, np.nan, dtype), np.full(shape, np.nan, dtype)
    for k, ch in enumerate(charts_of):
        rows = np.flatnonzero(charts == k)
        if rows.size:
            E[rows], pos[rows] = _observables(ch, y[rows], p, backend, dtype)
            vel[rows] = _velocities(ch, y[rows], p, backend, dtype)
    return E, pos, vel


def run_atlas(method: str, y0, chart: str, ts, p, opt: dict, dt, backend: str, name: str = ATLAS):
    """One run of atlas `name` from y0, a state of its member `chart`."""
    charts_of = load_atlas(name).charts
    y0 = np.asarray(y0, dt)
    pd = np.asarray(p, dt)
    tsd = np.asarray(ts, dt)
    chart0 = charts_of.index(chart)
    r = runner_for(name, method, dtype_key(dt), backend)
    if backend == "c":
        y, charts, infos = r.atlas_batch([chart0], y0[None, :], pd, tsd, r.options(opt))
        y, charts, inf = y[0], charts[0], infos[0]
        counters = {k: int(getattr(inf, k)) for k in COUNTERS}
        status, t_stop, y_stop = int(inf.status), float(inf.t), info_state(inf, len(y0), dt)
        switches, chart_stop = int(inf.nswitches), int(inf.chart)
        local_error = float(inf.local_error)
    else:
        status, y, charts, inf = r.numpy_integrator().integrate(method, chart0, y0, pd, tsd, dt, **opt)
        counters = {k: int(inf[k]) for k in COUNTERS}
        t_stop, y_stop = float(inf["t"]), stop_state(inf["y"], dt)
        switches, chart_stop = int(inf["nswitches"]), int(inf["chart"])
        local_error = float(inf["local_error"])
    ok_rows = charts >= 0
    E, pos, vel = observables(charts_of, y, np.where(ok_rows, charts, -1), pd, backend, dt)
    names = np.array([charts_of[c] if c >= 0 else None for c in charts], dtype=object)
    return SimulationResult(
        model=name, method=method, backend=backend, dtype=dtype_key(dt), t=np.asarray(ts, dt), y=y,
        energy=E, positions=pos, status=status, status_name=STATUS_NAMES[status], t_stop=t_stop,
        y_stop=y_stop, chart=names, switches=switches,
        chart_stop=charts_of[chart_stop] if 0 <= chart_stop < len(charts_of) else None, params=pd,
        velocities=vel, error_estimate=local_error if method in LOCAL_ERROR_METHODS else None,
        error_kind=LOCAL_SUM if method in LOCAL_ERROR_METHODS else None, **counters)
