"""simulate's common case in microseconds: what a (model, method, dtype) run needs, made once.

A call of derive.simulate on a built model used to spend about 50 us in Python around a
C run of a microsecond or two: NumPy round trips of four-element lists, the checks
redone on every call, thirty dataclass assignments, a ctypes pointer per array.  A
RunPlan holds everything that does not change between calls of one (model, method,
dtype): the model's sizes and names, the C entry point, the validated options of each
distinct set of option arguments (with their ctypes structs), the parameter vectors
that passed the model's physical checks, and a prototype of the result.

The plan only accelerates.  `plain_numbers` and friends accept an argument only when it
is plainly valid (Python or float64 numbers, finite, of the right count); anything else,
valid or not, goes to simulate's general path, which gives every refusal its one line.
So no check is dropped, and the two paths return equal results (tests/test_fast_path.py).
"""
from __future__ import annotations

import ctypes
from functools import partial

import numpy as np

from .build import address, dtype_key, integrator_library
from ..codegen.contract import (ADAPTIVE, COUNTERS, LOCAL_ERROR_METHODS, METHODS, STATUS_NAMES, TAYLOR, TOLERANCE_METHODS)
from .observables import _observables, _velocities
from .result import LAZY, LOCAL_SUM, result_factory
from ..codegen.contract import taylor_order
from .taylor_library import taylor_library
from ..codegen.integrators import model_info
from ..model import load_model

LIST_MAX = 64          # arrays up to this size are checked as Python lists (faster than NumPy's)
LONG_MAX = 10 ** 6     # longer output times: the general path (it checks their memory first)
INT_MAX = 2 ** 53      # a larger int is not exactly a double: left to the general path
SETTINGS_MAX = 256     # distinct option sets remembered per plan
CHECKED_MAX = 4096     # parameter vectors remembered per plan

_addressof = ctypes.addressof


class NotPlanned(Exception):
    """This (model, method, dtype) has no plan (an atlas, a model file's path, a model with
    inputs, an unknown name or dtype): the general path runs."""


def plain_numbers(value, size: int | None = None) -> list | None:
    """`value` as a list of Python numbers when it is plainly valid: a list, tuple or 1-D
    float64 array (of `size` items, if given; at most LIST_MAX for an array) of finite
    floats and exact ints.  None otherwise: the general path decides (and words any error)."""
    if type(value) is np.ndarray:
        if value.dtype != np.float64 or value.ndim != 1 or value.size > LIST_MAX:
            return None
        value = value.tolist()
    elif type(value) is not list and type(value) is not tuple:
        return None
    if size is not None and len(value) != size:
        return None
    for v in value:
        if type(v) is float or isinstance(v, float):     # a Python float or numpy.float64
            if v - v != 0:                                # NaN or infinite
                return None
        elif type(v) is not int or not -INT_MAX <= v <= INT_MAX:
            return None
    return list(value)


def strictly_monotone(t: list) -> bool:
    """Strictly increasing or strictly decreasing (a single time is)."""
    if len(t) < 3:
        return len(t) < 2 or t[1] != t[0]
    if t[1] > t[0]:
        return all(a < b for a, b in zip(t, t[1:]))
    return all(a > b for a, b in zip(t, t[1:]))


def plain_times(t) -> tuple[list | None, np.ndarray | None]:
    """The output times when plainly valid: (a list, None) for a short sequence, (None, the
    float64 array) for a long 1-D float64 array; (None, None) otherwise."""
    listed = plain_numbers(t)
    if listed is not None:
        return (listed, None) if listed and strictly_monotone(listed) else (None, None)
    if type(t) is np.ndarray and t.dtype == np.float64 and t.ndim == 1 and LIST_MAX < t.size <= LONG_MAX:
        d = t[1:] - t[:-1]
        if np.isfinite(t).all() and ((d > 0).all() or (d < 0).all()):
            return None, t
    return None, None


class Settings:
    """One set of option arguments of a plan, validated: the options dict (as run_options
    makes it), its ctypes struct and the pilot's, and the entry point for it."""
    __slots__ = ("opt", "struct", "pilot", "pilot_steps", "call", "Info", "y_offset", "step", "limit")

    def __init__(self, plan: "RunPlan", opt: dict, pilot_steps: int):
        lib = plan.lib
        self.opt = opt
        self.struct = lib.options(opt)
        self.pilot_steps = pilot_steps
        self.pilot = lib.options(dict(opt, max_steps=min(pilot_steps, opt["max_steps"])))
        if plan.method == TAYLOR:
            taylor = taylor_library(plan.model, taylor_order(opt["rtol"]))
            self.call, self.Info = partial(taylor.fns[plan.dtype], 1), taylor.Info
        else:
            self.call = partial(lib.fns[plan.dtype], 1, METHODS.index(plan.method))
            self.Info = lib.Info
        self.y_offset = self.Info.y.offset          # info.y read as an array in place
        # the step that bounds a run's step count (fixed: h; adaptive: hmax, 0: none)
        self.step = opt["hmax"] if plan.method in TOLERANCE_METHODS else opt["h"]
        self.limit = opt["max_steps"]


