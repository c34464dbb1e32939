"""One chunk of a sweep: its trajectories integrated as one batch, its quantities recorded.

This is the Dask task.  It runs anywhere derive is installed: the compiled
integrator comes from the worker's own cache, keyed by content hash (rendered and
compiled there on first use, derive/codegen/sources.py and integration/build.py),
and a model read from a file travels in the task as its description.

The batch runs in SLABS pieces of the time span (restarting each piece from the
last state).  Each piece samples the trajectories at the sweep's output times, and
the event times, maxima and energy are taken from those samples (events.py);
when every recorded quantity is an event time, a trajectory leaves the batch once
its events have happened, and so does one that energy alone keeps from them
(bounds.py).  The results depend only on the chunk, never on where it ran.
"""
from __future__ import annotations

import dataclasses
import hashlib
from functools import lru_cache

import numpy as np

from ..integration.build import integrator_library
from ..integration.contract import METHODS
from . import events as ev
from .bounds import energy as _energy, n_params as _n_params, unreachable
from .spec import Sweep

SLABS = 10                      # pieces of the time span
LYAPUNOV_BATCH = 64             # trajectories per Lyapunov batch (its fine grid is memory)


def variables(sweep: Sweep) -> list[str]:
    """The store's data variables, in order: the recorded quantities (final_state as one
    variable per state) and the integrator's status."""
    names = []
    verified = {f"{e.name}_time" for e in sweep.events if e.accuracy is not None}
    for q in sweep.record:
        names += [f"final_{s}" for s in sweep.state_names] if q == "final_state" else [q]
        names += [f"{q}_error"] if q in verified else []
    return names + ["status"]


def _model(sweep: Sweep) -> str:
    """The model's name here; a model file's description is written into this machine's
    cache and read from there (a worker needs no copy of the sweep's files)."""
    if sweep.model_text is None:
        return sweep.scene.model
    return _register(sweep.model_text)


@lru_cache(maxsize=None)
def _register(text: str) -> str:
    from ..model import load_model_file
    from ..model.description import _from_files
    from ..paths import cache_dir, replace_file
    for name, model in _from_files.items():         # read already (the process that parsed the sweep)
        if model.text == text:
            return name
    path = cache_dir() / "sweep-models" / f"{hashlib.sha256(text.encode()).hexdigest()[:24]}.toml"
    if not path.is_file():
        replace_file(path, lambda tmp: tmp.write_text(text))
    return load_model_file(path).name


def _options(lib, sweep: Sweep):
    o = lib.defaults()
    scene = sweep.scene
    if scene.rtol is not None:
        o.rtol = scene.rtol
    if scene.atol is not None:
        o.atol = scene.atol
    if scene.step is not None:
        o.h = scene.step
    return o


def _status(infos) -> np.ndarray:
    return np.fromiter((i.status for i in infos), np.int8, len(infos))


def integrate(sweep: Sweep, y0: np.ndarray, p: np.ndarray, dtype=np.float64,
              verify: bool = True) -> dict[str, np.ndarray]:
    """Quantities of the trajectories y0 (B, n) with parameters p (B, np), flat.
    dtype: long double for the verification of event times (verify_events), which
    records event times only; verify=False: no verification (that pass itself)."""
    model = _model(sweep)
    batch = _Batch(sweep, model, y0, p, dtype)
    if sweep.events_only and dtype == np.float64:
        batch.active &= ~unreachable(model, sweep, y0, p)
    scene = sweep.scene
    t = np.linspace(scene.t_start, scene.t_stop, scene.outputs).astype(dtype)
    bounds = np.unique(np.linspace(0, len(t) - 1, min(SLABS, len(t) - 1) + 1).round().astype(int))
    for a, b in zip(bounds[:-1], bounds[1:]):
        if not batch.active.any():
            break
        batch.slab(t[a:b + 1])
    out = batch.results()
    if "lyapunov_exponent" in sweep.record:
        out["lyapunov_exponent"] = lyapunov(model, y0, p, scene.t_stop - scene.t_start, batch.n_params)
    if verify:
        out.update(verify_events(sweep, y0, p, out))
    out["status"] = batch.status
    return out


