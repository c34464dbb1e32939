"""`derive bench`: the speed/accuracy trade, per model, method, precision and backend,
raced against the tools users would otherwise pick.

For every problem (PROBLEMS, data below) and every configuration (method x
tolerance or step x scalar type x backend; the peers of peers.py on the same
problem) one row: the final-state error against a long double reference that
states its own accuracy (reference.py), the largest relative energy error over
41 output times, the median wall time of repeated runs, the rhs evaluations,
and the trust horizon of the run (trust.py: the time at which its predicted
error e0 exp(lambda t) reaches the target accuracy).  A run whose predicted
error reaches the resolution level RESOLVE (1e-2 of the state's size) before
t_end has decorrelated from the true trajectory: its final state is not
compared ("beyond trust horizon").

From the rows: the time each method and peer needs to reach a final-state
error of `target` (1e-8; interpolated on the work-precision front), the ratios
against the peers and the targets of the issue, the integrator overhead
(time / (rhs evaluations x cost of one generated rhs)), and the throughput of
the batched RK4 (derive/codegen/loops.py) against its peers.

    rows = run_bench(BenchOptions(quick=True))
    write_all(result, Path("derive-bench"))

Toolkit series are `method backend scalar`: the generated integrators in C
(`C`, float32/float64/long double) and NumPy, and the generated single-trajectory
fixed-step loops (`C-loop`: rk4; rk8 = DOP853's 8th-order formula at a fixed
step; abm12 = the 12-step Adams-Bashforth-Moulton pair, two rhs evaluations a step;
derive/codegen/loops.py).  Timings call the compiled code directly
(integrator_library(model).run, the atlas library, the generated NumPy modules,
the loops), as the peers are called, so the Python overhead of derive.simulate is
not in them; the untimed observation run (energies) goes through derive.simulate.
Each configuration is warmed up, then timed once per round for `repeats` rounds
across all configurations of a problem (fewer for runs over 0.2 s and 1 s): the
median wall time and this thread's median CPU time are reported.
"""
from __future__ import annotations

import csv
import datetime as _dt
import math
import os
import platform
import statistics
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import peers as P, reference as R
from .trust import Lyapunov, atlas_lyapunov, initial_error, largest_lyapunov, trust_horizon
from ..codegen.contract import ADAPTIVE, METHODS, SINE_MIN
from ..codegen.loops import FIXED_METHODS, evaluations, throughput_models
from ..runtime.throughput import fixed_library, throughput_library, throughput_numpy
from ..runtime.simulate import normalise_params, normalise_y0, numpy_module, simulate
from ..runtime.atlas_runner import ATLAS_CHARTS, atlas_library, numpy_atlas
from ..runtime.build import integrator_library
from ..runtime.loader import build_fastest, load
from ..derivation.cartesian import cartesian_to_state, link_lengths, state_to_cartesian
from ..codegen.sources import c_source
from ..paths import bench_c_dir
import importlib
import ctypes
import importlib.util

DEFAULT_OUT = "derive-bench"     # `derive bench` writes here (relative to the current directory)
TARGET = 1e-8
RESOLVE = 1e-2            # decorrelation level (times the state's size): never compare beyond
OBSERVATIONS = 41         # output times of the energy run
SLOW_RUN = 0.2            # s: runs slower than this are repeated fewer times
G = 9.81

CSV_COLUMNS = ("problem", "model", "kind", "series", "method", "backend", "dtype", "rtol", "step",
               "status", "final_error", "energy_error", "seconds", "cpu_seconds", "repeats", "nfev", "overhead",
               "e0", "horizon_target", "horizon_resolve", "note")


# -- problems, as data ------------------------------------------------------------

@dataclass(frozen=True)
class Problem:
    name: str
    model: str
    y0: tuple            # state, or ("cartesian", 12 numbers) for the spherical atlas
    t_end: float
    params: tuple
    title: str
    base_step: float = 0.02       # largest fixed step of the sweep

    def y0_input(self):
        if self.y0 and self.y0[0] == "cartesian":
            return {"cartesian": list(self.y0[1])}
        return list(self.y0)


PROBLEMS = (
    Problem("regular", "planar", (1.0, 0.5, 0.0, 0.0), 20.0, (1.0, 1.0, 1.0, 1.0, G),
            "planar, regular: y0 = (1.0, 0.5, 0, 0) to t = 20"),
    Problem("chaotic", "planar", (2.5, 2.0, 0.0, 0.0), 5.0, (1.0, 1.0, 1.0, 1.0, G),
            "planar, chaotic: y0 = (2.5, 2.0, 0, 0) to t = 5"),
    Problem("compound", "compound", (1.5, 0.0, 0.0, 0.0), 10.0,
            (1.0, 1.0, 1.0, 1.0, 1.0 / 12.0, 1.0 / 12.0, G),
            "compound, seed 001's setting (uniform rods, L = m l^2/12): theta1 = 1.5 to t = 10"),
    Problem("spherical_pole", "spherical",
            ("cartesian", (0.0, 0.0, -1.0, 0.6, 0.0, -1.8, 1.5, 0.8, 0.0, 3.1, 1.8, 1.2)), 10.0,
            (1.0, 1.0, 1.0, 1.0, G),
            "spherical atlas through the pole: x1 = (0, 0, -1) hanging straight down, to t = 10"),
)

# tolerance and step sweeps; fixed steps are rounded to t_end / N with N a multiple
# of OBSERVATIONS - 1, so the observation run takes the very same steps
ADAPTIVE_RTOLS = {"float32": (1e-3, 1e-4, 1e-5),
                  "float64": (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13),
                  "longdouble": (1e-8, 1e-10, 1e-12, 1e-14, 1e-16)}
FIXED_DIVISORS = {"rk4": (1, 2, 4, 8, 16, 32), "midpoint": (1, 2, 4, 8), "gauss2": (1, 2, 4, 8, 16)}
NUMPY_KNOBS = {"dop853": (1e-6, 1e-8, 1e-10), "dopri5": (1e-5, 1e-7), "rk4": (2, 4),
               "midpoint": (2,), "gauss2": (2,)}
QUICK_KNOBS = {"dop853": (1e-9, 1e-12), "rk4": (4, 16)}
# the generated single-trajectory loops (derive/codegen/loops.py, <model>_fixed.c):
# step = base_step / divisor, rounded to the observation grid
LOOP_DIVISORS = {"rk8": (0.25, 0.35, 0.45, 0.6, 0.8, 1.0, 1.5, 2.0, 3.0, 4.0), "rk4": (1, 2, 4, 8, 16, 32, 64),
                 "abm12": (1.5, 2, 2.5, 3, 4, 5, 6, 8, 12)}
QUICK_LOOP_DIVISORS = {"rk8": (0.35, 0.6)}
METHOD_ORDER = {"rk4": 4, "midpoint": 2, "gauss2": 4, "rk8": 8, "abm12": 12}
DTYPE_EPS = {"float32": float(np.finfo(np.float32).eps), "float64": float(np.finfo(np.float64).eps),
             "longdouble": float(np.finfo(np.longdouble).eps)}

PEER_RTOLS = {"RK45": (1e-4, 1e-6, 1e-8, 1e-10), "DOP853": (1e-6, 1e-8, 1e-10, 1e-12, 1e-13),
              "LSODA": (1e-6, 1e-8, 1e-10, 1e-12)}
PEER_DIVISORS = (1, 2, 4, 8, 16, 32, 64)


@dataclass
class BenchOptions:
    problems: tuple[str, ...] | None = None    # names; None: all
    quick: bool = False                        # a small subset, seconds
    repeats: int = 5
    target: float = TARGET
    resolve: float = RESOLVE
    peers: bool = True
    throughput: bool = True
    mpmath: bool = True                        # the reference's mpmath spot check
    progress: Callable | None = None           # progress(done, total, label)


