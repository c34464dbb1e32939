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
commits that added this module have the figures).  The implicit methods and abm12 take
hold="zoh".

A time-dependent model (t in its forces, dissipation or pivot: issue 23 item 3) runs
here with inputs u(t, y); this loop passes each stage's time to the kernels that take it.
Otherwise it runs in the generated integrators (C or NumPy), which pass each stage's t
themselves.  A run's r.sol and its events are on
its own steps (stage_solution.py).
"""
from __future__ import annotations

import numpy as np

from ..codegen.contract import IMPLICIT, METHODS, MULTISTEP, STATUS, STATUS_NAMES
from ..codegen.tableau import load as load_tableau
from ..errors import SimulationInputError
from .loader import load, numpy_module
from .observables import _observables, _velocities, takes_time
from .result import LOCAL_SUM, SimulationResult
from .shared_library import EntryPoint
from .stage_solution import StageSolution, locate_on_steps

# the contract's explicit one-step methods: each stage is one rhs call at its own (t, y)
CONTINUOUS_METHODS = tuple(m for m in METHODS if m not in IMPLICIT and m not in MULTISTEP)
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


def _rhs_entry(kernel) -> EntryPoint:
    """The declaration of <model>_rhs: a pointer per array of the kernel (t first for a
    time-dependent model, y, p, u for one with inputs), then y'."""
    return EntryPoint("{model}_rhs", "int", ("void *",) * (len(kernel.inputs) + 1))


def _rhs(model: str, backend: str, p: np.ndarray, n: int):
    """rhs(t, y, u) -> y', p bound; t is passed where the kernel takes it, u where the
    model has inputs (None otherwise).  In C the kernel's own entry point on fixed
    buffers: the loader's general batch call (broadcasting, array checks) costs several
    times more."""
    if backend != "c":
        kernel = numpy_module(model).rhs
        timed = takes_time(kernel)

        def rhs_numpy(t, y, u):
            args = ((np.array([t]),) if timed else ()) + (y, p) + ((u,) if u is not None else ())
            return np.asarray(kernel(*args), np.float64)
        return rhs_numpy
    library = load(model)
    fn = library.bind(_rhs_entry(library.rhs), model=model)
    sizes = {"t": 1, "y": n, "p": len(p), "u": len(library.names.get("input_names", ()))}
    buffers = {name: np.empty(sizes[name]) for name, _ in library.rhs.inputs}
    buffers["p"][:] = p
    out = np.empty(n)
    # the addresses of the arrays and of y', taken once (arr.ctypes costs more than the
    # kernel); rhs reads `buffers`, so the closure keeps every buffer alive
    where = [buffers[name].ctypes.data for name, _ in library.rhs.inputs] + [out.ctypes.data]

    def rhs(t, y, u):
        buffers["y"][:] = y
        if "t" in buffers:
            buffers["t"][0] = t
        if u is not None:
            buffers["u"][:] = u
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
                   backend: str, u=None, events=(), project=None) -> SimulationResult:
    """One run stepped in Python with every stage at its own time, in float64 (simulate's
    checks have run): u(t, y) evaluated at every stage, and t passed to the kernels of a
    time-dependent model.

    Parameters
    ----------
    model : str
        A resolved model name (one chart).
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
    u : ContinuousInputs, ndarray or None
        The inputs' function (checked at each call), the inputs held over the run, or None
        (a model without inputs).
    events : tuple of Event
        Zero crossings to locate on the run's steps (derive/runtime/stage_solution.py).
    project : callable, optional
        y -> y on a closed loop's constraints, applied after every accepted step and to
        every output (derive/runtime/constraints.py): simulate(..., project=True).

    Returns
    -------
    SimulationResult
        As simulate's; r.sol(t) is one step of the method from the accepted step before t
        (stage_solution.StageSolution); the counters count this loop's steps and rhs calls.
    """
    if method not in CONTINUOUS_METHODS and project is not None and u is None:
        listed = f"{', '.join(CONTINUOUS_METHODS[:-1])} or {CONTINUOUS_METHODS[-1]}"
        raise SimulationInputError(f"project=True runs {listed} (stepped in "
                                   f"Python, projected after every step), not {method}")
    if method not in CONTINUOUS_METHODS:
        raise SimulationInputError(f"inputs as a function u(t, y) run {' or '.join(CONTINUOUS_METHODS)} "
                                   f"(explicit stages at their own times), not {method}; or give "
                                   f"hold='zoh' to hold them per output interval")
    rhs = _rhs(model, backend, np.asarray(p, np.float64), len(y0))
    counts = {"nfev": 0, "nsteps": 0, "naccepted": 0, "nrejected": 0}
    inputs = _inputs_at(u)

    def f(t, y):
        counts["nfev"] += 1
        return rhs(t, y, inputs(t, y))

    if project is None:
        def project(y):
            return y

    A, b, c, e, order = _tableau(method)
    ts64 = np.asarray(ts, np.float64)
    y = np.asarray(y0, np.float64).copy()
    out = np.full((len(ts64), len(y)), np.nan)
    out[0] = y
    starts: list = [(float(ts64[0]), y.copy())]          # each accepted step's (t, y): r.sol
    local_sum = 0.0
    if method in FIXED_TABLEAU:
        y, status = _fixed(f, A, b, c, ts64, y, float(opt["h"]), out, counts, starts, project)
    else:
        y, status, local_sum = _adaptive(method, f, A, b, c, e, order, ts64, y, opt, out, counts, starts,
                                         project)
    fixed = method in FIXED_TABLEAU
    reached = int(np.sum(np.isfinite(out[:, 0])))
    pd = np.asarray(p, np.float64)
    energy, positions = _observables(model, out[:reached], pd, backend, np.dtype(np.float64), ts64[:reached])
    velocities = _velocities(model, out[:reached], pd, backend, np.dtype(np.float64), ts64[:reached])

    def pad(a):
        return np.concatenate([a, np.full((len(ts64) - reached,) + a.shape[1:], np.nan)])

    result = SimulationResult(
        model=model, method=method, backend=backend, dtype="float64", t=ts64, y=out,
        energy=pad(energy), positions=pad(positions), velocities=pad(velocities), status=status,
        status_name=STATUS_NAMES[status], t_stop=float(ts64[reached - 1]), y_stop=out[reached - 1].copy(),
        njev=0, nnewton=0, params=pd, error_estimate=None if fixed else local_sum,
        error_kind=None if fixed else LOCAL_SUM,
        rtol=None if fixed else float(opt["rtol"]),
        step=float(opt["h"]) if method in FIXED_TABLEAU else None, **counts)
    step = (lambda t, y, h: project(_step(f, A, b, c, t, y, h)[0]))     # as the outputs are made
    result.sol = StageSolution(step, starts, float(ts64[0]), result.t_stop, pd, inputs)
    if events:
        result = locate_on_steps(result, events, float(opt.get("rtol") or 1e-10))
    return result


