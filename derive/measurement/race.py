"""`derive bench --race`: derive against heyoka, through both tools' public APIs, in one run.

heyoka (Taylor's method compiled by LLVM at run time, ../shared/ANCHORS.md) is the
strongest tool our users would pick instead.  Each row is one problem of the planar
double pendulum (m = l = 1, g = 9.81); each tool runs it at a sweep of its own
tolerances (derive: every adaptive method `derive.simulate` has, and every fixed-step
method at a sweep of steps, abm12 also with its stability guard loosened to rtol 1e-6; heyoka: `taylor_adaptive` at a sweep of `tol`), each
setting timed as the minimum wall time of repeated calls (the integrator built and
compiled before, by both tools: build time is not in the figures), its final state
compared with a reference.  A row's figure for a tool is the fastest setting whose
final-state error (max-norm) is at most the target (1e-8): its "time to 1e-8".  The
ratio is heyoka's time over derive's (above 1: derive is faster).

Rows:
- regular: y0 = (1, 0.5, 0, 0) to t = 20;
- chaotic: y0 = (2.5, 2, 0, 0) to t = 5;
- long double: the chaotic y0 to t = 10, heyoka in long double, derive in long double
  and double-double (its fastest way there);
- quad: the chaotic y0 to t = 20, past long double's horizon: derive's Taylor
  integrator in double-double and quad against heyoka in real128;
- ensemble: 4096 states (angles uniform in [-1, 1], rates 0, seed 0) to t = 10, every
  final error <= 1e-8: `derive.ensemble` (threads = cores) against heyoka's SIMD batch
  integrator (`taylor_adaptive_batch`, batch = its recommended SIMD width and twice it,
  one integrator a thread, the threads sharing the batches: _heyoka_ensemble);
- one call on a trivial span (t = 1e-6): the fixed cost of a call.
And SciPy's solve_ivp DOP853 with a lambdified rhs of the derivation (what a SymPy user
writes) on the regular and chaotic rows, the peer of `derive bench`'s 200x target.

Two pairings, in one run (issue 25 items 3 and 5): derive with the parameters passed at
run time (its general kernels: "derive") against heyoka with them as `par[]` ("heyoka"),
and derive with them folded into its kernels (`specialise=True`: "derive-specialised",
derive/codegen/specialise.py) against heyoka with them written in as numbers
("heyoka-numbers").  derive's two settings are timed interleaved, setting by setting, so
that a shared machine's load falls on both alike.  The extended rungs (double-double,
quad) read p at run time and have no specialised setting.

References: the long double runs of `derive.simulate` at its tightest tolerance for the
double rows and the ensemble (their error, about 1e-13 here, is far below the target);
for the long double row, heyoka in quadruple precision (real128) at tol 1e-30, checked
against derive's long double reference; for the quad row, derive in quad at rtol 2e-33
checked against heyoka real128 at tol 1e-33: the agreement is reported.  Both tools take
the same parameters, the doubles nearest 1, 9.81 (heyoka's real128 from the double,
exactly).
"""
from __future__ import annotations

import csv
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ToolMissingError
from ..runtime.ensemble import ensemble
from ..runtime.simulate import simulate
from ..codegen.contract import FIXED, IMPLICIT, MULTISTEP, TOLERANCE_METHODS, taylor_order
from .peers import lambdified_rhs, planar_accelerations, solve_ivp_final
import mpmath
from concurrent.futures import ThreadPoolExecutor
import platform

TARGET = 1e-8
PARAMS = (1.0, 1.0, 1.0, 1.0, 9.81)
NAMES = ("m1", "m2", "l1", "l2", "g")
# One grid of tolerances per row, swept by both tools (a finer grid for one side would let
# it land nearer the accuracy target: an unfair race): double, long double, the ensemble
DOUBLE_TOLS = (1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14)
LONG_DOUBLE_TOLS = (1e-10, 1e-12, 1e-13, 1e-14, 1e-15, 1e-16, 1e-17, 2e-18)
ENSEMBLE_TOLS = (1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14)
GUARD_LOOSENED = 1e-6     # abm12's guard loosened (rtol; atol follows at rtol 1e-3)
MIN_SECONDS = 0.15       # each setting is repeated until this much time has passed (at least 3 times)


