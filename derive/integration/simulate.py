"""`derive.simulate`: run the generated integrators and say plainly whether to trust the result.

    r = simulate("planar", [1.0, 0.5, 0, 0], numpy.linspace(0, 10, 101),
                 {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}, method="dop853")
    r.t, r.y, r.energy, r.positions, r.status, r.ok, r.message, r.nfev

Models: planar, compound, spherical_std, spherical_alt, spherical_rot (one chart
each: the run stops with status 'chart singular' rather than evaluate a kernel
where a polar sine is below `sine_min`, default 0.1) and "spherical" (the chart
atlas: standard, second and rotated chart, switched by the rule of seed 000
section 5.1; see derive/integration/atlas.py for the thresholds).

Bad input raises SimulationInputError (a ValueError) with a one-line message.
A run that cannot go on returns a result whose `status` says why
(step-size underflow, max steps, Newton divergence, non-finite, chart singular),
`t_stop` where and `y_stop` in which state; outputs past that point are NaN.
"""
from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import SimulationError, SimulationInputError  # noqa: F401  (SimulationError: re-exported)
from ..model import ModelError, is_model_file, load_model
from ..model.description import parameter_problem
from . import cartesian
from .atlas import run_atlas
from .build import dtype_key, integrator_library
from .codegen import model_info
from .contract import (ADAPTIVE, ATLAS_CHARTS, COUNTERS, FIXED_ORDER,  # noqa: F401  (re-exported)
                       METHODS, SINE_MIN, STATUS_NAMES, default_options)
from .observables import _observables, _velocities, numpy_module  # noqa: F401  (re-exported)
from .result import SimulationResult  # noqa: F401  (re-exported)

from ..model.atlas import ATLAS  # noqa: E402  (the chart atlas of the double spherical pendulum)
_DTYPES = {"float32": np.float32, "float": np.float32, "single": np.float32,
           "float64": np.float64, "double": np.float64,
           "longdouble": np.longdouble, "long double": np.longdouble, "float128": np.longdouble}
_DEFAULT_RTOL = {"float32": 1e-5, "float64": 1e-9, "longdouble": 1e-12}


# -- input normalisation -----------------------------------------------------

def _dtype(dtype) -> np.dtype:
    key = dtype if isinstance(dtype, str) else np.dtype(dtype).name
    if key not in _DTYPES:
        raise SimulationInputError(f"unknown dtype {dtype!r} (use float32, float64 or longdouble)")
    return np.dtype(_DTYPES[key])


def _finite_array(value, what: str) -> np.ndarray:
    try:
        a = np.array(value, dtype=np.longdouble)
    except (TypeError, ValueError):
        raise SimulationInputError(f"{what} must be numbers, got {value!r}") from None
    if not np.all(np.isfinite(a)):
        raise SimulationInputError(f"{what} contains NaN or infinity: {np.asarray(value).tolist()}")
    return a


def resolve_model(model) -> str:
    """The name of a model argument: a catalogue name, a model file read before (by its
    name), the path of a model file, or 'spherical' (the chart atlas)."""
    if isinstance(model, os.PathLike) or (isinstance(model, str) and is_model_file(model)):
        try:
            return load_model(model).name
        except ModelError as exc:
            raise SimulationInputError(str(exc)) from None
    if not isinstance(model, str):
        raise SimulationInputError(f"model must be a name or the path of a model file, got {model!r}")
    if model == ATLAS:
        return model
    try:
        load_model(model)
    except ModelError as exc:
        raise SimulationInputError(f"{exc}; or '{ATLAS}' for the chart atlas") from None
    return model


def _described(model: str):
    """The model description behind a run (the atlas: its standard chart)."""
    return load_model("spherical_std" if model == ATLAS else model)


def normalise_params(model: str, params) -> np.ndarray:
    names = model_info("spherical_std" if model == "spherical" else model).param_names
    if isinstance(params, Mapping):
        unknown = sorted(set(params) - set(names))
        if unknown:
            raise SimulationInputError(f"unknown parameter '{unknown[0]}' for model '{model}' "
                                       f"(parameters: {', '.join(names)})")
        missing = [n for n in names if n not in params]
        if missing:
            raise SimulationInputError(f"missing parameter '{missing[0]}' for model '{model}' "
                                       f"(parameters: {', '.join(names)})")
        values = [params[n] for n in names]
    elif isinstance(params, (Sequence, np.ndarray)) and not isinstance(params, str):
        values = list(np.asarray(params).reshape(-1)) if isinstance(params, np.ndarray) else list(params)
        if len(values) != len(names):
            raise SimulationInputError(f"model '{model}' takes {len(names)} parameters "
                                       f"({', '.join(names)}), got {len(values)}")
    else:
        raise SimulationInputError(f"params must be a mapping by name or a sequence in the order "
                                   f"{', '.join(names)}, got {type(params).__name__}")
    p = _finite_array(values, "params")
    check_parameter_values(_described(model), dict(zip(names, p)), SimulationInputError)
    return p