class _Batch:
    """The chunk's trajectories as they run, piece by piece, and what they record."""

    def __init__(self, sweep: Sweep, model: str, y0: np.ndarray, p: np.ndarray, dtype):
        self.sweep, self.model = sweep, model
        self.lib = integrator_library(model)
        self.opt = _options(self.lib, sweep)
        self.method = METHODS.index(sweep.scene.method)
        self.n_params = _n_params(model)
        B, self.n = y0.shape
        self.p = p.astype(dtype)
        self.state, self.status = y0.astype(dtype), np.zeros(B, np.int8)
        self.active = np.ones(B, bool)
        self.times = {e.name: np.full(B, np.nan) for e in sweep.events}
        coordinates = sweep.state_names[: self.n // 2]
        self.maxima = {q: i for i, q in enumerate(coordinates) if f"max_abs_{q}" in sweep.record}
        self.peak = {q: np.abs(self.state[:, i]).astype(np.float64) for q, i in self.maxima.items()}
        self.energy = "energy_error" in sweep.record
        if self.energy:
            self.E0 = _energy(model, y0, p[:, :self.n_params])
            self.drift = np.zeros(B)

    def slab(self, ts: np.ndarray) -> None:
        """Integrate the active trajectories over ts (their samples), then record."""
        rows = np.flatnonzero(self.active)
        p_rows = self.p[rows]
        y, infos = self.lib.run(self.method, self.state[rows], p_rows, ts, self.opt)
        st = _status(infos)

        def rerun(sub, start, local):
            yf, inf = self.lib.run(self.method, np.ascontiguousarray(start), p_rows[sub], local, self.opt)
            return yf, _status(inf)

        for e in self.sweep.events:
            pending = np.isnan(self.times[e.name][rows])
            found = ev.locate(rerun, y, ts, e.index, e.level, search=pending)
            self.times[e.name][rows] = np.where(pending, found, self.times[e.name][rows])
        self._maxima(rows, y, ts)
        if self.energy:
            E = _energy(self.model, y, p_rows[:, None, :self.n_params])
            change = np.nanmax(np.abs(E - self.E0[rows, None]), axis=1, initial=0.0)
            self.drift[rows] = np.fmax(self.drift[rows], change / np.maximum(np.abs(self.E0[rows]), 1e-300))
        self.state[rows] = y[:, -1]
        self.status[rows] = np.where(self.status[rows] == 0, st, self.status[rows])
        self.active[rows[st != 0]] = False
        if self.sweep.events_only:
            done = np.all([np.isfinite(self.times[e.name][rows]) for e in self.sweep.events], axis=0)
            self.active[rows[done]] = False

    def _maxima(self, rows, y, ts) -> None:
        """max |q| between the samples too: the cubic through the samples and rates."""
        h = self.n // 2
        for q, i in self.maxima.items():
            a = ev.hermite(y[:, :-1, i], y[:, :-1, i + h], y[:, 1:, i], y[:, 1:, i + h], np.diff(ts)[None, :])
            self.peak[q][rows] = np.fmax(self.peak[q][rows], np.nanmax(ev.max_abs(a), axis=1, initial=0.0))

    def results(self) -> dict[str, np.ndarray]:
        """The recorded quantities (NaN where the run failed), but the Lyapunov exponent."""
        ok = self.status == 0
        out = {}
        for q in self.sweep.record:
            if q == "final_state":
                final = np.where(ok[:, None], self.state, np.nan).astype(np.float64)
                out.update({f"final_{s}": final[:, i] for i, s in enumerate(self.sweep.state_names)})
            elif q == "energy_error":
                out[q] = np.where(ok, self.drift, np.nan)
            elif q.startswith("max_abs_"):
                out[q] = np.where(ok, self.peak[q[len("max_abs_"):]], np.nan)
            elif q.endswith("_time"):
                out[q] = self.times[q[: -len("_time")]]
        return out


VERIFY_TIGHTER = 10              # the check runs at rtol / 10 in double ...
LONG_DOUBLE_TIGHTER = 1000       # ... and, where that disagrees, at rtol / 1000 in long double
LONG_DOUBLE_RTOL_MIN = 1e-17     # 100 eps of long double (x86: eps 1.1e-19)


def verify_events(sweep: Sweep, y0: np.ndarray, p: np.ndarray, out: dict) -> dict[str, np.ndarray]:
    """Event times with an `accuracy`: each time found is computed again at rtol / 10; the
    two differ by d, and since the error of DOP853 is proportional to its tolerance the
    tighter time's error is about d / 9.  Where d exceeds the accuracy, the time is computed
    a third time in long double at rtol / 1000 (error about |d3| / 99 by the same reasoning,
    d3 its difference from the second).  -> the times replaced by the best one and
    `<event>_time_error`, the estimate (NaN where no event: a "no event" is not re-checked)."""
    result = {}
    for e in sweep.events:
        name = f"{e.name}_time"
        if e.accuracy is None or name not in out:
            continue
        first = out[name]
        best, error = first.copy(), np.full(len(first), np.nan)
        rows = np.flatnonzero(np.isfinite(first) & (first > sweep.scene.t_start))
        error[np.isfinite(first) & (first == sweep.scene.t_start)] = 0.0      # at the start: exact
        if rows.size:
            second = _event_again(sweep, e, y0[rows], p[rows], VERIFY_TIGHTER, np.float64)
            d = np.abs(second - first[rows])
            best[rows], error[rows] = second, d / (VERIFY_TIGHTER - 1)
            doubt = rows[~(d <= e.accuracy)]                 # disagreeing, or lost at rtol / 10
            if doubt.size:
                third = _event_again(sweep, e, y0[doubt], p[doubt], LONG_DOUBLE_TIGHTER, np.longdouble)
                d3 = np.abs(third - best[doubt])
                best[doubt] = third
                error[doubt] = d3 * VERIFY_TIGHTER / (LONG_DOUBLE_TIGHTER - VERIFY_TIGHTER)
        result[name], result[f"{name}_error"] = best, error
    return result


def _event_again(sweep: Sweep, event, y0, p, tighter: float, dtype) -> np.ndarray:
    scene = sweep.scene
    rtol = scene.rtol / tighter
    if dtype == np.longdouble:
        rtol = max(rtol, LONG_DOUBLE_RTOL_MIN)
    again = dataclasses.replace(sweep, record=(f"{event.name}_time",), events=(event,),
                                scene=dataclasses.replace(scene, rtol=rtol, atol=rtol * (scene.atol / scene.rtol)))
    return np.asarray(integrate(again, y0, p, dtype=dtype, verify=False)[f"{event.name}_time"], np.float64)


def lyapunov(model: str, y0: np.ndarray, p: np.ndarray, t_end: float, n_params: int) -> np.ndarray:
    """The largest Lyapunov exponent of each trajectory: the algorithm of
    derive.measurement.trust.largest_lyapunov (the same run, grid, Jacobian, Taylor
    step and start vector), batched over trajectories."""
    from ..codegen.loader import load
    from ..measurement.trust import JACOBIAN_STEPS_PER_UNIT_TIME
    lib = integrator_library(model)
    opt = lib.defaults()
    opt.rtol, opt.atol = 1e-11, 1e-13
    steps = max(200, int(JACOBIAN_STEPS_PER_UNIT_TIME * t_end))
    grid = np.linspace(0.0, t_end, 2 * steps + 1)
    dt = t_end / steps
    n = y0.shape[1]
    start = np.random.default_rng(0).standard_normal(n)
    start /= np.linalg.norm(start)
    out = np.full(len(y0), np.nan)
    jacobian = load(model).jacobian
    for lo in range(0, len(y0), LYAPUNOV_BATCH):
        sl = slice(lo, lo + LYAPUNOV_BATCH)
        y, infos = lib.run(METHODS.index("dop853"), y0[sl].astype(float), p[sl], grid, opt)
        ok = _status(infos) == 0
        args = (y[:, 1::2], p[sl, None, :n_params])
        if p.shape[1] > n_params:                      # a model's inputs follow its parameters
            args += (p[sl, None, n_params:],)
        J = jacobian(*args) * dt                        # (b, steps, n, n)
        delta = np.repeat(start[None, :], len(J), axis=0)
        log_growth = np.zeros(len(J))
        for k in range(steps):
            A = J[:, k]
            term = np.einsum("bij,bj->bi", A, delta)
            step = delta + term
            for m in (2, 3, 4):                          # Taylor polynomial of exp(A) applied to delta
                term = np.einsum("bij,bj->bi", A, term) / m
                step = step + term
            norm = np.linalg.norm(step, axis=1)
            log_growth += np.log(norm)
            delta = step / norm[:, None]
        out[sl] = np.where(ok, log_growth / t_end, np.nan)
    return out