class RunPlan:
    """What simulate needs of one (model, method, dtype) on the C backend, made once."""

    def __init__(self, model: str, method: str, dt: np.dtype, max_bytes: int, max_steps: float):
        """model: a resolved model name; max_bytes, max_steps: _check_size's limits."""
        info = model_info(model)
        description = load_model(model)
        if description.inputs or info.n_inputs:
            raise NotPlanned(model)
        self.model, self.method, self.dt, self.dtype = model, method, dt, dtype_key(dt)
        self.description = description
        self.n, self.n_params = info.n, info.n_params
        self.param_names = info.param_names
        self.n_coordinates = len(description.coordinate_names)
        self.eps = float(np.finfo(dt).eps)
        self.itemsize = dt.itemsize
        self.row_bytes = (self.n + 1 + 4 * max(self.n // 2, 1)) * self.itemsize   # as _check_size
        self.max_bytes, self.max_steps = max_bytes, max_steps
        self.tolerance = method in TOLERANCE_METHODS
        self.adaptive = method in ADAPTIVE
        self.single_chart = info.nguards > 0
        self.local_error = method in LOCAL_ERROR_METHODS
        self.lib = integrator_library(model)
        self.settings: dict[tuple, Settings] = {}
        self.checked: set[tuple] = set()
        self.make_result = result_factory(
            model=model, method=method, backend="c", dtype=self.dtype, energy=LAZY, positions=LAZY,
            velocities=LAZY, switches=0, chart_stop=model if self.single_chart else None,
            error_kind=LOCAL_SUM if self.local_error else None)

    # -- the arguments ----------------------------------------------------------------

    def params(self, params) -> list | None:
        """The parameter values in the model's order when plainly given (a mapping by
        exactly the model's names, or a sequence of the right length), or None."""
        names = self.param_names
        if type(params) is dict:
            if len(params) != len(names):
                return None
            try:
                params = [params[n] for n in names]
            except (KeyError, TypeError):
                return None
        return plain_numbers(params, len(names))

    def state(self, y0) -> list | None:
        """y0 when plainly a state of the model with no coordinate too large to move (the
        general path's _check_angles, with a margin: near its limit the general path decides)."""
        y = plain_numbers(y0, self.n)
        if y is None:
            return None
        q = y[:self.n_coordinates]
        if q and max(map(abs, q)) * self.eps > 0.5e-3:       # MAX_ANGLE_ULP / 2
            return None
        return y

    def fits(self, nt: int, span: float, s: Settings, budget_given: bool) -> bool:
        """Whether _check_size would let the run through (else the general path refuses it)."""
        if nt * self.row_bytes > self.max_bytes or not span - span == 0:
            return False
        steps = span / s.step if s.step else 0.0
        return steps <= self.max_steps and (budget_given or steps <= s.limit)

    # -- the run ----------------------------------------------------------------------

    def execute(self, s: Settings, struct, buf: np.ndarray, nt: int):
        """One C run: buf holds y0, then the parameters, then the nt output times (in the
        plan's dtype, contiguous): one pointer for all three.  -> SimulationResult."""
        n, np_, isz = self.n, self.n_params, self.itemsize
        out = np.empty((nt, n), self.dt)
        info = s.Info()
        base = address(buf)
        s.call(base, n, base + n * isz, 0, nt, base + (n + np_) * isz, address(out),
               _addressof(struct), _addressof(info))
        status = info.status
        t = buf[n + np_:]
        p = buf[n:n + np_]
        h_end = info.h_end
        return self.make_result(
            t=t, y=out, status=status, status_name=STATUS_NAMES[status], t_stop=info.t,
            y_stop=np.frombuffer(info, np.float64, n, s.y_offset), params=p,
            chart=np.array([self.model] * nt, dtype=object) if self.single_chart else None,
            observe=partial(_observe, self.model, out, p, self.dt),
            last_step=h_end if h_end and not self.tolerance else None,
            nfev=info.nfev, njev=info.njev, nsteps=info.nsteps, naccepted=info.naccepted,
            nrejected=info.nrejected, nnewton=info.nnewton,
            error_estimate=info.local_error if self.local_error else None)


def _observe(model: str, y: np.ndarray, p: np.ndarray, dt: np.dtype) -> tuple:
    """A run's energy, positions and velocities (on first access of one: result.py)."""
    return (*_observables(model, y, p, "c", dt), _velocities(model, y, p, "c", dt))



assert set(COUNTERS) == {"nfev", "njev", "nsteps", "naccepted", "nrejected", "nnewton"}, \
    "RunPlan.execute reads these counters by name"
