"""Compile the generated integrators (with their kernels) into a cached shared library.

A library is built from several generated sources (``<model>_integrate.c`` and
``<model>.c``; the atlas adds the three chart models) by
derive.runtime.loader.build_library, whose cache key hashes every source and
header, the compiler identity and the flags, so any change rebuilds.
"""
from __future__ import annotations

import ctypes
from functools import lru_cache

import numpy as np

from .loader import build_fastest
from .shared_library import (CTYPES, INTEGRATE_BATCH, INTEGRATE_DEFAULTS, SUFFIX, SharedLibrary, info_struct,
                             options_struct)
from ..codegen.sources import c_source
from ..model.description import forget_on_model_change
from .model_sizes import model_info

__all__ = ["CTYPES", "SUFFIX", "IntegratorLibrary", "OptionsCache", "address", "dtype_key", "info_struct",
           "integrator_library", "options_struct", "run_batch"]


@lru_cache(maxsize=64)
def dtype_key(dtype) -> str:
    """float32, float64 or longdouble (numpy names long double float128 or float96)."""
    dtype = np.dtype(dtype)
    return "longdouble" if dtype == np.longdouble and dtype != np.float64 else dtype.name


def address(a: np.ndarray) -> int:
    """The data pointer of a contiguous array, for a c_void_p argument: the address of a
    ctypes view of the buffer, the cheapest way to it (a.ctypes.data_as makes ctypes
    objects per call, costing more than a short run in C; the array interface builds a
    dict)."""
    try:
        return _addressof(_char_view(a))
    except (TypeError, ValueError):        # read-only or empty: the array interface
        return a.__array_interface__["data"][0]


_addressof, _char_view = ctypes.addressof, ctypes.c_char.from_buffer


class OptionsCache:
    """The options structs of a library, one per distinct set of values (the integrators
    only read them: const).  A subclass sets `Options` (the struct type) and `_defaults`
    (its bound C function that fills a struct with the defaults)."""

    def defaults(self):
        """The options struct as the library's defaults function fills it."""
        opt = self.Options()
        self._defaults(ctypes.addressof(opt))
        return opt

    def options(self, values: dict):
        """The options struct for `values` (field -> value; the rest the C defaults),
        built once per distinct set of values.  A run's own cancel flag makes a struct
        of its own (a pointer is no cache key)."""
        if values.get("cancel") is not None:
            return self._filled(values)
        cache = self.__dict__.setdefault("_options", {})
        key = tuple(values.items())
        opt = cache.get(key)
        if opt is None:
            if len(cache) > 256:
                cache.clear()
            opt = cache[key] = self._filled(values)
        return opt

    def _filled(self, values: dict):
        opt = self.defaults()
        for k, v in values.items():
            setattr(opt, k, v)
        return opt


class IntegratorLibrary(OptionsCache, SharedLibrary):
    """The RK methods of one model: <model>_integrate_batch{,_f,_l} and the options struct.

    Parameters
    ----------
    model : str
        A resolved model name.
    n, n_params : int
        Its states and its parameters with its inputs (the integrators take p = (params, inputs)).
    """

    def __init__(self, model: str, n: int, n_params: int):
        self.model, self.n, self.n_params = model, n, n_params
        src = [c_source(model, f"{model}_integrate.c"), c_source(model, f"{model}.c")]
        path, self.flags = build_fastest(f"{model}_integrate", src)
        super().__init__(path)
        self.Options = options_struct()
        self.Info = info_struct(n)
        self._defaults = self.bind(INTEGRATE_DEFAULTS, model=model)
        self.fns = self.bind_precisions(INTEGRATE_BATCH, model=model)

    def run(self, method: int, y0: np.ndarray, p: np.ndarray, t: np.ndarray, opt) -> tuple:
        """y0 (B, n), p (B, np) or (np,), t (nt,) -> y (B, nt, n), infos (B,)."""
        return run_batch(self.fns, self.Info, self.n, self.n_params, y0, p, t, opt, method)


@lru_cache(maxsize=32)
def _infos_type(Info: type, batch: int) -> type:
    return Info * batch


def run_batch(fns: dict, Info: type, n: int, n_params: int, y0: np.ndarray, p: np.ndarray,
              t: np.ndarray, opt, method: int | None = None) -> tuple:
    """Call a generated batch entry point (<model>_integrate_batch or _taylor_batch, by
    dtype in `fns`; `method` first where it takes one): y0 (B, n), p (B, np) or (np,),
    t (nt,) -> y (B, nt, n), infos (B,)."""
    dt = dtype_key(y0.dtype)
    y0 = np.ascontiguousarray(y0)
    B = y0.shape[0]
    p = np.ascontiguousarray(p, dtype=y0.dtype)
    pstride = 0 if p.ndim == 1 else n_params
    t = np.ascontiguousarray(t, dtype=y0.dtype)
    out = np.empty((B, len(t), n), y0.dtype)
    infos = _infos_type(Info, B)()
    head = (B,) if method is None else (B, method)
    fns[dt](*head, address(y0), n, address(p), pstride, len(t), address(t), address(out),
            ctypes.addressof(opt), ctypes.addressof(infos))
    return out, infos


@forget_on_model_change
@lru_cache(maxsize=None)
def integrator_library(model: str) -> IntegratorLibrary:
    info = model_info(model)
    return IntegratorLibrary(model, info.n, info.n_params + info.n_inputs)   # p = (params, inputs)