# -- configurations ---------------------------------------------------------------

@dataclass
class Config:
    problem: Problem
    kind: str                 # toolkit | peer
    series: str
    method: str
    backend: str
    dtype: str
    rtol: float | None
    step: float | None
    make: Callable            # () -> run; run() -> (final vector, nfev, ok, message)
    observe: Callable | None = None     # () -> relative energy error (untimed)
    note: str = ""


def fixed_step(problem: Problem, divisor: int) -> float:
    per = OBSERVATIONS - 1
    n = per * max(1, round(problem.t_end / (problem.base_step / divisor) / per))
    return problem.t_end / n


BACKEND_LABEL = {"c": "C", "numpy": "NumPy", "c-loop": "C-loop"}


def _series(method: str, backend: str, dtype: str) -> str:
    return f"{method} {BACKEND_LABEL[backend]} {dtype}"


def toolkit_configs(problem: Problem, opts: BenchOptions) -> list[Config]:
    out = []
    plan = []
    if opts.quick:
        for method, knobs in QUICK_KNOBS.items():
            plan.append((method, "c", "float64", knobs))
        plan.append(("dop853", "numpy", "float64", (1e-6,)))
    else:
        for method in METHODS:
            if method not in ADAPTIVE and method not in FIXED_DIVISORS:
                continue        # rk8, abm12: measured as the fixed-step C loops (LOOP_DIVISORS)
            for dtype in ("float64", "float32", "longdouble"):
                knobs = ADAPTIVE_RTOLS[dtype] if method in ADAPTIVE else FIXED_DIVISORS[method]
                plan.append((method, "c", dtype, knobs))
            plan.append((method, "numpy", "float64", NUMPY_KNOBS[method]))
    if problem.model in _loop_models():
        for method, divs in (QUICK_LOOP_DIVISORS if opts.quick else LOOP_DIVISORS).items():
            for div in divs:
                step = fixed_step(problem, div)
                out.append(Config(problem, "toolkit", _series(method, "c-loop", "float64"), method, "c-loop",
                                  "float64", None, step, _loop_runner(problem, method, step),
                                  _loop_observer(problem, method, step)))
    for method, backend, dtype, knobs in plan:
        for knob in knobs:
            rtol = knob if method in ADAPTIVE else None
            step = None if method in ADAPTIVE else fixed_step(problem, knob)
            out.append(Config(problem, "toolkit", _series(method, backend, dtype), method, backend, dtype,
                              rtol, step, _toolkit_runner(problem, method, backend, dtype, rtol, step),
                              _toolkit_observer(problem, method, backend, dtype, rtol, step)))
    return out


def _loop_models() -> list[str]:
    return throughput_models()


def _loop_runner(problem: Problem, method: str, step: float):
    """The generated fixed-step loop (<model>_fixed_<method>): rhs inlined, no driver."""
    def make():
        lib = fixed_library(problem.model)
        state, _, p = _prepared(problem)
        y0, pa = np.asarray(state, np.float64), np.asarray(p, np.float64)
        n = int(round(problem.t_end / step))
        nfev = evaluations(method, n)          # counted outside the timed call

        def run():
            y, done = lib.run(method, y0, pa, step, n)
            return y, nfev if done == n else evaluations(method, done), done == n, f"{done} of {n} steps"
        return run
    return make


def _loop_observer(problem: Problem, method: str, step: float):
    """Energies of the loop's trajectory at the observation times (the loop, restarted in pieces)."""
    def observe() -> float:
        lib = fixed_library(problem.model)
        state, _, p = _prepared(problem)
        y, pa = np.asarray(state, np.float64), np.asarray(p, np.float64)
        per = int(round(problem.t_end / step)) // (OBSERVATIONS - 1)
        energy = _energy_of(problem)
        E = [energy(y)]
        for _ in range(OBSERVATIONS - 1):
            y, done = lib.run(method, y, pa, step, per)
            if done != per:
                return math.inf
            E.append(energy(y))
        return _relative_energy_error(np.array(E))
    return observe


def _options(method: str, rtol, step) -> dict:
    return {"rtol": rtol if rtol is not None else 1e-9, "atol": (rtol if rtol is not None else 1e-9) * 1e-3,
            "h": step or 0.0, "hmin": 0.0, "hmax": 0.0, "max_steps": 100_000_000, "newton_tol": 0.0,
            "newton_max": 30, "sine_min": float(SINE_MIN)}


def _np_dtype(dtype: str):
    return {"float32": np.float32, "float64": np.float64, "longdouble": np.longdouble}[dtype]


def _prepared(problem: Problem):
    """(state, chart) of y0 and the parameters, normalised as derive.simulate does."""
    p = normalise_params(problem.model, list(problem.params))
    state, chart, _ = normalise_y0(problem.model, problem.y0_input(), p)
    return np.asarray(state), chart, p


def _toolkit_runner(problem: Problem, method: str, backend: str, dtype: str, rtol, step):
    def make():
        dt = _np_dtype(dtype)
        state, chart, p = _prepared(problem)
        y0, pd, t = np.asarray(state, dt), np.asarray(p, dt), np.array([0.0, problem.t_end], dt)
        opt = _options(method, rtol, step)
        idx = METHODS.index(method)
        spherical = problem.model == "spherical"
        vec = lambda y, ch: R.comparison_vector(problem.model, y, ch, p)
        if backend == "c":
            lib = atlas_library() if spherical else integrator_library(problem.model)
            o = lib.defaults()
            for k, v in opt.items():
                setattr(o, k, v)
            y0b = y0[None, :]
            if spherical:
                c0 = [ATLAS_CHARTS.index(chart)]

                def run():
                    y, charts, infos = lib.run(idx, c0, y0b, pd, t, o)
                    inf = infos[0]
                    ch = ATLAS_CHARTS[charts[0, -1]] if charts[0, -1] >= 0 else None
                    return vec(y[0, -1], ch), inf.nfev, inf.status == 0, f"status {inf.status}"
            else:
                def run():
                    y, infos = lib.run(idx, y0b, pd, t, o)
                    inf = infos[0]
                    return vec(y[0, -1], None), inf.nfev, inf.status == 0, f"status {inf.status}"
            return run
        if spherical:
            mod, c0 = numpy_atlas(), ATLAS_CHARTS.index(chart)

            def run():
                st, y, charts, inf = mod.integrate(method, c0, y0, pd, t, dt, **opt)
                ch = ATLAS_CHARTS[charts[-1]] if charts[-1] >= 0 else None
                return vec(y[-1], ch), int(inf["nfev"]), st == 0, f"status {st}"
            return run
        mod = numpy_module(f"{problem.model}_integrate")

        def run():
            st, y, inf = mod.integrate(method, y0, pd, t, dt, **opt)
            return vec(y[-1], None), int(inf["nfev"]), st == 0, f"status {st}"
        return run
    return make


def _relative_energy_error(E: np.ndarray) -> float:
    E = np.asarray(E, dtype=np.float64)
    if not np.all(np.isfinite(E)):
        return math.inf
    scale = abs(float(E[0])) or 1.0
    return float(np.max(np.abs(E - E[0]))) / scale


def _toolkit_observer(problem: Problem, method: str, backend: str, dtype: str, rtol, step):
    def observe() -> float:
        r = simulate(problem.model, problem.y0_input(), np.linspace(0.0, problem.t_end, OBSERVATIONS),
                     list(problem.params), method=method, rtol=rtol, atol=None if rtol is None else rtol * 1e-3,
                     step=step, dtype=dtype, backend=backend)
        return _relative_energy_error(r.energy) if r.ok else math.inf
    return observe


def _energy_of(problem: Problem):
    m = load(problem.model)
    p = np.asarray(problem.params, np.float64)
    return lambda y: float(m.energy(np.asarray(y, np.float64), p))


