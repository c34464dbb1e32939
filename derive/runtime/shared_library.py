"""One compiled shared library, opened once, its entry points bound from declarations.

Every ctypes wrapper of derive (the integrators, Taylor's scalar, lane and extended
integrators, the atlas, the throughput and fixed-step loops, the kernels, the
benchmarks' hand-written peers) is a `SharedLibrary`: the library is opened here and
nowhere else, and an entry point is bound from an `EntryPoint` declaration (its symbol,
with ``{model}`` and ``{suffix}`` filled in, and its C types as words), so no wrapper
repeats ctypes' argtypes by hand.  The structs a run passes (options, info) are made
from the run contract's field lists (derive/codegen/contract.py).

    lib = SharedLibrary(path)
    batch = lib.bind(INTEGRATE_BATCH, model="planar", suffix="_l")
    fns = lib.bind_precisions(INTEGRATE_BATCH, model="planar")   # dtype key -> function
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..codegen import contract

_REALS = {"double": ctypes.c_double, "float": ctypes.c_float, "long double": ctypes.c_longdouble}
# the hardware rungs of the precision ladder (the contract's table): ctypes type, suffix
CTYPES = {p.key: _REALS[p.ctype] for p in contract.PRECISION_TABLE if not p.taylor_only}
SUFFIX = {p.key: p.suffix for p in contract.PRECISION_TABLE if not p.taylor_only}

# C types as a declaration spells them; "real" is the scalar of the precision bound
_WORDS = {"void": None, "int": ctypes.c_int, "long": ctypes.c_long, "double": ctypes.c_double,
          "void *": ctypes.c_void_p, "int *": ctypes.POINTER(ctypes.c_int)}


@dataclass(frozen=True)
class EntryPoint:
    """The declaration of one C entry point.

    Parameters
    ----------
    symbol : str
        Its name, with ``{model}`` and ``{suffix}`` (the precision's) to fill in.
    returns : str
        The C type it returns (a word of the table above, or "real").
    args : tuple of str or None
        The C types of its arguments ("real" and "real *": the bound precision's scalar);
        None leaves ctypes' argtypes unset (the caller passes ctypes values).
    """
    symbol: str
    returns: str = "long"
    args: tuple[str, ...] | None = None


# the batch entry points' arguments, in order (derive/templates: <model>_integrate.h and
# the Taylor headers): B, [method,] y0, its row stride, p, its row stride (0: shared),
# nt, t, out, options, infos
_BATCH_ARGS = ("void *", "long", "void *", "long", "long", "void *", "void *", "void *", "void *")
INTEGRATE_BATCH = EntryPoint("{model}_integrate_batch{suffix}", "long", ("long", "int", *_BATCH_ARGS))
INTEGRATE_DEFAULTS = EntryPoint("{model}_integrate_defaults", "void", ("void *",))
TAYLOR_BATCH = EntryPoint("{model}_taylor_batch{suffix}", "long", ("long", *_BATCH_ARGS))
TAYLOR_LANES_BATCH = EntryPoint("{model}_taylor_lanes_batch{suffix}", "long", ("long", *_BATCH_ARGS))
TAYLOR_COEFFICIENTS = EntryPoint("{model}_taylor_coefficients{suffix}", "int",
                                 ("void *", "void *", "int", "void *", "double"))
# a time-dependent model's: the time first (a pointer to one value, as its kernels take t)
TAYLOR_COEFFICIENTS_TIMED = EntryPoint("{model}_taylor_coefficients{suffix}", "int",
                                       ("void *", "void *", "void *", "int", "void *", "double"))
# the atlas (spherical_atlas.h): the charts in and out beside the states
ATLAS_BATCH = EntryPoint("{model}_integrate_batch{suffix}", "long",
                         ("long", "int", "int *", "real *", "long", "real *", "long", "long", "real *",
                          "real *", "int *", "void *", "void *"))
ATLAS_DEFAULTS = EntryPoint("{model}_defaults", "void", ("void *",))
ATLAS_CHOOSE_CHART = EntryPoint("{model}_choose_chart{suffix}", "int", ("int", "real *", "real *", "real"))
THROUGHPUT_RK4 = EntryPoint("{model}_throughput_rk4", "long",
                            ("long", "void *", "long", "void *", "double", "long", "void *", "void *"))
FIXED_STEPS = EntryPoint("{model}_fixed_{suffix}", "long", ("void *", "void *", "double", "long"))
# a time-dependent model's loops take the start time first (t_start; the throughput loop's after p)
THROUGHPUT_RK4_TIMED = EntryPoint("{model}_throughput_rk4", "long", ("long", "void *", "long", "void *", "double",
                                                                       "double", "long", "void *", "void *"))
FIXED_STEPS_TIMED = EntryPoint("{model}_fixed_{suffix}", "long", ("double", "void *", "void *", "double", "long"))


# the contract's field types (options and info structs)
_FIELD_TYPES = {"double": ctypes.c_double, "long double": ctypes.c_longdouble, "long": ctypes.c_long, "int": ctypes.c_int,
                "const volatile int *": ctypes.POINTER(ctypes.c_int)}


def ctypes_fields(fields, n: int = 0) -> list[tuple]:
    """(name, ctypes type) of contract fields (derive/codegen/contract.py); arrays get length n."""
    return [(f.name, _FIELD_TYPES[f.ctype] * n if f.length else _FIELD_TYPES[f.ctype]) for f in fields]


def info_state(info, n: int, dtype) -> np.ndarray:
    """The state an info struct holds (its long double y), as a run of `dtype` reports it.

    Parameters
    ----------
    info : ctypes.Structure
        An info struct (info_struct's type), of a run of n states.
    n : int
        The number of states.
    dtype : numpy dtype
        The run's real type.

    Returns
    -------
    ndarray, shape (n,)
        A copy: np.longdouble for a long double run (its full precision), float64 for a
        float or double run (exactly its value).
    """
    return stop_state(np.frombuffer(info, np.longdouble, n, type(info).y.offset), dtype)


def stop_state(y, dtype) -> np.ndarray:
    """A run's stop state as a result reports it (a NumPy run's info["y"], say).

    Parameters
    ----------
    y : array_like
        The state.
    dtype : numpy dtype
        The run's real type.

    Returns
    -------
    ndarray
        np.longdouble for a long double run, else float64.
    """
    return np.array(y, np.longdouble if np.dtype(dtype) == np.longdouble else np.float64)


def options_struct(extra: tuple = ()) -> type:
    """The <model>_integrate_options struct (extra: contract fields appended, e.g. the atlas')."""
    return type("Options", (ctypes.Structure,), {"_fields_": ctypes_fields(contract.OPTIONS + tuple(extra))})


def info_struct(n: int, extra: tuple = ()) -> type:
    """The <model>_integrate_info struct for n states (extra: contract fields appended)."""
    return type("Info", (ctypes.Structure,), {"_fields_": ctypes_fields(contract.INFO + tuple(extra), n)})


def _ctype(word: str, real):
    if word == "real":
        return real
    if word == "real *":
        return ctypes.POINTER(real)
    return _WORDS[word]


class SharedLibrary:
    """A compiled shared library, opened once, with entry points bound from declarations.

    Parameters
    ----------
    path : path-like
        The library (a build of derive.runtime.loader.build_library, or any).

    Attributes
    ----------
    path : pathlib.Path
    lib : ctypes.CDLL
        The open library (``lib[symbol]`` gives a fresh function object each time, so
        two wrappers of one library never share argtypes).
    """

    def __init__(self, path):
        self.path = Path(path)
        self.lib = ctypes.CDLL(str(self.path))

    def bind(self, entry: EntryPoint, real=ctypes.c_double, **names):
        """The function `entry` names (``{model}``, ``{suffix}`` from `names`), typed.

        Parameters
        ----------
        entry : EntryPoint
        real : ctypes type
            What "real" stands for in the declaration.
        **names : str
            The fields of the symbol (model, suffix).
        """
        fn = self.lib[entry.symbol.format(**names)]
        fn.restype = _ctype(entry.returns, real)
        if entry.args is not None:
            fn.argtypes = [_ctype(word, real) for word in entry.args]
        return fn

    def bind_precisions(self, entry: EntryPoint, dtypes=tuple(SUFFIX), **names) -> dict:
        """{dtype key: `entry` in that precision} for the hardware rungs in `dtypes`."""
        return {dt: self.bind(entry, CTYPES[dt], suffix=SUFFIX[dt], **names) for dt in dtypes}

    def value(self, ctype, symbol: str):
        """The value of the exported variable `symbol` of C type `ctype`."""
        return ctype.in_dll(self.lib, symbol)
