"""Runs on specialised kernels: ``simulate(..., specialise=True)``, ``ensemble(...,
specialise=True)`` and a scene's ``pendulum.specialise``.

A run that fixes its parameters may run the model's kernels with the values folded in
(derive/codegen/specialise.py: the derivation with the numbers substituted, then the
normal pipeline), compiled once per model and value set into the cache.  The run is then
the same call on the specialised model's name, with the same p (which its kernels no longer
read where a value is folded in): its checks, fast path and compiled call, dense output,
events and results are the general run's.  What it refuses, in one line: another backend
than the C one (the NumPy modules would print the values as Python floats, not in the
run's type), the chart atlas (a run across charts), and the double-double and quad rungs
(the run reads p exactly there, strings as exact decimals: specialised kernels take floats).

Bit for bit the runs differ from the general ones: each folded constant is rounded once
instead of after every operation that made it, so the two agree to rounding (a
fixed-step or Taylor run) or to the tolerance (an adaptive RK run, whose accept and reject
decisions rounding may tip): tests/runtime/test_specialised.py measures both.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import lru_cache

import numpy as np

from ..codegen.specialise import specialise as fold
from ..errors import SimulationInputError, SpecError
from ..model.description import forget_on_model_change

SPECIALISED_DTYPES = ("float32", "float64", "longdouble")     # the native rungs: compiled C literals


def check_specialise(specialise) -> bool:
    """The specialise= argument as a bool, or a one-line refusal of anything else."""
    if not isinstance(specialise, (bool, np.bool_)):
        raise SimulationInputError(f"specialise must be True or False, got {specialise!r}")
    return bool(specialise)


def refuse_unspecialisable(backend, dtype_key: str | None, atlas: bool, what: str = "simulate") -> None:
    """One line for what specialised kernels do not run: another backend, the chart atlas,
    the extended rungs (`dtype_key` None: one of them, or a dtype refused elsewhere)."""
    if backend != "c":
        raise SimulationInputError(f"specialise=True folds the parameters into compiled C: it runs with "
                                   f"backend='c', not {backend!r}")
    if atlas:
        raise SimulationInputError(f"specialise=True runs one chart's model, not the chart atlas: {what} "
                                   f"without specialise= for the atlas")
    if dtype_key not in SPECIALISED_DTYPES:
        raise SimulationInputError(f"specialise=True runs in {', '.join(SPECIALISED_DTYPES)} (the kernels' "
                                   f"constants are C literals of the run's type); the extended precisions "
                                   f"read p at run time: leave specialise= out")


def folded_model(name: str, names: Sequence[str], values, fixed=None) -> str:
    """The specialised model of `name` with the parameters `names` at `values` folded in
    (`fixed`: a mask of those to fold, default all), made on first use.

    Parameters
    ----------
    name : str
        A resolved single-chart model's name.
    names : sequence of str
        Its parameter names, in order.
    values : sequence of numbers
        Their values (a long double keeps all its bits).
    fixed : sequence of bool, optional
        Which to fold; the others stay run-time parameters.

    Returns
    -------
    str
        The specialised model's name (the model's own when nothing is folded).

    Raises
    ------
    SimulationInputError
        Values that leave the equations undefined.
    """
    chosen = tuple((n, v) for n, v, keep in zip(names, values, fixed if fixed is not None else [True] * len(names))
                   if keep)
    try:
        return _folded(name, chosen)
    except SpecError as exc:
        raise SimulationInputError(f"specialise=True: {exc}") from None


@forget_on_model_change
@lru_cache(maxsize=1024)
def _folded(name: str, chosen: tuple) -> str:
    """codegen's specialise(name, dict(chosen)), once per model and value set in a process
    (it reads the specialised derivation's cache entry: milliseconds, not a call's cost)."""
    return fold(name, dict(chosen))


class _Names(dict):
    """simulate's (model, params, backend, dtype) -> specialised name, for a repeated call
    (a dictionary lookup instead of the checks and the digest); forgotten when a model file
    read before changes, as the caches of model names are."""

    def cache_clear(self) -> None:
        self.clear()


KNOWN = forget_on_model_change(_Names())
KNOWN_MAX = 4096


def call_key(model, params, backend, dtype):
    """The key of a call's specialised model in KNOWN, or None (an argument that is no key:
    the call is resolved afresh).  Cheap for the common arguments (a repeated call's whole
    cost of specialise=True is this and one dictionary lookup): a tuple as it is, a dict by
    its items in their order, a list or an array by its values."""
    kind = type(params)
    if kind is not tuple:
        if kind is dict or isinstance(params, Mapping):
            params = ("by name", *params.items())
        elif kind is list:
            params = ("in order", *params)
        elif isinstance(params, np.ndarray):
            params = ("array", params.dtype.str, *params.ravel().tolist())
    key = (model, params, backend, dtype)
    try:
        hash(key)
    except TypeError:
        return None
    return key


def remember(key, name: str) -> None:
    if key is None:
        return
    if len(KNOWN) >= KNOWN_MAX:
        KNOWN.clear()
    KNOWN[key] = name
