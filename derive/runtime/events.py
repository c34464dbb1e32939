"""Events: zero crossings of an expression in a model's states, parameters and inputs.

    r = simulate("planar", y0, t, params, events={"flip": "cos(theta2/2)"})
    r.events["flip"].t, r.events["flip"].y, r.t_events, r.y_events        # SciPy-like too

An event is an expression (parsed by the safe grammar of derive/model/expressions.py,
never evaluated as Python), a `direction` (+1: rising through zero in the direction of
integration, -1: falling, 0: both; as SciPy's solve_ivp) and `terminal` (false; true,
or a count n: the run stops at the n-th crossing, as SciPy >= 1.15 and heyoka).
"Link 2 flips over the top" is `cos(theta2/2)`: it changes sign at theta2 = pi, 3 pi, ...
(cos(theta2) + 1 only touches zero there: a touch is no crossing and is not found).

Locating, on the run's dense output r.sol (derive/runtime/dense.py):
1. sampling: every output interval is sampled on its own trajectory at 2^L points, with
   2^L at least twice that trajectory's accepted steps (at least 4), so there are at
   least two samples per accepted step on average over each output interval, besides
   the output rows themselves.  A crossing is found when g changes sign between two
   samples: two crossings closer together than about half a local step (a graze of
   zero) can be missed, as SciPy, which looks only at step ends, misses those closer
   than a step.
2. refining: each bracket by the Illinois method (regula falsi that halves the retained
   end's value when that end is kept twice; a bisection when the bracket fails to halve
   in two iterations), all brackets at once, one batch integration per iteration, to
   a bracket of 1e-3 rtol times its output interval (or 4 eps of t): far below the
   time uncertainty that the run's own state error (rtol) implies, so the event time is
   as accurate as the run.
A terminal event stops the run there: status stays 'ok' (0), t_stop and y_stop are the
event's, `r.terminal_event` names it, outputs after it are NaN and r.sol is NaN past it.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import ModelError, SimulationInputError
from ..model.description import NAME
from ..model.expressions import parse_expression
from .result import EventRecord
from .shared_library import stop_state

SAMPLES_MIN_LEVEL = 2          # at least 2^2 sample intervals per output interval
SAMPLES_PER_STEP = 2           # samples per accepted step, at least (on average)
MAX_LEVEL = 20                 # 2^20 samples in one output interval at most
XTOL_RTOL = 1e-3               # bracket width: this times rtol times the output interval
MAX_ITERATIONS = 200
KEYS = ("expression", "direction", "terminal")


@dataclass(frozen=True)
class Event:
    name: str
    expression: str
    direction: int               # -1, 0, +1
    terminal: int                # 0: not terminal; n: stop at the n-th crossing
    function: object             # g(states (m, n), params (np,), inputs (m, ni) or None) -> (m,)


def parse_events(model_info, events, where: str = "events", error=SimulationInputError) -> tuple[Event, ...]:
    """The events of a run, checked: a mapping name -> expression or {expression, direction,
    terminal}, or a sequence of those (named event1, event2, ... unless they say 'name')."""
    if events is None:
        return ()
    if isinstance(events, Mapping):
        items = list(events.items())
    elif isinstance(events, Sequence) and not isinstance(events, (str, bytes)):
        items = []
        for i, spec in enumerate(events):
            name = spec.get("name", f"event{i + 1}") if isinstance(spec, Mapping) else f"event{i + 1}"
            items.append((name, {k: v for k, v in spec.items() if k != "name"} if isinstance(spec, Mapping)
                          else spec))
    else:
        raise error(f"{where} must be a mapping of name to expression, or a list of expressions; "
                    f"got {type(events).__name__}")
    names = [str(n) for n, _ in items]
    bad = [n for n in names if not NAME.match(n)]
    if bad:            # names become CSV fields and NPZ keys: identifiers only
        raise error(f"{where}: the event name {bad[0]!r} is not an identifier (letters, digits, _)")
    if len(set(names)) != len(names):
        raise error(f"{where}: the event name '{next(n for n in names if names.count(n) > 1)}' is used twice")
    return tuple(_event(model_info, str(name), spec, f"{where}.{name}", error) for name, spec in items)


def _event(info, name: str, spec, where: str, error) -> Event:
    if not isinstance(spec, Mapping):
        spec = {"expression": spec}
    unknown = [k for k in spec if k not in KEYS]
    if unknown:
        raise error(f"{where}: unknown key '{unknown[0]}' (allowed: {', '.join(KEYS)})")
    if "expression" not in spec:
        raise error(f"{where}: missing key 'expression'")
    direction = spec.get("direction", 0)
    if isinstance(direction, bool) or direction not in (-1, 0, 1):
        raise error(f"{where}.direction must be -1, 0 or +1, got {direction!r}")
    terminal = spec.get("terminal", False)
    if isinstance(terminal, bool):
        count = int(terminal)
    elif isinstance(terminal, (int, np.integer)) and terminal >= 0:
        count = int(terminal)
    else:
        raise error(f"{where}.terminal must be true, false or a whole number of crossings, got {terminal!r}")
    text = spec["expression"]
    symbols = {n: sp.Symbol(n) for n in (*info.state_names, *info.param_names, *info.input_names)}
    try:
        expr = parse_expression(text, symbols, f"{where}.expression")
    except ModelError as exc:
        raise error(str(exc)) from None
    ordered = [symbols[n] for n in (*info.state_names, *info.param_names, *info.input_names)]
    compiled = sp.lambdify(ordered, expr, modules="numpy")   # code printed from a parsed expression
    n, n_params = len(info.state_names), len(info.param_names)

    def function(states, params, inputs):
        states = np.asarray(states)
        cols = [states[:, i] for i in range(n)] + list(np.asarray(params)[:n_params])
        if inputs is not None:
            cols += [np.asarray(inputs)[:, j] for j in range(np.shape(inputs)[1])]
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(compiled(*cols), states.dtype), states.shape[:1]).copy()

    return Event(name, str(text), int(direction), count, function)


# -- locating ------------------------------------------------------------------------------

@dataclass
class _Samples:
    """Sample points of the run, in the run's order: interval, offset from its row, state."""
    k: np.ndarray
    offset: np.ndarray
    y: np.ndarray