@dataclass
class Point:
    tool: str            # "derive dop853", "heyoka taylor", ...
    knob: str            # "rtol=1e-10", "tol=1e-12", "h=0.01"
    seconds: float
    error: float


@dataclass
class Row:
    name: str
    title: str
    points: list[Point] = field(default_factory=list)
    note: str = ""

    def best(self, tool: str) -> Point | None:
        """The fastest point of `tool` ("derive", "derive-specialised", "heyoka", ...: the first
        word of a point's label) that meets the target, or None."""
        ok = [p for p in self.points if p.tool.split()[0] == tool and p.error <= TARGET]
        return min(ok, key=lambda p: p.seconds) if ok else None


# derive's two settings: (the tool's label in the race, specialise=)
DERIVE_SETTINGS = (("derive", False), ("derive-specialised", True))


def _heyoka():
    try:
        import heyoka    # the bench extra: a peer
    except ImportError:
        raise ToolMissingError("derive bench --race needs heyoka: pip install 'derive[bench]' "
                               "(or pip install heyoka)") from None
    return heyoka


def heyoka_system(hy, folded: bool = False):
    """The planar double pendulum in heyoka's expression system: seed 000 (1.34)-(1.35), the
    compact form a heyoka user writes.  Parameters as par[0..4] (m1, m2, l1, l2, g), or
    `folded`: their values (PARAMS) written in as numbers, so that heyoka folds them at
    construction (the fair peer of a kernel specialised to those values)."""
    th1, th2, w1, w2 = hy.make_vars("th1", "th2", "w1", "w2")
    m1, m2, l1, l2, g = PARAMS if folded else (hy.par[i] for i in range(5))
    a1, a2 = planar_accelerations(hy.sin, hy.cos)(th1, th2, w1, w2, m1, m2, l1, l2, g)
    return [(th1, w1), (th2, w2), (w1, a1), (w2, a2)]


# heyoka's two settings: (the tool's label in the race, parameters folded in as numbers)
HEYOKA_SETTINGS = (("heyoka", False), ("heyoka-numbers", True))


def _heyoka_pars(folded: bool, values):
    """The pars= argument of a heyoka integrator: the parameters, or none when folded."""
    return {} if folded else {"pars": np.array(values)}


def _timed(run) -> float:
    """Minimum wall time of repeated calls of run() (at least 3, for MIN_SECONDS)."""
    return _timed_together([run])[0]


def _timed_together(runs) -> list[float]:
    """The minimum wall time of each of `runs`, called in turn round by round (at least 3
    rounds, for MIN_SECONDS each on average), so that the load of a shared machine falls on
    them alike."""
    best, spent, n = [math.inf] * len(runs), 0.0, 0
    while n < 3 or spent < MIN_SECONDS * len(runs):
        for i, run in enumerate(runs):
            t0 = time.perf_counter()
            run()
            dt = time.perf_counter() - t0
            best[i], spent = min(best[i], dt), spent + dt
        n += 1
        if n >= 2000:
            break
    return best


def _both_settings(make, label: str, knob: str, error) -> list[Point]:
    """One setting of derive in both DERIVE_SETTINGS, timed together: make(specialise) is
    the run (a callable returning its result), error(result) its final error."""
    runs = [make(specialise) for _, specialise in DERIVE_SETTINGS]
    errors = [error(run()) for run in runs]          # the first call builds (not timed)
    return [Point(f"{name} {label}", knob, seconds, e)
            for (name, _), seconds, e in zip(DERIVE_SETTINGS, _timed_together(runs), errors)]


def _error(y, ref) -> float:
    y = np.asarray(y, dtype=np.longdouble)
    if not np.all(np.isfinite(y)):
        return math.inf
    return float(np.max(np.abs(y - np.asarray(ref, np.longdouble))))


# -- the single-trajectory rows ---------------------------------------------------------

def _derive_reference(y0, t_end: float) -> np.ndarray:
    r = simulate("planar", y0, [0.0, t_end], PARAMS, method="dop853", rtol=2e-18,
                        atol=1e-22, dtype="longdouble")
    r.raise_for_status()
    return r.y[-1]


