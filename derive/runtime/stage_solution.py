"""The continuous solution and the events of a run stepped in Python (continuous_inputs.py:
inputs u(t, y) at every stage, a time-dependent model).

r.sol(t) is one step of the run's own method from the start (t_i, y_i) of the accepted
step that holds t, over t - t_i.  Why that is the solution: the step from t_i over its
full length h_i is the step the run took, so sol(t_i + h_i) is y_i+1 (sol is continuous
across steps, and equals every output row); inside the step a shorter step of the same
method from the same y_i has a local error no larger than the run's step's (its error
constant times a smaller power of the length).  Why not dense.py's: that one starts each
output interval at time 0 (a time shift), true only of an autonomous model with inputs
constant over the interval; here the right-hand side depends on t.

Events are located on the steps: g is sampled at each accepted step's start and its
midpoint (two samples per step, as events.py samples), a sign change brackets a crossing
and the Illinois method (regula falsi that halves the value of an end kept twice) on
g(sol(t)) refines it to a bracket of 1e-3 rtol times the step (or 4 eps of t).
"""
from __future__ import annotations

import numpy as np

from ..errors import SimulationInputError
from .events import _apply
from .result import EventRecord

XTOL_RTOL = 1e-3               # bracket width: this times rtol times the step holding it
MAX_ITERATIONS = 200


class StageSolution:
    """sol(t) -> (n,) for a scalar t, (len(t), n) for an array of times, in the span of
    the run (NaN past its end: a failed run's t_stop or a terminal event's time).

    Parameters
    ----------
    step : callable
        step(t, y, h) -> the state after one step of the run's method.
    starts : list of (float, ndarray)
        Each accepted step's start, in the run's order (the first: the initial state).
    t0, t_end : float
        Where the run starts and how far it is known.
    params : ndarray
        The model's parameters.
    inputs : callable
        inputs(t, y) -> the inputs there (None for a model without).
    """

    def __init__(self, step, starts, t0: float, t_end: float, params: np.ndarray, inputs):
        self._step = step
        self.t_starts = np.array([t for t, _ in starts], np.float64)
        self.y_starts = np.array([y for _, y in starts], np.float64)
        self.t0, self.t_end, self.params, self.inputs = float(t0), float(t_end), params, inputs
        self.direction = 1.0 if len(self.t_starts) < 2 or self.t_starts[-1] >= self.t0 else -1.0

    def at(self, t: float) -> np.ndarray:
        """The state at one time t in the span."""
        d = self.direction
        if (t - self.t0) * d < 0:
            raise SimulationInputError(f"sol({t:g}) is before the run's start t = {self.t0:g}")
        if (t - self.t_end) * d > 0:
            return np.full(self.y_starts.shape[1], np.nan)
        i = int(np.searchsorted(self.t_starts * d, t * d, side="right")) - 1
        offset = t - self.t_starts[i]
        return self.y_starts[i].copy() if offset == 0 else self._step(self.t_starts[i], self.y_starts[i], offset)

    def __call__(self, t):
        if np.ndim(t) == 0:
            return self.at(float(t))
        return np.array([self.at(float(x)) for x in np.asarray(t, np.float64).ravel()])


def locate_on_steps(result, events, rtol: float):
    """The crossings of every event on result.sol (a StageSolution); a terminal event
    truncates the result (events._apply)."""
    sol = result.sol
    times = _sample_times(sol)
    states = sol(times)
    found = {e.name: _crossings(sol, e, times, states, rtol) for e in events}
    return _apply(result, events, found)


def _sample_times(sol: StageSolution) -> np.ndarray:
    """Every step's start and midpoint, up to the end of the run."""
    d = sol.direction
    starts = sol.t_starts[(sol.t_starts - sol.t_end) * d <= 0]
    ends = np.append(starts[1:], sol.t_end)
    mids = 0.5 * (starts + ends)
    times = np.ravel(np.column_stack([starts, mids]))
    return np.append(times, sol.t_end) if ends[-1] != starts[-1] else times


def _g(sol: StageSolution, event, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The event's function at the states y at times t (the inputs there, if any)."""
    u = [sol.inputs(a, b) for a, b in zip(t, y)]
    inputs = None if not u or u[0] is None else np.array(u, np.float64)
    return np.asarray(event.function(y, sol.params, inputs), np.float64)


def _crossings(sol: StageSolution, event, times, states, rtol: float) -> EventRecord:
    g = _g(sol, event, times, states)
    a, b = g[:-1], g[1:]
    up, down = (a < 0) & (b >= 0), (a > 0) & (b <= 0)
    wanted = up | down if event.direction == 0 else (up if event.direction > 0 else down)
    roots, ys = [], []
    for i in np.flatnonzero(wanted):
        t, y = _refine(sol, event, times[i], times[i + 1], g[i], g[i + 1], rtol)
        roots.append(t)
        ys.append(y)
    n = states.shape[1]
    return EventRecord(event.name, event.expression, np.array(roots, np.float64),
                       np.array(ys, np.float64).reshape(-1, n),
                       np.where(up[wanted], 1, -1).astype(int))


def _refine(sol: StageSolution, event, lo: float, hi: float, glo: float, ghi: float, rtol: float):
    """One bracket by the Illinois method -> (t, y) at the crossing."""
    xtol = max(XTOL_RTOL * rtol * abs(hi - lo), 4 * np.finfo(float).eps * max(abs(lo), abs(hi)))
    side = 0
    for _ in range(MAX_ITERATIONS):
        if abs(hi - lo) <= xtol:
            break
        x = (lo * ghi - hi * glo) / (ghi - glo) if ghi != glo else 0.5 * (lo + hi)
        if not min(lo, hi) < x < max(lo, hi):
            x = 0.5 * (lo + hi)
        gx = float(_g(sol, event, np.array([x]), sol(np.array([x])))[0])
        if not np.isfinite(gx):           # beyond a failure: the crossing is before x
            hi = x
            continue
        if np.sign(gx) == np.sign(glo):
            lo, glo = x, gx
            ghi = ghi * 0.5 if side == 1 else ghi
            side = 1
        else:
            hi, ghi = x, gx
            glo = glo * 0.5 if side == -1 else glo
            side = -1
    t = lo if abs(glo) <= abs(ghi) else hi
    return t, sol.at(t)