def locate(result, events: tuple[Event, ...], rtol: float):
    """The crossings of every event on result.sol; a terminal event truncates the result."""
    sol = result.sol
    if sol is None:
        raise SimulationInputError("events need the dense output of an adaptive method (dopri5, dop853)")
    samples = _sample(sol, result)
    inputs = sol.inputs
    found = {}
    for event in events:
        g = event.function(samples.y, sol.params, None if inputs is None else inputs[samples.k])
        found[event.name] = _crossings(sol, event, samples, g, rtol)
    return _apply(result, events, found)


def _sample(sol, result) -> _Samples:
    """The output rows, and 2^L points on each interval's trajectory (see the module doc)."""
    t = np.asarray(sol.t, sol.dtype)
    rows = sol.rows
    if rows == 0:
        return _Samples(np.zeros(0, int), np.zeros(0, sol.dtype), np.zeros((0, sol.y.shape[1]), sol.dtype))
    spans = np.diff(t[:rows]) if rows > 1 else np.zeros(0, sol.dtype)
    ks = list(range(rows - 1))
    partial = rows < len(t) and (sol.t_end - t[rows - 1]) * sol.direction > 0
    if partial:                           # a failed run: up to where it stopped
        spans = np.append(spans, sol.dtype.type(sol.t_end) - t[rows - 1])
        ks.append(rows - 1)
    ks = np.asarray(ks, int)
    parts_k, parts_off, parts_y = [np.arange(rows)], [np.zeros(rows, sol.dtype)], [np.asarray(sol.y[:rows], sol.dtype)]
    if partial:
        parts_k.append(np.array([rows - 1]))
        parts_off.append(np.array([spans[-1]], sol.dtype))
        parts_y.append(np.asarray(result.y_stop, sol.dtype)[None, :])
    level = np.full(len(ks), SAMPLES_MIN_LEVEL)
    done = np.zeros(len(ks), bool)
    while len(ks) and not done.all():
        for L in np.unique(level[~done]):
            members = np.flatnonzero((level == L) & ~done)
            k, off, y, steps = _interior(sol, ks[members], spans[members], int(L))
            parts_k.append(k)
            parts_off.append(off)
            parts_y.append(y)
            needed = np.minimum(np.ceil(np.log2(np.maximum(SAMPLES_PER_STEP * steps, 1))), MAX_LEVEL)
            needed = np.maximum(needed, SAMPLES_MIN_LEVEL).astype(int)
            done[members] = True
            finer = needed > L
            level[members[finer]], done[members[finer]] = needed[finer], False
    k = np.concatenate(parts_k)
    off = np.concatenate(parts_off)
    y = np.concatenate(parts_y)
    order = np.lexsort((off * sol.direction, k))
    k, off, y = k[order], off[order], y[order]
    keep = np.ones(len(k), bool)              # a point sampled at two levels: once
    keep[1:] = (k[1:] != k[:-1]) | (off[1:] != off[:-1])
    return _Samples(k[keep], off[keep], y[keep])


