"""High-precision references for the benchmark problems, each stating its own accuracy.

The reference is the generated DOP853 in long double (64-bit mantissa, unit
roundoff 5.4e-20) at rtol = RTOL (just above 10 eps, the tightest simulate
accepts) and atol = rtol * 1e-3.  Its accuracy is stated, not assumed:

* `accuracy`: the largest difference between that run and a second one at
  10 x looser tolerances (CHECK_FACTOR).  The tighter run is the more accurate
  of the two, so the difference bounds the looser run's error and, DOP853
  being of order 8, overstates the tighter one's; at least the rounding a run
  can accumulate (steps x unit roundoff x the state's size), which dominates
  over short spans where both runs agree to the last bits;
* `mpmath_check`: an independent spot check, the long double reference against
  mpmath's Taylor-series ODE solver (`mpmath.odefun`, 24 digits, the lambdified
  derivation) over a short span.

Comparisons use the state itself for planar and compound models and the 12
Cartesian numbers (x1, x2, v1, v2) for the spherical atlas, whose chart may
differ between two runs.  The trust horizon of the reference at its own
tolerance must cover t_end (the benchmark checks it with trust.py).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from ..derivation.cartesian import link_lengths, state_to_cartesian
from ..runtime.simulate import normalise_params, simulate
from ..codegen.contract import REFERENCE_METHOD
from .peers import derivation_rhs
import mpmath
import sympy as sp

RTOL = 1.1e-18          # >= 10 eps of long double (1.08e-18)
CHECK_FACTOR = 10.0
MPMATH_DPS = 24


@dataclass
class Reference:
    problem: str
    final: np.ndarray          # comparison vector at t_end (long double; Cartesian for spherical)
    accuracy: float            # stated accuracy (max-norm of the comparison vector)
    method: str
    check: str
    nfev: int
    seconds: float
    energy0: float = float("nan")
    extra: dict = field(default_factory=dict)


def comparison_vector(model: str, y, chart: str | None, params) -> np.ndarray:
    """What two runs of `model` are compared by: the state, or Cartesian (x1, x2, v1, v2)."""
    if model != "spherical":
        return np.asarray(y)
    return state_to_cartesian(chart, np.asarray(y, float), link_lengths(chart, params))


def _run(problem, rtol: float):
    r = simulate(problem.model, problem.y0_input(), [0.0, problem.t_end], problem.params,
                 method=REFERENCE_METHOD, rtol=rtol, atol=rtol * 1e-3, dtype="longdouble")
    r.raise_for_status()
    chart = r.chart_stop if problem.model == "spherical" else None
    return comparison_vector(problem.model, r.y[-1], chart, r.params), r


def compute(problem) -> Reference:
    """The reference of a benchmark problem (see derive/measurement/bench/problems.py, PROBLEMS)."""
    start = time.perf_counter()
    tight, run = _run(problem, RTOL)
    seconds = time.perf_counter() - start
    loose, _ = _run(problem, RTOL * CHECK_FACTOR)
    diff = float(np.max(np.abs(np.asarray(tight, np.longdouble) - np.asarray(loose, np.longdouble))))
    scale = max(float(np.max(np.abs(np.asarray(tight, float)))), 1.0)
    eps = float(np.finfo(np.float64 if problem.model == "spherical" else np.longdouble).eps)  # Cartesian: float64
    floor = max(run.nsteps * float(np.finfo(np.longdouble).eps), eps) * scale
    return Reference(
        problem=problem.name, final=np.asarray(tight), accuracy=max(diff, floor),
        method=f"dop853, long double, rtol {RTOL:.2g}, atol {RTOL * 1e-3:.2g}",
        check=f"difference to rtol {RTOL * CHECK_FACTOR:.2g}: {diff:.2g}",
        nfev=run.nfev, seconds=seconds, energy0=float(run.energy[0]))


def mpmath_check(problem, t: float, dps: int = MPMATH_DPS) -> float:
    """Max-norm difference between the long double reference and mpmath.odefun at time t
    (planar and compound problems: the lambdified derivation at `dps` digits)."""

    f = sp.lambdify(*derivation_rhs(problem.model), "mpmath", cse=True)
    p64 = normalise_params(problem.model, problem.params).astype(np.float64)
    with mpmath.workdps(dps):
        p = [mpmath.mpf(float(v)) for v in p64]           # the same binary numbers as the C run
        y0 = [mpmath.mpf(float(v)) for v in problem.y0]
        sol = mpmath.odefun(lambda _t, y: f(y, p), 0, y0)
        exact = [mpmath.nstr(v, dps) for v in sol(t)]
    r = simulate(problem.model, problem.y0, [0.0, t], p64, method=REFERENCE_METHOD, rtol=RTOL,
                 atol=RTOL * 1e-3, dtype="longdouble")
    r.raise_for_status()
    return float(np.max(np.abs(r.y[-1] - np.array([np.longdouble(s) for s in exact]))))
