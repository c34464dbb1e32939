"""The timing loop, and the cost of one generated rhs evaluation the overhead is measured in.

Each configuration is warmed up, then timed once per round for `repeats` rounds across
all configurations of a problem (fewer for runs over SLOW_RUN and 1 s): the median wall
time and this thread's median CPU time are reported.
"""
from __future__ import annotations

import statistics
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import toolkit
from .problems import Config, Problem, knob
from ...runtime.simulate import simulate

SLOW_RUN = 0.2            # s: runs slower than this are repeated fewer times


@dataclass
class Timing:
    """The timed runs of one configuration: a warm-up, then one run per round."""
    run: Callable | None
    result: tuple | None = None
    rounds: int = 0                     # timed runs still wanted
    walls: list = field(default_factory=list)
    cpus: list = field(default_factory=list)
    error: str | None = None


def start_timing(c: Config, repeats: int) -> Timing:
    """Build the run and warm it up (timed: a run of a second or more is timed only once).
    The CPU time (this thread's) leaves out the time other processes of a shared machine take."""
    try:
        run = c.make()
        w0, c0 = time.perf_counter(), time.thread_time()
        result = run()
        warm, warm_cpu = time.perf_counter() - w0, time.thread_time() - c0
    except Exception as exc:               # a peer that cannot run this problem says why
        return Timing(None, error=f"{type(exc).__name__}: {exc}".splitlines()[0])
    t = Timing(run, result)
    if warm >= 1.0:
        t.walls, t.cpus = [warm], [warm_cpu]
    else:
        t.rounds = min(repeats, repeats if warm < SLOW_RUN else 3)
    return t


def time_once(t: Timing) -> None:
    """One more timed run of a configuration, unless it has its rounds (or failed)."""
    if t.run is None or len(t.walls) >= t.rounds:
        return
    w0, c0 = time.perf_counter(), time.thread_time()
    t.run()
    t.walls.append(time.perf_counter() - w0)
    t.cpus.append(time.thread_time() - c0)


def timed_rounds(cfgs: list[Config], repeats: int, tick=None) -> list[Timing]:
    """Time configurations in rounds (every configuration once per round, up to `repeats`
    rounds): a slow phase of a shared machine then touches one run of many configurations,
    which the medians discard, instead of every run of a few.

    Parameters
    ----------
    cfgs : list of Config
    repeats : int
    tick : callable, optional
        tick(label), once per configuration warmed up.

    Returns
    -------
    list of Timing
        In the order of `cfgs`.
    """
    timings = []
    for c in cfgs:
        timings.append(start_timing(c, repeats))
        if tick:
            tick(f"{c.problem.name} warm-up {c.series} {knob({'rtol': c.rtol, 'step': c.step})}")
    for _ in range(repeats):
        for t in timings:
            time_once(t)
    return timings


def rhs_cost_ns(problem: Problem, chained: bool = True, repeats: int = 7, evals: int = 1_000_000) -> float:
    """Median CPU time of one generated C rhs evaluation (double), timed in a C loop over the
    states this problem visits (its trajectory at 10^4 times: sin and cos cost depends on
    the argument).  The atlas: each chart's rhs on the states in that chart, weighted.

    chained: each evaluation's input depends on the previous output (derive/measurement/c/rhs_cost.c), as in
    an integrator -- the cost the overhead check divides by.  Unchained, the CPU overlaps
    consecutive evaluations, and with libmvec's vector sin/cos an evaluation costs well
    under half as much (their latency does not shrink as their throughput does)."""
    r = simulate(problem.model, problem.y0_input(), np.linspace(0.0, problem.t_end, 10_001),
                 list(problem.params), method="dop853", rtol=1e-10)
    r.raise_for_status()
    charts = r.chart if problem.model == "spherical" else np.array([problem.model] * len(r.y), object)
    p = np.ascontiguousarray(r.params, np.float64)
    total = 0.0
    for name in sorted(set(charts)):
        reps = max(1, evals // len(r.y))
        run = toolkit.rhs_cost_run(name, r.y[charts == name], p, reps, chained)
        run()
        times = []
        for _ in range(repeats):
            t0 = time.thread_time()
            run()
            times.append(time.thread_time() - t0)
        total += statistics.median(times) / reps
    return total / len(r.y) * 1e9
