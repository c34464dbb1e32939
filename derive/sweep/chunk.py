"""One chunk of a sweep: its trajectories integrated as one batch, its quantities recorded.

This is the Dask task.  It runs anywhere derive is installed: the compiled
integrator comes from the worker's own cache, keyed by content hash (rendered and
compiled there on first use, derive/codegen/sources.py and runtime/build.py),
and a model read from a file travels in the task as its description.

The batch runs in SLABS pieces of the time span (restarting each piece from the
last state).  Each piece samples the trajectories at the sweep's output times, and
the event times, maxima and energy are taken from those samples (level_crossings.py);
when every recorded quantity is an event time, a trajectory leaves the batch once
its events have happened, and so does one that energy alone keeps from them
(bounds.py).  Event times with an accuracy are then verified (verify.py).  The
method is any of the compiled integrators or Taylor's method (<model>_taylor.c, whose
dense output makes the samples nearly free).  The results depend only on the chunk,
never on where it ran.
"""
from __future__ import annotations

import numpy as np

from ..codegen.contract import STATUS
from ..runtime import constraints
from ..runtime.energy_error import relative_change, scale_of
from ..runtime.runner import library_path, runner_for
from . import level_crossings as ev
from .bounds import energy as _energy, n_params as _n_params, unreachable
from .sweep_file import Sweep
from .runners import status_of, model_name, runner, scene_runner
from .verify import rungs, verify_events
from ..runtime.loader import load
from ..measurement.trust import JACOBIAN_STEPS_PER_UNIT_TIME
from concurrent.futures import ThreadPoolExecutor

SLABS = 10                      # pieces of the time span
CONSTRAINT_DRIFT = "constraint_drift"   # a loop's largest |Phi| or |J q'| over the samples
LYAPUNOV_BATCH = 64             # trajectories per Lyapunov batch (its fine grid is memory)


def variables(sweep: Sweep) -> list[str]:
    """The store's data variables, in order: the recorded quantities (final_state as one
    variable per state) and the integrator's status."""
    names = []
    verified = {f"{e.name}_time" for e in sweep.events if e.accuracy is not None}
    for q in sweep.record:
        names += [f"final_{s}" for s in sweep.state_names] if q == "final_state" else [q]
        names += [f"{q}_error"] if q in verified else []
    # a closed loop's drift off its constraints, always: what it stores is then never silently off the loop
    names += [CONSTRAINT_DRIFT] if sweep.free else []
    return names + ["status"]


def prepare(sweep: Sweep) -> None:
    """Build (or load from the cache) every integrator the sweep's chunks use, alongside
    one another (each a compiler process, and a Taylor library of high order is a long
    compile)."""
    model = model_name(sweep)
    library_path(model)                          # renders the sources and builds the RK library, once
    scene = sweep.scene
    settings = [(scene.rtol, scene.atol, scene.step, np.float64)]
    if any(e.accuracy is not None for e in sweep.events):
        settings += [(rtol, atol, None, dtype) for rtol, atol, dtype in rungs(scene)]
    with ThreadPoolExecutor(max_workers=len(settings)) as pool:
        list(pool.map(lambda s: runner(model, scene.method, *s), settings))


def integrate(sweep: Sweep, y0: np.ndarray, p: np.ndarray) -> dict[str, np.ndarray]:
    """Quantities of the trajectories y0 (B, n) with parameters p (B, np), flat; event
    times with an `accuracy` verified (verify.py)."""
    model = model_name(sweep)
    closed = np.ones(len(y0), bool)
    if sweep.free:                    # a loop's starts, solved onto it from their free coordinates
        y0, closed = constraints.close_from_free(model, y0, p, list(sweep.free))
    batch = _Batch(sweep, model, y0, p)
    batch.status[~closed] = STATUS["BAD_INPUT"]       # the loop cannot close there: not run
    batch.active &= closed
    if sweep.events_only:
        batch.active &= ~unreachable(model, sweep, y0, p)
    scene = sweep.scene
    t = np.linspace(scene.t_start, scene.t_stop, scene.outputs)
    bounds = np.unique(np.linspace(0, len(t) - 1, min(SLABS, len(t) - 1) + 1).round().astype(int))
    for a, b in zip(bounds[:-1], bounds[1:]):
        if not batch.active.any():
            break
        batch.slab(t[a:b + 1])
    out = batch.results()
    if "lyapunov_exponent" in sweep.record:
        out["lyapunov_exponent"] = lyapunov(model, y0, p, scene.t_stop - scene.t_start, batch.n_params)
    out.update(verify_events(sweep, model, y0, p, out))
    out["status"] = batch.status
    return out


