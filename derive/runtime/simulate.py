"""`derive.simulate`: run the generated integrators and say plainly whether to trust the result.

    r = simulate("planar", [1.0, 0.5, 0, 0], numpy.linspace(0, 10, 101),
                 {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}, method="dop853")
    r.t, r.y, r.energy, r.positions, r.status, r.ok, r.message, r.nfev
    r.error_estimate, r.error_kind      (the run's own error estimate: result.py)

Models: planar, compound, spherical_std, spherical_alt, spherical_rot (one chart
each: the run stops with status 'chart singular' rather than evaluate a kernel
where a polar sine is below `sine_min`, default 0.1) and "spherical" (the chart
atlas: standard, second and rotated chart, switched by the rule of seed 000
section 5.1; see derive/runtime/atlas_runner.py for the thresholds).

Bad input raises SimulationInputError (a ValueError) with a one-line message.
A run that cannot go on returns a result whose `status` says why
(step-size underflow, max steps, Newton divergence, non-finite, chart singular),
`t_stop` where and `y_stop` in which state; outputs past that point are NaN.
"""
from __future__ import annotations

import ctypes
import math
import os
import signal
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache, partial

import numpy as np

from ..errors import SimulationError, SimulationInputError  # noqa: F401  (SimulationError: re-exported)
from ..model import Model, ModelError, is_model_file, load_model
from ..model.description import forget_on_model_change, parameter_problem
from ..derivation import cartesian
from . import dense
from . import events as events_module
from .atlas_runner import run_atlas
from .build import dtype_key
from .model_sizes import model_info
from ..codegen.integrators import ModelInfo
from ..codegen.contract import METHODS, STATUS_NAMES  # noqa: F401  (re-exported: the contract's tables)
from ..codegen.contract import (ADAPTIVE, ATLAS_METHODS, COUNTERS, DEFAULT_METHOD, FIXED_ORDER, PRECISION,
                                MULTISTEP, PRECISION_NAMES, PRECISION_TABLE, RUN_METHODS, STATUS, TAYLOR,
                                TOLERANCE_METHODS, default_options)
from .observables import _observables, _velocities, numpy_module  # noqa: F401  (re-exported)
from .fast_path import CHECKED_MAX, SETTINGS_MAX, NotPlanned, RunPlan, plain_times
from .runner import Settings, runner_for
from .taylor_solution import TaylorSolution
from . import constraints, continuous_inputs, extended, extended_run
from . import compiled_call
from . import specialised
from .result import LAZY, LOCAL_SUM, LazySolution, SimulationResult, as_fields  # noqa: F401  (SimulationResult: re-exported)

from ..model.atlas import ATLAS, Atlas, atlas_family, atlas_for, find_atlas  # noqa: E402  (chart atlases)
# the rungs of the precision ladder the RK methods compute in: every name of each
# (the contract's table) -> its NumPy type, and simulate's default tolerance in each
_DTYPES = {name: np.dtype(key).type for name, key in PRECISION_NAMES.items()
           if not PRECISION[key].taylor_only}
_DEFAULT_RTOL = {p.key: p.default_rtol for p in PRECISION_TABLE if not p.taylor_only}
_DEFAULT_OPTIONS = default_options()
MAX_STEPS_STATUS = STATUS["MAX_STEPS"]      # a run that stopped at its step budget


# -- input normalisation -----------------------------------------------------

def _dtype(dtype) -> np.dtype:
    key = dtype if isinstance(dtype, str) else np.dtype(dtype).name
    if key not in _DTYPES:
        raise SimulationInputError(f"unknown dtype {dtype!r} (use float32, float64 or longdouble)")
    return np.dtype(_DTYPES[key])


def _first_text(value):
    """The first string among the numbers of `value` (nested sequences or an array), or None:
    NumPy would read "9.81" as 9.81, a scene file refuses it, and so does a call."""
    if isinstance(value, (str, bytes)):
        return value
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "SU":
            return value.flat[0] if value.size else None
        if value.dtype.kind != "O":
            return None
        value = value.ravel().tolist()
    if isinstance(value, (list, tuple)):
        for x in value:
            text = _first_text(x)
            if text is not None:
                return text
    return None