def check_parameter_values(description, values: Mapping, error=SimulationInputError) -> None:
    """Lengths and masses > 0, inertias >= 0, fractions in [0, 1]; g and the other
    parameters (damping, ...) may be any finite number.  The roles come from the model."""
    problem = parameter_problem(description, values)
    if problem is not None:
        name, why = problem
        raise error(f"parameter {name} = {float(values[name]):g} {why}" if name else
                    f"model '{description.name}': {why}")


def normalise_inputs(model: str, inputs) -> np.ndarray | None:
    """The run-time inputs of a model, in its order (None for a model without inputs)."""
    names = load_model(model).inputs if model != ATLAS else ()
    if not names:
        if inputs is not None and len(inputs):
            raise SimulationInputError(f"model '{model}' has no inputs; got inputs={inputs!r}")
        return None
    if inputs is None:
        raise SimulationInputError(f"model '{model}' needs its inputs ({', '.join(names)}): give inputs=...")
    if callable(inputs):
        return HeldInputs(model, names, inputs)
    return _input_values(model, names, inputs)


class HeldInputs:
    """Inputs given as a function of t: sampled at each output time and held until the
    next (a zero-order hold, as a digital controller applies them); the run integrates
    each output interval with its inputs constant, so it is exact for that input."""

    def __init__(self, model: str, names, function):
        self.model, self.names, self.function = model, names, function

    def at(self, t: float) -> np.ndarray:
        try:
            value = self.function(float(t))
        except Exception as exc:       # the user's function failed: say where, in one line
            raise SimulationInputError(f"inputs({float(t):g}) raised {type(exc).__name__}: {exc}") from None
        return _input_values(self.model, self.names, value, f"inputs({float(t):g})")


def _input_values(model: str, names, inputs, what: str = "inputs") -> np.ndarray:
    if isinstance(inputs, Mapping):
        unknown = sorted(set(inputs) - set(names))
        if unknown:
            raise SimulationInputError(f"unknown input '{unknown[0]}' of model '{model}' (inputs: {', '.join(names)})")
        missing = [n for n in names if n not in inputs]
        if missing:
            raise SimulationInputError(f"missing input '{missing[0]}' of model '{model}' (inputs: {', '.join(names)})")
        values = [inputs[n] for n in names]
    else:
        values = list(np.asarray(inputs, dtype=object).reshape(-1))
        if len(values) != len(names):
            raise SimulationInputError(f"model '{model}' takes {len(names)} inputs ({', '.join(names)}), "
                                       f"got {len(values)} from {what}")
    for n, v in zip(names, values):       # a string such as "1" is no number (as in a scene)
        if isinstance(v, (bool, str, bytes)) or not isinstance(v, (int, float, np.number)):
            raise SimulationInputError(f"{what}: input {n} must be a number, got {v!r}")
    return _finite_array(values, what)


def _cartesian_y0(model: str, value, p: np.ndarray) -> np.ndarray:
    c = _finite_array(value, "y0['cartesian']").astype(np.float64).reshape(-1)
    if c.size != 12:
        raise SimulationInputError(f"y0['cartesian'] must have 12 numbers (x1, x2, v1, v2), got {c.size}")
    l1, l2 = float(p[2]), float(p[3])
    x1, x2, v1, v2 = c[0:3], c[3:6], c[6:9], c[9:12]
    d, w = x2 - x1, v2 - v1
    tol = 1e-8
    if abs(np.linalg.norm(x1) - l1) > tol * l1:
        raise SimulationInputError(f"y0['cartesian']: |x1| = {np.linalg.norm(x1):.12g} but l1 = {l1:.12g}")
    if abs(np.linalg.norm(d) - l2) > tol * l2:
        raise SimulationInputError(f"y0['cartesian']: |x2 - x1| = {np.linalg.norm(d):.12g} but l2 = {l2:.12g}")
    speed = max(np.linalg.norm(v1), np.linalg.norm(w), 1.0)
    if abs(x1 @ v1) > tol * l1 * speed or abs(d @ w) > tol * l2 * speed:
        raise SimulationInputError("y0['cartesian']: the velocities are not tangent to the links "
                                   "(x1.v1 and (x2-x1).(v2-v1) must vanish)")
    return c


