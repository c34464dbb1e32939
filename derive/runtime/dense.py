"""`r.sol(t)`: the continuous solution of an adaptive run (dopri5, dop853), at any t in its span.

For an autonomous model the right-hand side depends on the state, the parameters and
the inputs, never on t, and inputs are held constant over each output interval.  So the
solution at t between the output rows t_k <= t < t_k+1 is the solution from y_k over the
offset t - t_k, and every interval can start at time 0 (a time shift).  A time-dependent
model's (t in its forces, dissipation or pivot) has no such shift: each interval starts
at its own t_k (one batch call per output row, the integrator passing each stage's t).
sol(t) integrates
from the last output row at or before t with the run's own method, tolerances, options
and inputs; the runner's batch call (the C batch entry point, or the NumPy batch function)
integrates all the intervals a query needs at once, one trajectory per interval.

Why it is as accurate as the run: y_k is the run's own output; from it the same method
at the same rtol and atol integrates a span no longer than one output interval, so the
local error it adds is within the run's tolerance over that interval, of the same order
as the error the run itself made between y_k and y_k+1 (sol(t_k) is y_k exactly).

Why it is a continuous function of t (so a root finder may use it): each interval's
trajectory is integrated to a fixed end, the same for every query of that interval
(the largest output interval of its size class, at most twice its length), and the
integrators' step sequence does not depend on the output times (they are reached by the
method's dense output: 4th order for dopri5, 7th for dop853).  So sol on one interval is
the piecewise polynomial of one deterministic run, whatever else is asked at once.

Past the run's end (a failed run's t_stop, or a terminal event) sol is NaN; outside the
span of the output times it refuses with one line.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SimulationInputError
from .build import dtype_key
from ..codegen.contract import ADAPTIVE
from .runner import runner_for
from ..model import load_model
from ..model.atlas import find_atlas

MAX_ELEMENTS = 2 ** 23           # numbers of one batch call's output (64 MiB in double)


@dataclass
class DenseOutput:
    """The continuous solution of one adaptive run: sol(t) -> (n,) for a scalar t,
    (len(t), n) for an array of times (any order, repeats allowed)."""
    model: str
    method: str
    backend: str
    dtype: np.dtype
    options: dict
    params: np.ndarray                 # the model's parameters
    t: np.ndarray                      # the run's output times
    y: np.ndarray                      # the run's output rows
    inputs: np.ndarray | None = None   # per row (len(t), n_inputs), or None (no inputs)
    t_end: float | None = None         # the solution is known to here (t_stop; an event)
    _ends: np.ndarray = field(default=None, repr=False)

    def __post_init__(self):
        if self.method not in ADAPTIVE:
            raise SimulationInputError(f"dense output is for the adaptive methods ({', '.join(ADAPTIVE)}), "
                                       f"not {self.method}")
        self.dtype = np.dtype(self.dtype)
        self.direction = 1.0 if len(self.t) < 2 or self.t[-1] >= self.t[0] else -1.0
        if self.t_end is None:
            self.t_end = float(self.t[-1])

    # built on first use: every adaptive run has a sol, few runs call it (simulate's own
    # cost per call stays that of the run)
    @property
    def rows(self) -> int:
        """The number of valid leading rows (all of them unless the run stopped)."""
        if "_rows" not in self.__dict__:
            finite = np.isfinite(np.asarray(self.y, float)).all(axis=1)
            self.__dict__["_rows"] = int(np.argmin(finite)) if not finite.all() else len(self.t)
        return self.__dict__["_rows"]

    @property
    def ends(self) -> np.ndarray:
        if self._ends is None:
            self._ends = _interval_ends(np.asarray(self.t, self.dtype))
        return self._ends

    # -- the public call -----------------------------------------------------------

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
        k = self.row_of(tq)
        y = self.at(k, tq - np.asarray(self.t, self.dtype)[k])
        return y[0] if scalar else y

    def row_of(self, tq: np.ndarray) -> np.ndarray:
        """The last valid output row at or before each t (in the run's direction)."""
        s = (np.asarray(self.t, self.dtype)[:self.rows] - self.t[0]) * self.direction
        k = np.searchsorted(s, (tq - self.t[0]) * self.direction, side="right") - 1
        return np.clip(k, 0, max(self.rows - 1, 0))

    # -- states at offsets from output rows ------------------------------------------

    def at(self, rows: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """The states at t_rows[i] + offsets[i] (offsets in the run's direction, within the
        interval after that row, or up to t_end after the last valid row)."""
        rows = np.asarray(rows, int).reshape(-1)
        offsets = np.asarray(offsets, self.dtype).reshape(-1)
        n = self.y.shape[1]
        out = np.full((len(rows), n), np.nan, self.dtype)
        if self.rows == 0:
            return out
        t_rows = np.asarray(self.t, self.dtype)
        reached = (t_rows[rows] + offsets - self.t_end) * self.direction <= 0
        exact = offsets == 0
        out[exact & reached] = np.asarray(self.y, self.dtype)[rows[exact & reached]]
        todo = np.flatnonzero(reached & ~exact)
        classes = self.ends[rows[todo]]
        for end in np.unique(classes):
            members = todo[classes == end]
            out[members] = self.integrate(rows[members], offsets[members], end)[0]
        return out

    def integrate(self, rows: np.ndarray, offsets: np.ndarray, end: float) -> tuple[np.ndarray, np.ndarray]:
        """From each row y_rows[i] at time 0 to `end` (one size class: every interval the same
        end), the states at offsets[i]; and the accepted steps of each trajectory.  Several
        queries of one row share its trajectory; the batch is cut so its output fits in memory."""
        if self.timed:
            return self._integrate_timed(rows, offsets, end)
        out = np.empty((len(rows), self.y.shape[1]), self.dtype)
        steps = np.zeros(len(rows), int)
        unique_rows, which = np.unique(rows, return_inverse=True)
        per = max(1, MAX_ELEMENTS // max(1, (len(np.unique(offsets)) + 2) * self.y.shape[1]))
        for start in range(0, len(unique_rows), per):
            chunk = unique_rows[start:start + per]
            mine = (which >= start) & (which < start + len(chunk))
            local = np.unique(offsets[mine] * self.direction) * self.direction   # in the run's direction
            tail = [] if local[-1] == end else [end]
            times = np.concatenate([[0], local[local != 0], tail]).astype(self.dtype)
            y, accepted = self._batch(chunk, times)
            i = which[mine] - start
            j = np.searchsorted(times * self.direction, offsets[mine] * self.direction)
            out[mine] = y[i, j]
            steps[mine] = accepted[i]
        return out, steps

    def _integrate_timed(self, rows: np.ndarray, offsets: np.ndarray, end: float) -> tuple[np.ndarray, np.ndarray]:
        """`integrate` for a time-dependent model: each row's own run from its time t_k to
        t_k + end through its own query times (the same end for every query of the row, so
        sol is still one deterministic run per interval)."""
        out = np.empty((len(rows), self.y.shape[1]), self.dtype)
        steps = np.zeros(len(rows), int)
        t_rows = np.asarray(self.t, self.dtype)
        d = self.direction
        for row in np.unique(rows):
            mine = rows == row
            start = t_rows[row]
            at = (start + offsets[mine]).astype(self.dtype)
            times = np.unique(np.concatenate([[start, start + self.dtype.type(end)], at]).astype(self.dtype) * d) * d
            y, accepted = self._call(self._row_y0(row), self._row_p(row), times)
            out[mine] = y[0, np.searchsorted(times * d, at * d)]
            steps[mine] = accepted[0]
        return out, steps

    def _row_y0(self, row: int) -> np.ndarray:
        return np.ascontiguousarray(np.asarray(self.y, self.dtype)[row:row + 1])

    def _row_p(self, row: int) -> np.ndarray:
        p = np.asarray(self.params, self.dtype)[None, :]
        if self.inputs is not None:
            p = np.concatenate([p, np.asarray(self.inputs, self.dtype)[row:row + 1]], axis=1)
        return np.ascontiguousarray(p)

    @property
    def timed(self) -> bool:
        """Whether the model has explicit time (no time shift: each row starts at its t)."""
        if "_timed" not in self.__dict__:
            self.__dict__["_timed"] = find_atlas(self.model) is None and load_model(self.model).is_time_dependent
        return self.__dict__["_timed"]

    def _batch(self, rows: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One batch call: trajectory b from y_rows[b] at times[0] = 0 through `times`."""
        y0 = np.ascontiguousarray(np.asarray(self.y, self.dtype)[rows])
        p = np.broadcast_to(np.asarray(self.params, self.dtype), (len(rows), len(self.params)))
        if self.inputs is not None:
            p = np.concatenate([p, np.asarray(self.inputs, self.dtype)[rows]], axis=1)
        return self._call(np.ascontiguousarray(y0), np.ascontiguousarray(p), times)

    def _call(self, y0: np.ndarray, p: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The runner's batch call: trajectory b from y0[b] at times[0] through `times`."""
        r = runner_for(self.model, self.method, dtype_key(self.dtype), self.backend)
        if self.backend == "c":
            y, infos, _ = r.batch(y0, p, times, r.options(self.options))
            accepted = np.array([info.naccepted for info in infos], int)
        else:
            # the NumPy integrators' floating-point warnings (a trajectory that fails) are not
            # the query's: the NaN rows say what failed, as the C backend's do
            with np.errstate(all="ignore"):
                y, infos, _ = r.batch(y0, p, times, r.options(self.options))
            accepted = np.array([info["naccepted"] for info in infos], int)
        return y, accepted

    # -- composing ---------------------------------------------------------------------

    def rows_of(self, t: np.ndarray, y: np.ndarray, inputs=None, t_end: float | None = None) -> "DenseOutput":
        """The same run settings over other output rows (joined chunks of one run)."""
        return DenseOutput(self.model, self.method, self.backend, self.dtype, self.options, self.params,
                           t, y, inputs if inputs is not None else None, t_end)


def _interval_ends(t: np.ndarray) -> np.ndarray:
    """Per output row, the end of the trajectory that serves the interval after it: the
    largest interval of its size class (intervals within a factor 2, by their binary
    exponent).  Depends only on the run's output times, so sol on an interval is the
    same function whatever is asked with it; a uniform grid is one class."""
    if len(t) < 2:
        return np.zeros(len(t), t.dtype)
    gaps = np.abs(np.diff(t))
    _, exponent = np.frexp(np.asarray(gaps, float))
    ends = np.empty(len(t), t.dtype)
    for e in np.unique(exponent):
        members = exponent == e
        ends[:-1][members] = gaps[members].max()
    ends[-1] = ends[-2]                   # the last row: only t_end == t[-1] itself is asked
    return ends * (1 if t[-1] >= t[0] else -1)


def dense_output(result, model: str, method: str, backend: str, dtype, options: dict, params,
                 inputs=None) -> DenseOutput | None:
    """The sol of a finished run (None for a fixed-step method)."""
    if method not in ADAPTIVE:
        return None
    rows = None
    if inputs is not None:
        inputs = np.asarray(inputs, dtype)
        rows = np.broadcast_to(inputs, (len(result.t), inputs.shape[-1])) if inputs.ndim == 1 else inputs
    end = float(result.t_stop) if not result.ok else float(result.t[-1])
    return DenseOutput(model, method, backend, dtype, dict(options), np.asarray(params, dtype),
                       np.asarray(result.t, dtype), np.asarray(result.y, dtype), rows, end)


__all__ = ["DenseOutput", "dense_output"]