def _decimals_as_floats(value):
    """`value` with every string in it read as a float (nested mappings and sequences): what
    the checks of an extended-precision run see, where a string is an exact decimal.  A
    string that is no number stays, for the checks to name it."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    if isinstance(value, Mapping):
        return {k: _decimals_as_floats(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_decimals_as_floats(v) for v in value]
    if isinstance(value, np.ndarray) and value.dtype.kind in "OSU":
        return [_decimals_as_floats(v) for v in value.tolist()]
    return value


def _finite_array(value, what: str) -> np.ndarray:
    text = _first_text(value)
    if text is not None:
        raise SimulationInputError(f"{what} must be numbers, got the string {text!r}")
    try:
        a = np.array(value, dtype=np.longdouble)
    except (TypeError, ValueError):
        raise SimulationInputError(f"{what} must be numbers, got {value!r}") from None
    if not np.isfinite(a).all():
        raise SimulationInputError(f"{what} contains NaN or infinity: {np.asarray(value).tolist()}")
    return a


def resolve_model(model, atlas: bool = False, explicit_time: bool = False, stage: str | None = None) -> str:
    """The name of a model argument: a catalogue name, a model file read before (by its
    name), the path of a model file, or 'spherical' (the chart atlas).  With atlas=True,
    the key of the model's chart atlas (a spherical chain's: '<name>_atlas').  A
    time-dependent model is refused unless explicit_time (a caller that passes t); `stage`
    names the caller in that refusal."""
    if isinstance(model, os.PathLike) or (isinstance(model, str) and is_model_file(model)):
        try:
            name = load_model(model).name
        except ModelError as exc:
            raise SimulationInputError(str(exc)) from None
    elif not isinstance(model, str):
        raise SimulationInputError(f"model must be a name or the path of a model file, got {model!r}")
    elif find_atlas(model) is not None:
        return model
    else:
        try:
            name = load_model(model).name
        except ModelError as exc:
            raise SimulationInputError(f"{exc}; or '{ATLAS}' for the chart atlas") from None
    if not explicit_time:
        refuse_explicit_time(load_model(name), stage or ("the chart atlas" if atlas else "this stage"))
    if not atlas:
        return name
    try:
        return atlas_for(name).name
    except ModelError as exc:
        raise SimulationInputError(f"atlas=True: {exc}") from None


# what runs a time-dependent model: the refusals of the stages that do not pass t say so
TIMED_RUNS = ("derive.simulate or derive.ensemble of the single-chart model (every method, each stage "
              "at its own time t) or derive.scipy_rhs with solve_ivp")


def refuse_explicit_time(model: Model, stage: str = "this stage") -> None:
    """Refuse, in one line naming why and what runs it instead, to run a time-dependent
    model where `stage` (ensembles, the atlas, ...) does not pass the time t to its kernels."""
    if model.is_time_dependent:
        raise SimulationInputError(
            f"{model.name}: explicit time in the model (t in its forces, dissipation or pivot): "
            f"{stage} does not pass t to its kernels; use {TIMED_RUNS}")


def _check_timed(ref, method: str, dt: np.dtype) -> None:
    """What a time-dependent model's run with inputs u(t, y) at every stage takes (it steps
    in Python): an explicit one-step method, each stage at its own t, in float64.  The
    generated integrators run every method, with hold='zoh'."""
    why = (f"{ref.name}: explicit time in the model (t in its forces, dissipation or pivot) with inputs "
           f"u(t, y) at every stage, stepped in Python")
    if method not in continuous_inputs.CONTINUOUS_METHODS:
        raise SimulationInputError(f"{why}: method {method} is not one of "
                                   f"{', '.join(continuous_inputs.CONTINUOUS_METHODS)}; hold='zoh' runs it")
    if np.dtype(dt) != np.float64:
        raise SimulationInputError(f"{why}: it runs in float64, not {np.dtype(dt).name}; hold='zoh' runs it")


@dataclass(frozen=True, eq=False)
class ModelRef:
    """A resolved run name and what a run reads of it, looked up once (model_ref) and
    passed down; formats as its name, so a message reads the same with a name or a ref."""
    name: str
    atlas: Atlas | None          # the chart atlas the name stands for, or None (a single model)
    standard: str                # whose description, parameters and state order a run takes
    description: Model           # the standard model's
    info: ModelInfo              # the standard model's sizes and names

    def __str__(self) -> str:
        return self.name

    def __format__(self, spec: str) -> str:
        return format(self.name, spec)


@forget_on_model_change
@lru_cache(maxsize=256)
def model_ref(name: str) -> ModelRef:
    """The ModelRef of a resolved name (resolve_model's)."""
    atlas = find_atlas(name)
    standard = atlas.charts[0] if atlas is not None else name
    return ModelRef(name, atlas, standard, load_model(standard), model_info(standard))


def _ref(model) -> ModelRef:
    return model if isinstance(model, ModelRef) else model_ref(model)


def _atlas(model):
    """The atlas a run name stands for, or None (a single model)."""
    return _ref(model).atlas


def _standard(model) -> str:
    """The model whose description, parameters and state order a run takes (an atlas: its
    standard chart)."""
    return _ref(model).standard


def _described(model):
    """The model description behind a run (an atlas: its standard chart)."""
    return _ref(model).description


def normalise_params(model, params) -> np.ndarray:
    names = _ref(model).info.param_names
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
    for n, v in zip(names, values):       # a string such as "9.81" is no number (as in a scene)
        if isinstance(v, (bool, str, bytes)):
            raise SimulationInputError(f"parameter {n} must be a number, got {type(v).__name__} {v!r}")
    p = _finite_array(values, "params")
    described = _described(model)
    key = (described.content_hash, tuple(p.tolist()))
    if key not in _POSSIBLE:            # checked once per parameter vector and model text
        check_parameter_values(described, dict(zip(names, p)), SimulationInputError)
        if len(_POSSIBLE) > 4096:
            _POSSIBLE.clear()
        _POSSIBLE.add(key)
    return p


_POSSIBLE: set = set()       # (model hash, parameter values) that passed check_parameter_values


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
    names = _described(model).inputs
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
    """Inputs given as a function u(t, y), sampled at each output time (with the state
    there) and held until the next (hold="zoh": a zero-order hold, as a digital controller
    applies them); the run integrates each output interval with its inputs constant, so
    it is exact for that input.  (Without hold, simulate evaluates u at every stage:
    derive/runtime/continuous_inputs.py.)"""

    def __init__(self, model: str, names, function):
        self.model, self.names, self.function = model, names, function

    def at(self, t: float, y) -> np.ndarray:
        try:
            value = self.function(float(t), np.array(y, np.float64))
        except Exception as exc:       # the user's function failed: say where, in one line
            raise SimulationInputError(f"inputs({float(t):g}, y) raised {type(exc).__name__}: {exc}") from None
        return _input_values(self.model, self.names, value, f"inputs({float(t):g}, y)")


HOLDS = (None, "zoh")        # hold=: None, inputs u(t, y) at every stage; "zoh", per output interval


def _check_hold(hold, u, dtype) -> None:
    if hold not in HOLDS:
        raise SimulationInputError(f"unknown hold {hold!r} (None: inputs u(t, y) at every stage; "
                                   f"'zoh': held per output interval)")
    if hold is None and isinstance(u, HeldInputs) and np.dtype(_dtype(dtype)) != np.float64:
        raise SimulationInputError("inputs u(t, y) at every stage run in float64; give hold='zoh' "
                                   f"for dtype {dtype}")


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
    """{'cartesian': [...]}: the positions of every bob, then their velocities (2 N d
    numbers), checked against the links' lengths (from the description) and tangency."""
    description = _described(model)
    lengths = cartesian.link_lengths(description.name, p)
    d, n = description.dimension, len(lengths)
    c = _finite_array(value, "y0['cartesian']").astype(np.float64).reshape(-1)
    if c.size != 2 * n * d:
        raise SimulationInputError(f"y0['cartesian'] must have {2 * n * d} numbers (the {n} bobs' "
                                   f"positions, then their velocities), got {c.size}")
    x = np.vstack([np.zeros(d), c[:n * d].reshape(n, d)])
    v = np.vstack([np.zeros(d), c[n * d:].reshape(n, d)])
    tol = 1e-8
    for i, length in enumerate(lengths, 1):
        link, rate = x[i] - x[i - 1], v[i] - v[i - 1]
        if abs(np.linalg.norm(link) - length) > tol * length:
            raise SimulationInputError(f"y0['cartesian']: |x{i} - x{i - 1}| = {np.linalg.norm(link):.12g} "
                                       f"but link {i}'s length is {length:.12g}" if i > 1 else
                                       f"y0['cartesian']: |x1| = {np.linalg.norm(link):.12g} but link 1's "
                                       f"length is {length:.12g}")
        if abs(link @ rate) > tol * length * max(np.linalg.norm(rate), 1.0):
            raise SimulationInputError(f"y0['cartesian']: the velocities are not tangent to the links "
                                       f"((x{i} - x{i - 1}).(v{i} - v{i - 1}) must vanish)")
    return c


def _chart_models(model) -> tuple[str, ...]:
    """The charts a mapping y0 may name: an atlas's members, a chart model's own atlas's."""
    ref = _ref(model)
    if ref.atlas is not None:
        return ref.atlas.charts
    description = ref.description
    family = atlas_family(description) if description.dimension == 3 else None
    if family is not None:
        return family.charts
    return (ref.name,) if ref.info.nguards > 0 else ()


def normalise_y0(model, y0, p: np.ndarray) -> tuple[np.ndarray, str | None, np.ndarray | None]:
    """(state, chart model, Cartesian state or None).  For an atlas the chart is chosen."""
    ref = _ref(model)
    atlas, info = ref.atlas, ref.info
    charts = _chart_models(ref)
    spherical = bool(charts) or (atlas is None and info.nguards > 0)
    lengths = cartesian.link_lengths(ref.standard, p) if spherical else ()
    if isinstance(y0, Mapping):
        keys = set(y0)
        if not spherical:
            raise SimulationInputError(f"model '{model}' takes y0 as a sequence of "
                                       f"{info.n} numbers")
        n = info.n
        if keys == {"cartesian"}:
            c = _cartesian_y0(ref, y0["cartesian"], p)
        elif keys == {"chart", "state"} and y0["chart"] in charts:
            s = _finite_array(y0["state"], "y0['state']").astype(np.float64).reshape(-1)
            if s.size != n:
                raise SimulationInputError(f"y0['state'] must have {n} numbers, got {s.size}")
            c = cartesian.state_to_cartesian(y0["chart"], s, lengths)
        else:
            raise SimulationInputError(f"y0 as a mapping must be {{'cartesian': [{3 * len(lengths) * 2} numbers]}} or "
                                       f"{{'chart': one of {', '.join(charts)}, 'state': [{n} numbers]}}")
        chart = cartesian.choose_chart(c, lengths, atlas.name) if atlas is not None else ref.name
        return cartesian.cartesian_to_state(chart, c, lengths), chart, c
    n = info.n
    if isinstance(y0, str):
        raise SimulationInputError(f"y0 must be {n} numbers, got a string")
    a = _finite_array(y0, "y0").reshape(-1)
    if a.size != n:
        raise SimulationInputError(f"model '{model}' takes y0 with {n} numbers "
                                   f"({', '.join(info.state_names)}), got {a.size}")
    if atlas is not None:
        # a standard-chart state (exact at the poles too): through Cartesian coordinates
        c = cartesian.state_to_cartesian(atlas.charts[0], a.astype(np.float64), lengths)
        chart = cartesian.choose_chart(c, lengths, atlas.name)
        if chart == atlas.charts[0]:
            return a, chart, c
        return cartesian.cartesian_to_state(chart, c, lengths), chart, c
    return a, (ref.name if spherical else None), None


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
        dt = a[1:] - a[:-1]
        if not ((dt > 0).all() or (dt < 0).all()):
            raise SimulationInputError("t must be strictly increasing or strictly decreasing")
    return a


# -- the entry point --------------------------------------------------------------

def simulate(model: str, y0, t, params, method: str | None = None, rtol: float | None = None,
             atol: float | None = None, step: float | None = None, dtype="float64",
             backend: str = "c", max_steps: int | None = None, sine_min: float | None = None,
             newton_tol: float | None = None, newton_max: int | None = None,
             hmax: float | None = None, inputs=None, atlas: bool = False, events=None,
             error_estimate: str = "local", hold: str | None = None,
             project: bool = False, specialise: bool = False) -> SimulationResult:
    """Integrate `model` from y0 at t[0] and report every output time in t.

    Parameters
    ----------
    model : str or path
        A catalogue name, the path of a model file, or "spherical" (the chart atlas).
    y0 : sequence or mapping
        The initial state, the coordinates then their rates, in order; a spherical model or
        the atlas also takes {'cartesian': [...]} (positions then velocities of the bobs) or
        {'chart': name, 'state': [...]}.
    t : sequence
        The output times, strictly monotone (decreasing: the run goes backwards).
    params : mapping or sequence
        The model's parameters, by name or in order.
    method : str, optional
        rk4, midpoint, gauss2, rk8, abm12 (fixed step: `step` required), dopri5, dop853
        (adaptive: rtol, atol; `step` is the initial step, optional; the default), taylor
        (the generated Taylor integrator: order and step from rtol).
    rtol, atol : float, optional
        Tolerances of the adaptive methods and Taylor (default: the dtype's), and of abm12's
        stability guard.
    step : float, optional
        The fixed step h (the initial step of an adaptive method).
    dtype : str
        float32, float64, longdouble, or the top of the precision ladder, "double-double"
        (106 bits) and "quad" (IEEE binary128, 113 bits), which run taylor (the default
        there) and give r.y_exact, the values exactly as mpmath numbers, beside r.y in long
        double (derive/runtime/extended.py).
    backend : {"c", "numpy"}
        Compiled generated C, or the generated NumPy.
    max_steps, sine_min, newton_tol, newton_max, hmax : optional
        The integrator's options (docs/c-api.md lists them with their defaults).
    inputs : mapping, sequence or callable, optional
        The model's run-time inputs: a mapping by name or a sequence in the model's order,
        held constant over the run; or a function u(t, y) returning one, evaluated at every
        stage of the integrator (rk4, rk8, dopri5 or dop853, stepped in Python over the
        compiled rhs: derive/runtime/continuous_inputs.py), so the error follows the method's
        order.  A time-dependent model (t in its forces, dissipation or pivot) runs in the
        generated C or NumPy like any model (every method, each stage at its own t); with inputs u(t, y) at every stage it steps in Python with those four methods in
        float64 (events and r.sol on its steps: derive/runtime/stage_solution.py).
    hold : {None, "zoh"}
        "zoh": a callable `inputs` is sampled at each output time instead (with the state
        there) and held until the next (a zero-order hold: a digital controller), any method.
    atlas : bool
        True: run the model's chart atlas (a chain of spherical links in the standard
        chart: its standard, second and rotated charts, switched by the rule of seed 000
        section 5.1; y0 in the standard chart, as {'cartesian': [...]} or {'chart', 'state'}).
    events : mapping, optional
        Zero crossings to locate, {name: expression or {expression, direction, terminal}}
        (derive/runtime/events.py); r.events, r.t_events, r.y_events.
    error_estimate : {"local", "rerun"}
        "local" (free): r.error_estimate is the run's own sum of local-error estimates
        (dopri5, dop853, abm12, taylor; None for the others); "rerun": a second run at
        rtol / 100 (a fixed step: half the step) gives an estimate of the global error of
        r.y, per output row in r.error_y.  r.error_kind says which (result.py).
    project : bool
        A closed loop (a model with constraints) only: True projects the state onto the
        constraints after every step (rk4, rk8, dopri5 or dop853, stepped in Python over
        the compiled rhs, as inputs u(t, y) are; no events, rerun estimate or dense
        output), so r.constraint_drift is at roundoff; False (the default) runs the
        generated loop on the exact index-1 equations and reports their drift
        (derive/runtime/constraints.py).
    specialise : bool
        True: run kernels with the parameter values folded in as constants (the derivation
        with the numbers substituted, then CSE and compilation again: built once per model
        and value set into the cache, derive/codegen/specialise.py); r.model names that
        specialised model.  The same equations: the run agrees with the general one to
        rounding (an adaptive RK run: to its tolerance).  Compiled C in float32, float64 or
        long double, one chart (not the atlas).

    Returns
    -------
    SimulationResult
        The states r.y at every output time, r.status and r.status_name, the counters,
        positions, energy; adaptive runs have r.sol(t), the continuous solution
        (derive/runtime/dense.py).  A run that stops early is returned, not raised:
        r.ok is False and r.message says why (r.raise_for_status() raises it).

    Raises
    ------
    SimulationInputError
        An unknown model, method, dtype or option, a missing parameter, a state or inputs
        of the wrong size, output times that are not strictly monotone; a closed loop's
        initial state off its constraints (derive.consistent_state projects it).
    BuildError
        backend "c": the model's library cannot be compiled (the message holds the
        compiler's output); CompilerMissingError, a BuildError, where there is no compiler.

    Notes
    -----
    A fixed step h steps on the grid t[0] + k h whatever the output times: an output
    between grid points is reached by a shortened step from the grid point before it
    (r.step is h, r.last_step the shortened step to the last output, None when it is on
    the grid), so a result does not depend on how many outputs were asked for.

    abm12 (12-step Adams-Bashforth-Moulton, PECE) has a small stability region: it
    stops with status 'multistep unstable' before a step whose predictor-corrector
    difference (Milne's estimate of its local error) exceeds atol + rtol abs(y) (rtol: the
    dtype's default unless given; atol: rtol 1e-3): r.guard is that (rtol, atol), and the
    message of a run it stopped names them (a looser rtol loosens the guard).  On the
    planar double pendulum (unit masses and lengths, g = 9.81) h = 0.01 is too large for
    many states with fast rotation; see docs/methods.md, "Fixed-step methods".

    Ctrl-C stops a run of the C backend within a step (the generated loops read a
    cancellation flag) and raises KeyboardInterrupt.

    Examples
    --------
    >>> import numpy as np
    >>> import derive
    >>> params = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
    >>> r = derive.simulate("planar", [1.0, 0.5, 0.0, 0.0], np.linspace(0.0, 1.0, 3), params,
    ...                     rtol=1e-8, backend="numpy")
    >>> r.ok, r.method, r.y.shape
    (True, 'dop853', (3, 4))
    >>> np.round(r.y[-1], 4)
    array([-0.2587, -1.005 , -0.5404, -2.7025])
    >>> bool(abs(r.sol(0.5) - r.y[1]).max() < 1e-12)        # the continuous solution
    True

    A fixed-step method steps on the grid t[0] + k h:

    >>> r = derive.simulate("planar", [1.0, 0.5, 0.0, 0.0], [0.0, 1.0], params, method="rk4",
    ...                     step=0.01, backend="numpy")
    >>> r.nsteps, r.step
    (100, 0.01)
    """
    if specialise is not False:
        known = None
        if type(params) is tuple and specialise is True and atlas is False:
            try:        # a repeated call with a tuple of parameters: one lookup (specialised.call_key's key)
                known = KNOWN_SPECIALISED.get((model, params, backend, dtype))
            except TypeError:          # an unhashable argument: _specialised's checks word it
                pass
        model = known or _specialised(model, params, specialise, backend, dtype, atlas)
    dispatch = compiled_call.COMPILED.dispatch
    pilot = None
    if FAST_PATH and dispatch is not None and project is False:
        # a repeated plain call: its compiled call, if it has one (the whole of its Python)
        done = dispatch(model, y0, t, params, method, rtol, atol, step, dtype, backend, max_steps, sine_min,
                        newton_tol, newton_max, hmax, inputs, atlas, events, error_estimate, hold)
        if done is not None:
            if type(done) is not tuple:
                return done
            pilot = done[0]                 # an adaptive run's pilot, stopped at its step budget
    return _simulate(model, y0, t, params, method, rtol, atol, step, dtype, backend, max_steps, sine_min,
                     newton_tol, newton_max, hmax, inputs, atlas, events, error_estimate, hold, pilot, project)


KNOWN_SPECIALISED = specialised.KNOWN


def _specialised(model, params, specialise, backend, dtype, atlas) -> str:
    """The name of the model simulate(..., specialise=True) runs: `model` with `params`
    folded in (derive/runtime/specialised.py), looked up by the call's arguments after the
    first call; `model` itself for specialise=False."""
    key = specialised.call_key(model, params, backend, dtype) if specialise is True and atlas is False else None
    name = specialised.KNOWN.get(key)
    if name is not None:
        return name
    if not specialised.check_specialise(specialise):
        return model
    precision = extended.precision_of(dtype)
    specialised.refuse_unspecialisable(backend, None if precision else dtype_key(_dtype(dtype)), atlas)
    ref = model_ref(resolve_model(model, explicit_time=True))
    if ref.atlas is not None:
        specialised.refuse_unspecialisable(backend, dtype_key(_dtype(dtype)), True)
    p = normalise_params(ref, params)
    name = specialised.folded_model(ref.name, ref.info.param_names, p)
    specialised.remember(key, name)
    return name


def _simulate(model, y0, t, params, method, rtol, atol, step, dtype, backend, max_steps, sine_min, newton_tol,
              newton_max, hmax, inputs, atlas, events, error_estimate, hold, pilot, project) -> SimulationResult:
    """simulate's Python paths: the fast path (fast_path.py; `pilot`: a compiled call's
    pilot that stopped at its step budget, to go on from) and the general path.  Apart
    from simulate, which would otherwise make the cells of this function's closures on
    every call, the compiled ones too."""
    plain = FAST_PATH and backend == "c" and not atlas and inputs is None and events is None and \
        hold is None and project is False and isinstance(error_estimate, str) and error_estimate == "local"
    precision = extended.precision_of(dtype)
    original_method = method
    if method is None:
        method = TAYLOR if precision else DEFAULT_METHOD
    if plain and precision is None:
        key = compiled_call.call_key(model, original_method, dtype, rtol, atol, step, hmax, max_steps,
                                     newton_tol, newton_max, sine_min)
        fast = _fast_simulate(model, y0, t, params, method, rtol, atol, step, dtype, max_steps,
                              sine_min, newton_tol, newton_max, hmax, arguments=key, pilot=pilot)
        if fast is not None:
            return fast
    model = resolve_model(model, atlas, explicit_time=not atlas)
    ref = model_ref(model)          # looked up once, passed down
    _check_error_estimate(error_estimate)
    if not isinstance(method, str) or method not in RUN_METHODS:
        raise SimulationInputError(f"unknown method {method!r} (known: {', '.join(RUN_METHODS)})")
    if backend not in ("c", "numpy"):
        raise SimulationInputError(f"unknown backend {backend!r} (use 'c' or 'numpy')")
    if method == TAYLOR and (backend != "c" or ref.atlas is not None):
        raise SimulationInputError("the Taylor integrator runs in generated C on single-chart models: "
                                   "use backend='c' and a model, not the atlas")
    _check_project(project, ref, precision, dtype, atlas, events, error_estimate, hold)
    if precision is not None:
        return _simulate_extended(ref, precision, y0, t, params, method, rtol=rtol, atol=atol, step=step,
                                  max_steps=max_steps, sine_min=sine_min, hmax=hmax, inputs=inputs,
                                  events=events, error_estimate=error_estimate)
    dt = _dtype(dtype)
    p = normalise_params(ref, params)
    u = normalise_inputs(ref, inputs)
    _check_hold(hold, u, dtype)
    ts = normalise_t(t)
    state, chart, _ = normalise_y0(ref, y0, p)
    _check_angles(ref, state, dt)
    loop = ref.atlas is None and constraints.is_constrained(model)
    if loop:
        constraints.check_initial_state(model, state, p)
    opt = run_options(method, dt, ts, rtol=rtol, atol=atol, step=step, hmax=hmax, max_steps=max_steps,
                      newton_tol=newton_tol, newton_max=newton_max, sine_min=sine_min)
    if ref.atlas is not None and method not in ATLAS_METHODS:
        raise SimulationInputError(f"the chart atlas has no method '{method}' "
                                   f"(it has {', '.join(ATLAS_METHODS)})")
    _check_size(method, ts, state, opt, dt, budget_given=max_steps is not None)
    wanted = _events_of(ref, method, events)
    if project:
        result = continuous_inputs.run_continuous(model, method, state, ts, p, opt, backend, _stage_inputs(ref, u),
                                                  project=lambda y: constraints.project(model, y, p))
        return constraints.report_drift(result, model, p)
    timed = ref.description.is_time_dependent
    # stepped in Python: inputs u(t, y) at every stage (the generated integrators, C and
    # NumPy, pass each stage's t to a time-dependent model themselves)
    if isinstance(u, HeldInputs) and hold is None:
        if timed:
            _check_timed(ref, method, dt)
        elif ref.atlas is not None:
            raise SimulationInputError("inputs u(t, y) at every stage: not on the chart atlas "
                                       "(give hold='zoh' for it)")
        stages_u = continuous_inputs.ContinuousInputs(ref, u.names, u.function, _input_values) \
            if isinstance(u, HeldInputs) else u
        result = continuous_inputs.run_continuous(model, method, state, ts, p, opt, backend, stages_u, wanted)
        if error_estimate == "rerun":
            again = dict(method=method, rtol=rtol, atol=atol, step=step, backend=backend, max_steps=max_steps,
                         hmax=hmax, inputs=inputs)
            _estimate_by_rerun(result, lambda **tighter: simulate(model, y0, t, params, **{**again, **tighter}),
                               method, opt, dt, max_steps)
        return constraints.report_drift(result, model, p) if loop else result

    def run(o):
        if ref.atlas is not None:
            return run_atlas(method, state, chart, ts, p, o, dt, backend, model)
        if isinstance(u, HeldInputs):
            return _run_held(model, method, state, ts, p, o, dt, backend, u)
        return _run_single(model, method, state, ts, p, o, dt, backend, u)

    held = isinstance(u, HeldInputs)
    result = _drive(run, method, ts, opt, backend, max_steps is not None, held=held)
    result = _finish(result, model, method, backend, dt, opt, p, atlas=ref.atlas is not None,
                     inputs=lambda: np.array([u.at(a, y) for a, y in zip(ts, result.y)]) if held else u)
    if wanted:
        result = events_module.locate(result, wanted, opt["rtol"])
    if error_estimate == "rerun":
        again = dict(method=method, rtol=rtol, atol=atol, step=step, dtype=dtype, backend=backend,
                     max_steps=max_steps, sine_min=sine_min, newton_tol=newton_tol, newton_max=newton_max,
                     hmax=hmax, inputs=inputs, atlas=atlas, hold=hold)
        _estimate_by_rerun(result, lambda **tighter: simulate(model, y0, t, params, **{**again, **tighter}),
                           method, opt, dt, max_steps)
    return constraints.report_drift(result, model, p) if loop else result


def _check_project(project, ref, precision, dtype, atlas, events, error_estimate, hold) -> None:
    """project=True: a closed loop's run, projected after every step (simulate's docstring);
    refused in one line for anything else."""
    if not isinstance(project, bool):
        raise SimulationInputError(f"project must be True or False, got {project!r}")
    if not project:
        return
    if atlas or not constraints.is_constrained(str(ref)):
        raise SimulationInputError(f"project=True is for a closed loop (a model with constraints); "
                                   f"'{ref}' has none")
    other_dtype = precision is not None or np.dtype(_dtype(dtype)) != np.float64
    for given, what in ((other_dtype, f"dtype {dtype}"), (events is not None, "events"),
                        (error_estimate != "local", "rerun estimate"), (hold is not None, "hold='zoh'")):
        if given:
            raise SimulationInputError(f"project=True steps in Python in float64, with no {what}: run "
                                       f"without project= (its drift is reported) for those")


def _stage_inputs(ref, u) -> "continuous_inputs.ContinuousInputs | None":
    """The inputs of a run stepped in Python: a function u(t, y) as given, constant inputs as
    one returning them, None for a model without inputs."""
    if u is None:
        return None
    if isinstance(u, HeldInputs):
        return continuous_inputs.ContinuousInputs(ref, u.names, u.function, _input_values)
    return continuous_inputs.ContinuousInputs(ref, ref.description.inputs, lambda t, y: u, _input_values)


def _simulate_extended(model, precision, y0, t, params, method, *, rtol, atol, step, max_steps, sine_min,
                       hmax, inputs, events, error_estimate="local") -> SimulationResult:
    """The double-double and quad rungs: simulate's checks on the arguments, then the
    Taylor integrator in that precision (derive/runtime/extended.py)."""
    if method != TAYLOR:
        raise SimulationInputError(f"dtype '{precision}' runs the Taylor integrator: use method='taylor' "
                                   f"(or leave method out), not '{method}'")
    for name, value in (("step", step), ("atol", atol), ("events", events)):
        if value is not None:
            raise SimulationInputError(f"dtype '{precision}' takes no {name}= (the Taylor integrator's "
                                       f"order and step follow rtol)")
    if callable(inputs):
        raise SimulationInputError(f"dtype '{precision}' takes inputs held constant (a mapping or a sequence)")
    if error_estimate != "local":
        raise SimulationInputError(f"dtype '{precision}' estimates its error from its own run "
                                   f"(error_estimate='local'); for a rerun, run again at a smaller rtol")
    model, ref = str(model), _ref(model)
    # the usual checks, one line each; here a string is an exact decimal (the run reads
    # every input exactly), checked as the number nearest it
    p = normalise_params(ref, _decimals_as_floats(params))
    normalise_inputs(ref, _decimals_as_floats(inputs))
    ts = normalise_t(_decimals_as_floats(t))
    state, _, _ = normalise_y0(ref, _decimals_as_floats(y0), p)
    _check_angles(ref, state, np.dtype(np.longdouble))
    loop = constraints.is_constrained(model)
    if loop:
        constraints.check_initial_state(model, state, p)
    run_options(TAYLOR, np.dtype(np.float64), ts, hmax=hmax, max_steps=max_steps, sine_min=sine_min)
    if isinstance(y0, Mapping) and set(y0) & {"cartesian", "chart", "state"}:
        raise SimulationInputError(f"dtype '{precision}' takes y0 as the state (a sequence or a mapping by name)")
    result = extended_run.simulate_extended(model, precision, y0, t, params, rtol, hmax, max_steps, sine_min,
                                            inputs)
    y, pm, dt = result.y, result.params, np.dtype(np.longdouble)

    def observe():       # in long double, on first access of r.energy, r.positions or r.velocities
        t = result.t if ref.description.is_time_dependent else None      # a moving pivot's kernels take t
        return (*_observables(model, y, pm, "c", dt, t), _velocities(model, y, pm, "c", dt, t))

    result.observe = observe
    result.energy = result.positions = result.velocities = LAZY
    return constraints.report_drift(result, model, pm) if loop else result


# -- error_estimate="rerun" ------------------------------------------------------------

RERUN_TIGHTER = 100          # the reference run's rtol and atol: the run's / 100
_WIDER = {"float32": np.float64, "float64": np.longdouble}    # for a reference beyond 10 eps


def _check_error_estimate(error_estimate) -> None:
    if not isinstance(error_estimate, str) or error_estimate not in ("local", "rerun"):
        raise SimulationInputError(f"error_estimate must be 'local' (the run's own local-error sum, free) "
                                   f"or 'rerun' (a second, more accurate run), got {error_estimate!r}")


def _reference_settings(method: str, opt: dict, dt: np.dtype, max_steps) -> tuple[dict, str, float]:
    """The reference run's arguments, what error_kind calls it, and the factor its
    difference is scaled by: rtol and atol / 100 (in a wider dtype where rtol / 100 is
    below 10 eps), or half the fixed step (Richardson: the error of the run at h is
    (y_h - y_h/2) / (1 - 2^-order))."""
    budget = None if max_steps is None else 4 * int(max_steps)
    if method not in TOLERANCE_METHODS:
        h = opt["h"] / 2
        return {"step": h, "max_steps": budget}, f"rerun at step={h:.3g}", 1 / (1 - 2.0 ** -FIXED_ORDER[method])
    rtol, atol, kind = opt["rtol"] / RERUN_TIGHTER, opt["atol"] / RERUN_TIGHTER, dtype_key(dt)
    while rtol < 10 * float(np.finfo(_DTYPES[kind]).eps):
        wider = _WIDER.get(kind)
        if wider is None or np.finfo(wider).eps == np.finfo(_DTYPES[kind]).eps:
            raise SimulationInputError(f"error_estimate='rerun': rtol = {opt['rtol']:g} leaves no tighter "
                                       f"tolerance for a reference run in {kind} (10 eps = "
                                       f"{10 * float(np.finfo(_DTYPES[kind]).eps):.3g}); loosen rtol")
        kind = dtype_key(wider)
    where = "" if kind == dtype_key(dt) else f" in {kind}"
    return ({"rtol": rtol, "atol": atol, "step": None, "dtype": kind, "max_steps": budget},
            f"rerun at rtol={rtol:.3g}{where}", 1.0)


def _estimate_by_rerun(result: SimulationResult, rerun, method: str, opt: dict, dt: np.dtype, max_steps) -> None:
    """Fill result's error fields from a second, more accurate run (error_estimate='rerun')."""
    if len(result.t) < 2:              # the start alone: y0 itself, exact (and no step to halve)
        result.error_y, result.error_estimate = np.zeros(np.shape(result.y)), 0.0
        result.error_kind = "rerun: the start alone, exact"
        return
    changes, kind, factor = _reference_settings(method, opt, dt, max_steps)
    try:
        reference = rerun(**changes)
    except SimulationInputError as exc:
        raise SimulationInputError(f"error_estimate='rerun': the reference run "
                                   f"({kind.removeprefix('rerun ')}): {exc}") from None
    wide = np.longdouble
    error_y = np.abs(np.asarray(result.y, wide) - np.asarray(reference.y, wide)) * wide(factor)
    error_y = np.asarray(error_y, np.float64)
    if result.chart is not None and reference.chart is not None:
        error_y[np.asarray(result.chart != reference.chart)] = np.nan   # other charts: no comparison
    comparable = np.isfinite(error_y)
    result.error_y = error_y
    result.error_estimate = float(error_y[comparable].max()) if comparable.any() else None
    result.error_kind = kind


# -- the fast path: simulate's common case through a plan (derive/runtime/fast_path.py) ------

FAST_PATH = True       # off: every call takes the general path (tests compare the two)


@forget_on_model_change
@lru_cache(maxsize=256)
def run_plan(model: str, method: str, dtype) -> RunPlan:
    """The plan of simulate(model, ..., method=method, dtype=dtype) on the C backend;
    NotPlanned (not cached: a model read later may make a name valid) where there is none."""
    if not isinstance(model, str) or is_model_file(model) or find_atlas(model) is not None or \
            not isinstance(method, str) or method not in RUN_METHODS:
        raise NotPlanned(model)
    try:
        return RunPlan(resolve_model(model, explicit_time=True), method, _dtype(dtype), MAX_OUTPUT_BYTES,
                       MAX_FIXED_STEPS)      # a time-dependent model too: its integrators pass t
    except NotPlanned:
        raise
    except Exception as exc:       # a bad name or dtype, a failed build: the general path says it
        raise NotPlanned(model) from exc


def _fast_simulate(model, y0, t, params, method, rtol, atol, step, dtype, max_steps, sine_min,
                   newton_tol, newton_max, hmax, arguments=None, pilot=None) -> SimulationResult | None:
    """simulate(...) for a model by name on the C backend, without inputs or events, when
    every argument is plainly valid: the same result as the general path, in a few
    microseconds.  None for anything else (the general path then runs, and refuses bad
    input with its one line); what it refuses itself (the model's parameter checks, the
    option checks of run_options) it refuses with the general path's words, at the same
    point of the same order of checks.

    `arguments`: simulate's option arguments (compiled_call.call_key): a second run with them
    registers their compiled call.  `pilot`: an adaptive run's pilot that stopped at its
    step budget, run already by that compiled call."""
    try:
        plan = run_plan(model, method, dtype)
    except (NotPlanned, TypeError):              # TypeError: an unhashable argument
        return None
    p = plan.params(params)
    if p is None:
        return None
    key = tuple(p)
    if key not in plan.checked:                  # once per parameter vector (as normalise_params)
        check_parameter_values(plan.description, dict(zip(plan.param_names, p)), SimulationInputError)
        if len(plan.checked) >= CHECKED_MAX:
            plan.checked.clear()
        plan.checked.add(key)
    times, long_times = plain_times(t)
    y = plan.state(y0)
    if y is None or (times is None and long_times is None):
        return None
    nt = len(times) if times is not None else long_times.size
    s = _fast_settings(plan, (rtol, atol, step, hmax, max_steps, newton_tol, newton_max, sine_min, nt > 1))
    if s is None:
        return None
    if times is not None:
        span = abs(times[-1] - times[0])
        buf = np.array(y + p + times, plan.dt)
    else:
        span = abs(float(long_times[-1]) - float(long_times[0]))
        buf = np.concatenate((np.array(y + p, plan.dt), long_times), dtype=plan.dt)
    if not plan.fits(nt, span, s, max_steps is not None):
        return None                              # _check_size refuses it, with the figure
    opt = s.opt
    execute = plan.runner.execute

    def run(o):                                  # a run with other options (cancellable, ...)
        return execute(s, plan.runner.options(o), buf, nt)

    if plan.tolerance and max_steps is None:
        # _drive's first case, the common one, without the calls around it: the pilot, which
        # is the run unless it stopped at its step budget (then _run_estimated decides)
        result = execute(s, s.pilot, buf, nt) if pilot is None else pilot
        if result.status == MAX_STEPS_STATUS:
            return _finish(_run_estimated(run, method, buf[plan.n + plan.n_params:], opt, "c", result),
                           plan.model, method, "c", plan.dt, opt, result.params)
    else:
        result = _drive(run, method, buf[plan.n + plan.n_params:], opt, "c", max_steps is not None,
                        direct=lambda: execute(s, s.struct, buf, nt))
    if arguments is not None and nt > 1:
        _register_compiled(arguments, plan, s, max_steps is not None)
    return _finish(result, plan.model, method, "c", plan.dt, opt, result.params)


def _register_compiled(key: tuple, plan: RunPlan, s: Settings, budget_given: bool) -> None:
    """On the second run with the option arguments `key`, their compiled call
    (derive/runtime/compiled_call.py): the same run as the fast path's, its checks, its
    result, _finish's fields, in one C call.  A run the fast path makes other than
    directly (cancellable: _drive) has none."""
    if not compiled_call.seen_twice(key):
        return
    if s.compiled is None:
        opt = s.opt
        if plan.tolerance:
            if budget_given and opt["max_steps"] > PILOT_STEPS["c"]:
                return
            struct, quick, finish = (s.struct if budget_given else s.pilot), math.inf, {"rtol": opt["rtol"]}
        else:
            struct, quick, finish = s.struct, QUICK_STEPS, {"step": opt["h"]}
            if plan.method in MULTISTEP:
                finish["guard"] = (float(opt["rtol"]), float(opt["atol"]))
        if plan.method in ADAPTIVE:
            finish["_sol"] = LazySolution(partial(_solution, plan.model, plan.method, plan.dt, opt))
        checks = dict(plan.compiled_checks(budget_given), quick_steps=quick,
                      pilot=int(plan.tolerance and not budget_given))
        s.compiled = plan.runner.compiled_call(s, struct, checks, finish) or False
    compiled_call.register(key, s.compiled or None)


def _solution(model: str, method: str, dt: np.dtype, opt: dict, result: SimulationResult):
    """A compiled call's r.sol, made on first access (as _finish makes it)."""
    return dense.dense_output(result, model, method, "c", dt, opt, result.params)


def _fast_settings(plan, args: tuple) -> Settings | None:
    """The plan's validated options for these option arguments (run_options once per
    distinct set; its refusals are the general path's), or None (not plain numbers)."""
    try:
        s = plan.settings.get(args)
    except TypeError:                            # an unhashable option: the general path
        return None
    if s is not None:
        return s
    if not all(a is None or type(a) is float or type(a) is int for a in args[:-1]):
        return None
    rtol, atol, step, hmax, max_steps, newton_tol, newton_max, sine_min, several = args
    opt = run_options(plan.method, plan.dt, (0.0, 1.0) if several else (0.0,), rtol=rtol, atol=atol,
                      step=step, hmax=hmax, max_steps=max_steps, newton_tol=newton_tol,
                      newton_max=newton_max, sine_min=sine_min)
    try:
        s = Settings(plan.runner, opt, PILOT_STEPS["c"])
    except Exception:          # e.g. no Taylor integrator: the general path says so, in its order
        return None
    if len(plan.settings) >= SETTINGS_MAX:
        plan.settings.clear()
    plan.settings[args] = s
    return s


def run_options(method: str, dt: np.dtype, ts: np.ndarray, rtol=None, atol=None, step=None, hmax=None,
                max_steps=None, newton_tol=None, newton_max=None, sine_min=None) -> dict:
    """The integrator options of a run (simulate's and ensemble's), checked: each bad
    value is one line naming it."""
    eps = float(np.finfo(dt).eps)
    given = {"rtol": _DEFAULT_RTOL[dtype_key(dt)] if rtol is None else rtol, "atol": atol, "hmax": hmax,
             "max_steps": max_steps, "newton_tol": newton_tol, "newton_max": newton_max, "sine_min": sine_min}
    opt = {k: given[k] if given.get(k) is not None else v for k, v in _DEFAULT_OPTIONS.items()}
    opt["atol"] = atol                       # None: from rtol below
    for key in ("rtol", "atol", "hmax", "newton_tol", "sine_min"):
        v = opt[key]
        if v is not None and (not isinstance(v, (int, float, np.floating)) or not np.isfinite(v) or v < 0):
            raise SimulationInputError(f"{key} = {v!r} must be a finite number >= 0")
    if opt["atol"] is None:
        opt["atol"] = opt["rtol"] * 1e-3
    if method in TOLERANCE_METHODS:
        if not 10 * eps <= opt["rtol"] < 1:
            raise SimulationInputError(f"rtol = {opt['rtol']:g} is outside [10 eps, 1) for {dtype_key(dt)} "
                                       f"(10 eps = {10 * eps:.3g})")
    elif step is None and np.size(ts) > 1:
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
    return opt


# an adaptive run's first steps, which tell how long the whole would take: most runs end
# within them (then that is the result: no work is repeated); a run that needs more starts
# again, cancellable, after the estimate.  The budget is one short enough to need no
# Ctrl-C: in C tens of thousands of steps, on the NumPy backend (Python code per step) a
# few hundred.
PILOT_STEPS = {"c": 50_000, "numpy": 200}
QUICK_STEPS = 20_000    # a fixed-step run this short runs directly (too short to need Ctrl-C)


def _fixed_steps(ts: np.ndarray, opt: dict) -> float:
    span = float(abs(ts[-1] - ts[0])) if len(ts) > 1 else 0.0
    return span / opt["h"] if opt.get("h") else 0.0


def _drive(run, method: str, ts: np.ndarray, opt: dict, backend: str, budget_given: bool,
           held: bool = False, direct=None) -> SimulationResult:
    """run(opt) as simulate runs it (both paths): an adaptive run's pilot first, in this
    thread (most runs end within it), a short run directly (a fixed step, or a step budget
    within a pilot's), the rest cancellable (_interruptible).  `direct`: the direct run,
    where the caller has it ready (the fast path, which also runs the pilot itself)."""
    if method in TOLERANCE_METHODS:
        if not budget_given and not held:
            return _run_estimated(run, method, ts, opt, backend)
        quick = opt["max_steps"] <= PILOT_STEPS[backend] and not held
    else:
        quick = _fixed_steps(ts, opt) <= QUICK_STEPS
    if quick:
        return direct() if direct else run(opt)
    return _interruptible(run, opt, backend)


def _finish(result: SimulationResult, model: str, method: str, backend: str, dt: np.dtype, opt: dict,
            p: np.ndarray, atlas: bool = False, inputs=None) -> SimulationResult:
    """A run's tolerance or step (a multistep run: its guard's rtol and atol too), and an
    adaptive single-model run's continuous solution (`inputs`: a function giving the inputs
    at each output, or None)."""
    if method in TOLERANCE_METHODS:
        result.rtol = opt["rtol"]
    else:
        result.step = opt["h"]
        if method in MULTISTEP:
            result.guard = (float(opt["rtol"]), float(opt["atol"]))
    if method in ADAPTIVE and not atlas:
        result.sol = dense.dense_output(result, model, method, backend, dt, opt, p,
                                        None if inputs is None else inputs())
    if method == TAYLOR and not atlas and _ref(model).description.is_time_dependent:
        result.sol = _taylor_solution(result, model, dt, opt, p, None if inputs is None else inputs())
    return result


def _taylor_solution(result: SimulationResult, model: str, dt, opt: dict, p, inputs):
    """A time-dependent model's Taylor run's r.sol (derive/runtime/taylor_solution.py: each
    interval from its row at its own time); `inputs` held over the run, or None."""
    values = np.asarray(p, dt) if inputs is None else np.concatenate([np.asarray(p, dt), np.asarray(inputs, dt)])
    end = float(result.t_stop) if not result.ok else float(result.t[-1])
    return TaylorSolution(model, dt, opt, values, result.t, result.y, end)


def _run_estimated(run, method: str, ts: np.ndarray, opt: dict, backend: str,
                   pilot: SimulationResult | None = None) -> SimulationResult:
    """An adaptive run within the default step budget, or refused with the figure.

    The run starts with max_steps = PILOT_STEPS[backend]: most runs end within that, and then
    that is the result (the steps are the same, whatever the budget).  Otherwise the
    time those steps covered gives the steps the whole span needs; beyond max_steps
    (10^8 by default: minutes of C) the run is refused before the rest of the work.
    `pilot`: that first run, done already (simulate's fast path)."""
    # the pilot runs in this thread (milliseconds: too short to need Ctrl-C, and a worker
    # thread would cost more than most whole runs)
    pilot_steps = PILOT_STEPS[backend]
    if pilot is None:
        pilot = run(dict(opt, max_steps=min(pilot_steps, opt["max_steps"])))
    if pilot.status != MAX_STEPS_STATUS or opt["max_steps"] <= pilot_steps:
        return pilot
    span = float(abs(ts[-1] - ts[0]))
    covered = abs(pilot.t_stop - float(ts[0]))
    needed = pilot_steps * span / covered if covered > 0 else float("inf")
    if needed > opt["max_steps"]:
        raise SimulationInputError(
            f"{method} at rtol {opt['rtol']:g} from t = {float(ts[0]):g} to {float(ts[-1]):g} needs about "
            f"{needed:.2g} steps (its first {pilot_steps} reached t = {pilot.t_stop:.3g}), more than "
            f"max_steps = {opt['max_steps']:.3g}: shorten the span, loosen rtol or give max_steps=")
    return _interruptible(run, opt, backend)


def _interruptible(run, opt: dict, backend: str) -> SimulationResult:
    """run(opt) so that Ctrl-C stops it: KeyboardInterrupt after the C loop has stopped.

    A ctypes call releases the GIL but Python runs signal handlers only between
    bytecodes of the main thread, so while the C loop runs in the main thread no
    handler would run.  Here the run goes to a worker thread; the main thread waits
    (a wait that signals interrupt), and its SIGINT handler sets the run's own
    cancellation flag (options.cancel, read by the generated loop before every step).
    Off the main thread (no signal handlers there) or with SIGINT ignored, the run is
    direct; the NumPy backend is Python and stops on KeyboardInterrupt by itself."""
    if backend != "c":
        return run(opt)
    flag = ctypes.c_int(0)
    opt = dict(opt, cancel=ctypes.pointer(flag))
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) in (signal.SIG_IGN, None):
        return run(opt)
    box: dict = {}

    def work():
        try:
            box["result"] = run(opt)
        except BaseException as exc:         # handed to the caller's thread below
            box["error"] = exc

    def on_sigint(signum, frame):
        flag.value = 1

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        worker = threading.Thread(target=work, name="derive-run", daemon=True)
        worker.start()
        worker.join()
    finally:
        signal.signal(signal.SIGINT, previous)
    if "error" in box:
        raise box["error"]
    if flag.value:
        raise KeyboardInterrupt(f"run cancelled at t = {box['result'].t_stop:g}")
    return box["result"]