class _Batch:
    """The chunk's trajectories as they run, piece by piece, and what they record."""

    def __init__(self, sweep: Sweep, model: str, y0: np.ndarray, p: np.ndarray):
        self.sweep, self.model = sweep, model
        self.run = scene_runner(sweep, model)
        self.n_params = _n_params(model)
        B, self.n = y0.shape
        self.p = np.asarray(p, np.float64)
        self.state, self.status = np.array(y0, np.float64), np.zeros(B, np.int8)
        self.active = np.ones(B, bool)
        self.times = {e.name: np.full(B, np.nan) for e in sweep.events}
        coordinates = sweep.state_names[: self.n // 2]
        self.maxima = {q: i for i, q in enumerate(coordinates) if f"max_abs_{q}" in sweep.record}
        self.peak = {q: np.abs(self.state[:, i]).astype(np.float64) for q, i in self.maxima.items()}
        self.loop_drift = np.zeros(B) if sweep.free else None
        self.energy = "energy_error" in sweep.record
        if self.energy:
            self.E0 = _energy(model, y0, p[:, :self.n_params])
            # relative to max(|E0|, m g l), which cannot vanish as |E0| can (runtime/energy_error.py)
            self.scale = np.broadcast_to(scale_of(model, self.p[:, :self.n_params], self.E0), (B,))
            self.drift = np.zeros(B)

    def slab(self, ts: np.ndarray) -> None:
        """Integrate the active trajectories over ts (their samples), then record."""
        rows = np.flatnonzero(self.active)
        p_rows = self.p[rows]
        y, st = self.run(self.state[rows], p_rows, ts)

        def rerun(sub, start, local):
            return self.run(start, p_rows[sub], local)

        for e in self.sweep.events:
            pending = np.isnan(self.times[e.name][rows])
            found = ev.locate(rerun, y, ts, e.index, e.level, search=pending)
            self.times[e.name][rows] = np.where(pending, found, self.times[e.name][rows])
        self._maxima(rows, y, ts)
        if self.loop_drift is not None:
            phi, phi_dot = constraints.residuals(self.model, y, p_rows[:, None, :self.n_params])
            worst = np.fmax(np.nanmax(np.abs(phi), axis=(1, 2)), np.nanmax(np.abs(phi_dot), axis=(1, 2)))
            self.loop_drift[rows] = np.fmax(self.loop_drift[rows], worst)
        if self.energy:
            E = _energy(self.model, y, p_rows[:, None, :self.n_params])
            change = relative_change(E, self.E0[rows, None], self.scale[rows, None])
            self.drift[rows] = np.fmax(self.drift[rows], np.nanmax(change, axis=1, initial=0.0))
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
        if self.loop_drift is not None:
            out[CONSTRAINT_DRIFT] = np.where(ok, self.loop_drift, np.nan)
        return out


def lyapunov(model: str, y0: np.ndarray, p: np.ndarray, t_end: float, n_params: int) -> np.ndarray:
    """The largest Lyapunov exponent of each trajectory: the algorithm of
    derive.measurement.trust.largest_lyapunov (the same run, grid, Jacobian, Taylor
    step and start vector), batched over trajectories."""
    reference = runner_for(model, "dop853")
    opt = reference.options({"rtol": 1e-11, "atol": 1e-13})
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
        y, infos, _ = reference.batch(y0[sl].astype(float), p[sl], grid, opt)
        ok = status_of(infos) == 0
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