def peer_configs(problem: Problem, opts: BenchOptions) -> list[Config]:
    """The peers of peers.py on a problem (hand-written rhs and compiled loops: planar only)."""
    out: list[Config] = []
    y0, T, p = list(problem.y0), problem.t_end, tuple(problem.params)
    if problem.model == "spherical":
        return [_peer(problem, "solve_ivp DOP853 + lambdify (standard chart)", "DOP853", 1e-8, None,
                      lambda: _standard_chart_peer(problem),
                      "the standard chart is singular at the pole the run starts from")]
    planar = problem.model == "planar"
    energy = _energy_of(problem)

    def ivp(rhs_factory, method, rtol):
        def make():
            rhs = rhs_factory()

            def run():
                from scipy.integrate import solve_ivp    # the bench extra: a peer
                sol = solve_ivp(rhs, (0.0, T), y0, method=method, rtol=rtol, atol=rtol * 1e-3, args=p)
                return sol.y[:, -1], sol.nfev, bool(sol.success), sol.message
            return run
        return make

    def lsoda(rhs_factory, rtol):
        def make():
            rhs = rhs_factory()

            def run():
                y, nfev = P.odeint_final(rhs, y0, T, p, rtol, rtol * 1e-3)
                return y, nfev, bool(np.all(np.isfinite(y))), ""
            return run
        return make

    def fixed(loop_factory, step):
        n = int(round(T / step))

        def make():
            loop = loop_factory()
            pa = np.asarray(p, np.float64)
            y0a = np.asarray(y0, np.float64)
            return lambda: (loop(y0a, pa, step, n), 4 * n, True, "")
        return make

    quick = opts.quick
    rhs_kinds = [(LAMBDIFY_DEFAULT, lambda: P.lambdified_rhs(problem.model, cse=False)),
                 (LAMBDIFY_CSE, lambda: P.lambdified_rhs(problem.model, cse=True))]
    if planar and not quick:
        rhs_kinds.append(("hand-written rhs", lambda: P.hand_numpy_rhs))
    for label, factory in rhs_kinds:
        for method in (("DOP853",) if quick else ("RK45", "DOP853")):
            for rtol in ((1e-8, 1e-12) if quick else PEER_RTOLS[method]):
                out.append(_peer(problem, f"solve_ivp {method} + {label}", method, rtol, None,
                                 ivp(factory, method, rtol)))
    if not quick:
        lsoda_kinds = [("hand-written rhs", lambda: P.hand_numpy_rhs)] if planar else \
            [(LAMBDIFY_CSE, lambda: P.lambdified_rhs(problem.model, cse=True))]
        if planar and _numba_ok():
            lsoda_kinds.append(("numba rhs", P.numba_rhs))
        for label, factory in lsoda_kinds:
            for rtol in PEER_RTOLS["LSODA"]:
                out.append(_peer(problem, f"odeint LSODA + {label}", "LSODA", rtol, None, lsoda(factory, rtol)))
    if planar:
        loops = [("hand-written C RK4", P.hand_c_rk4, "c")]
        if not quick and _numba_ok():
            loops.append(("numba RK4", P.numba_rk4, "numba"))
        for label, factory, backend in loops:
            for div in ((4, 64) if quick else PEER_DIVISORS):
                step = fixed_step(problem, div)
                out.append(_peer(problem, label, "rk4", None, step, fixed(factory, step), backend=backend))
    for c in out:
        c.observe = (lambda e: lambda final: abs(e(final) - e(y0)) / (abs(e(y0)) or 1.0))(energy)
    return out


def _numba_ok() -> bool:
    try:
        importlib.import_module("numba")
    except ImportError:
        return False
    return True


def _peer(problem, series, method, rtol, step, make, note="", backend="python") -> Config:
    return Config(problem, "peer", series, method, backend, "float64", rtol, step, make, None, note)


# the two lambdify peers: plain `sympy.lambdify` (its default, cse=False) and the stronger
# one with common subexpressions eliminated (cse=True); see peers.lambdified_rhs
LAMBDIFY_DEFAULT = "lambdify (default)"
LAMBDIFY_CSE = "lambdify (cse=True)"
IVP_DEFAULT = f"solve_ivp DOP853 + {LAMBDIFY_DEFAULT}"
IVP_CSE = f"solve_ivp DOP853 + {LAMBDIFY_CSE}"
# peer figures quoted in the issue ("measured here"), shown beside this run's.  The issue
# names its peer "solve_ivp DOP853 + lambdify" without saying how it lambdified: its
# figures are shown beside both variants (the default's is the closer one, see the summary).
ISSUE_LAMBDIFY = {"regular": 74e-3, "chaotic": 196e-3}
ISSUE_FIGURES = {**{(p, s): v for p, v in ISSUE_LAMBDIFY.items() for s in (IVP_DEFAULT, IVP_CSE)},
                 ("regular", "odeint LSODA + numba rhs"): 10e-3, ("chaotic", "odeint LSODA + numba rhs"): 21e-3,
                 ("regular", "hand-written C RK4"): 0.85e-3, ("chaotic", "hand-written C RK4"): 7.7e-3}
ISSUE_THROUGHPUT = (("vectorised NumPy", 5.3e6), ("numba parallel", 1.7e7),
                    ("hand-written SIMD C, one core", 5.9e7))
PEER_EVAL_BUDGET = 200_000      # a peer that needs more rhs evaluations than this has failed


class _GaveUp(Exception):
    pass


def _standard_chart_peer(problem: Problem):
    """What a user without an atlas runs: solve_ivp on the standard chart's lambdified rhs.
    It stops at the first non-finite derivative or after PEER_EVAL_BUDGET evaluations."""
    _, _, p = _prepared(problem)
    c12 = np.asarray(problem.y0[1], float)
    y0 = cartesian_to_state("spherical_std", c12, link_lengths("spherical_std", p))
    raw = P.lambdified_rhs("spherical_std")
    args = tuple(float(v) for v in p)

    def run():
        from scipy.integrate import solve_ivp    # the bench extra: a peer
        count = [0]

        def rhs(t, y, *a):
            count[0] += 1
            f = raw(t, y, *a)
            if not np.all(np.isfinite(f)):
                raise _GaveUp(f"non-finite derivative at t = {t:.3g} (the chart's pole)")
            if count[0] > PEER_EVAL_BUDGET:
                raise _GaveUp(f"gave up after {PEER_EVAL_BUDGET} rhs evaluations at t = {t:.3g}")
            return f
        try:
            with np.errstate(all="ignore"):
                sol = solve_ivp(rhs, (0.0, problem.t_end), y0, method="DOP853", rtol=1e-8, atol=1e-11,
                                args=args)
        except _GaveUp as exc:
            return None, count[0], False, str(exc)
        if not sol.success:
            return None, sol.nfev, False, f"failed at t = {sol.t[-1]:.3g}: {sol.message}"
        return R.comparison_vector("spherical", sol.y[:, -1], "spherical_std", p), sol.nfev, True, ""
    return run


# -- trust horizons --------------------------------------------------------------

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
    state, chart, p = _prepared(problem)
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


LOCAL_ERROR_SAMPLES = 8


def trajectory_samples(problem: Problem, k: int = LOCAL_ERROR_SAMPLES) -> list:
    """k states along the problem's trajectory (y0 inputs for simulate), where local errors are probed."""
    r = simulate(problem.model, problem.y0_input(), np.linspace(0.0, problem.t_end, k + 1),
                 list(problem.params), method="dop853", rtol=1e-12)
    if problem.model == "spherical":
        return [{"chart": r.chart[i], "state": list(r.y[i])} for i in range(k)]
    return [list(r.y[i]) for i in range(k)]