def _events_of(model: str, method: str, events) -> tuple:
    """The checked events of a run (before any work), or () without events."""
    if events is None or (hasattr(events, "__len__") and not len(events)):
        return ()
    if _atlas(model) is not None:
        raise SimulationInputError(f"events are not available on the chart atlas '{model}' (its state "
                                   f"changes chart); run one chart model")
    if method not in ADAPTIVE:
        raise SimulationInputError(f"events need the dense output of an adaptive method "
                                   f"({', '.join(ADAPTIVE)}), not {method}")
    return events_module.parse_events(_ref(model).info, events)


MAX_ANGLE_ULP = 1e-3             # radians: a coordinate rounded coarser than this cannot move


def _check_angles(model: str, state, dt: np.dtype) -> None:
    """Refuse a starting angle so large that its rounding is coarser than MAX_ANGLE_ULP: a
    step could not change it (theta = 1e300 stays 1e300 while its rate evolves), and the
    run would be silently wrong while meeting its relative tolerance."""
    if _atlas(model) is not None:
        return                            # an atlas starts from Cartesian coordinates
    names = _described(model).coordinate_names
    q = np.asarray(state, np.longdouble)[:len(names)]
    if float(np.max(np.abs(q), initial=0.0)) * float(np.finfo(dt).eps) <= MAX_ANGLE_ULP:
        return                            # the usual case, in one comparison
    for name, q in zip(names, q):
        if abs(float(q)) * float(np.finfo(dt).eps) > MAX_ANGLE_ULP:
            raise SimulationInputError(f"y0: {name} = {float(q):g} rad is too large for {dtype_key(dt)} "
                                       f"(rounded to {abs(float(q)) * float(np.finfo(dt).eps):.2g} rad, a "
                                       f"step could not change it); reduce it modulo 2 pi")


