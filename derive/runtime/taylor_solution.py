"""`r.sol(t)` of a time-dependent model's Taylor run: its continuous solution between rows.

An autonomous model's solution from a row may start at time 0 (derive/runtime/dense.py
shifts every interval there); a time-dependent model's may not: its jet reads t.  So
sol(t) between the output rows t_k <= t < t_k+1 integrates from y_k at t_k itself, with
the run's own Taylor integrator (its order, rtol and options), to t_k+1, and evaluates
the series at every t asked inside (the integrator's dense output).  Each interval's
trajectory ends at its next row whatever is asked, and Taylor's steps never depend on
the output times, so sol on an interval is one deterministic piecewise polynomial: a
continuous function of t (the energy balance's Gauss sums use it, derive/runtime/power.py).
sol(t_k) is y_k exactly; past the run's end (a failed run's t_stop) it is NaN.
"""
from __future__ import annotations

import numpy as np

from ..codegen.contract import taylor_order
from ..errors import SimulationInputError
from .build import dtype_key
from .runner import runner_for
from .taylor_library import taylor_library


class TaylorSolution:
    """The continuous solution of a time-dependent model's Taylor run (C, a hardware
    precision): sol(t) -> (n,) for a scalar t, (len(t), n) for an array of times.

    Parameters
    ----------
    model : str
        A resolved model name.
    dtype : numpy dtype
        The run's (float32, float64 or long double).
    options : dict
        The run's options (rtol, hmax, max_steps, sine_min, ...).
    params : ndarray
        The parameters, then the inputs (held over the run), as the integrator takes them.
    t, y : ndarray
        The run's output times and rows.
    t_end : float
        The solution is known to here (the run's end or where it stopped).
    """

    def __init__(self, model: str, dtype, options: dict, params: np.ndarray, t: np.ndarray, y: np.ndarray,
                 t_end: float):
        self.dtype = np.dtype(dtype)
        self.t = np.asarray(t, self.dtype)
        self.y = np.asarray(y, self.dtype)
        self.params = np.ascontiguousarray(params, self.dtype)
        self.t_end = float(t_end)
        self.direction = 1.0 if len(self.t) < 2 or self.t[-1] >= self.t[0] else -1.0
        runner = runner_for(model, "taylor", dtype_key(self.dtype))
        self.options = runner.options(dict(options))
        self.library = taylor_library(model, taylor_order(options["rtol"]), dtype_key(self.dtype))
        finite = np.isfinite(np.asarray(self.y, float)).all(axis=1)
        self.rows = int(np.argmin(finite)) if not finite.all() else len(self.t)

    def __call__(self, t):
        tq = np.asarray(t, dtype=self.dtype)
        scalar = tq.ndim == 0
        tq = tq.reshape(-1)
        if not np.all(np.isfinite(tq)):
            raise SimulationInputError("sol(t): t must be finite numbers")
        lo, hi = sorted((float(self.t[0]), float(self.t[-1])))
        outside = (tq < lo) | (tq > hi)
        if outside.any():
            raise SimulationInputError(f"sol(t): t = {float(tq[outside][0]):.17g} is outside the run's "
                                       f"span [{lo:.17g}, {hi:.17g}]")
        out = np.full((len(tq), self.y.shape[1]), np.nan, self.dtype)
        if self.rows == 0:
            return out[0] if scalar else out
        reached = (tq - self.t_end) * self.direction <= 0
        k = self._row_of(tq)
        for row in np.unique(k[reached]):
            members = np.flatnonzero(reached & (k == row))
            out[members] = self._interval(int(row), tq[members])
        return out[0] if scalar else out

    def _row_of(self, tq: np.ndarray) -> np.ndarray:
        """The last valid output row at or before each t (in the run's direction)."""
        s = (self.t[:self.rows] - self.t[0]) * self.direction
        k = np.searchsorted(s, (tq - self.t[0]) * self.direction, side="right") - 1
        return np.clip(k, 0, self.rows - 1)

    def _interval(self, row: int, tq: np.ndarray) -> np.ndarray:
        """The states at the times tq after row `row`: one run from (t_row, y_row) through
        them to the next row (the last row: t_row itself is all there is)."""
        start = self.t[row]
        if row + 1 >= len(self.t):
            return np.broadcast_to(self.y[row], (len(tq), self.y.shape[1]))
        inside = np.unique((tq - start) * self.direction)
        inside = inside[inside > 0] * self.direction + start
        end = self.t[row + 1]
        times = np.concatenate([[start], inside[inside != end], [end]]).astype(self.dtype)
        y, _ = self.library.run(self.y[row][None, :], self.params, times, self.options)
        index = np.searchsorted((times - start) * self.direction, (tq - start) * self.direction)
        return y[0, index]


__all__ = ["TaylorSolution"]
