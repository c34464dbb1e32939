"""How long does a chaotic trajectory stay trustworthy?

The largest Lyapunov exponent lambda comes from the variational equations
    delta' = J(y(t)) delta,
with J the generated Jacobian of rhs, evaluated in one batch call along a
reference trajectory (DOP853, tight tolerance, dense output at the midpoints
of a fine grid).  Each grid step propagates delta with the fourth-order Taylor
polynomial of exp(J(t_mid) dt) and renormalises it (Benettin's method); the
mean log growth rate is lambda.

An error e0 committed early grows like e0 exp(lambda t).  The trust horizon of
a run is the time where that reaches the accuracy the user asked for:
    t_trust = ln(target / e0) / lambda,
with e0 the larger of the integrator's tolerance and the precision's unit
roundoff (times the state's size).  Beyond t_trust the computed trajectory
no longer resolves the true one to `target`; benchmarks never compare there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from ..errors import InputError
from ..runtime import loader     # looked up at each call (a test checks which backend runs)
from ..runtime.simulate import (SimulationError, normalise_inputs, normalise_params, normalise_y0,
                                simulate)
from ..derivation.cartesian import cartesian_to_state, link_lengths
from ..model import load_model
from ..model.atlas import find_atlas, load_atlas
from ..runtime.extended import UNIT_ROUNDOFF
from ..codegen.contract import FIXED_ORDER, REFERENCE_METHOD

JACOBIAN_STEPS_PER_UNIT_TIME = 400
# The exponent is a property of the motion: measured over at most this much of a long run
# (400 Jacobians a unit of time), so the estimate of a run to t = 1e300 costs what one to
# t = 20 does, and never more memory than that.
MAX_WINDOW = 20.0
REFERENCE_RTOL = 1e-11     # the tolerance of the trajectory the exponent is measured along


@dataclass
class Lyapunov:
    exponent: float            # largest Lyapunov exponent (1/time units)
    t_end: float               # length of the trajectory it was measured on
    model: str
    method: str                # how it was computed
    steps_per_time: float | None = None   # DOP853 steps a unit of time at REFERENCE_RTOL (effort)
    requested: float | None = None        # the span asked for (t_end is at most MAX_WINDOW of it)

    @property
    def window_note(self) -> str:
        """Why the exponent was measured over less than the span asked for ("" when it was not)."""
        if self.requested is None or self.requested <= self.t_end:
            return ""
        return (f"measured over t = 0 to {self.t_end:g} of the {self.requested:g} asked: the exponent is "
                f"a property of the motion, and the window is bounded at {MAX_WINDOW:g} to bound its cost")

    def error_growth(self, t: float) -> float:
        """exp(lambda t), or inf where that overflows a double (no error survives it)."""
        x = max(self.exponent, 0.0) * t
        return math.exp(x) if x < 700 else math.inf


def _tangent_projections(model: str, kernels, args) -> np.ndarray | None:
    """A closed loop's orthogonal projections onto the tangent space of its states, the
    null space of G = d(Phi, J q')/dy, at each state of `args`; None for an open chain.
    Without them the variational vector would grow along directions off the constraints
    (which the index-1 equations let drift), not only along the motion's."""
    if not load_model(model).is_constrained:
        return None
    G = np.asarray(kernels.constraint_state_jacobian(*args[:2]), np.float64)
    eye = np.eye(G.shape[-1])
    return np.stack([eye - g.T @ np.linalg.solve(g @ g.T, g) for g in G])


def largest_lyapunov(model: str, y0, params, t_end: float, seed: int = 0, inputs=None,
                     backend: str = "c") -> Lyapunov:
    """lambda from the variational equations along y(t), t in [0, min(t_end, MAX_WINDOW)]
    (a model with run-time inputs: held at `inputs`); backend "numpy" needs no C compiler."""
    requested = float(t_end)
    t_end = min(requested, MAX_WINDOW)
    n = max(200, int(JACOBIAN_STEPS_PER_UNIT_TIME * t_end))
    grid = np.linspace(0.0, t_end, 2 * n + 1)
    run = simulate(model, y0, grid, params, method=REFERENCE_METHOD, rtol=REFERENCE_RTOL,
                   atol=REFERENCE_RTOL / 100, inputs=inputs, backend=backend)
    run.raise_for_status()
    p = normalise_params(model, params).astype(np.float64)
    args = (run.y[1::2].astype(np.float64), p)                        # at the midpoints
    if inputs is not None:
        args += (normalise_inputs(model, inputs).astype(np.float64),)
    kernels = loader.load(model) if backend == "c" else loader.numpy_module(model)
    jac = np.asarray(kernels.jacobian(*args), np.float64)
    on_loop = _tangent_projections(model, kernels, args)
    dt = t_end / n
    rng = np.random.default_rng(seed)
    delta = rng.standard_normal(run.y.shape[1])
    delta /= np.linalg.norm(delta)
    log_growth = 0.0
    for k, J in enumerate(jac):
        if on_loop is not None:       # a closed loop: off the constraints is no motion of it
            delta = on_loop[k] @ delta
            delta /= np.linalg.norm(delta)
        A = J * dt
        term = A @ delta
        step = delta + term
        for k in (2, 3, 4):                 # Taylor polynomial of exp(A) applied to delta
            term = A @ term / k
            step = step + term
        norm = float(np.linalg.norm(step))
        log_growth += math.log(norm)
        delta = step / norm
    return Lyapunov(log_growth / t_end, t_end, model, "variational equations, generated Jacobian",
                    steps_per_time=run.nsteps / t_end, requested=requested)


def atlas_lyapunov(y0, params, t_end: float, seed: int = 0, atlas: str = "spherical",
                   backend: str = "c") -> Lyapunov | None:
    """lambda of a run of a chart atlas (a spherical chain), in whichever single chart
    covers the whole trajectory (the exponent does not depend on the chart);
    None when every chart meets its singularity on the way."""
    p = normalise_params(atlas, params)
    c = normalise_y0(atlas, y0, p)[2]
    charts = load_atlas(atlas).charts
    lengths = link_lengths(charts[0], p)
    for chart in charts:
        start = cartesian_to_state(chart, c, lengths)
        try:
            return largest_lyapunov(chart, start, params, t_end, seed, backend=backend)
        except SimulationError:      # this chart's pole lies on the trajectory
            continue
    return None


def unit_roundoff(dtype) -> float:
    """eps of a precision of the ladder: a NumPy dtype, or 'double-double' or 'quad'."""
    if isinstance(dtype, str) and dtype in UNIT_ROUNDOFF:
        return UNIT_ROUNDOFF[dtype]
    return float(np.finfo(np.dtype(dtype)).eps)


def initial_error(rtol: float, dtype, state_scale: float) -> float:
    """The error a run commits early on: tolerance or unit roundoff, at the state's scale."""
    eps = unit_roundoff(dtype)
    return max(rtol, eps) * max(state_scale, 1.0)


def trust_horizon(lyapunov: Lyapunov, target: float, e0: float) -> float:
    """Time at which e0 exp(lambda t) reaches target (inf for lambda <= 0)."""
    if lyapunov.exponent <= 0:
        return math.inf
    if e0 >= target:
        return 0.0
    if not math.isfinite(lyapunov.exponent):
        return 0.0
    return math.log(target / e0) / lyapunov.exponent


# -- from a run's result (derive.runtime.result.SimulationResult) ----------------

def lyapunov_exponent(result) -> float | None:
    """Largest Lyapunov exponent of the motion of a run, over the run (variational
    equations with the generated Jacobian); None for an atlas run whose every chart
    meets its singularity.  Memoised on the result."""
    if "_lyapunov" not in result.__dict__:
        t_end = float(result.t[-1] - result.t[0])
        params = np.asarray(result.params, np.float64)
        backend = getattr(result, "backend", "c")         # a NumPy run's estimate needs no compiler
        if result.model == "spherical":
            est = atlas_lyapunov({"chart": result.chart[0], "state": list(result.y[0])}, params, t_end,
                                 backend=backend)
        else:
            est = largest_lyapunov(result.model, np.asarray(result.y[0], np.float64), params, t_end,
                                   backend=backend)
        result.__dict__["_lyapunov"] = None if est is None else est.exponent
    return result.__dict__["_lyapunov"]


def _check_trust_arguments(result, target) -> None:
    """One line for what no horizon can be measured of (a negative target gave t0, NaN gave NaN)."""
    if not all(hasattr(result, name) for name in ("model", "t", "y", "params", "rtol")):
        raise InputError(f"trust_horizon: result must be a run of derive.simulate, got {type(result).__name__}")
    if isinstance(target, bool) or not isinstance(target, (int, float, np.floating, np.integer)) \
            or not math.isfinite(target) or target <= 0:
        raise InputError(f"trust_horizon: target must be a positive number (the error to stay within), "
                         f"got {target!r}")
    if find_atlas(result.model) is None and load_model(result.model).is_time_dependent:
        raise InputError(f"trust_horizon: {result.model}: explicit time in the model: the Lyapunov estimate "
                         f"steps the variational equations with the generated Jacobian, which it evaluates "
                         f"without t; use error_estimate='rerun' in derive.simulate for the run's error instead")


def trust_horizon_of(result, target: float = 1e-8) -> float | None:
    """The time until which a run resolves the true motion to `target`.

    Parameters
    ----------
    result : SimulationResult
        A run of `derive.simulate`.
    target : float
        The error to stay within.

    Returns
    -------
    float or None
        The time at which the run's early error e0 (the tolerance, or h^order for a fixed
        step, at least the unit roundoff, times the state's size), growing like
        e0 exp(lambda t) with lambda the largest Lyapunov exponent, reaches `target`; None
        when no exponent can be estimated.

    Raises
    ------
    InputError
        `result` is not a run of derive.simulate, or `target` not a positive number.
    BuildError
        The variational equations of a C run need a model's compiled library, and it cannot
        be built (a NumPy run's estimate needs no compiler).

    Examples
    --------
    >>> import derive
    >>> r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 5.0], [1, 1, 1, 1, 9.81],
    ...                     rtol=1e-8, backend="numpy")
    >>> horizon = derive.trust_horizon(r, 1e-6)
    >>> 0.0 < horizon < derive.trust_horizon(r, 1e-3)     # a looser target is met for longer
    True
    >>> derive.trust_horizon(r, 0.0)
    Traceback (most recent call last):
    ...
    derive.errors.InputError: trust_horizon: target must be a positive number (the error to stay within), got 0.0
    """
    _check_trust_arguments(result, target)
    exponent = lyapunov_exponent(result)
    if exponent is None:
        result.__dict__.setdefault("_trust_horizons", {})[target] = None
        return None
    local = result.rtol if result.rtol is not None else (result.step or 0.0) ** FIXED_ORDER[result.method]
    dtype = np.dtype(np.longdouble) if result.dtype == "longdouble" else result.dtype
    e0 = initial_error(local, dtype, float(np.max(np.abs(np.asarray(result.y[0], float)))))
    lyap = Lyapunov(exponent, float(result.t[-1] - result.t[0]), result.model, "")
    horizon = float(result.t[0]) + trust_horizon(lyap, target, e0)
    # kept on the result, so its summary (SimulationResult._repr_html_) can show it
    result.__dict__.setdefault("_trust_horizons", {})[target] = horizon
    return horizon