def local_error(problem: Problem, method: str, dtype: str, step: float, backend: str = "c",
                samples: list | None = None) -> float:
    """The error a fixed-step run commits per step (what rtol is for an adaptive one): one
    step of size h against two of h/2 (Richardson), the largest over states along the
    trajectory (at y0 alone a pendulum released at rest would understate it)."""
    k = 2.0 ** METHOD_ORDER.get(method, 4)
    worst = 0.0
    for start in samples or [problem.y0_input()]:
        if backend == "c-loop":
            lib = fixed_library(problem.model)
            p = np.asarray(problem.params, np.float64)
            # a multistep method's first steps are its starter's: compare over a span of
            # 3k steps and charge the difference to its 2k+1 own steps
            history = FIXED_METHODS[method].get("steps", 1)
            span, own = (3 * history, 2 * history + 1) if history > 1 else (1, 1)
            a, _ = lib.run(method, start, p, step, span)
            b, _ = lib.run(method, start, p, step / 2, 2 * span)
            worst = max(worst, float(np.max(np.abs(a - b))) / own)
            continue
        args = dict(method=method, dtype=dtype)
        a = simulate(problem.model, start, [0.0, step], list(problem.params), step=step, **args)
        b = simulate(problem.model, start, [0.0, step], list(problem.params), step=step / 2, **args)
        if not (a.ok and b.ok):
            return math.inf
        va = R.comparison_vector(problem.model, a.y[-1], a.chart_stop, a.params)
        vb = R.comparison_vector(problem.model, b.y[-1], b.chart_stop, b.params)
        worst = max(worst, float(np.max(np.abs(np.asarray(va, float) - np.asarray(vb, float)))))
    return worst * k / (k - 1)


def horizons(info: ProblemInfo, c: Config, opts: BenchOptions, cache: dict) -> tuple[float, float, float]:
    """(e0, horizon to the target, horizon to RESOLVE) of a configuration."""
    eps = DTYPE_EPS[c.dtype]
    if c.rtol is not None:
        e0 = initial_error(c.rtol, _np_dtype(c.dtype), info.scale)
    else:
        backend = "c-loop" if c.backend == "c-loop" else "c"
        key = (c.method if c.method in METHOD_ORDER else "rk4", c.dtype, c.step, backend)
        if key not in cache:
            if "samples" not in cache:
                cache["samples"] = trajectory_samples(info.problem)
            cache[key] = local_error(info.problem, key[0], c.dtype, c.step, backend, cache["samples"])
        e0 = max(cache[key], eps * max(info.scale, 1.0))
    lyap = info.lyapunov
    return (e0, trust_horizon(lyap, opts.target, e0),
            trust_horizon(lyap, opts.resolve * max(info.scale, 1.0), e0))


# -- measuring ---------------------------------------------------------------------

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
    if t.run is None or len(t.walls) >= t.rounds:
        return
    w0, c0 = time.perf_counter(), time.thread_time()
    t.run()
    t.walls.append(time.perf_counter() - w0)
    t.cpus.append(time.thread_time() - c0)


def timed_rounds(cfgs: list[Config], repeats: int, tick=None) -> list[Timing]:
    """Time configurations in rounds (every configuration once per round, up to `repeats`
    rounds): a slow phase of a shared machine then touches one run of many configurations,
    which the medians discard, instead of every run of a few."""
    timings = []
    for c in cfgs:
        timings.append(start_timing(c, repeats))
        if tick:
            tick(f"{c.problem.name} warm-up {c.series} {_knob({'rtol': c.rtol, 'step': c.step})}")
    for _ in range(repeats):
        for t in timings:
            time_once(t)
    return timings


def measure(c: Config, info: ProblemInfo, opts: BenchOptions, cache: dict, rhs_ns: dict,
            timing: Timing | None = None) -> dict:
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


def rhs_loop(model: str):
    """derive/measurement/c/rhs_cost.c compiled against the model's generated C as the integrators are
    (loader.build_fastest: libmvec's vector sin/cos where they build)."""

    path, _ = build_fastest(f"{model}_rhs_cost", [c_source(model, f"{model}.c"), bench_c_dir() / "rhs_cost.c"],
                            extra=(f"-DRHS={model}_rhs", "-include", f"{model}.h"))
    lib = ctypes.CDLL(str(path))
    fn = lib.rhs_cost_loop
    fn.restype = ctypes.c_double
    fn.argtypes = [ctypes.c_long, ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                   ctypes.c_long, ctypes.c_int, ctypes.c_double]
    return fn


def rhs_cost_ns(problem: Problem, chained: bool = True, repeats: int = 7, evals: int = 1_000_000) -> float:
    """Median CPU time of one generated C rhs evaluation (double), timed in a C loop over the
    states this problem visits (its trajectory at 10^4 times: sin and cos cost depends on
    the argument).  The atlas: each chart's rhs on the states in that chart, weighted.

    chained: each evaluation's input depends on the previous output (derive/measurement/c/rhs_cost.c), as in
    an integrator -- the cost the overhead check divides by.  Unchained, the CPU overlaps
    consecutive evaluations: measured here with libmvec's vector sin/cos, the planar rhs
    costs 19 ns so against 43 ns chained (their latency does not shrink as their throughput
    does)."""
    r = simulate(problem.model, problem.y0_input(), np.linspace(0.0, problem.t_end, 10_001),
                 list(problem.params), method="dop853", rtol=1e-10)
    r.raise_for_status()
    charts = r.chart if problem.model == "spherical" else np.array([problem.model] * len(r.y), object)
    p = np.ascontiguousarray(r.params, np.float64)
    total = 0.0
    for name in sorted(set(charts)):
        y = np.ascontiguousarray(r.y[charts == name], np.float64)
        out = np.empty_like(y)
        fn = rhs_loop(name)
        reps = max(1, evals // len(r.y))
        args = (len(y), y.shape[1], y.ctypes.data, p.ctypes.data, out.ctypes.data, reps, int(chained), 0.0)
        fn(*args)
        times = []
        for _ in range(repeats):
            t0 = time.thread_time()
            fn(*args)
            times.append(time.thread_time() - t0)
        total += statistics.median(times) / reps
    return total / len(r.y) * 1e9


# -- throughput ---------------------------------------------------------------------

THROUGHPUT_BATCHES = (10_000, 100_000, 1_000_000)
THROUGHPUT_WORK = 20_000_000          # trajectory-steps per timed C run
THROUGHPUT_H = 0.01


def throughput_states(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-np.pi, np.pi, (n, 2)), rng.uniform(-3, 3, (n, 2))])


def _rate(fn, B: int, nsteps: int, repeats: int) -> tuple[float, int]:
    fn(1)                                  # warm-up (and numba compilation)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(nsteps)
        times.append(time.perf_counter() - t0)
    return B * nsteps / statistics.median(times), len(times)