def _inputs_at(u):
    """u as a function of (t, y): the user's (checked), the held values, or None."""
    if u is None or callable(u):
        return u if u is not None else (lambda t, y: None)
    held = np.asarray(u, np.float64)
    return lambda t, y: held


def _fixed(f, A, b, c, ts, y, h, out, counts, starts, project):
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
            starts.append((t, y))
        rest = ts[j] - t
        out[j] = y if rest == 0 else project(_step(f, A, b, c, t, y, rest)[0])
        if not np.isfinite(out[j]).all():
            return y, STATUS["NONFINITE"]
    return y, STATUS["OK"]


def _adaptive(method, f, A, b, c, e, order, ts, y, opt, out, counts, starts, project):
    """dopri5 or dop853 with the usual step control (Hairer, Norsett, Wanner II.4): accept where the
    scaled error norm is <= 1, the next step h (0.9 err^(-1/order)) within [0.2, 10] h.  The
    steps do not depend on the output times (only the last ends on the last of them): an
    output inside an accepted step is one step of the method from that step's start (what
    r.sol gives there), as the generated integrators reach theirs by dense output.  So a
    finer output grid does not make a run more accurate than its tolerance asks (nor a
    reference run at a tighter one take the same steps)."""
    rtol, atol = float(opt["rtol"]), float(opt["atol"])
    direction = np.sign(ts[-1] - ts[0]) or 1.0
    t, t_end = ts[0], ts[-1]
    h = float(opt.get("h") or 0.0) or 1e-3 * max(abs(t_end - t), 1e-3)
    h = abs(h) * direction
    hmax = float(opt.get("hmax") or np.inf)
    max_steps, local_sum = int(opt["max_steps"]), 0.0
    K0 = f(t, y)
    j = 1
    while j < len(ts):
        if counts["nsteps"] >= max_steps:
            return y, STATUS["MAX_STEPS"], local_sum
        h = direction * min(abs(h), hmax, abs(t_end - t))
        y_new, K = _step(f, A, b, c, t, y, h, K0)
        scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
        err = _error_norm(method, e, K, h, scale)
        counts["nsteps"] += 1
        if not np.isfinite(err):
            return y, STATUS["NONFINITE"], local_sum
        if err <= 1.0:
            counts["naccepted"] += 1
            local_sum += err * float(np.max(scale))
            t_new = t_end if abs(t_end - t - h) <= 1e-14 * abs(t_end) + 1e-300 else t + h
            projected = project(y_new)        # a closed loop's step back onto its constraints
            while j < len(ts) and (ts[j] - t_new) * direction <= 0:      # the outputs this step passed
                out[j] = projected if ts[j] == t_new else project(_step(f, A, b, c, t, y, ts[j] - t)[0])
                j += 1
            # dopri5 is FSAL (its last stage is f at the new point, unless projected away
            # from it); dop853 evaluates it
            fsal = method == "dopri5" and projected is y_new
            t, y, K0 = t_new, projected, (K[-1] if fsal else f(t_new, projected))
            starts.append((t, y))
        else:
            counts["nrejected"] += 1
        h *= min(10.0, max(0.2, 0.9 * (err if err > 0 else 1e-10) ** (-1.0 / order)))
    return y, STATUS["OK"], local_sum
