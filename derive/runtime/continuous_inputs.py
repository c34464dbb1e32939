"""Inputs in continuous time: `simulate(..., inputs=u)` with u(t, y) evaluated at every
stage of the integrator, so a run's error follows its method's order whatever the
output grid (the zero-order hold, hold="zoh", keeps u constant per output interval).

The generated integrators take the inputs as constants of a run, so here the explicit
Runge-Kutta methods (rk4 and rk8 on the fixed grid t0 + k h, dopri5 and dop853
adaptive) step in a Python loop over their tableau (derive/codegen/tableaus), calling
the model's compiled rhs kernel (or its NumPy kernel) once per stage with
u(t_stage, y_stage).  Chosen over a ctypes callback from the generated C loop into
Python: that costs the same Python call per stage (the user's u is Python either way),
needs a callback slot in every generated integrator (changing each model's files) and
takes the GIL back at every stage.  A stage costs the Python loop, the user's function
and one direct call of <model>_rhs on buffers whose addresses are taken once (the
commits that added this module have the figures).  Such a run has no dense output
(r.sol is None), events or rerun estimate; the implicit methods and abm12 take
hold="zoh".
"""
from __future__ import annotations

import numpy as np

from ..codegen.contract import STATUS, STATUS_NAMES
from ..codegen.tableau import load as load_tableau
from ..errors import SimulationInputError
from ..model import load_model
from .loader import load, numpy_module
from .observables import _observables, _velocities
from .result import LOCAL_SUM, SimulationResult
from .shared_library import EntryPoint

CONTINUOUS_METHODS = ("rk4", "rk8", "dopri5", "dop853")     # explicit: a stage is one rhs call at (t, y)
FIXED_TABLEAU = {"rk4": "rk4", "rk8": "dop853"}   # rk8: DOP853's 8th-order formula at a fixed step


class ContinuousInputs:
    """u(t, y) of a run, checked at each call (a bad value is one line)."""

    def __init__(self, model: str, names, function, values):
        self.model, self.names, self.function, self.values = model, names, function, values

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        try:
            value = self.function(float(t), np.array(y, np.float64))
        except Exception as exc:       # the user's function failed: say where, in one line
            raise SimulationInputError(f"inputs({float(t):g}, y) raised {type(exc).__name__}: {exc}") from None
        if isinstance(value, (list, tuple, np.ndarray)):     # the common case, checked cheaply
            try:
                u = np.asarray(value, np.float64)
            except (TypeError, ValueError):
                u = None
            if u is not None and u.shape == (len(self.names),) and np.isfinite(u).all() and \
                    not any(isinstance(v, (bool, str, bytes, np.bool_)) for v in value):
                return u
        return np.asarray(self.values(self.model, self.names, value, f"inputs({float(t):g}, y)"), np.float64)


def _tableau(method: str):
    """(A, b, c, error weights, order) of a method's step, as float64 arrays; the error
    weights: dopri5's e (one row, over its 7 stages with FSAL), dop853's (e3, e5) rows
    (b - bhh and the 5th-order estimate over its 12), none for the fixed steps."""
    t = load_tableau(FIXED_TABLEAU.get(method, method))
    s = t.stages
    A = np.zeros((s, s))
    for (i, j), v in t.a.items():
        if i < s:                                 # rows past the step's stages: dense output
            A[i, j] = float(v)
    c = np.array([float(x) for x in t.c[:s]])
    b = np.array([float(x) for x in t.b[:s]])

    def row(weights, minus=None):
        out = np.zeros(s)
        for k, v in weights.items():
            out[k] = float(v)
        return out if minus is None else minus - out

    if method == "dopri5":
        e = row(t.extra["e"])[None, :]
    elif method == "dop853":
        e = np.array([row(t.extra["e3_minus"], b), row(t.extra["e5"])])
    else:
        e = None
    return A, b, c, e, t.order


def _error_norm(method: str, e, K, h: float, scale) -> float:
    """The step's scaled error norm (<= 1: accepted), as the generated integrators take it."""
    if method == "dopri5":
        return float(np.sqrt(np.mean((h * (e[0] @ K) / scale) ** 2)))
    e3 = float(np.sum(((e[0] @ K) / scale) ** 2))        # dop853 (Hairer's DOP853)
    e5 = float(np.sum(((e[1] @ K) / scale) ** 2))
    deno = e5 + 0.01 * e3
    return abs(h) * e5 / np.sqrt(len(scale) * (deno if deno > 0 else 1.0))