def run_throughput(opts: BenchOptions) -> list[dict]:
    """trajectory-steps per second of batched fixed-step RK4 on planar states."""
    p = np.array([1.0, 1.0, 1.0, 1.0, G])
    h = THROUGHPUT_H
    tp = throughput_library("planar")
    gen_np = throughput_numpy("planar")
    rows = []
    reps = 3
    batches = (10_000, 100_000) if opts.quick else THROUGHPUT_BATCHES
    work = THROUGHPUT_WORK // (10 if opts.quick else 1)
    ncpu = os.cpu_count() or 1
    for B in batches:
        Y = np.ascontiguousarray(throughput_states(B).T)
        nsteps = max(5, work // B)
        for threads in sorted({1, ncpu}):
            def fn(k, threads=threads):
                tp.rk4_soa(Y.copy(), p, h, k, threads=threads)
            rate, n = _rate(fn, B, nsteps, reps)
            rows.append({"path": "generated C batch RK4 (SoA, vectorised)", "batch": B, "threads": threads,
                         "steps": nsteps, "rate": rate, "repeats": n,
                         "note": "libmvec vector sin/cos" if tp.vector_math else "scalar libm (no libmvec)"})
    small = (10_000,) if opts.quick else (10_000, 100_000)
    for B in small:
        y0 = throughput_states(B)
        Y = np.ascontiguousarray(y0.T)
        nsteps = max(2, 2_000_000 // B // (5 if opts.quick else 1))
        rate, n = _rate(lambda k: gen_np.rk4(Y, p, h, k), B, nsteps, reps)
        rows.append({"path": "generated NumPy batch RK4 (SoA)", "batch": B, "threads": 1, "steps": nsteps,
                     "rate": rate, "repeats": n, "note": "sin/cos from half-angle tangents"})
        rate, n = _rate(lambda k: P.numpy_rk4_batch(y0, p, h, k), B, nsteps, reps)
        rows.append({"path": "peer: hand-written vectorised NumPy RK4", "batch": B, "threads": 1,
                     "steps": nsteps, "rate": rate, "repeats": n, "note": ""})
    B = 10_000
    y0 = throughput_states(B)
    nsteps = 20 if opts.quick else 100
    hc = P.hand_c_rk4_batch()
    rate, n = _rate(lambda k: hc(y0, p, h, k), B, nsteps, reps)
    rows.append({"path": "peer: hand-written C RK4 loop over the batch", "batch": B, "threads": 1,
                 "steps": nsteps, "rate": rate, "repeats": n, "note": "scalar, cc -O2"})
    lib = integrator_library("planar")
    o = lib.defaults()
    o.h = h

    def scalar(k):
        lib.run(METHODS.index("rk4"), y0, p, np.array([0.0, h * k]), o)
    rate, n = _rate(scalar, B, nsteps, reps)
    rows.append({"path": "generated C scalar RK4 (planar_integrate_batch)", "batch": B, "threads": 1,
                 "steps": nsteps, "rate": rate, "repeats": n, "note": "one trajectory after another"})
    if _numba_ok() and not opts.quick:
        nb = P.numba_rk4_parallel()
        B2 = 100_000
        y2 = throughput_states(B2)
        rate, n = _rate(lambda k: nb(y2, p, h, k), B2, 20, reps)
        rows.append({"path": "peer: numba parallel RK4 (prange)", "batch": B2, "threads": ncpu, "steps": 20,
                     "rate": rate, "repeats": n, "note": ""})
    elif not _numba_ok():
        rows.append({"path": "peer: numba parallel RK4 (prange)", "batch": 0, "threads": 0, "steps": 0,
                     "rate": float("nan"), "repeats": 0, "note": "numba not installed: not run"})
    return rows


def numpy_trig_costs(n: int = 10_000, reps: int = 50) -> dict[str, float]:
    """ns per element of numpy.sin, numpy.cos and numpy.tan on float64 arrays of n angles:
    why the generated NumPy code takes sin and cos from half-angle tangents."""
    x = throughput_states(n)[:, 0].copy()
    out = {}
    for name in ("sin", "cos", "tan"):
        f = getattr(np, name)
        best = math.inf
        for _ in range(reps):
            t0 = time.perf_counter()
            f(x)
            best = min(best, time.perf_counter() - t0)
        out[name] = best / n * 1e9
    return out


def throughput_agreement(n: int = 10_000, nsteps: int = 100) -> dict:
    """Batched C and NumPy RK4 against the scalar generated RK4: max difference after
    nsteps steps of THROUGHPUT_H (t = 1, inside the trust horizon of these states)."""
    p = np.array([1.0, 1.0, 1.0, 1.0, G])
    y0 = throughput_states(n, seed=1)
    lib = integrator_library("planar")
    o = lib.defaults()
    o.h = THROUGHPUT_H
    ys, _ = lib.run(METHODS.index("rk4"), y0, p, np.array([0.0, THROUGHPUT_H * nsteps]), o)
    ref = ys[:, -1]
    yc, _, _ = throughput_library("planar").rk4(y0, p, THROUGHPUT_H, nsteps, threads=2)
    yn, _, _ = throughput_numpy("planar").rk4(y0.T, p, THROUGHPUT_H, nsteps)
    dc = np.max(np.abs(yc - ref), axis=1)
    dn = np.max(np.abs(yn.T - ref), axis=1)
    return {"n": n, "steps": nsteps, "t": THROUGHPUT_H * nsteps, "c_max": float(dc.max()),
            "numpy_max": float(dn.max()), "c_over": int((dc > 1e-12).sum()),
            "numpy_over": int((dn > 1e-12).sum())}


# -- the run -------------------------------------------------------------------------

@dataclass
class BenchResult:
    rows: list[dict]
    infos: dict[str, ProblemInfo]
    rhs_ns: dict[str, float]                            # chained (rhs_cost_ns)
    rhs_ns_independent: dict[str, float] = field(default_factory=dict)
    throughput: list[dict] = field(default_factory=list)
    agreement: dict | None = None
    numpy_trig: dict = field(default_factory=dict)      # ns per element of numpy.sin/cos/tan
    machine: dict = field(default_factory=dict)
    options: BenchOptions | None = None
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)


def selected_problems(opts: BenchOptions) -> list[Problem]:
    names = opts.problems or (("regular", "chaotic") if opts.quick else tuple(p.name for p in PROBLEMS))
    known = {p.name: p for p in PROBLEMS}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"unknown problem '{unknown[0]}' (known: {', '.join(known)})")
    return [known[n] for n in names]


def run_bench(opts: BenchOptions) -> BenchResult:
    start = time.perf_counter()
    problems = selected_problems(opts)
    notes = []
    have_scipy = _module_ok("scipy")
    if opts.peers and not have_scipy:
        notes.append("scipy not installed: the solve_ivp and odeint peers were not run")
    if opts.peers and not _numba_ok():
        notes.append("numba not installed: the numba peers were not run")
    plans = []
    for prob in problems:
        cfgs = toolkit_configs(prob, opts)
        if opts.peers and have_scipy:
            cfgs += peer_configs(prob, opts)
        elif opts.peers and prob.model == "planar":
            cfgs += [c for c in peer_configs(prob, opts) if "solve_ivp" not in c.series
                     and "odeint" not in c.series]
        plans.append((prob, cfgs))
    total = len(problems) + 2 * sum(len(c) for _, c in plans) + (2 if opts.throughput else 0)
    done = 0

    def tick(label=""):
        nonlocal done
        done += 1
        if opts.progress:
            opts.progress(done, total, label)

    machine = machine_info()
    rhs_ns = {p.name: rhs_cost_ns(p, chained=True) for p in problems}
    rhs_ns_independent = {p.name: rhs_cost_ns(p, chained=False) for p in problems}
    infos, rows = {}, []
    for prob, cfgs in plans:
        info = problem_info(prob, opts)
        if opts.mpmath and not opts.quick and prob.name == "chaotic":
            info.mpmath_t = 0.5
            info.mpmath_error = R.mpmath_check(prob, info.mpmath_t)
        infos[prob.name] = info
        tick(f"{prob.name} reference")
        cache: dict = {}
        timings = timed_rounds(cfgs, opts.repeats, tick)
        for c, t in zip(cfgs, timings):
            rows.append(measure(c, info, opts, cache, rhs_ns, t))
            tick(f"{prob.name} {c.series} {_knob(rows[-1])}")
    result = BenchResult(rows, infos, rhs_ns, rhs_ns_independent, machine=machine, options=opts, notes=notes)
    if opts.throughput:
        result.agreement = throughput_agreement(2_000 if opts.quick else 10_000)
        tick("throughput agreement")
        result.throughput = run_throughput(opts)
        result.numpy_trig = numpy_trig_costs()
        tick("throughput")
    result.seconds = time.perf_counter() - start
    return result


def _module_ok(name: str) -> bool:
    return importlib.util.find_spec(name) is not None