def _derive_points(y0, t_end: float, ref, dtype: str = "float64") -> list[Point]:
    """derive at a sweep of its settings, each in both DERIVE_SETTINGS (timed together)."""
    points = []
    rtols = DOUBLE_TOLS if dtype == "float64" else LONG_DOUBLE_TOLS

    def error(r):
        return _error(r.y[-1], ref) if r.ok else math.inf
    for method in TOLERANCE_METHODS:          # dopri5, dop853 and taylor
        for rtol in rtols:
            def make(specialise, method=method, rtol=rtol):
                return lambda: simulate("planar", y0, [0.0, t_end], PARAMS, method=method, rtol=rtol,
                                        dtype=dtype, specialise=specialise)
            points += _both_settings(make, method, f"rtol={rtol:g}", error)
    if dtype == "float64":
        for method in (m for m in FIXED if m not in IMPLICIT):
            # a multistep method also with its stability guard loosened (simulate's rtol=):
            # what a user who reads its stop message runs
            guards = (None, GUARD_LOOSENED) if method in MULTISTEP else (None,)
            for h in (0.02, 0.01, 0.005, 0.0025, 0.00125):
                for guard in guards:
                    def make(specialise, method=method, h=h, guard=guard):
                        return lambda: simulate("planar", y0, [0.0, t_end], PARAMS, method=method, step=h,
                                                rtol=guard, specialise=specialise)
                    knob = f"h={h:g}" + (f" rtol={guard:g}" if guard is not None else "")
                    points += _both_settings(make, method, knob, error)
    return points


def _heyoka_points(hy, y0, t_end: float, ref, fp_type=float, tols=None, error=None) -> list[Point]:
    """heyoka at a sweep of tol, in both settings (HEYOKA_SETTINGS)."""
    points = []
    if tols is None:
        tols = DOUBLE_TOLS if fp_type is float else LONG_DOUBLE_TOLS
    for name, folded in HEYOKA_SETTINGS:
        sys_ = heyoka_system(hy, folded)
        for tol in tols:
            ta = hy.taylor_adaptive(sys_, np.array([fp_type(v) for v in y0]),
                                    **_heyoka_pars(folded, [fp_type(v) for v in PARAMS]),
                                    tol=fp_type(tol), fp_type=fp_type, compact_mode=False)
            start = np.array([fp_type(v) for v in y0])

            def run(ta=ta, start=start):
                ta.time = fp_type(0.0)
                ta.state[:] = start
                ta.propagate_until(fp_type(t_end))
                return ta.state.copy()

            final = run()
            label = f"{name} taylor" if fp_type in (float, np.longdouble) else f"{name} taylor real128"
            points.append(Point(label, f"tol={tol:g}", _timed(run), (error or _error)(final, ref)))
    return points


def _scipy_points(y0, t_end: float, ref) -> list[Point]:
    rhs = lambdified_rhs("planar", cse=True)
    points = []
    for rtol in (1e-9, 1e-11, 1e-13):
        run = lambda: solve_ivp_final(rhs, list(y0), t_end, PARAMS, "DOP853", rtol, rtol * 1e-3)[0]
        points.append(Point("scipy solve_ivp DOP853 (lambdify)", f"rtol={rtol:g}", _timed(run),
                            _error(run(), ref)))
    return points


def trajectory_row(hy, name: str, title: str, y0, t_end: float, scipy: bool = True) -> Row:
    ref = _derive_reference(y0, t_end)
    row = Row(name, title)
    row.points += _derive_points(y0, t_end, ref)
    row.points += _heyoka_points(hy, y0, t_end, ref)
    if scipy:
        row.points += _scipy_points(y0, t_end, ref)
    return row


def long_double_row(hy, y0=(2.5, 2.0, 0.0, 0.0), t_end: float = 10.0) -> Row:
    ld = np.longdouble
    row = Row("long double", f"chaotic, y0 = {tuple(y0)}, t = {t_end:g}, heyoka in long double")
    ref = _quad_reference(hy, y0, t_end)
    ours = _derive_reference(y0, t_end)
    row.note = (f"reference: heyoka real128 at tol 1e-30; derive's long double reference (dop853, "
                f"rtol 2e-18) differs from it by {_error(ours, ref):.1e}")
    row.points += _derive_points(y0, t_end, ref, dtype="longdouble")
    row.points += _ladder_points(y0, t_end, [_mp(v) for v in ref], ("double-double",), (1e-16, 1e-18, 1e-20))
    row.points += _heyoka_points(hy, y0, t_end, ref, fp_type=ld)
    return row