RHS = EntryPoint("{model}_rhs", "int", ("void *", "void *", "void *", "void *"))
RHS_WITHOUT_INPUTS = EntryPoint("{model}_rhs", "int", ("void *", "void *", "void *"))   # a loop run with project=True


def _rhs(model: str, backend: str, p: np.ndarray, n: int):
    """rhs(y, u) -> y', p bound.  In C the kernel's own entry point on fixed buffers: the
    loader's general batch call (broadcasting, array checks) costs several times more."""
    inputs = bool(load_model(model).inputs)
    if backend != "c":
        kernel = numpy_module(model).rhs
        if not inputs:
            return lambda y, u: np.asarray(kernel(y, p), np.float64)
        return lambda y, u: np.asarray(kernel(y, p, u), np.float64)
    fn = load(model).bind(RHS if inputs else RHS_WITHOUT_INPUTS, model=model)
    buffers = (np.empty(n), np.ascontiguousarray(p, np.float64),
               np.empty(len(load(model).names["input_names"]) if inputs else 0), np.empty(n))
    # the addresses of (y, p, u, y'), taken once (arr.ctypes costs more than the kernel);
    # rhs reads `buffers`, so the closure keeps every buffer alive
    where = [a.ctypes.data for a in buffers] if inputs else [a.ctypes.data for a in buffers[:2] + buffers[3:]]

    def rhs(y, u):
        state, _, inputs, out = buffers
        state[:], inputs[:] = y, u
        fn(*where)
        return out.copy()

    return rhs


def _step(f, A, b, c, t, y, h, K0=None):
    """One explicit RK step: (y_new, K)."""
    s = len(b)
    K = np.empty((s, len(y)))
    for i in range(s):
        if i == 0 and K0 is not None:
            K[0] = K0
            continue
        K[i] = f(t + c[i] * h, y + h * (A[i, :i] @ K[:i]))
    return y + h * (b @ K), K


def run_continuous(model: str, method: str, y0, ts: np.ndarray, p: np.ndarray, opt: dict,
                   backend: str, u: ContinuousInputs | None, project=None) -> SimulationResult:
    """One run with u(t, y) evaluated at every stage, in float64 (simulate's checks have run).

    Parameters
    ----------
    model : str
        A resolved model name (one chart, with inputs).
    method : str
        rk4, rk8 (fixed step opt["h"]), dopri5 or dop853 (opt["rtol"], opt["atol"]).
    y0 : array_like
        The initial state.
    ts : ndarray
        The output times, strictly monotone; ts[0] is the start.
    p : ndarray
        The parameters.
    opt : dict
        simulate's run options (run_options).
    backend : str
        "c" (the compiled rhs kernel) or "numpy".
    u : ContinuousInputs or None
        The inputs' function, checked at each call; None for a model without inputs (a
        closed loop run with `project`).
    project : callable, optional
        y -> y on a closed loop's constraints, applied after every accepted step and to
        every output (derive/runtime/constraints.py): simulate(..., project=True).

    Returns
    -------
    SimulationResult
        As simulate's; sol is None, the counters count this loop's steps and rhs calls.
    """
    if method not in CONTINUOUS_METHODS and u is None:
        listed = f"{', '.join(CONTINUOUS_METHODS[:-1])} or {CONTINUOUS_METHODS[-1]}"
        raise SimulationInputError(f"project=True runs {listed} (stepped in "
                                   f"Python, projected after every step), not {method}")
    if method not in CONTINUOUS_METHODS:
        raise SimulationInputError(f"inputs as a function u(t, y) run {' or '.join(CONTINUOUS_METHODS)} "
                                   f"(explicit stages at their own times), not {method}; or give "
                                   f"hold='zoh' to hold them per output interval")
    rhs = _rhs(model, backend, np.asarray(p, np.float64), len(y0))
    counts = {"nfev": 0, "nsteps": 0, "naccepted": 0, "nrejected": 0}

    none = np.zeros(0)

    def f(t, y):
        counts["nfev"] += 1
        return rhs(y, none if u is None else u(t, y))

    if project is None:
        def project(y):
            return y

    A, b, c, e, order = _tableau(method)
    ts64 = np.asarray(ts, np.float64)
    y = np.asarray(y0, np.float64).copy()
    out = np.full((len(ts64), len(y)), np.nan)
    out[0] = y
    status, local_sum = STATUS["OK"], 0.0
    if method in FIXED_TABLEAU:
        y, status = _fixed(f, A, b, c, ts64, y, float(opt["h"]), out, counts, project)
    else:
        y, status, local_sum = _adaptive(method, f, A, b, c, e, order, ts64, y, opt, out, counts, project)
    fixed = method in FIXED_TABLEAU
    reached = int(np.sum(np.isfinite(out[:, 0])))
    pd = np.asarray(p, np.float64)
    energy, positions = _observables(model, out[:reached], pd, backend, np.dtype(np.float64))
    velocities = _velocities(model, out[:reached], pd, backend, np.dtype(np.float64))

    def pad(a):
        return np.concatenate([a, np.full((len(ts64) - reached,) + a.shape[1:], np.nan)])

    return SimulationResult(
        model=model, method=method, backend=backend, dtype="float64", t=ts64, y=out,
        energy=pad(energy), positions=pad(positions), velocities=pad(velocities), status=status,
        status_name=STATUS_NAMES[status], t_stop=float(ts64[reached - 1]), y_stop=out[reached - 1].copy(),
        njev=0, nnewton=0, params=pd, error_estimate=None if fixed else local_sum,
        error_kind=None if fixed else LOCAL_SUM,
        rtol=None if fixed else float(opt["rtol"]),
        step=float(opt["h"]) if method in FIXED_TABLEAU else None, **counts)