def normalise_y0(model: str, y0, p: np.ndarray) -> tuple[np.ndarray, str | None, np.ndarray | None]:
    """(state, chart model, cartesian 12 or None).  For 'spherical' the chart is chosen."""
    spherical = model == "spherical" or model in ATLAS_CHARTS
    if isinstance(y0, Mapping):
        keys = set(y0)
        if not spherical:
            raise SimulationInputError(f"model '{model}' takes y0 as a sequence of "
                                       f"{model_info(model).n} numbers")
        if keys == {"cartesian"}:
            c12 = _cartesian_y0(model, y0["cartesian"], p)
        elif keys == {"chart", "state"} and y0["chart"] in ATLAS_CHARTS:
            s = _finite_array(y0["state"], "y0['state']").astype(np.float64).reshape(-1)
            if s.size != 8:
                raise SimulationInputError(f"y0['state'] must have 8 numbers, got {s.size}")
            c12 = cartesian.state_to_cartesian(y0["chart"], s, float(p[2]), float(p[3]))
        else:
            raise SimulationInputError("y0 as a mapping must be {'cartesian': [12 numbers]} or "
                                       f"{{'chart': one of {', '.join(ATLAS_CHARTS)}, 'state': [8 numbers]}}")
        chart = cartesian.choose_chart(c12, float(p[2]), float(p[3])) if model == "spherical" else model
        return cartesian.cartesian_to_state(chart, c12, float(p[2]), float(p[3])), chart, c12
    n = model_info("spherical_std" if model == "spherical" else model).n
    if isinstance(y0, str):
        raise SimulationInputError(f"y0 must be {n} numbers, got a string")
    a = _finite_array(y0, "y0").reshape(-1)
    if a.size != n:
        raise SimulationInputError(f"model '{model}' takes y0 with {n} numbers "
                                   f"({', '.join(model_info('spherical_std' if model == 'spherical' else model).state_names)}), got {a.size}")
    if model == "spherical":
        # a standard-chart state (exact at the poles too): through Cartesian coordinates
        c12 = cartesian.state_to_cartesian("spherical_std", a.astype(np.float64), float(p[2]), float(p[3]))
        chart = cartesian.choose_chart(c12, float(p[2]), float(p[3]))
        if chart == "spherical_std":
            return a, chart, c12
        return cartesian.cartesian_to_state(chart, c12, float(p[2]), float(p[3])), chart, c12
    return a, (model if spherical else None), None


def normalise_t(t) -> np.ndarray:
    if np.ndim(t) and np.size(t) * 16 * 8 > MAX_OUTPUT_BYTES:     # before any copy of it
        raise SimulationInputError(f"{np.size(t):,} output times are more than one run can hold "
                                   f"in {MAX_OUTPUT_BYTES / 2 ** 30:g} GiB: give fewer output times")
    a = _finite_array(t, "t").reshape(-1) if np.ndim(t) else None
    if a is None:
        raise SimulationInputError("t must be a sequence of output times (t[0] is the start)")
    if a.size < 1:
        raise SimulationInputError("t is empty: give at least the start time")
    if a.size > 1:
        dt = np.diff(a)
        if not (np.all(dt > 0) or np.all(dt < 0)):
            raise SimulationInputError("t must be strictly increasing or strictly decreasing")
    return a


# -- the entry point --------------------------------------------------------------