LADDER_TOLS = (1e-20, 1e-22, 1e-24, 1e-26, 1e-28, 1e-30)


def quad_row(hy, y0=(2.5, 2.0, 0.0, 0.0), t_end: float = 20.0) -> Row:
    """Past long double's horizon: derive's double-double and quad against heyoka's real128."""
    q = hy.real128
    row = Row("quad", f"chaotic, y0 = {tuple(y0)}, t = {t_end:g}, heyoka in real128")
    ta = hy.taylor_adaptive(heyoka_system(hy), np.array([q(v) for v in y0]), pars=np.array([q(v) for v in PARAMS]),
                            tol=q("1e-33"), fp_type=q)
    ta.propagate_until(q(t_end))
    ref = [_mp(str(v)) for v in ta.state]
    ours = simulate("planar", list(y0), [0.0, t_end], PARAMS, dtype="quad", rtol=2e-33).y_exact[-1]
    with mpmath.workdps(45):
        agree = float(max(abs(a - b) for a, b in zip(ours, ref)))
    row.note = (f"reference: heyoka real128 at tol 1e-33; derive in quad at rtol 2e-33 differs from it by "
                f"{agree:.1e}")
    row.points += _ladder_points(y0, t_end, ref, ("double-double", "quad"), LADDER_TOLS)
    row.points += _heyoka_points(hy, y0, t_end, ref, fp_type=q, tols=LADDER_TOLS, error=_mp_error)
    return row


def _mp(text):
    with mpmath.workdps(45):
        return mpmath.mpf(str(text))


def _mp_error(state, ref) -> float:
    """max |state - ref| in mpmath (beyond what long double resolves)."""
    with mpmath.workdps(45):
        values = [mpmath.mpf(str(v)) for v in state]
        if not all(mpmath.isfinite(v) for v in values):
            return math.inf
        return float(max(abs(a - b) for a, b in zip(values, ref)))


def _ladder_points(y0, t_end: float, ref: list, precisions, tols) -> list[Point]:
    """derive's Taylor integrator on the rungs above long double (exact results: r.y_exact)."""
    points = []
    for precision in precisions:
        for tol in tols:
            run = lambda: simulate("planar", list(y0), [0.0, t_end], PARAMS, dtype=precision, rtol=tol)
            r = run()
            points.append(Point(f"derive taylor {precision}", f"rtol={tol:g}", _timed(run),
                                _mp_error(r.y_exact[-1], ref) if r.ok else math.inf))
    return points


def _quad_reference(hy, y0, t_end: float) -> np.ndarray:
    q = hy.real128
    ta = hy.taylor_adaptive(heyoka_system(hy), np.array([q(v) for v in y0]),
                            pars=np.array([q(v) for v in PARAMS]), tol=q("1e-30"), fp_type=q)
    ta.propagate_until(q(t_end))
    return np.array([np.longdouble(str(v)) for v in ta.state])


# -- the ensemble row -------------------------------------------------------------------