def machine_info() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {}
    for mod in ("numpy", "scipy", "numba", "sympy", "matplotlib"):
        try:
            versions[mod] = __import__(mod).__version__
        except ImportError:
            versions[mod] = "not installed"
    try:
        cc = subprocess.run([os.environ.get("CC", "cc"), "--version"], capture_output=True,
                            text=True).stdout.splitlines()[0]
    except (OSError, IndexError):
        cc = "unknown"
    try:
        load = " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        load = "unknown"
    return {"date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "cpu": cpu, "nproc": os.cpu_count() or 1, "platform": platform.platform(),
            "python": platform.python_version(), "compiler": cc, "loadavg": load, **versions}


# -- analysis ---------------------------------------------------------------------------

def front(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """(seconds, error) points on the work-precision front: each more accurate than every cheaper one."""
    out = []
    for t, e in sorted(points):
        if e > 0 and (not out or e < out[-1][1]):
            out.append((t, e))
    return out


def time_to(points: list[tuple[float, float]], target: float) -> float | None:
    """Time to reach `target` error: log-log interpolation on the front between the last
    point above it and the first at or below it; the first point when it is already below."""
    f = front(points)
    for i, (t, e) in enumerate(f):
        if e <= target:
            if i == 0:
                return t
            t0, e0 = f[i - 1]
            w = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return math.exp(math.log(t0) + w * (math.log(t) - math.log(t0)))
    return None


def series_times(rows: list[dict], target: float) -> dict[tuple[str, str], dict]:
    """Per (problem, series): time to target, the runs compared, the kind."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["problem"], r["series"]), []).append(r)
    out = {}
    for key, rs in groups.items():
        ok = [r for r in rs if r.get("status") == "ok" and r.get("final_error") is not None and r.get("seconds")]
        pts = [(r["seconds"], r["final_error"]) for r in ok]
        t = time_to(pts, target)
        cpu = time_to([(r["cpu_seconds"], r["final_error"]) for r in ok if r.get("cpu_seconds")], target)
        passing = [r for r in rs if r.get("status") == "ok" and r.get("final_error") is not None
                   and r["final_error"] <= target]
        best_pass = min(passing, key=lambda r: r["seconds"]) if passing else None
        out[key] = {"time": t, "cpu": cpu, "kind": rs[0]["kind"], "runs": len(rs), "compared": len(pts),
                    "beyond": sum(r.get("status") == "beyond trust horizon" for r in rs),
                    "failed": sum(r.get("status") == "failed" for r in rs),
                    "at": best_pass, "notes": sorted({r.get("note") or "" for r in rs} - {""})}
    return out


def best_toolkit(times: dict, problem: str) -> tuple[str, dict] | None:
    cands = [(s, v) for (p, s), v in times.items() if p == problem and v["kind"] == "toolkit"
             and v["time"] is not None]
    return min(cands, key=lambda kv: kv[1]["time"]) if cands else None


def targets(result: BenchResult) -> list[dict]:
    """The issue's targets (items 4 and 5), measured in this run."""
    opts = result.options
    times = series_times(result.rows, opts.target)
    out = []
    for prob in ("regular", "chaotic"):
        best = best_toolkit(times, prob)
        if best is None:
            continue
        name, b = best
        for peer, factor in ((IVP_DEFAULT, 200.0), (IVP_CSE, 200.0), ("hand-written C RK4", 3.0)):
            v = times.get((prob, peer))
            if v is None or v["time"] is None:
                continue
            ratio = v["time"] / b["time"]
            label = PEER_LABELS.get(peer, "")
            out.append({"what": f"{prob}: best toolkit ({name}) vs {peer}{label}",
                        "target": f">= {factor:g}x faster",
                        "measured": f"{ratio:.1f}x ({b['time'] * 1e3:.3g} ms vs {v['time'] * 1e3:.3g} ms)",
                        "met": ratio >= factor})
        at = b["at"]
        if at and at.get("overhead"):
            out.append({"what": f"{prob}: integrator overhead of {name} (run at {_knob(at)})",
                        "target": "<= 1.5 x (rhs evaluations x one rhs)",
                        "measured": f"{at['overhead']:.2f} x ({at['nfev']} evaluations x "
                                    f"{result.rhs_ns[prob]:.1f} ns = "
                                    f"{at['nfev'] * result.rhs_ns[prob] * 1e-6:.3g} ms; measured "
                                    f"{at['cpu_seconds'] * 1e3:.3g} ms CPU)",
                        "met": at["overhead"] <= 1.5})
    tp = [r for r in result.throughput if r["path"].startswith("generated C batch")]
    if tp:
        best = max(tp, key=lambda r: r["rate"])
        out.append({"what": "throughput: batched fixed-step RK4, planar", "target": ">= 5e7 trajectory-steps/s",
                    "measured": f"{best['rate']:.3g} (B = {best['batch']:.0e}, {best['threads']} threads)",
                    "met": best["rate"] >= 5e7})
    if result.agreement:
        a = result.agreement
        worst = max(a["c_max"], a["numpy_max"])
        out.append({"what": f"throughput: batch = scalar path ({a['n']} states, t = {a['t']:g})",
                    "target": "<= 1e-12", "measured": f"C {a['c_max']:.2g}, NumPy {a['numpy_max']:.2g}",
                    "met": worst <= 1e-12})
    gen = {r["batch"]: r["rate"] for r in result.throughput if r["path"].startswith("generated NumPy")}
    hand = {r["batch"]: r["rate"] for r in result.throughput if "hand-written vectorised NumPy" in r["path"]}
    for B in sorted(set(gen) & set(hand)):
        ratio = gen[B] / hand[B]
        noise = " -- a tie within run-to-run noise, not a win (both spend most of their time in " \
            "NumPy's float64 sin/cos)" if abs(ratio - 1) < 0.05 else ""
        out.append({"what": f"throughput: generated NumPy batch vs hand-written NumPy (B = {B:.0e})",
                    "target": "faster", "measured": f"{ratio:.2f}x ({gen[B]:.3g} vs {hand[B]:.3g}){noise}",
                    "met": ratio > 1 and not noise})
    return out


PEER_LABELS = {IVP_DEFAULT: " -- plain sympy.lambdify, cse=False",
               IVP_CSE: " -- stronger peer, common subexpressions eliminated"}


def _knob(r: dict) -> str:
    if r.get("rtol") is not None:
        return f"rtol {r['rtol']:.0e}"
    return f"h {r['step']:.3g}" if r.get("step") is not None else ""


# -- writers ---------------------------------------------------------------------------------

def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.6g}"
    return str(v)


def write_csv(result: BenchResult, path: Path) -> Path:
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for r in result.rows:
            w.writerow([_fmt(r.get(c)) for c in CSV_COLUMNS])
    return path


def write_throughput_csv(result: BenchResult, path: Path) -> Path:
    cols = ("path", "batch", "threads", "steps", "rate", "repeats", "note")
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in result.throughput:
            w.writerow([_fmt(r.get(c)) for c in cols])
    return path