def simulate(model: str, y0, t, params, method: str = "dop853", rtol: float | None = None,
             atol: float | None = None, step: float | None = None, dtype="float64",
             backend: str = "c", max_steps: int | None = None, sine_min: float | None = None,
             newton_tol: float | None = None, newton_max: int | None = None,
             hmax: float | None = None, inputs=None) -> SimulationResult:
    """Integrate `model` from y0 at t[0] and report every output time in t.

    method: rk4, midpoint, gauss2 (fixed step: `step` required), dopri5, dop853
    (adaptive: rtol, atol; `step` is the initial step, optional).  dtype: float32,
    float64 or longdouble.  backend: "c" (compiled generated C) or "numpy".
    model: a catalogue name, the path of a model file, or "spherical" (the chart atlas).
    inputs: the model's run-time inputs: a mapping by name or a sequence in the model's
    order, held constant over the run; or a function of t returning one, sampled at each
    output time and held until the next (zero-order hold).
    """
    model = resolve_model(model)
    if not isinstance(method, str) or method not in METHODS:
        raise SimulationInputError(f"unknown method {method!r} (known: {', '.join(METHODS)})")
    if backend not in ("c", "numpy"):
        raise SimulationInputError(f"unknown backend {backend!r} (use 'c' or 'numpy')")
    dt = _dtype(dtype)
    eps = float(np.finfo(dt).eps)
    p = normalise_params(model, params)
    u = normalise_inputs(model, inputs)
    ts = normalise_t(t)
    state, chart, _ = normalise_y0(model, y0, p)
    _check_angles(model, state, dt)
    given = {"rtol": _DEFAULT_RTOL[dtype_key(dt)] if rtol is None else rtol, "atol": atol, "hmax": hmax,
             "max_steps": max_steps, "newton_tol": newton_tol, "newton_max": newton_max, "sine_min": sine_min}
    opt = {k: given[k] if given.get(k) is not None else v for k, v in default_options().items()}
    opt["atol"] = atol                       # None: from rtol below
    for key in ("rtol", "atol", "hmax", "newton_tol", "sine_min"):
        v = opt[key]
        if v is not None and (not isinstance(v, (int, float, np.floating)) or not np.isfinite(v) or v < 0):
            raise SimulationInputError(f"{key} = {v!r} must be a finite number >= 0")
    if opt["atol"] is None:
        opt["atol"] = opt["rtol"] * 1e-3
    if method in ADAPTIVE:
        if not 10 * eps <= opt["rtol"] < 1:
            raise SimulationInputError(f"rtol = {opt['rtol']:g} is outside [10 eps, 1) for {dtype_key(dt)} "
                                       f"(10 eps = {10 * eps:.3g})")
    elif step is None and ts.size > 1:
        raise SimulationInputError(f"method '{method}' has a fixed step: give step=...")
    if step is not None:            # the fixed step, or an adaptive method's initial step
        if not (isinstance(step, (int, float, np.floating)) and np.isfinite(step) and step > 0):
            raise SimulationInputError(f"step = {step!r} must be a positive finite number")
        opt["h"] = float(step)
    if not isinstance(opt["max_steps"], (int, np.integer)) or opt["max_steps"] < 1:
        raise SimulationInputError(f"max_steps = {opt['max_steps']!r} must be a positive integer")
    if not isinstance(opt["newton_max"], (int, np.integer)) or opt["newton_max"] < 1:
        raise SimulationInputError(f"newton_max = {opt['newton_max']!r} must be a positive integer")
    if not 0 <= opt["sine_min"] < 1:
        raise SimulationInputError(f"sine_min = {opt['sine_min']!r} must be in [0, 1)")
    if opt["atol"] == 0:
        # pure relative control has no error norm for a component that is exactly zero (a
        # pendulum at rest: 0/0, then every step rejected): atol = 0 is taken as 1e-20 rtol,
        # far below any state's unit, large enough for the initial-step estimate
        opt["atol"] = ATOL_FOR_ZERO * opt["rtol"]
    _check_size(method, ts, state, opt, dt)

    if model == "spherical":
        result = run_atlas(method, state, chart, ts, p, opt, dt, backend)
    elif isinstance(u, HeldInputs):
        result = _run_held(model, method, state, ts, p, opt, dt, backend, u)
    else:
        result = _run_single(model, method, state, ts, p, opt, dt, backend, u)
    if method in ADAPTIVE:
        result.rtol = opt["rtol"]
    else:
        result.step = opt["h"]
    return result


MAX_ANGLE_ULP = 1e-3             # radians: a coordinate rounded coarser than this cannot move


def _check_angles(model: str, state, dt: np.dtype) -> None:
    """Refuse a starting angle so large that its rounding is coarser than MAX_ANGLE_ULP: a
    step could not change it (theta = 1e300 stays 1e300 while its rate evolves), and the
    run would be silently wrong while meeting its relative tolerance."""
    if model == ATLAS:
        return                            # the atlas starts from Cartesian coordinates
    names = _described(model).coordinate_names
    for name, q in zip(names, np.asarray(state, np.longdouble)[:len(names)]):
        if abs(float(q)) * float(np.finfo(dt).eps) > MAX_ANGLE_ULP:
            raise SimulationInputError(f"y0: {name} = {float(q):g} rad is too large for {dtype_key(dt)} "
                                       f"(rounded to {abs(float(q)) * float(np.finfo(dt).eps):.2g} rad, a "
                                       f"step could not change it); reduce it modulo 2 pi")


ATOL_FOR_ZERO = 1e-20             # atol = 0 means atol = 1e-20 rtol (see simulate)
MAX_OUTPUT_BYTES = 2 ** 32         # 4 GiB of trajectory and observables for one run
MAX_FIXED_STEPS = 10 ** 10         # about an hour of the cheapest rhs: refused before any work


