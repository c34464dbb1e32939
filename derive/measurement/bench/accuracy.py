"""Errors and trust horizons: each problem's reference and Lyapunov exponent, the error a
fixed step commits, and the row of one timed configuration.

A run's trust horizon (trust.py) is the time at which its predicted error e0 exp(lambda t)
reaches the target accuracy.  A run whose predicted error reaches the resolution level
RESOLVE (1e-2 of the state's size) before t_end has decorrelated from the true
trajectory: its final state is not compared ("beyond trust horizon").
"""
from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

import numpy as np

from .. import reference as R
from ..trust import Lyapunov, atlas_lyapunov, initial_error, largest_lyapunov, trust_horizon
from . import toolkit
from .problems import DTYPE_EPS, METHOD_ORDER, BenchOptions, Config, Problem, np_dtype, prepared
from .timing import Timing, timed_rounds
from ...codegen.contract import MULTISTEP
from ...codegen.loops import FIXED_METHODS
from ...derivation.cartesian import cartesian_to_state, link_lengths, state_to_cartesian
from ...runtime.simulate import simulate

LOCAL_ERROR_SAMPLES = 8


@dataclass
class ProblemInfo:
    problem: Problem
    reference: R.Reference
    lyapunov: Lyapunov
    scale: float                 # size of the state (max |y0|, Cartesian for the atlas)
    reference_horizon: float     # until when the reference resolves TARGET / 100
    mpmath_error: float | None = None
    mpmath_t: float | None = None


def spherical_lyapunov(problem: Problem, delta: float = 1e-9) -> Lyapunov:
    """When no single chart holds the run: growth of a small perturbation between two long
    double references (a finite-difference estimate, not the variational equations)."""
    state, chart, p = prepared(problem)
    lengths = link_lengths(chart, p)
    c12 = state_to_cartesian(chart, state, lengths)
    moved = cartesian_to_state(chart, c12, lengths)
    moved[4] += delta                     # a rate: stays on the constraint manifold
    c12b = state_to_cartesian(chart, moved, lengths)
    d0 = float(np.max(np.abs(c12b - c12)))
    a = R._run(problem, 1e-16)[0]
    b = R._run(Problem(problem.name, problem.model, ("cartesian", tuple(c12b)), problem.t_end,
                       problem.params, problem.title), 1e-16)[0]
    d1 = float(np.max(np.abs(np.asarray(a, float) - np.asarray(b, float))))
    return Lyapunov(math.log(max(d1, d0) / d0) / problem.t_end, problem.t_end, problem.model,
                    "finite difference of two long double runs (no chart holds the whole run)")


def problem_info(problem: Problem, opts: BenchOptions) -> ProblemInfo:
    """The reference of a problem, its largest Lyapunov exponent, its size and the
    reference's own trust horizon (to opts.target / 100)."""
    ref = R.compute(problem)
    if problem.model == "spherical":
        lyap = atlas_lyapunov(problem.y0_input(), list(problem.params), problem.t_end) \
            or spherical_lyapunov(problem)
    else:
        lyap = largest_lyapunov(problem.model, problem.y0_input(), list(problem.params), problem.t_end)
    scale = float(np.max(np.abs(np.asarray(ref.final, float)))) if problem.model == "spherical" else \
        float(np.max(np.abs(problem.y0)))
    e0 = initial_error(R.RTOL, np.longdouble, scale)
    return ProblemInfo(problem, ref, lyap, scale, trust_horizon(lyap, opts.target * 1e-2, e0))


def trajectory_samples(problem: Problem, k: int = LOCAL_ERROR_SAMPLES) -> list:
    """k states along the problem's trajectory (y0 inputs for simulate), where local errors are probed."""
    r = simulate(problem.model, problem.y0_input(), np.linspace(0.0, problem.t_end, k + 1),
                 list(problem.params), method="dop853", rtol=1e-12)
    if problem.model == "spherical":
        return [{"chart": r.chart[i], "state": list(r.y[i])} for i in range(k)]
    return [list(r.y[i]) for i in range(k)]


def _loop_step_error(problem: Problem, method: str, step: float, start) -> float:
    """One loop run of h against one of h/2 from `start`, per own step of the method."""
    loop = toolkit.loop_run(problem.model)
    p = np.asarray(problem.params, np.float64)
    # a multistep method's first steps are its starter's: compare over a span of
    # 3k steps and charge the difference to its 2k+1 own steps
    history = FIXED_METHODS[method].get("steps", 1)
    span, own = (3 * history, 2 * history + 1) if history > 1 else (1, 1)
    a, _ = loop(method, start, p, step, span)
    b, _ = loop(method, start, p, step / 2, 2 * span)
    return float(np.max(np.abs(a - b))) / own


def _integrator_step_error(problem: Problem, method: str, dtype: str, step: float, start) -> float:
    """One step of h against two of h/2 from `start` by derive.simulate; inf if one fails."""
    args = dict(method=method, dtype=dtype)
    a = simulate(problem.model, start, [0.0, step], list(problem.params), step=step, **args)
    b = simulate(problem.model, start, [0.0, step], list(problem.params), step=step / 2, **args)
    if not (a.ok and b.ok):
        return math.inf
    va = R.comparison_vector(problem.model, a.y[-1], a.chart_stop, a.params)
    vb = R.comparison_vector(problem.model, b.y[-1], b.chart_stop, b.params)
    return float(np.max(np.abs(np.asarray(va, float) - np.asarray(vb, float))))


