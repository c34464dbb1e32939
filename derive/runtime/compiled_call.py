"""simulate's plain call compiled: from its Python arguments to its result in one C call.

Measured (cProfile and timed loops of `derive.simulate` on a trivial span), a plain call
spent about a tenth of its time in the integrator and in ctypes' conversion of its
arguments, the rest in Python around them: reading and checking the arguments, filling
the buffer, reading the info struct, building the result and its continuous solution.
So the call itself is compiled: c/compiled_call.c is a CPython extension module, built
on first use into derive's build cache with the C compiler derive already uses (as the
kernels are: derive/runtime/loader.py), against this Python's and NumPy's headers.  A
`Call` of it holds one runner's settings (Runner.compiled_call); called with (y0, t,
params) it makes simulate's fast-path checks in C, calls the runner's entry point and
returns the SimulationResult, or None for anything not plainly valid (then the Python
fast path runs, which refuses bad input with its one line).  Where the extension cannot be
built (no Python headers, no compiler), simulate runs the Python fast path as before.

The Python fast path registers the Call of each set of option arguments it has run
(`register`), so the second call with them is compiled; `lookup` finds it by simulate's
own arguments.  Cleared when a model file is read again with new content.
"""
from __future__ import annotations

import importlib.machinery
import importlib.util
import sys
import sysconfig
from pathlib import Path

import numpy as np

from ..errors import BuildError
from ..model.description import forget_on_model_change
from ..codegen.contract import STATUS
from .loader import build_library

SOURCE = Path(__file__).with_name("c") / "compiled_call.c"
MODULE = "_derive_compiled_call"
FLAGS = ("-std=c11", "-O2", "-fPIC", "-shared")
CALLS_MAX = 256          # registered calls kept (then forgotten, and registered again on use)
REALS = {"float32": 0, "float64": 1, "longdouble": 2}      # compiled_call.c's REAL_* codes
MAX_STEPS_STATUS = STATUS["MAX_STEPS"]      # a pilot stopped at its step budget: simulate goes on


class _Extension:
    """The compiled module, built and imported once per process (None where it cannot be);
    `dispatch` its simulate's arguments -> result (None until it is built)."""
    module = None
    tried = False
    dispatch = None

    @classmethod
    def get(cls):
        if not cls.tried:
            cls.tried = True
            cls.module = _build_and_import()
            if cls.module is not None:
                cls.module.use(_calls, MAX_STEPS_STATUS)
                cls.dispatch = cls.module.dispatch
        return cls.module


COMPILED = _Extension    # simulate reads COMPILED.dispatch: None, or the compiled dispatch


def _build_and_import():
    """The extension module, or None where it cannot be built (the Python fast path runs)."""
    include = sysconfig.get_paths().get("include")
    if not include or not (Path(include) / "Python.h").is_file():
        return None
    flags = (*FLAGS, "-I", include, "-I", np.get_include(),
             f"-DDERIVE_ABI={sys.implementation.cache_tag}_{np.__version__}")
    try:
        path = build_library(MODULE, [SOURCE], flags=flags)
    except BuildError:
        return None
    loader = importlib.machinery.ExtensionFileLoader(MODULE, str(path))
    spec = importlib.util.spec_from_file_location(MODULE, str(path), loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def available() -> bool:
    """Whether the compiled call path is built (building it on the first call).

    Returns
    -------
    bool
        False where it cannot be built (no Python headers, no compiler): simulate's Python
        fast path runs then.
    """
    return _Extension.get() is not None


class _Calls(dict):
    """The registered calls by simulate's arguments (call_key), and the keys run once."""

    def __init__(self):
        super().__init__()
        self.once: set = set()

    def cache_clear(self) -> None:          # forget_on_model_change's hook
        self.clear()
        self.once.clear()
        self.changed()

    def changed(self) -> None:
        """Tell the compiled dispatch, which remembers the call it found last."""
        if _Extension.module is not None:
            _Extension.module.forget()


_calls = forget_on_model_change(_Calls())


def lookup(key: tuple):
    """The registered call of simulate's option arguments.

    Parameters
    ----------
    key : tuple
        From call_key.

    Returns
    -------
    Call or None
        None: none registered (or an unhashable argument).
    """
    try:
        return _calls.get(key)
    except TypeError:              # an unhashable argument: the Python paths decide
        return None


def call_key(model, method, dtype, rtol, atol, step, hmax, max_steps, newton_tol, newton_max, sine_min) -> tuple:
    """The key of a call's option arguments as simulate received them.

    Parameters
    ----------
    model, method, dtype, rtol, atol, step, hmax, max_steps, newton_tol, newton_max, sine_min
        simulate's arguments of those names, as given (method None included).

    Returns
    -------
    tuple
        The key c/compiled_call.c's dispatch makes of them (equal arguments are one key, as
        in the fast path's settings).
    """
    return (model, method, dtype, rtol, atol, step, hmax, max_steps, newton_tol, newton_max, sine_min)


def seen_twice(key: tuple) -> bool:
    """Whether simulate has run with these option arguments before (a call made once is
    not worth building the extension for); remembers them.

    Parameters
    ----------
    key : tuple
        From call_key.

    Returns
    -------
    bool
    """
    try:
        if key in _calls.once:
            return True
        if len(_calls.once) >= CALLS_MAX:
            _calls.once.clear()
        _calls.once.add(key)
    except TypeError:
        pass
    return False


def register(key: tuple, call) -> None:
    """Remember a compiled call for simulate's option arguments.

    Parameters
    ----------
    key : tuple
        From call_key.
    call : Call or None
        Runner.compiled_call's (None: nothing to remember).
    """
    if call is None:
        return
    if len(_calls) >= CALLS_MAX:
        _calls.clear()
    try:
        _calls[key] = call
    except TypeError:
        pass
    _calls.changed()


def make_call(spec: dict):
    """A Call of the extension.

    Parameters
    ----------
    spec : dict
        What the call holds (Runner.compiled_call fills it: c/compiled_call.c's call_new
        reads it).

    Returns
    -------
    Call or None
        None where the extension is not available.
    """
    module = _Extension.get()
    return None if module is None else module.Call(spec)


__all__ = ["REALS", "available", "call_key", "lookup", "make_call", "register", "seen_twice", "COMPILED"]
