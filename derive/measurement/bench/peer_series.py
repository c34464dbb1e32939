"""The peers' configurations of a problem: the tools of peers.py at their sweeps.

SciPy's solve_ivp (RK45, DOP853) with the two lambdified rhs of the derivation and (planar)
the hand-written one; odeint's LSODA; the hand-written C RK4 loop and numba's (planar).
On the spherical atlas the one peer is what a user without an atlas runs: solve_ivp on
the standard chart, which is singular at the pole the run starts from.
"""
from __future__ import annotations

import numpy as np

from .. import peers as P
from ..reference import comparison_vector
from . import toolkit
from .problems import PEER_DIVISORS, PEER_RTOLS, BenchOptions, Config, Problem, energy_scale, fixed_step, prepared
from ...derivation.cartesian import cartesian_to_state, link_lengths

# the two lambdify peers: plain `sympy.lambdify` (its default, cse=False) and the stronger
# one with common subexpressions eliminated (cse=True); see peers.lambdified_rhs
LAMBDIFY_DEFAULT = "lambdify (default)"
LAMBDIFY_CSE = "lambdify (cse=True)"
IVP_DEFAULT = f"solve_ivp DOP853 + {LAMBDIFY_DEFAULT}"
IVP_CSE = f"solve_ivp DOP853 + {LAMBDIFY_CSE}"
PEER_EVAL_BUDGET = 200_000      # a peer that needs more rhs evaluations than this has failed


def _ivp(problem: Problem, rhs_factory, method: str, rtol: float):
    y0, T, p = list(problem.y0), problem.t_end, tuple(problem.params)

    def make():
        rhs = rhs_factory()

        def run():
            from scipy.integrate import solve_ivp    # the bench extra: a peer
            sol = solve_ivp(rhs, (0.0, T), y0, method=method, rtol=rtol, atol=rtol * 1e-3, args=p)
            return sol.y[:, -1], sol.nfev, bool(sol.success), sol.message
        return run
    return make


def _lsoda(problem: Problem, rhs_factory, rtol: float):
    y0, T, p = list(problem.y0), problem.t_end, tuple(problem.params)

    def make():
        rhs = rhs_factory()

        def run():
            y, nfev = P.odeint_final(rhs, y0, T, p, rtol, rtol * 1e-3)
            return y, nfev, bool(np.all(np.isfinite(y))), ""
        return run
    return make


def _fixed(problem: Problem, loop_factory, step: float):
    n = int(round(problem.t_end / step))

    def make():
        loop = loop_factory()
        pa = np.asarray(tuple(problem.params), np.float64)
        y0a = np.asarray(list(problem.y0), np.float64)
        return lambda: (loop(y0a, pa, step, n), 4 * n, True, "")
    return make


def _ivp_configs(problem: Problem, quick: bool) -> list[Config]:
    rhs_kinds = [(LAMBDIFY_DEFAULT, lambda: P.lambdified_rhs(problem.model, cse=False)),
                 (LAMBDIFY_CSE, lambda: P.lambdified_rhs(problem.model, cse=True))]
    if problem.model == "planar" and not quick:
        rhs_kinds.append(("hand-written rhs", lambda: P.hand_numpy_rhs))
    out = []
    for label, factory in rhs_kinds:
        for method in (("DOP853",) if quick else ("RK45", "DOP853")):
            for rtol in ((1e-8, 1e-12) if quick else PEER_RTOLS[method]):
                out.append(_peer(problem, f"solve_ivp {method} + {label}", method, rtol, None,
                                 _ivp(problem, factory, method, rtol)))
    return out


def _lsoda_configs(problem: Problem) -> list[Config]:
    planar = problem.model == "planar"
    kinds = [("hand-written rhs", lambda: P.hand_numpy_rhs)] if planar else \
        [(LAMBDIFY_CSE, lambda: P.lambdified_rhs(problem.model, cse=True))]
    if planar and P.have_numba():
        kinds.append(("numba rhs", P.numba_rhs))
    return [_peer(problem, f"odeint LSODA + {label}", "LSODA", rtol, None, _lsoda(problem, factory, rtol))
            for label, factory in kinds for rtol in PEER_RTOLS["LSODA"]]


def _loop_configs(problem: Problem, quick: bool) -> list[Config]:
    loops = [("hand-written C RK4", P.hand_c_rk4, "c")]
    if not quick and P.have_numba():
        loops.append(("numba RK4", P.numba_rk4, "numba"))
    out = []
    for label, factory, backend in loops:
        for div in ((4, 64) if quick else PEER_DIVISORS):
            step = fixed_step(problem, div)
            out.append(_peer(problem, label, "rk4", None, step, _fixed(problem, factory, step), backend=backend))
    return out


def peer_configs(problem: Problem, opts: BenchOptions) -> list[Config]:
    """The peers of peers.py on a problem (hand-written rhs and compiled loops: planar only).

    Parameters
    ----------
    problem : Problem
    opts : BenchOptions
        `quick` selects the small sweep (and leaves out LSODA and numba).

    Returns
    -------
    list of Config
        Each observes the relative energy error of its final state.
    """
    if problem.model == "spherical":
        return [_peer(problem, "solve_ivp DOP853 + lambdify (standard chart)", "DOP853", 1e-8, None,
                      lambda: _standard_chart_peer(problem),
                      "the standard chart is singular at the pole the run starts from")]
    out = _ivp_configs(problem, opts.quick)
    if not opts.quick:
        out += _lsoda_configs(problem)
    if problem.model == "planar":
        out += _loop_configs(problem, opts.quick)
    energy, y0 = toolkit.energy_of(problem), list(problem.y0)
    for c in out:
        c.observe = (lambda e: lambda final: abs(e(final) - e(y0)) / energy_scale(problem, e(y0)))(energy)
    return out


def _peer(problem, series, method, rtol, step, make, note="", backend="python") -> Config:
    return Config(problem, "peer", series, method, backend, "float64", rtol, step, make, None, note)


class _GaveUp(Exception):
    pass


def _standard_chart_peer(problem: Problem):
    """What a user without an atlas runs: solve_ivp on the standard chart's lambdified rhs.
    It stops at the first non-finite derivative or after PEER_EVAL_BUDGET evaluations."""
    _, _, p = prepared(problem)
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
        return comparison_vector("spherical", sol.y[:, -1], "spherical_std", p), sol.nfev, True, ""
    return run
