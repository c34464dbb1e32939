"""simulate's common case in microseconds: the checks of a (model, method, dtype) run, made once.

A call of derive.simulate on a built model would spend most of its time in Python around a
C run of a microsecond or two: NumPy round trips of four-element lists, the checks
redone on every call.  A RunPlan holds what does not change between calls of one (model,
method, dtype): the model's sizes and names and the parameter vectors that passed the
model's physical checks.  The run is the runner's (derive/runtime/runner.py), the same
call the general path makes; its `settings` cache the validated options of each
distinct set of option arguments (with their ctypes structs and entry point).

The plan only accelerates.  `plain_numbers` and friends accept an argument only when it
is plainly valid (Python or float64 numbers, finite, of the right count); anything else,
valid or not, goes to simulate's general path, which gives every refusal its one line.
So no check is dropped, and the two paths return equal results (tests/test_fast_path.py).
"""
from __future__ import annotations

import numpy as np

from .build import dtype_key
from ..codegen.contract import ADAPTIVE, TOLERANCE_METHODS
from .model_sizes import model_info
from ..model import load_model
from .runner import Settings, runner_for

LIST_MAX = 64          # arrays up to this size are checked as Python lists (faster than NumPy's)
LONG_MAX = 10 ** 6     # longer output times: the general path (it checks their memory first)
INT_MAX = 2 ** 53      # a larger int is not exactly a double: left to the general path
SETTINGS_MAX = 256     # distinct option sets remembered per plan
CHECKED_MAX = 4096     # parameter vectors remembered per plan



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


class RunPlan:
    """The argument checks simulate's fast path makes of one (model, method, dtype) on the
    C backend, made once; the run itself is the runner's (`runner`, its `settings` the
    validated option sets)."""

    def __init__(self, model: str, method: str, dt: np.dtype, max_bytes: int, max_steps: float):
        """model: a resolved model name; max_bytes, max_steps: _check_size's limits."""
        info = model_info(model)
        description = load_model(model)
        if description.inputs or info.n_inputs or description.is_constrained:
            raise NotPlanned(model)         # a closed loop: its start is checked, its drift reported
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
        self.runner = runner_for(model, method, self.dtype)
        self.settings: dict[tuple, Settings] = self.runner.settings
        self.checked: set[tuple] = set()

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

    def compiled_checks(self, budget_given: bool) -> dict:
        """What the compiled call path (derive/runtime/compiled_call.py) checks, as this
        plan does: the names and remembered vectors of `params`, `state`'s angle limit,
        `fits`' limits.

        Parameters
        ----------
        budget_given : bool
            max_steps was given.

        Returns
        -------
        dict
            Fields of the call's spec (Runner.compiled_call).
        """
        return {"names": tuple(self.param_names), "checked": self.checked, "n_coordinates": self.n_coordinates,
                "eps": self.eps, "row_bytes": self.row_bytes, "max_bytes": self.max_bytes,
                "max_steps": self.max_steps, "budget_given": int(budget_given)}

    def fits(self, nt: int, span: float, s: Settings, budget_given: bool) -> bool:
        """Whether _check_size would let the run through (else the general path refuses it)."""
        if nt * self.row_bytes > self.max_bytes or not span - span == 0:
            return False
        steps = span / s.step if s.step else 0.0
        return steps <= self.max_steps and (budget_given or steps <= s.limit)