def _interior(sol, ks, spans, level: int):
    """2^level - 1 points inside each interval, on a grid shared by its size class; and the
    accepted steps of each trajectory (one per interval)."""
    ends = sol.ends[ks]
    out_k, out_off, out_y = [], [], []
    steps = np.zeros(len(ks), int)
    for end in np.unique(ends):
        members = np.flatnonzero(ends == end)
        grid = np.arange(1, 2 ** level, dtype=sol.dtype) * (sol.dtype.type(end) / 2 ** level)
        inside = np.abs(grid)[None, :] < np.abs(spans[members])[:, None]
        inside[:, 0] = True                      # every trajectory once, for its step count
        rows = np.repeat(ks[members], inside.sum(axis=1))
        offsets = np.broadcast_to(grid, inside.shape)[inside]
        y, accepted = sol.integrate(rows, offsets, end)
        first = np.searchsorted(rows, ks[members])      # rows sorted by interval within a class
        steps[members] = accepted[first]
        real = np.abs(offsets) < np.abs(np.repeat(spans[members], inside.sum(axis=1)))
        out_k.append(rows[real])
        out_off.append(offsets[real])
        out_y.append(y[real])
    return np.concatenate(out_k), np.concatenate(out_off), np.concatenate(out_y), steps


def _crossings(sol, event: Event, s: _Samples, g: np.ndarray, rtol: float) -> EventRecord:
    t_rows = np.asarray(sol.t, sol.dtype)
    a, b = g[:-1], g[1:]
    up, down = (a < 0) & (b >= 0), (a > 0) & (b <= 0)
    wanted = up | down if event.direction == 0 else (up if event.direction > 0 else down)
    i = np.flatnonzero(wanted)
    # a bracket ends at the next sample: inside the interval of its left point, or that
    # interval's end (the next output row, offset = the interval)
    k = s.k[i]
    lo = s.offset[i]
    hi = np.where(s.k[i + 1] == k, s.offset[i + 1], t_rows[np.minimum(k + 1, len(t_rows) - 1)] - t_rows[k])
    root, y = _refine(sol, k, lo, hi, g[i], g[i + 1], s.y[i], s.y[i + 1], event, rtol)
    return EventRecord(event.name, event.expression, t_rows[k] + root, y, np.where(up[i], 1, -1))


