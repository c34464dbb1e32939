"""Event times verified to an accuracy: every time found is computed again until two runs agree.

The first pass (chunk.py) finds each trajectory's first event at the sweep's
tolerance R.  Its error is that of the trajectory (the integrator's local errors
grown by the motion) over the crossing speed |q'|, which no single run reveals: a
slow, late crossing of a chaotic motion is off by 2e-3 at the flip map's Taylor
R = 1e-9 and by 2e-5 at DOP853's 1e-12.  So each time is computed again by a run
that differs only in its tolerance, and the two are compared.  Along the same
motion the runs' errors scale with their local errors: a run whose local error is
r times the other's has about r times its error, so their difference d is about the
looser one's error and the tighter one's is about d r / (1 - r).  The ladder:

  1. double at R / TIGHTER: where d <= the accuracy, its time is kept;
  2. the rest (disagreeing, or lost within the window) in long double at
     R / TIGHTER^2 (no tighter than LONG_DOUBLE_RTOL_MIN): its time is kept (past
     double precision: the slow crossings whose error is the rounding of a double
     run, which no tighter tolerance in double removes).

Why the runs are a factor TIGHTER = 1000 apart, not 10: "about r times" is a trend,
not a bound.  Measured on 10 000 points of the flip map against DOP853 in long double
at rtol 1e-17, the tighter run of a pair a factor 10 apart was at times the worse one
(its error up to 1.8 times the looser one's for DOP853, 15 times for Taylor's method one
order up), so two runs could agree to 1e-6 and both be off by more; a factor 1000
apart, the tighter one's error was at most 0.11 (DOP853) and 0.24 (Taylor) of the
looser one's, typically 1/1700 and 1/600.  The estimate stored, d r / (1 - r), is that
typical value, not a bound.

r is the tolerance ratio for DOP853 and Dormand-Prince 5 (their error is proportional to
the tolerance), and e^(-2 dp) for Taylor's method, whose local error at its step rule is
about e^(-2 p) for order p (taylor_library.taylor_order: p follows the tolerance in
whole steps; a thousandth of it is 3 or 4 orders more).

A run again knows where to stop: each trajectory is integrated from the start only
up to a few samples past its first time (WINDOW; the trajectories are grouped by that
end, one batch call each), so no time is spent past the event, and the event search
is the first pass's (events.locate) on the same sample times.  A "no event" of the
first pass is not checked again (bench/sweep.py --check measures the classification
against independent references).
"""
from __future__ import annotations

import math

import numpy as np

from ..codegen.contract import TAYLOR
from ..codegen.contract import taylor_order
from . import level_crossings as ev
from .runners import runner
from .sweep_file import Sweep

TIGHTER = 1000                   # each run again: a thousandth of the tolerance before
DOUBLE_RTOL_MIN = 1e-15          # 10 eps of double: no tighter in double
LONG_DOUBLE_RTOL_MIN = 1e-17     # 100 eps of long double (x86: eps 1.1e-19)
WINDOW = 10                      # samples: run-again ends are rounded up to a multiple of this


def error_ratio(method: str, loose: float, tight: float) -> float:
    """About how much smaller the error of a run at tolerance `tight` is than at `loose`."""
    if method == TAYLOR:
        return math.exp(-2 * (taylor_order(tight) - taylor_order(loose)))
    return tight / loose


def rungs(scene) -> list[tuple[float, float | None, type]]:
    """(rtol, atol, dtype) of each run again: R / TIGHTER in double, R / TIGHTER^2 in long double
    (atol in the scene's ratio to rtol; Taylor's method has none)."""
    R = scene.rtol
    out = []
    for rtol, dtype in ((max(R / TIGHTER, DOUBLE_RTOL_MIN), np.float64),
                        (max(R / TIGHTER ** 2, LONG_DOUBLE_RTOL_MIN), np.longdouble)):
        out.append((rtol, None if scene.atol is None else rtol * scene.atol / R, dtype))
    return out


def verify_events(sweep: Sweep, model: str, y0: np.ndarray, p: np.ndarray, out: dict) -> dict[str, np.ndarray]:
    """The event times with an `accuracy`, each replaced by the best of the ladder, and
    `<event>_time_error`, its estimated error (NaN where no event: not checked again)."""
    scene = sweep.scene
    t = np.linspace(scene.t_start, scene.t_stop, scene.outputs)
    R = scene.rtol
    result = {}
    for e in sweep.events:
        name = f"{e.name}_time"
        if e.accuracy is None or name not in out:
            continue
        best = out[name].copy()
        error = np.full(len(best), np.nan)
        error[np.isfinite(best) & (best == scene.t_start)] = 0.0           # at the start: exact
        rows = np.flatnonzero(np.isfinite(best) & (best > scene.t_start))
        first = best[rows]
        previous, previous_tol = first.copy(), np.full(rows.size, R)
        ladder = rungs(scene)
        for k, (tight, atol, dtype) in enumerate(ladder):
            if not rows.size:
                break
            run = runner(model, scene.method, tight, atol)
            lost = np.isnan(previous)              # by the rung before: this one runs to the end
            until = np.where(lost, np.nan, np.fmax(previous, first))
            again = run_again(run, y0[rows], p[rows], t, e, until, dtype)
            if k == len(ladder) - 1:                 # the last word: lost in the window, to the end
                beyond = np.flatnonzero(np.isnan(again) & np.isfinite(until))
                if beyond.size:
                    again[beyond] = run_again(run, y0[rows[beyond]], p[rows[beyond]], t, e,
                                              np.full(beyond.size, np.nan), dtype)
            against = np.where(lost, first, previous)
            d = np.abs(again - against)
            loose = np.where(lost, R, previous_tol)
            r = np.ones_like(loose)
            for tol in np.unique(loose):
                r[loose == tol] = error_ratio(scene.method, tol, tight)
            keep = (d <= e.accuracy) | (k == len(ladder) - 1)
            best[rows[keep]] = again[keep]          # the last rung's, even NaN: no event by the best run
            error[rows[keep]] = d[keep] * r[keep] / (1 - r[keep])
            rows, first = rows[~keep], first[~keep]
            previous, previous_tol = again[~keep], np.full(rows.size, tight)
        result[name], result[f"{name}_error"] = best, error
    return result


def run_again(run, y0: np.ndarray, p: np.ndarray, t: np.ndarray, event, until: np.ndarray,
              dtype) -> np.ndarray:
    """The first event times of y0 (B, n) on the sample times t, each trajectory integrated
    from t[0] to WINDOW-rounded samples past `until` (NaN: to the end)."""
    out = np.full(len(y0), np.nan)
    last = len(t) - 1
    j = np.where(np.isfinite(until), np.searchsorted(t, np.nan_to_num(until, nan=t[-1])), last)
    end = np.minimum((j // WINDOW + 1) * WINDOW, last)
    ts = t.astype(dtype)
    level = dtype(event.level)
    y0, p = y0.astype(dtype), p.astype(dtype)
    for stop in np.unique(end):
        rows = np.flatnonzero(end == stop)
        local_t = ts[: stop + 1]
        p_rows = p[rows]
        y, _ = run(y0[rows], p_rows, local_t)

        def rerun(sub, start, local):
            return run(start, p_rows[sub], local)

        out[rows] = ev.locate(rerun, y, local_t, event.index, level)
    return out