def write_plots(result: BenchResult, out: Path) -> list[Path]:
    """One log-log work-precision plot (error against time) per problem; needs matplotlib."""
    try:
        import matplotlib    # the plot extra, imported when a figure is drawn
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt    # the plot extra, imported when a figure is drawn
    except ImportError:
        result.notes.append("matplotlib not installed: no plots (pip install derive[plot])")
        return []
    paths = []
    target = result.options.target if result.options else TARGET
    for name, info in result.infos.items():
        rows = [r for r in result.rows if r["problem"] == name and r.get("status") == "ok"
                and r.get("final_error") is not None and r.get("seconds")]
        if not rows:
            continue
        fig, ax = plt.subplots(figsize=(11, 6.5))
        series = sorted({r["series"] for r in rows}, key=lambda s: (rows_kind(rows, s) != "toolkit", s))
        peer_colors = plt.get_cmap("Set1")
        peers_seen = 0
        for s in series:
            pts = sorted((r["seconds"], max(r["final_error"], 1e-17)) for r in rows if r["series"] == s)
            if rows_kind(rows, s) == "peer":
                color = "black" if s.startswith("hand-written C") else peer_colors(peers_seen % 9)
                peers_seen += 1
                style = dict(ls="--", marker="s", color=color, lw=1.2)
                label = "peer: " + s
            else:
                method, backend, dtype = s.split()
                style = dict(ls=DTYPE_STYLE[dtype] if backend == "C" else "-",
                             marker={"C": "o", "NumPy": "^", "C-loop": "D"}[backend],
                             color=METHOD_COLOR.get(method, "gray"),
                             lw=2.0 if dtype == "float64" and backend != "NumPy" else 1.0,
                             alpha=0.6 if backend == "NumPy" else 1.0)
                label = s
            ax.loglog([t * 1e3 for t, _ in pts], [e for _, e in pts], ms=3.5, label=label, **style)
        ax.axhline(target, color="gray", lw=0.8)
        ax.axhline(max(info.reference.accuracy, 1e-17), color="gray", lw=0.5, ls=":")
        ax.set_xlabel("wall time per run (ms, median)")
        ax.set_ylabel("final-state error (max norm) vs long double reference")
        ax.set_title(f"{info.problem.title}\n(lambda = {info.lyapunov.exponent:.3g}; runs beyond their "
                     "trust horizon are not shown)", fontsize=9)
        ax.legend(fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        ax.grid(True, which="both", lw=0.3)
        ax.text(0.99, 0.01, f"{result.machine.get('cpu', '')}, {result.machine.get('nproc', '')} cores, "
                f"{result.machine.get('date', '')}", transform=ax.transAxes, ha="right", va="bottom", fontsize=6,
                color="gray")
        fig.tight_layout()
        path = out / f"work_precision_{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


METHOD_COLOR = {"rk4": "tab:blue", "dopri5": "tab:orange", "dop853": "tab:green", "midpoint": "tab:purple",
                "gauss2": "tab:brown", "rk8": "tab:cyan"}
DTYPE_STYLE = {"float64": "-", "float32": ":", "longdouble": "-."}


def rows_kind(rows, series) -> str:
    return next(r["kind"] for r in rows if r["series"] == series)


def _ms(t) -> str:
    return "not reached" if t is None else f"{t * 1e3:.3g}"


def summary_markdown(result: BenchResult, plots: list[Path] | None = None) -> str:
    opts = result.options or BenchOptions()
    m = result.machine
    times = series_times(result.rows, opts.target)
    lines = ["# Work-precision benchmark", "",
             f"Measured on {m.get('date')} on {m.get('cpu')} ({m.get('nproc')} cores), {m.get('platform')}; "
             f"Python {m.get('python')}, NumPy {m.get('numpy')}, SciPy {m.get('scipy')}, numba {m.get('numba')}, "
             f"SymPy {m.get('sympy')}; {m.get('compiler')}.  Load average when the run started: "
             f"{m.get('loadavg')} (the machine may be shared: timings are medians of repeats).",
             "", f"Command: `derive bench{' --quick' if opts.quick else ''} --repeats {opts.repeats}` "
             f"({result.seconds:.0f} s).  Every row of `bench.csv`: final-state error against the reference, "
             "largest relative energy error over 41 output times (peers: at t_end), median wall time, "
             "rhs evaluations, trust horizons.  Timings call the compiled integrators directly.", ""]
    for n in result.notes:
        lines.append(f"- Note: {n}")
    if result.notes:
        lines.append("")
    lines += ["## Problems, references and trust horizons", "",
              "| problem | model | t_end | largest Lyapunov exponent | e^(lambda t_end) | reference | "
              "stated accuracy | reference horizon (to 1e-10) |",
              "|---|---|---|---|---|---|---|---|"]
    for name, info in result.infos.items():
        lam = info.lyapunov.exponent
        lines.append(f"| {name} | {info.problem.model} | {info.problem.t_end:g} | {lam:.3g} "
                     f"({'variational' if 'variational' in info.lyapunov.method else 'finite difference'}) | "
                     f"{math.exp(max(lam, 0) * info.problem.t_end):.3g} | {info.reference.method} | "
                     f"{info.reference.accuracy:.2g} ({info.reference.check}) | "
                     f"{'covers' if info.reference_horizon >= info.problem.t_end else 'DOES NOT cover'} "
                     f"t_end ({_h(info.reference_horizon)}) |")
    for name, info in result.infos.items():
        if info.mpmath_error is not None:
            lines += ["", f"Independent check of the {name} reference: long double DOP853 against mpmath's "
                          f"Taylor solver (24 digits) at t = {info.mpmath_t:g}: difference {info.mpmath_error:.2g}."]
    lines += ["", f"A run's trust horizon is where its predicted error e0 exp(lambda t) reaches the target "
                  f"{opts.target:g} (e0: rtol or the per-step error of a fixed step, at least the unit roundoff, "
                  f"times the state's size).  Where the prediction reaches {opts.resolve:g} of the state's size "
                  "before t_end the run has decorrelated from the true trajectory: it is listed as `beyond "
                  "trust horizon` and its final state is not compared.", ""]
    lines += _horizon_table(result, opts)
    lines += ["", f"## Time to reach a final-state error of {opts.target:g}", "",
              "Interpolated (log-log) on each series' work-precision front; ratio = the series' time over the "
              "best toolkit method's.  Toolkit series are `method backend scalar`.", ""]
    for name in result.infos:
        best = best_toolkit(times, name)
        lines += [f"### {name}", ""]
        if best:
            lines.append(f"Best toolkit method: **{best[0]}**, {_ms(best[1]['time'])} ms.")
            lines.append("")
        lines += ["| kind | series | time to 1e-8 (ms, wall) | (ms, CPU) | x best toolkit | "
                  "runs compared / beyond horizon / failed |", "|---|---|---|---|---|---|"]
        entries = sorted(((s, v) for (p, s), v in times.items() if p == name and v["time"] is not None),
                         key=lambda kv: kv[1]["time"])
        for s, v in entries:
            ratio = "" if best is None else f"{v['time'] / best[1]['time']:.1f}"
            lines.append(f"| {v['kind']} | {s} | {_ms(v['time'])} | {_ms(v['cpu'])} | {ratio} | "
                         f"{v['compared']} / {v['beyond']} / {v['failed']} |")
        missing = sorted(((s, v) for (p, s), v in times.items() if p == name and v["time"] is None),
                         key=lambda kv: (kv[1]["kind"], kv[0]))
        if missing:
            lines += ["", f"Not reaching {opts.target:g} within their sweep (or only past their trust "
                      "horizon): " + "; ".join(_missing(s, v) for s, v in missing) + "."]
        lines.append("")
    lines += ["## Targets", "", "| what | target | measured | met |", "|---|---|---|---|"]
    for t in targets(result):
        lines.append(f"| {t['what']} | {t['target']} | {t['measured']} | {'yes' if t['met'] else '**no**'} |")
    lines += _issue_table(result, times)
    lines += ["", "Overhead = CPU time of the run / (rhs evaluations x CPU time of one generated C rhs "
              "evaluation, double, timed in a C loop over the states each problem visits, each "
              "evaluation waiting for the one before as in an integrator, median; derive/measurement/c/rhs_cost.c): "
              + ", ".join(f"{k} {v:.1f} ns" for k, v in result.rhs_ns.items()) + ".  Evaluations that "
              "do not wait for each other (the CPU overlaps them): "
              + ", ".join(f"{k} {v:.1f} ns" for k, v in result.rhs_ns_independent.items()) + "."]
    if result.throughput:
        lines += ["", "## Throughput: batched fixed-step RK4, planar", "",
                  "| path | trajectories | threads | steps | trajectory-steps/s | note |", "|---|---|---|---|---|---|"]
        for r in sorted(result.throughput, key=lambda r: -(r["rate"] if r["rate"] == r["rate"] else 0)):
            lines.append(f"| {r['path']} | {r['batch']:,} | {r['threads']} | {r['steps']} | {r['rate']:.3g} | "
                         f"{r['note']} |")
        if result.numpy_trig:
            t = result.numpy_trig
            lines += ["", f"NumPy float64 per element here (best of 50, 10,000 angles): sin {t['sin']:.2g} ns, "
                          f"cos {t['cos']:.2g} ns, tan {t['tan']:.2g} ns.  The generated NumPy code takes each "
                          "sin/cos pair from one tangent of the half angle and five array operations "
                          "(derive/codegen/emit.py, half_angle_sincos); the hand-written peer calls sin and cos."]
        a = result.agreement
        if a:
            lines += ["", f"Agreement with the scalar generated RK4 over {a['n']:,} random states, {a['steps']} "
                          f"steps (t = {a['t']:g}): C batch max difference {a['c_max']:.2g} ({a['c_over']} "
                          f"above 1e-12), NumPy batch {a['numpy_max']:.2g} ({a['numpy_over']} above 1e-12)."]
    if plots:
        lines += ["", "## Work-precision plots", ""]
        for p in plots:
            lines.append(f"![{p.stem}]({p.name})")
    return "\n".join(lines) + "\n"


def _issue_table(result: BenchResult, times: dict) -> list[str]:
    rows = [(p, peer, fig, times.get((p, peer))) for (p, peer), fig in ISSUE_FIGURES.items()
            if p in result.infos]
    if not rows:
        return []
    lines = ["", "Peer figures quoted in the issue beside this run's (time to 1e-8, ms), and the best toolkit "
                 "method's speed-up against each:", "",
             "| problem | peer | issue | this run | best toolkit vs issue figure | vs this run |",
             "|---|---|---|---|---|---|"]
    for p, peer, fig, v in rows:
        best = best_toolkit(times, p)
        here = v["time"] if v else None
        b = best[1]["time"] if best else None
        lines.append(f"| {p} | {peer} | {fig * 1e3:.3g} | {_ms(here)} | "
                     f"{'' if not b else f'{fig / b:.0f}x'} | {'' if not (b and here) else f'{here / b:.0f}x'} |")
    lines += _closest_lambdify(times, result)
    lines.append("")
    lines.append("Throughput peers quoted in the issue (trajectory-steps/s): "
                 + ", ".join(f"{k} {v:.2g}" for k, v in ISSUE_THROUGHPUT) + ".")
    return lines


def _closest_lambdify(times: dict, result: BenchResult) -> list[str]:
    """Which lambdify variant this run's figures are closer to the issue's (log ratio)."""
    out = []
    for prob, fig in ISSUE_LAMBDIFY.items():
        if prob not in result.infos:
            continue
        here = {s: (times.get((prob, s)) or {}).get("time") for s in (IVP_DEFAULT, IVP_CSE)}
        here = {s: t for s, t in here.items() if t}
        if not here:
            continue
        close = min(here, key=lambda s: abs(math.log(here[s] / fig)))
        out.append(f"{prob}: the issue's {fig * 1e3:.3g} ms for `solve_ivp DOP853 + lambdify` is closest to "
                   f"this run's `{close}` ({here[close] * 1e3:.3g} ms, the issue's figure {fig / here[close]:.2g}x it"
                   + "".join(f"; `{s}` {t * 1e3:.3g} ms" for s, t in here.items() if s != close) + ").")
    if out:
        out = ["", "The issue does not say how its lambdify peer was built; plain `sympy.lambdify` (the default, "
                   "cse=False) is what a user gets without asking, cse=True is the stronger peer.  Both are "
                   "measured and both are in the targets."] + [""] + [f"- {x}" for x in out]
    return out


def _missing(series: str, v: dict) -> str:
    extra = list(v["notes"])
    if v["beyond"]:
        extra.append(f"{v['beyond']} of {v['runs']} runs beyond the trust horizon")
    if v["failed"]:
        extra.append(f"{v['failed']} failed")
    return series + (f" ({'; '.join(extra)})" if extra else "")


def _h(t: float, bare: bool = False) -> str:
    if math.isinf(t):
        return "inf"
    return f"{t:.3g}" if bare else f"t = {t:.3g}"


HORIZON_RTOLS = (1e-3, 1e-5, 1e-8, 1e-11, 1e-13, 1e-16)


def _horizon_table(result: BenchResult, opts: BenchOptions) -> list[str]:
    """Trust horizons of the C dop853 runs: per problem and precision, at a few tolerances,
    `to the target / to resolve the trajectory`."""
    cells: dict[tuple[str, str], dict[float, str]] = {}
    runs = [r for r in result.rows if r["kind"] == "toolkit" and r["method"] == "dop853" and
            r["backend"] == "c" and r.get("horizon_target") is not None]
    wanted = set(HORIZON_RTOLS) & {r["rtol"] for r in runs} or {r["rtol"] for r in runs}
    for r in runs:
        if r["rtol"] in wanted:
            cells.setdefault((r["problem"], r["dtype"]), {})[r["rtol"]] = \
                f"{_h(r['horizon_target'], bare=True)} / {_h(r['horizon_resolve'], bare=True)}"
    if not cells:
        return []
    rtols = sorted(wanted, reverse=True)
    lines = [f"Trust horizons of dop853 (C) runs, `to {opts.target:g} / to resolve` (time units):", "",
             "| problem | scalar | " + " | ".join(f"rtol {t:.0e}" for t in rtols) + " |",
             "|---|---|" + "---|" * len(rtols)]
    for (prob, dtype), c in cells.items():
        lines.append(f"| {prob} | {dtype} | " + " | ".join(c.get(t, "") for t in rtols) + " |")
    return lines


def write_all(result: BenchResult, out: Path, plots: bool = True) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    files = [write_csv(result, out / "bench.csv")]
    if result.throughput:
        files.append(write_throughput_csv(result, out / "throughput.csv"))
    pngs = write_plots(result, out) if plots else []
    files += pngs
    md = out / "summary.md"
    md.write_text(summary_markdown(result, pngs))
    files.append(md)
    return files


def console_report(result: BenchResult) -> str:
    """What `derive bench` prints: time to target per problem with ratios, targets, throughput."""
    opts = result.options or BenchOptions()
    times = series_times(result.rows, opts.target)
    lines = []
    for n in result.notes:
        lines.append(f"note: {n}")
    for name, info in result.infos.items():
        best = best_toolkit(times, name)
        lines.append(f"{name}: lambda {info.lyapunov.exponent:.3g}, reference accuracy "
                     f"{info.reference.accuracy:.2g}; time to {opts.target:g}:")
        entries = sorted(((s, v) for (p, s), v in times.items() if p == name and v["time"] is not None),
                         key=lambda kv: kv[1]["time"])
        for s, v in entries:
            ratio = "" if best is None else f"  {v['time'] / best[1]['time']:7.1f}x best"
            lines.append(f"  {v['kind']:7s} {s:45s} {_ms(v['time']):>9s} ms{ratio}")
        missing = sorted(s for (p, s), v in times.items() if p == name and v["time"] is None)
        if missing:
            lines.append(f"  not reached: {', '.join(missing)}")
    lines.append("targets:")
    for t in targets(result):
        lines.append(f"  [{'met' if t['met'] else 'NOT met'}] {t['what']}: {t['measured']} (target {t['target']})")
    for r in result.throughput:
        lines.append(f"throughput {r['path']}: {r['rate']:.3g} trajectory-steps/s "
                     f"(B = {r['batch']:,}, {r['threads']} threads)")
    lines.append(f"bench finished in {result.seconds:.0f} s")
    return "\n".join(lines)