def _fixed(f, A, b, c, ts, y, h, out, counts, project):
    """The grid t0 + k h; an output between grid points by a shortened step from the grid
    point before it (as the generated fixed-step loop does)."""
    t0, direction = ts[0], np.sign(ts[-1] - ts[0]) or 1.0
    h = abs(h) * direction
    k, t = 0, t0
    for j in range(1, len(ts)):
        while (t0 + (k + 1) * h - ts[j]) * direction <= 0:
            y = project(_step(f, A, b, c, t, y, h)[0])
            k += 1
            t = t0 + k * h
            counts["nsteps"] += 1
            counts["naccepted"] += 1
        rest = ts[j] - t
        out[j] = y if rest == 0 else project(_step(f, A, b, c, t, y, rest)[0])
        if not np.isfinite(out[j]).all():
            return y, STATUS["NONFINITE"]
    return y, STATUS["OK"]


def _adaptive(method, f, A, b, c, e, order, ts, y, opt, out, counts, project):
    """dopri5 or dop853 with the usual step control (Hairer, Norsett, Wanner II.4): accept where the
    scaled error norm is <= 1, the next step h (0.9 err^(-1/order)) within [0.2, 10] h;
    each output reached by a step that ends on it; `project` applied to each accepted step."""
    rtol, atol = float(opt["rtol"]), float(opt["atol"])
    direction = np.sign(ts[-1] - ts[0]) or 1.0
    t = ts[0]
    h = float(opt.get("h") or 0.0) or 1e-3 * max(abs(ts[-1] - ts[0]), 1e-3)
    h = abs(h) * direction
    hmax = float(opt.get("hmax") or np.inf)
    max_steps, local_sum = int(opt["max_steps"]), 0.0
    K0 = f(t, y)
    for j in range(1, len(ts)):
        while (ts[j] - t) * direction > 0:
            if counts["nsteps"] >= max_steps:
                return y, STATUS["MAX_STEPS"], local_sum
            h = direction * min(abs(h), hmax, abs(ts[j] - t))
            y_new, K = _step(f, A, b, c, t, y, h, K0)
            scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
            err = _error_norm(method, e, K, h, scale)
            counts["nsteps"] += 1
            if not np.isfinite(err):
                return y, STATUS["NONFINITE"], local_sum
            if err <= 1.0:
                counts["naccepted"] += 1
                local_sum += err * float(np.max(scale))
                t = ts[j] if abs(ts[j] - t - h) <= 1e-14 * abs(ts[j]) + 1e-300 else t + h
                # dopri5 is FSAL (its last stage is f at the new point, unless projected away
                # from it); dop853 evaluates it
                projected = project(y_new)
                fsal = method == "dopri5" and projected is y_new
                y, K0 = projected, (K[-1] if fsal else f(t, projected))
            else:
                counts["nrejected"] += 1
            h *= min(10.0, max(0.2, 0.9 * (err if err > 0 else 1e-10) ** (-1.0 / order)))
        out[j] = y
    return y, STATUS["OK"], local_sum