def ensemble_states(B: int = 4096, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y0 = np.zeros((B, 4))
    y0[:, :2] = rng.uniform(-1.0, 1.0, (B, 2))
    return y0


def ensemble_row(hy, B: int = 4096, t_end: float = 10.0) -> Row:
    y0 = ensemble_states(B)
    threads = os.cpu_count() or 1
    ref = ensemble("planar", y0, [0.0, t_end], PARAMS, method="dop853", rtol=2e-18, atol=1e-22,
                          dtype="longdouble", threads=threads).y[:, -1]
    row = Row("ensemble", f"{B} states (angles uniform in [-1, 1], rates 0), t = {t_end:g}, "
                          f"every final error <= 1e-8; {threads} threads")

    def worst(y):
        return float(np.max(np.abs(np.asarray(y, np.longdouble) - ref))) if np.all(np.isfinite(y)) else math.inf

    for method in TOLERANCE_METHODS:
        for rtol in ENSEMBLE_TOLS:
            def make(specialise, method=method, rtol=rtol):
                return lambda: ensemble("planar", y0, [0.0, t_end], PARAMS, method=method, rtol=rtol,
                                        threads=threads, specialise=specialise)
            row.points += _both_settings(make, method, f"rtol={rtol:g}",
                                         lambda r: worst(r.y[:, -1]) if r.all_ok else math.inf)
    for name, folded in HEYOKA_SETTINGS:
        sys_ = heyoka_system(hy, folded)
        for width in sorted({hy.recommended_simd_size(), 2 * hy.recommended_simd_size()}):
            for tol in ENSEMBLE_TOLS:
                run = _heyoka_ensemble(hy, sys_, y0, t_end, tol, width, threads, folded)
                final = run()
                row.points.append(Point(f"{name} taylor batch {width}", f"tol={tol:g}", _timed(run), worst(final)))
    return row


def _heyoka_ensemble(hy, sys_, y0, t_end: float, tol: float, width: int, threads: int, folded: bool = False):
    """An ensemble with heyoka at its fastest: one SIMD batch integrator
    (`taylor_adaptive_batch`, `width` lanes) per thread, built before timing, each thread
    resetting and propagating its share of the batches (heyoka releases the GIL while it
    integrates); not its own `ensemble_propagate_until_batch`, which copies the
    integrator for every batch.  `folded`: sys_ has the parameters as numbers."""
    B = len(y0)
    pars = {} if folded else {"pars": np.tile(np.array(PARAMS)[:, None], width)}
    integrators = [hy.taylor_adaptive_batch(sys_, np.zeros((4, width)), **pars, tol=tol, compact_mode=False)
                   for _ in range(threads)]
    chunks = [(k, min(k + width, B)) for k in range(0, B, width)]
    shares = [chunks[i::threads] for i in range(threads)]
    out = np.empty_like(y0)

    def work(i):
        ta = integrators[i]
        for a, b in shares[i]:
            block = np.zeros((4, width))
            block[:, :b - a] = y0[a:b].T
            ta.set_time(0.0)
            ta.state[:] = block
            ta.propagate_until(t_end)
            out[a:b] = ta.state[:, :b - a].T
        return None

    def run():
        with ThreadPoolExecutor(max_workers=threads) as pool:
            list(pool.map(work, range(threads)))
        return out.copy()

    return run


CALL_ROUNDS = 60         # rounds of the trivial call, each tool's batch in turn
CALL_BATCH = 200         # calls per batch (the figure: the fastest batch's time per call)


def trivial_call_row(hy) -> Row:
    """The fixed cost of a call: `derive.simulate` on a trivial span against heyoka's
    `propagate_until` (resetting time and state, as a user's loop over initial states
    does), in both heyoka settings; the tools' batches of calls interleaved round by round,
    so that the load of a shared machine falls on all of them alike, each tool's figure the
    fastest batch."""
    y0 = (1.0, 0.5, 0.0, 0.0)
    row = Row("one call", "one call on a trivial span (t = 1e-6): the fixed cost of a call")
    calls = {f"{name} dop853": (lambda specialise=specialise: simulate("planar", y0, [0.0, 1e-6], PARAMS,
                                                                      specialise=specialise))
             for name, specialise in DERIVE_SETTINGS}
    for name, folded in HEYOKA_SETTINGS:
        ta = hy.taylor_adaptive(heyoka_system(hy, folded), np.array(y0), **_heyoka_pars(folded, PARAMS), tol=1e-15)
        start = np.array(y0)

        def call(ta=ta, start=start):
            ta.time = 0.0
            ta.state[:] = start
            ta.propagate_until(1e-6)
        calls[f"{name} taylor"] = call
    best = dict.fromkeys(calls, math.inf)
    for f in calls.values():
        f()
        f()                      # the second call of a kind: derive's compiled call path from here
    for _ in range(CALL_ROUNDS):
        for tool, f in calls.items():
            t0 = time.perf_counter()
            for _ in range(CALL_BATCH):
                f()
            best[tool] = min(best[tool], (time.perf_counter() - t0) / CALL_BATCH)
    row.points += [Point(tool, "simulate" if tool.startswith("derive") else "propagate_until", seconds, 0.0)
                   for tool, seconds in best.items()]
    return row


# -- time per step, per Taylor order --------------------------------------------------

STEP_TOLS = (1e-6, 1e-8, 1e-10, 1e-12, 1e-14)     # Taylor orders 8, 11, 13, 15, 18


def per_step_row(hy, y0=(2.5, 2.0, 0.0, 0.0), t_end: float = 5.0) -> Row:
    """Taylor's method against itself: derive's `taylor` and heyoka (both settings) at the
    same tolerance, so the same order and step rule (Jorba and Zou), on the chaotic row;
    each figure a run's time over its steps (one call, the call's cost spread over the
    steps), and heyoka's `ta.step()` alone (a Python loop of single steps).  The setting
    names the order and the steps: the steps differ a little between the tools (their
    step-size formulas use the coefficients of the last two orders in different norms)."""
    row = Row("per step", f"chaotic, y0 = {tuple(y0)}, t = {t_end:g}: time per step, Taylor's method")
    ref = _derive_reference(y0, t_end)
    for tol in STEP_TOLS:
        runs = [lambda specialise=specialise: simulate("planar", y0, [0.0, t_end], PARAMS, method="taylor", rtol=tol,
                                                       specialise=specialise)
                for _, specialise in DERIVE_SETTINGS]
        results = [run() for run in runs]
        for (name, _), r, seconds in zip(DERIVE_SETTINGS, results, _timed_together(runs)):
            row.points.append(Point(f"{name} taylor", f"order={taylor_order(tol)} steps={r.nsteps} rtol={tol:g}",
                                    seconds / r.nsteps, _error(r.y[-1], ref)))
    for name, folded in HEYOKA_SETTINGS:
        sys_ = heyoka_system(hy, folded)
        for tol in STEP_TOLS:
            ta = hy.taylor_adaptive(sys_, np.array(y0), **_heyoka_pars(folded, PARAMS), tol=tol, compact_mode=False)
            start = np.array(y0)

            def run(ta=ta, start=start):
                ta.time = 0.0
                ta.state[:] = start
                return ta.propagate_until(t_end)[3]          # (outcome, min_h, max_h, steps, ...)
            steps = run()
            final = ta.state.copy()
            knob = f"order={ta.order} steps={steps} tol={tol:g}"
            row.points.append(Point(f"{name} taylor", knob, _timed(run) / steps, _error(final, ref)))

            def single_steps(ta=ta, start=start, steps=steps):
                ta.time = 0.0
                ta.state[:] = start
                for _ in range(steps):
                    ta.step()
            row.points.append(Point(f"{name} taylor step()", knob, _timed(single_steps) / steps, math.nan))
    return row


# -- the race ---------------------------------------------------------------------------

@dataclass
class Race:
    rows: list[Row]
    heyoka_version: str
    machine: str
    load: str = ""           # the machine's load averages at the start and the end of the run


def _load() -> str:
    try:
        return "/".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:          # no load average on this system
        return "?"


def run_race(quick: bool = False, progress=None) -> Race:
    hy = _heyoka()
    load = _load()
    jobs = [lambda: trajectory_row(hy, "regular", "regular, y0 = (1, 0.5, 0, 0), t = 20", (1.0, 0.5, 0.0, 0.0), 20.0,
                                   scipy=not quick),
            lambda: trajectory_row(hy, "chaotic", "chaotic, y0 = (2.5, 2, 0, 0), t = 5", (2.5, 2.0, 0.0, 0.0), 5.0,
                                   scipy=not quick),
            lambda: trivial_call_row(hy)]
    if not quick:
        jobs += [lambda: per_step_row(hy), lambda: long_double_row(hy), lambda: quad_row(hy),
                 lambda: ensemble_row(hy)]
    rows = []
    for k, job in enumerate(jobs):
        rows.append(job())
        if progress:
            progress(k + 1, len(jobs))
    machine = f"{platform.machine()}, {os.cpu_count()} cores, {platform.python_implementation()} {platform.python_version()}"
    return Race(rows, hy.__version__, machine, f"{load} at the start, {_load()} at the end (1/5/15 min)")


def _ms(seconds: float | None) -> str:
    if seconds is None:
        return "not reached"
    return f"{seconds * 1e6:.1f} us" if seconds < 1e-3 else f"{seconds * 1e3:.3g} ms"


# the pairings of the summary, in one run: derive's general kernels against heyoka with
# par[], derive's specialised kernels against heyoka with the numbers folded in (the fair
# comparison of each), as (derive's setting, its peer)
PAIRS = (("derive", "heyoka"), ("derive-specialised", "heyoka-numbers"))
TABLE_ROWS_SKIPPED = ("per step",)       # a table of its own (step_table)


def summary_rows(race: Race) -> list[dict]:
    """One dict a row: for each pairing (PAIRS) derive's best and its peer's, with their
    settings and the ratio (the peer's time / derive's, under the peer's name); solve_ivp's
    time over the general derive's.  A tool with no point in the row reads "-" (the extended
    rungs have no specialised setting), one whose points all miss the target "not reached"."""
    out = []
    for row in race.rows:
        if row.name in TABLE_ROWS_SKIPPED:
            continue
        s = {"row": row.title}
        for ours_name, peer in PAIRS:
            ours, theirs = row.best(ours_name), row.best(peer)
            for name, point in ((ours_name, ours), (peer, theirs)):
                s[name] = _ms(point and point.seconds) if _has(row, name) else "-"
                s[f"{name} setting"] = _setting(row, point) if point else ""
            s[f"{peer} ratio"] = (theirs.seconds / ours.seconds) if ours and theirs else None
        general, scipy = row.best("derive"), row.best("scipy")
        s["ratio"] = s["heyoka ratio"]
        s["scipy"] = (scipy.seconds / general.seconds) if general and scipy else None
        out.append(s)
    return out


def _has(row: Row, tool: str) -> bool:
    return any(p.tool.split()[0] == tool for p in row.points)


def _setting(row: Row, point: Point) -> str:
    """How a summary names a point's setting: derive's its method and knob (the call row:
    simulate), a peer's its knob."""
    if not point.tool.startswith("derive"):
        return point.knob
    if row.name == "one call":
        return "simulate" + (" specialise=True" if point.tool.startswith("derive-specialised") else "")
    return f"{' '.join(point.tool.split()[1:])} {point.knob}"


def step_table(race: Race) -> list[dict]:
    """The per-step row by tolerance: each tool's time per step and its steps and order."""
    row = next((r for r in race.rows if r.name == "per step"), None)
    if row is None:
        return []
    by_tol: dict[str, dict] = {}
    for p in row.points:
        knobs = dict(k.split("=") for k in p.knob.split())
        tol = knobs.get("rtol", knobs.get("tol"))
        by_tol.setdefault(tol, {"tol": tol})[p.tool] = (p.seconds, knobs["order"], knobs["steps"])
    return list(by_tol.values())


def _ratio(a, b) -> str:
    return f"{a / b:.2f}" if a and b else "-"


def markdown(race: Race) -> str:
    lines = [f"# derive against heyoka {race.heyoka_version}, through both public APIs",
             "", f"Machine: {race.machine}; load {race.load or '?'}. Time to a final-state error <= "
                 f"{TARGET:g} (fastest setting of each tool, minimum wall time of repeated calls). "
                 "Two pairings: derive with the parameters passed at run time against heyoka with them "
                 "as par[] (heyoka), and derive with them folded into its kernels (specialise=True: "
                 "derive specialised) against heyoka with them written in as numbers (heyoka-numbers); "
                 "each ratio = the heyoka setting's time / its derive's (above 1: derive faster); "
                 "solve_ivp = SciPy DOP853 with a lambdified rhs, its time / derive's.",
             "", "| row | derive | setting | heyoka | setting | heyoka / derive | derive specialised | setting | "
                 "heyoka-numbers | setting | heyoka-numbers / derive specialised | solve_ivp / derive |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary_rows(race):
        ratios = {k: f"{s[k]:.2f}" if s[k] else "-" for k in ("heyoka ratio", "heyoka-numbers ratio")}
        scipy = f"{s['scipy']:.0f}" if s["scipy"] else "-"
        lines.append(f"| {s['row']} | {s['derive']} | {s['derive setting']} | {s['heyoka']} | "
                     f"{s['heyoka setting']} | {ratios['heyoka ratio']} | {s['derive-specialised']} | "
                     f"{s['derive-specialised setting']} | {s['heyoka-numbers']} | "
                     f"{s['heyoka-numbers setting']} | {ratios['heyoka-numbers ratio']} | {scipy} |")
    steps = step_table(race)
    if steps:
        lines += ["", "Time per step of Taylor's method (chaotic y0 to t = 5; a run's time over its steps; "
                      "step(): heyoka's single steps from Python), by tolerance and order:", "",
                  "| tol | order | derive | steps | heyoka | steps | heyoka / derive | derive specialised | "
                  "heyoka-numbers | heyoka-numbers / derive specialised | heyoka step() | heyoka-numbers step() |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for s in steps:
            d, h, ds, f = (s.get(k, (None, "-", "-")) for k in ("derive taylor", "heyoka taylor",
                                                                  "derive-specialised taylor", "heyoka-numbers taylor"))
            hs, fs = (s.get(k, (None,))[0] for k in ("heyoka taylor step()", "heyoka-numbers taylor step()"))
            lines.append(f"| {s['tol']} | {d[1]} | {_us(d[0])} | {d[2]} | {_us(h[0])} | {h[2]} | {_ratio(h[0], d[0])} | "
                         f"{_us(ds[0])} | {_us(f[0])} | {_ratio(f[0], ds[0])} | {_us(hs)} | {_us(fs)} |")
    notes = [f"- {r.name}: {r.note}" for r in race.rows if r.note]
    return "\n".join(lines + ([""] + notes if notes else [])) + "\n"


def _us(seconds) -> str:
    return "-" if seconds is None else f"{seconds * 1e6:.3g} us"


def write_race(race: Race, out: Path, plots: bool = True) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    files = [out / "race.md", out / "race.csv"]
    files[0].write_text(markdown(race))
    with files[1].open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(("row", "tool", "setting", "seconds", "final_error"))
        for row in race.rows:
            for p in row.points:
                w.writerow((row.name, p.tool, p.knob, f"{p.seconds:.6g}", f"{p.error:.3g}"))
    if plots:
        files.append(_plot(race, out / "race.png"))
    return files


def _plot(race: Race, path: Path) -> Path:
    import matplotlib    # the plot extra, imported when a figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt    # the plot extra, imported when a figure is drawn
    rows = [r for r in race.rows if r.name not in ("one call", *TABLE_ROWS_SKIPPED)]
    tools = sorted({p.tool for r in rows for p in r.points})
    colours = {tool: f"C{i % 10}" for i, tool in enumerate(tools)}      # one colour per tool everywhere
    fig, axes = plt.subplots(1, len(rows), figsize=(4.6 * len(rows), 4.2), squeeze=False)
    for ax, row in zip(axes[0], rows):
        for tool in sorted({p.tool for p in row.points}):
            pts = sorted((p.seconds, max(p.error, 1e-20)) for p in row.points
                         if p.tool == tool and math.isfinite(p.error))
            if pts:
                style = {"heyoka": "s-", "heyoka-numbers": "s--", "scipy": "^--",
                         "derive-specialised": "o:"}.get(tool.split()[0], "o-")
                ax.loglog([e for _, e in pts], [s for s, _ in pts], style, ms=3, label=tool,
                          color=colours[tool])
        ax.axvline(TARGET, color="grey", lw=0.8, ls=":")
        ax.set_xlabel("final-state error")
        ax.set_ylabel("wall time per run [s]")
        ax.set_title(row.name, fontsize=10)
        ax.invert_xaxis()
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=6)
    fig.suptitle(f"work-precision: derive and heyoka {race.heyoka_version}", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def read_race(csv_path: Path, heyoka_version: str = "", machine: str = "") -> Race:
    """A race back from its race.csv (to draw it again)."""
    rows: dict[str, Row] = {}
    with Path(csv_path).open() as fh:
        for rec in csv.DictReader(fh):
            row = rows.setdefault(rec["row"], Row(rec["row"], rec["row"]))
            row.points.append(Point(rec["tool"], rec["setting"], float(rec["seconds"]), float(rec["final_error"])))
    return Race(list(rows.values()), heyoka_version, machine)


def console(race: Race) -> str:
    return markdown(race)