def local_error(problem: Problem, method: str, dtype: str, step: float, backend: str = "c",
                samples: list | None = None) -> float:
    """The error a fixed-step run commits per step (what rtol is for an adaptive one): one
    step of size h against two of h/2 (Richardson), the largest over states along the
    trajectory (at y0 alone a pendulum released at rest would understate it).

    Parameters
    ----------
    problem : Problem
    method, dtype : str
    step : float
    backend : {"c", "c-loop"}
        The integrator through derive.simulate, or the generated fixed-step loop.
    samples : list, optional
        Start states (trajectory_samples); y0 alone without them.

    Returns
    -------
    float
        The Richardson estimate of the local error, inf when a run failed.
    """
    k = 2.0 ** METHOD_ORDER.get(method, 4)
    worst = 0.0
    for start in samples or [problem.y0_input()]:
        if backend == "c-loop":
            worst = max(worst, _loop_step_error(problem, method, step, start))
            continue
        err = _integrator_step_error(problem, method, dtype, step, start)
        if math.isinf(err):
            return math.inf
        worst = max(worst, err)
    return worst * k / (k - 1)


def horizons(info: ProblemInfo, c: Config, opts: BenchOptions, cache: dict) -> tuple[float, float, float]:
    """(e0, horizon to the target, horizon to RESOLVE) of a configuration."""
    eps = DTYPE_EPS[c.dtype]
    if c.rtol is not None:
        e0 = initial_error(c.rtol, np_dtype(c.dtype), info.scale)
    else:
        # a multistep method's own steps follow its start: measured on its loop (the same
        # formula; one step of the integrator would be the starter's)
        backend = "c-loop" if c.backend == "c-loop" or c.method in MULTISTEP else "c"
        key = (c.method if c.method in METHOD_ORDER else "rk4", c.dtype, c.step, backend)
        if key not in cache:
            if "samples" not in cache:
                cache["samples"] = trajectory_samples(info.problem)
            cache[key] = local_error(info.problem, key[0], c.dtype, c.step, backend, cache["samples"])
        e0 = max(cache[key], eps * max(info.scale, 1.0))
    lyap = info.lyapunov
    return (e0, trust_horizon(lyap, opts.target, e0),
            trust_horizon(lyap, opts.resolve * max(info.scale, 1.0), e0))


def measure(c: Config, info: ProblemInfo, opts: BenchOptions, cache: dict, rhs_ns: dict,
            timing: Timing | None = None) -> dict:
    """The row of one configuration: times, rhs evaluations, horizons, energy and final-state errors.

    Parameters
    ----------
    c : Config
    info : ProblemInfo
        The problem's reference and Lyapunov exponent.
    opts : BenchOptions
    cache : dict
        Local errors of fixed steps, shared by the configurations of one problem.
    rhs_ns : dict
        ns per generated rhs evaluation, per problem (the overhead's unit); may be empty.
    timing : Timing, optional
        The configuration's timed runs; timed here when not given.

    Returns
    -------
    dict
        Keyed by the CSV's columns; `status` says whether the final state was compared.
    """
    row = {"problem": c.problem.name, "model": c.problem.model, "kind": c.kind, "series": c.series,
           "method": c.method, "backend": c.backend, "dtype": c.dtype, "rtol": c.rtol, "step": c.step,
           "note": c.note}
    t = timing if timing is not None else timed_rounds([c], opts.repeats)[0]
    if t.error is not None:
        row.update(status="failed", seconds=None, note=t.error)
        return row
    final, nfev, ok, message = t.result
    seconds, cpu = statistics.median(t.walls), statistics.median(t.cpus)
    row.update(seconds=seconds, cpu_seconds=cpu, repeats=len(t.walls), nfev=int(nfev))
    if not ok:
        row.update(status="failed", note="; ".join(x for x in (c.note, str(message)) if x))
        return row
    e0, h_target, h_resolve = horizons(info, c, opts, cache)
    row.update(e0=e0, horizon_target=h_target, horizon_resolve=h_resolve)
    if c.observe is not None:
        row["energy_error"] = c.observe() if c.kind == "toolkit" else c.observe(final)
    if info.reference_horizon < c.problem.t_end:
        row.update(status="reference beyond its trust horizon")
    elif h_resolve < c.problem.t_end:
        row.update(status="beyond trust horizon")
    else:
        err = float(np.max(np.abs(np.asarray(final, np.longdouble) - np.asarray(info.reference.final,
                                                                                  np.longdouble))))
        row.update(status="ok", final_error=err)
    if c.kind == "toolkit" and c.backend in ("c", "c-loop") and c.dtype == "float64" and rhs_ns.get(c.problem.name):
        row["overhead"] = cpu / (nfev * rhs_ns[c.problem.name] * 1e-9)
    return row