ATOL_FOR_ZERO = 1e-20             # atol = 0 means atol = 1e-20 rtol (see simulate)
MAX_OUTPUT_BYTES = 2 ** 32         # 4 GiB of trajectory and observables for one run
MAX_FIXED_STEPS = 10 ** 10         # about an hour of the cheapest rhs: refused before any work


def _check_size(method: str, ts: np.ndarray, state, opt: dict, dt: np.dtype, budget_given: bool = False) -> None:
    """Refuse, with the figure, a run whose output would not fit in memory or whose
    fixed step (or largest step) means more steps than any run should take, or (with
    the default budget) more than max_steps: a run that would stop after minutes of
    work with 'maximum number of steps reached'.  (Adaptive runs: _run_estimated.)"""
    n = np.size(state)
    rows = len(ts) * (n + 1 + 4 * max(n // 2, 1))          # states, energy, positions, velocities
    nbytes = rows * np.dtype(dt).itemsize
    if nbytes > MAX_OUTPUT_BYTES:
        raise SimulationInputError(f"{len(ts):,} output times would need {nbytes / 2 ** 30:.3g} GiB "
                                   f"(limit {MAX_OUTPUT_BYTES / 2 ** 30:g} GiB): give fewer output times")
    span = float(abs(ts[-1] - ts[0])) if len(ts) > 1 else 0.0
    if not np.isfinite(span):
        raise SimulationInputError(f"the time span {ts[0]:g} to {ts[-1]:g} is not finite")
    h = opt["h"] if method not in TOLERANCE_METHODS else opt["hmax"]
    what = "step" if method not in TOLERANCE_METHODS else "hmax"
    steps = span / h if h else 0.0          # in floating point: never an overflowing integer
    if steps > MAX_FIXED_STEPS:
        raise SimulationInputError(f"{what} = {h:g} over a span of {span:g} means {steps:.3g} steps "
                                   f"(limit {MAX_FIXED_STEPS:.0e}): refused before any work")
    if steps > opt["max_steps"] and not budget_given:
        raise SimulationInputError(f"{what} = {h:g} over a span of {span:g} means {steps:.3g} steps, more than "
                                   f"max_steps = {opt['max_steps']:.3g}: refused before any work "
                                   f"(give max_steps= to run them)")


def _run_held(model, method, y0, ts, p, opt, dt, backend, u: HeldInputs) -> SimulationResult:
    """One run per output interval, each with the inputs sampled at its start (one runner
    and one set of options for them all)."""
    r = runner_for(model, method, dtype_key(dt), backend)
    s = Settings(r, opt) if backend == "c" else None
    first = _run_on(r, s, y0, ts[:1], p, opt, dt, u.at(ts[0], y0))
    parts, y = [first], first.y[-1]
    for a, b in zip(ts[:-1], ts[1:]):
        part = _run_on(r, s, y, np.array([a, b]), p, opt, dt, u.at(a, y))
        parts.append(part)
        if not part.ok:
            break
        y = part.y[-1]
    last = parts[-1]
    n = len(ts)

    def rows(attr):
        got = np.concatenate([getattr(parts[0], attr)] + [getattr(r, attr)[1:] for r in parts[1:]])
        pad = np.full((n - len(got),) + got.shape[1:], np.nan, got.dtype)       # after a stop: NaN
        return np.concatenate([got, pad])

    out = SimulationResult(**{**as_fields(last), "t": np.asarray(ts, dt), "y": rows("y"), "energy": rows("energy"),
                              "positions": rows("positions"), "velocities": rows("velocities"),
                              "params": np.asarray(p, dt)})
    for k in COUNTERS:
        setattr(out, k, sum(getattr(r, k) for r in parts))
    if out.error_kind == LOCAL_SUM:
        out.error_estimate = sum(r.error_estimate for r in parts)
    return out


def _run_single(model, method, y0, ts, p, opt, dt, backend, u=None) -> SimulationResult:
    """One run of a single model through its runner."""
    r = runner_for(model, method, dtype_key(dt), backend)
    return _run_on(r, Settings(r, opt) if backend == "c" else None, y0, ts, p, opt, dt, u)


def _run_on(r, s: Settings | None, y0, ts, p, opt: dict, dt, u=None) -> SimulationResult:
    """One run of runner `r` from y0 over the output times ts: in C with the settings `s`
    (None on the NumPy backend, which takes the options `opt` as they are)."""
    n, n_params, n_inputs = r.n, r.n_params, r.n_inputs
    buf = np.empty(n + n_params + n_inputs + len(ts), dt)   # y0, the parameters and inputs, t
    buf[:n], buf[n:n + n_params] = y0, p
    if n_inputs:
        buf[n + n_params:n + n_params + n_inputs] = u
    buf[n + n_params + n_inputs:] = ts
    if s is not None:
        return r.execute(s, s.struct, buf, len(ts))
    pd = buf[n:n + n_params + n_inputs]
    return r.numpy_run(buf[:n], pd, buf[n:n + n_params], buf[n + n_params + n_inputs:], opt)
