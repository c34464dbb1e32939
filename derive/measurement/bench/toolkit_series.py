"""The toolkit's configurations of a problem: its integrators and loops at their sweeps.

Toolkit series are `method backend scalar`: the generated integrators in C (`C`,
float32/float64/long double) and NumPy, and the generated single-trajectory fixed-step
loops (`C-loop`: rk4; rk8 = DOP853's 8th-order formula at a fixed step;
derive/codegen/loops.py).  abm12 (the 12-step Adams-Bashforth-Moulton pair, two rhs
evaluations a step) is timed as `simulate` runs it: the generated integrator (`C`) with
its stability guard at simulate's default rtol, which stops a step too large for the
motion (a failed row), not the loop, which has no guard.
The timed runs call the compiled code through toolkit.py (the integrators through the
run time's runner, the dispatch derive.simulate takes), as the peers are called, so the
argument checks and result object of derive.simulate are not in them; the untimed
observation run (energies) goes through derive.simulate.
"""
from __future__ import annotations

import math

import numpy as np

from . import toolkit
from .problems import (ADAPTIVE_RTOLS, FIXED_DIVISORS, GUARDED_DIVISORS, LOOP_DIVISORS, NUMPY_KNOBS, OBSERVATIONS,
                       QUICK_KNOBS, QUICK_LOOP_DIVISORS, BenchOptions, Config, Problem,
                       fixed_step, prepared, relative_energy_error)
from ...codegen.contract import ADAPTIVE, METHODS
from ...codegen.loops import evaluations, throughput_models
from ...runtime.simulate import simulate

BACKEND_LABEL = {"c": "C", "numpy": "NumPy", "c-loop": "C-loop"}


def _series(method: str, backend: str, dtype: str) -> str:
    return f"{method} {BACKEND_LABEL[backend]} {dtype}"


def _integrator_plan(opts: BenchOptions) -> list[tuple]:
    """(method, backend, dtype, knobs) of the integrator series: rtols or step divisors."""
    plan = []
    if opts.quick:
        for method, knobs in QUICK_KNOBS.items():
            plan.append((method, "c", "float64", knobs))
        plan.append(("dop853", "numpy", "float64", (1e-6,)))
        return plan
    for method in METHODS:
        if method in GUARDED_DIVISORS:
            plan.append((method, "c", "float64", GUARDED_DIVISORS[method]))
            continue
        if method not in ADAPTIVE and method not in FIXED_DIVISORS:
            continue        # rk8: measured as the fixed-step C loop (LOOP_DIVISORS)
        for dtype in ("float64", "float32", "longdouble"):
            knobs = ADAPTIVE_RTOLS[dtype] if method in ADAPTIVE else FIXED_DIVISORS[method]
            plan.append((method, "c", dtype, knobs))
        plan.append((method, "numpy", "float64", NUMPY_KNOBS[method]))
    return plan


def _loop_configs(problem: Problem, opts: BenchOptions) -> list[Config]:
    out = []
    for method, divs in (QUICK_LOOP_DIVISORS if opts.quick else LOOP_DIVISORS).items():
        for div in divs:
            step = fixed_step(problem, div)
            out.append(Config(problem, "toolkit", _series(method, "c-loop", "float64"), method, "c-loop",
                              "float64", None, step, loop_runner(problem, method, step),
                              loop_observer(problem, method, step)))
    return out


def toolkit_configs(problem: Problem, opts: BenchOptions) -> list[Config]:
    """The toolkit's configurations of `problem`: the fixed-step loops first (models that
    have them), then every integrator series at its sweep.

    Parameters
    ----------
    problem : Problem
    opts : BenchOptions
        `quick` selects the small sweep.

    Returns
    -------
    list of Config
    """
    loops = problem.model in throughput_models()
    out = _loop_configs(problem, opts) if loops else []
    for method, backend, dtype, knobs in _integrator_plan(opts):
        if method in GUARDED_DIVISORS and not loops:
            continue            # its local error (the trust horizon's e0) is measured on the loop
        for knob in knobs:
            rtol = knob if method in ADAPTIVE else None
            step = None if method in ADAPTIVE else fixed_step(problem, knob)
            out.append(Config(problem, "toolkit", _series(method, backend, dtype), method, backend, dtype,
                              rtol, step, toolkit_runner(problem, method, backend, dtype, rtol, step),
                              toolkit_observer(problem, method, backend, dtype, rtol, step)))
    return out


def loop_runner(problem: Problem, method: str, step: float):
    """The generated fixed-step loop (<model>_fixed_<method>): rhs inlined, no driver.

    Returns
    -------
    callable
        make() -> run; run() -> (final state, rhs evaluations, ok, message).
    """
    def make():
        loop = toolkit.loop_run(problem.model)
        state, _, p = prepared(problem)
        y0, pa = np.asarray(state, np.float64), np.asarray(p, np.float64)
        n = int(round(problem.t_end / step))
        nfev = evaluations(method, n)          # counted outside the timed call

        def run():
            y, done = loop(method, y0, pa, step, n)
            return y, nfev if done == n else evaluations(method, done), done == n, f"{done} of {n} steps"
        return run
    return make


def loop_observer(problem: Problem, method: str, step: float):
    """Energies of the loop's trajectory at the observation times (the loop, restarted in pieces).

    Returns
    -------
    callable
        observe() -> the largest relative energy error over OBSERVATIONS times.
    """
    def observe() -> float:
        loop = toolkit.loop_run(problem.model)
        state, _, p = prepared(problem)
        y, pa = np.asarray(state, np.float64), np.asarray(p, np.float64)
        per = int(round(problem.t_end / step)) // (OBSERVATIONS - 1)
        energy = toolkit.energy_of(problem)
        E = [energy(y)]
        for _ in range(OBSERVATIONS - 1):
            y, done = loop(method, y, pa, step, per)
            if done != per:
                return math.inf
            E.append(energy(y))
        return relative_energy_error(np.array(E), problem)
    return observe


def toolkit_runner(problem: Problem, method: str, backend: str, dtype: str, rtol, step):
    """A generated integrator on `problem` (toolkit.integrator_run, made when timing starts).

    Returns
    -------
    callable
        make() -> run; run() -> (comparison vector at t_end, rhs evaluations, ok, message).
    """
    return lambda: toolkit.integrator_run(problem, method, backend, dtype, rtol, step)


def toolkit_observer(problem: Problem, method: str, backend: str, dtype: str, rtol, step):
    """The same configuration through derive.simulate at the observation times.

    Returns
    -------
    callable
        observe() -> the largest relative energy error (inf for a failed run).
    """
    def observe() -> float:
        r = simulate(problem.model, problem.y0_input(), np.linspace(0.0, problem.t_end, OBSERVATIONS),
                     list(problem.params), method=method, rtol=rtol, atol=None if rtol is None else rtol * 1e-3,
                     step=step, dtype=dtype, backend=backend)
        return relative_energy_error(r.energy, problem) if r.ok else math.inf
    return observe