def _refine(sol, k, lo, hi, glo, ghi, ylo, yhi, event: Event, rtol: float):
    """Illinois iteration on all brackets at once (see the module doc); -> (offsets, states)."""
    t_rows = np.asarray(sol.t, sol.dtype)
    eps = float(np.finfo(sol.dtype).eps)
    width = np.abs(hi - lo)
    interval = np.abs(np.where(k + 1 < len(t_rows), t_rows[np.minimum(k + 1, len(t_rows) - 1)] - t_rows[k], hi))
    xtol = np.maximum(XTOL_RTOL * rtol * interval, 4 * eps * (np.abs(t_rows[k]) + interval))
    lo, hi, glo, ghi = lo.copy(), hi.copy(), glo.astype(float), ghi.astype(float)
    ylo, yhi = ylo.copy(), yhi.copy()
    side = np.zeros(len(k), int)           # which end was kept last: -1 lo, +1 hi
    width_before = width.copy()
    inputs = sol.inputs
    for iteration in range(MAX_ITERATIONS):
        active = (np.abs(hi - lo) > xtol) & (glo != 0) & (ghi != 0)
        if not active.any():
            break
        j = np.flatnonzero(active)
        x = (lo[j] * ghi[j] - hi[j] * glo[j]) / (ghi[j] - glo[j])
        stalled = np.abs(hi[j] - lo[j]) > 0.5 * width_before[j]
        if iteration % 2 == 1:
            width_before[j] = np.abs(hi[j] - lo[j])
        bisect = stalled & (iteration % 2 == 1) | ~np.isfinite(x)
        x = np.where(bisect, 0.5 * (lo[j] + hi[j]), x)
        inside = ((x - lo[j]) * (hi[j] - x) > 0)
        x = np.where(inside, x, 0.5 * (lo[j] + hi[j])).astype(sol.dtype)
        yx = sol.at(k[j], x)
        gx = event.function(yx, sol.params, None if inputs is None else inputs[k[j]]).astype(float)
        same_as_lo = np.sign(gx) == np.sign(glo[j])
        nan = ~np.isfinite(gx)
        for arr, val in ((lo, x), (glo, gx), (ylo, yx)):
            arr[j[same_as_lo & ~nan]] = val[same_as_lo & ~nan]
        for arr, val in ((hi, x), (ghi, gx), (yhi, yx)):
            arr[j[~same_as_lo & ~nan]] = val[~same_as_lo & ~nan]
        # Illinois: the end kept twice in a row has its value halved
        kept_hi, kept_lo = same_as_lo & ~nan, ~same_as_lo & ~nan
        ghi[j[kept_hi & (side[j] == 1)]] *= 0.5
        glo[j[kept_lo & (side[j] == -1)]] *= 0.5
        side[j] = np.where(kept_hi, 1, np.where(kept_lo, -1, 0))
        if nan.any():                       # beyond a failure: not a crossing to refine
            hi[j[nan]], ghi[j[nan]] = lo[j[nan]], glo[j[nan]]
    at_lo = np.abs(glo) <= np.abs(ghi)
    return np.where(at_lo, lo, hi), np.where(at_lo[:, None], ylo, yhi)


def _apply(result, events: tuple[Event, ...], found: dict[str, EventRecord]):
    """r.events; the earliest terminal crossing stops the run (the module doc)."""
    t0 = float(result.t[0])
    direction = 1.0 if len(result.t) < 2 or result.t[-1] >= result.t[0] else -1.0
    stop, stopper = None, None
    for event in events:
        rec = found[event.name]
        if event.terminal and len(rec) >= event.terminal:
            when = float(rec.t[event.terminal - 1])
            if stop is None or (when - stop) * direction < 0:
                stop, stopper = when, event.name
    if stop is not None:
        for name, rec in found.items():
            keep = (np.asarray(rec.t, float) - stop) * direction <= 0
            found[name] = EventRecord(rec.name, rec.expression, rec.t[keep], rec.y[keep], rec.direction[keep])
        _truncate(result, stop, found[stopper].y[-1], direction, t0)
        result.terminal_event = stopper
    result.events = found
    return result


def _truncate(result, stop: float, y_stop, direction: float, t0: float) -> None:
    after = (np.asarray(result.t, float) - stop) * direction > 0
    for attr in ("y", "energy", "positions", "velocities"):
        value = getattr(result, attr)
        if value is not None:
            value = np.array(value)
            value[after] = np.nan
            setattr(result, attr, value)
    if result.chart is not None:
        result.chart = np.array(result.chart, dtype=object)
        result.chart[after] = None
    result.status, result.status_name = 0, "ok"
    result.t_stop, result.y_stop = stop, stop_state(y_stop, np.asarray(result.y).dtype)   # long double kept
    if result.sol is not None:
        result.sol.t_end = stop