def _check_size(method: str, ts: np.ndarray, state, opt: dict, dt: np.dtype) -> None:
    """Refuse, with the figure, a run whose output would not fit in memory or whose
    fixed step (or largest step) means more steps than any run should take."""
    n = np.size(state)
    rows = len(ts) * (n + 1 + 4 * max(n // 2, 1))          # states, energy, positions, velocities
    nbytes = rows * np.dtype(dt).itemsize
    if nbytes > MAX_OUTPUT_BYTES:
        raise SimulationInputError(f"{len(ts):,} output times would need {nbytes / 2 ** 30:.3g} GiB "
                                   f"(limit {MAX_OUTPUT_BYTES / 2 ** 30:g} GiB): give fewer output times")
    span = float(abs(ts[-1] - ts[0])) if len(ts) > 1 else 0.0
    if not np.isfinite(span):
        raise SimulationInputError(f"the time span {ts[0]:g} to {ts[-1]:g} is not finite")
    h = opt["h"] if method not in ADAPTIVE else opt["hmax"]
    if h and span / h > MAX_FIXED_STEPS:
        what = "step" if method not in ADAPTIVE else "hmax"
        raise SimulationInputError(f"{what} = {h:g} over a span of {span:g} means {span / h:.3g} steps "
                                   f"(limit {MAX_FIXED_STEPS:.0e}): refused before any work")


def _run_held(model, method, y0, ts, p, opt, dt, backend, u: HeldInputs) -> SimulationResult:
    """One run per output interval, each with the inputs sampled at its start."""
    first = _run_single(model, method, y0, ts[:1], p, opt, dt, backend, u.at(ts[0]))
    parts, y = [first], first.y[-1]
    for a, b in zip(ts[:-1], ts[1:]):
        r = _run_single(model, method, y, np.array([a, b]), p, opt, dt, backend, u.at(a))
        parts.append(r)
        if not r.ok:
            break
        y = r.y[-1]
    last = parts[-1]
    n = len(ts)

    def rows(attr):
        got = np.concatenate([getattr(parts[0], attr)] + [getattr(r, attr)[1:] for r in parts[1:]])
        pad = np.full((n - len(got),) + got.shape[1:], np.nan, got.dtype)       # after a stop: NaN
        return np.concatenate([got, pad])

    out = SimulationResult(**{**last.__dict__, "t": np.asarray(ts, dt), "y": rows("y"), "energy": rows("energy"),
                              "positions": rows("positions"), "velocities": rows("velocities"),
                              "params": np.asarray(p, dt)})
    for k in COUNTERS:
        setattr(out, k, sum(getattr(r, k) for r in parts))
    return out


def _run_single(model, method, y0, ts, p, opt, dt, backend, u=None) -> SimulationResult:
    y0 = np.asarray(y0, dt)
    pd = np.asarray(p, dt)
    if u is not None and len(u):            # the integrators take p = (params, inputs)
        pd = np.concatenate([pd, np.asarray(u, dt)])
    tsd = np.asarray(ts, dt)
    if backend == "c":
        lib = integrator_library(model)
        o = lib.defaults()
        for k, v in opt.items():
            setattr(o, k, v)
        y, infos = lib.run(METHODS.index(method), y0[None, :], pd, tsd, o)
        y, inf = y[0], infos[0]
        counters = {k: int(getattr(inf, k)) for k in COUNTERS}
        status, t_stop, y_stop = int(inf.status), float(inf.t), np.array(inf.y[:])
    else:
        mod = numpy_module(f"{model}_integrate")
        status, y, inf = mod.integrate(method, y0, pd, tsd, dt, **opt)
        counters = {k: int(inf[k]) for k in COUNTERS}
        t_stop, y_stop = float(inf["t"]), np.asarray(inf["y"], float)
    E, pos = _observables(model, y, np.asarray(p, dt), backend, dt)
    vel = _velocities(model, y, np.asarray(p, dt), backend, dt)
    single_chart = model_info(model).nguards > 0     # a chart model: its chart at every output
    return SimulationResult(
        model=model, method=method, backend=backend, dtype=dtype_key(dt), t=np.asarray(ts, dt), y=y,
        energy=E, positions=pos, status=status, status_name=STATUS_NAMES[status], t_stop=t_stop,
        y_stop=y_stop, chart=np.array([model] * len(ts), dtype=object) if single_chart else None,
        switches=0, chart_stop=model if single_chart else None, params=np.asarray(p, dt), velocities=vel, **counters)
