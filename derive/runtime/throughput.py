"""The batched RK4 and fixed-step loops, built and called: ctypes access to the files
derive.codegen.loops renders (<model>_throughput.c, <model>_fixed.c) and the NumPy
module of the batched loop.

    tp = throughput_library("planar")
    y, status, steps = tp.rk4(y0s, p, h, nsteps, threads=2)     # y0s (B, 4)
    y, done = fixed_library("planar").run("abm12", y0, p, h, nsteps)
"""
from __future__ import annotations

import ctypes
import os
import platform
import threading
from functools import lru_cache

import numpy as np

from .loader import LoaderError, build_fastest, build_library, numpy_module
from .shared_library import FIXED_STEPS, FIXED_STEPS_TIMED, THROUGHPUT_RK4, THROUGHPUT_RK4_TIMED, SharedLibrary
from ..codegen.names import VECTOR_MATH
from ..codegen.sources import c_source
from ..model.description import forget_on_model_change
from ..codegen.loops import BLOCK, FIXED_METHODS, takes_time

PORTABLE_FLAGS = ("-std=c99", "-O3", "-ffp-contract=off", "-fPIC", "-shared")
VECTOR_FLAGS = ("-std=c99", "-O3", "-march=native", "-ffp-contract=off", "-fopenmp-simd",
                *(f"-fno-builtin-{f}" for f in VECTOR_MATH), "-DDERIVE_VECTOR_MATH",
                "-fPIC", "-shared", "-Wl,--no-as-needed", "-lmvec")


# -- build and call -------------------------------------------------------------

class ThroughputLibrary(SharedLibrary):
    """ctypes access to <model>_throughput_rk4; `vector_math` says whether libmvec is in use."""

    def __init__(self, model: str, vector_math: bool | None = None):
        self.model = model
        src = c_source(model, f"{model}_throughput.c")
        if not src.is_file():
            raise LoaderError(f"model '{model}' has no batched loop (its rhs has a chart guard)")
        attempts = [VECTOR_FLAGS, PORTABLE_FLAGS]
        if vector_math is False or platform.system() != "Linux" or platform.machine() != "x86_64":
            attempts = [PORTABLE_FLAGS]
        elif vector_math is True:
            attempts = [VECTOR_FLAGS]
        last = None
        for flags in attempts:
            try:
                path = build_library(f"{model}_throughput", [src], flags=flags)
                self.flags = flags
                break
            except LoaderError as exc:          # no libmvec, no -march=native: portable build
                last = exc
        else:
            raise last
        self.vector_math = self.flags is VECTOR_FLAGS
        super().__init__(path)
        self.timed = takes_time(model)      # the rhs has t: the loop takes the start time
        self.fn = self.bind(THROUGHPUT_RK4_TIMED if self.timed else THROUGHPUT_RK4, model=model)
        self.n = self.value(ctypes.c_int, f"{model}_throughput_n_states").value
        self.n_params = self.value(ctypes.c_int, f"{model}_throughput_n_params").value

    def rk4_soa(self, y: np.ndarray, p, h: float, nsteps: int, threads: int | None = None, t_start: float = 0.0):
        """In place on y (n_states, B) float64 C-contiguous, from the time t_start (a
        time-dependent model's; the others ignore it); -> (status (B,), steps (B,))."""
        if y.dtype != np.float64 or not y.flags.c_contiguous or y.ndim != 2 or y.shape[0] != self.n:
            raise ValueError(f"y must be a C-contiguous float64 array of shape ({self.n}, B)")
        p = np.ascontiguousarray(p, dtype=np.float64).reshape(self.n_params)
        B = y.shape[1]
        status = np.zeros(B, np.intc)
        steps = np.zeros(B, np.int64)
        threads = max(1, min(threads or os.cpu_count() or 1, max(1, B // BLOCK)))
        bounds = np.linspace(0, B, threads + 1).astype(int)
        bounds[1:-1] = (bounds[1:-1] // BLOCK) * BLOCK        # whole blocks per thread
        failed = [0] * threads

        def work(k):
            a, e = int(bounds[k]), int(bounds[k + 1])
            time = (float(t_start),) if self.timed else ()
            failed[k] = self.fn(e - a, y.ctypes.data + 8 * a, B, p.ctypes.data, *time, float(h), int(nsteps),
                                status.ctypes.data + status.itemsize * a, steps.ctypes.data + 8 * a)

        if threads == 1:
            work(0)
        else:            # ctypes releases the GIL: one OS thread per slice
            pool = [threading.Thread(target=work, args=(k,)) for k in range(threads)]
            for t in pool:
                t.start()
            for t in pool:
                t.join()
        return status, steps

    def rk4(self, y0, p, h: float, nsteps: int, threads: int | None = None, t_start: float = 0.0):
        """y0 (B, n_states) at t_start -> (y (B, n_states), status (B,), steps completed (B,))."""
        y = np.ascontiguousarray(np.asarray(y0, np.float64).reshape(-1, self.n).T)
        status, steps = self.rk4_soa(y, p, h, nsteps, threads, t_start)
        return y.T.copy(), status, steps


class FixedLibrary(SharedLibrary):
    """ctypes access to <model>_fixed_<method> (generated/c/<model>_fixed.c, built as the
    integrators are, by loader.build_fastest): one trajectory, a fixed step, the rhs inlined."""

    def __init__(self, model: str):
        self.model = model
        src = c_source(model, f"{model}_fixed.c")
        if not src.is_file():
            raise LoaderError(f"model '{model}' has no fixed-step loops (its rhs has a chart guard)")
        path, self.flags = build_fastest(f"{model}_fixed", [src])
        super().__init__(path)
        self.timed = takes_time(model)      # the rhs has t: the loops take the start time
        entry = FIXED_STEPS_TIMED if self.timed else FIXED_STEPS
        self.fns = {method: self.bind(entry, model=model, suffix=method) for method in FIXED_METHODS}

    def run(self, method: str, y0, p, h: float, nsteps: int, t_start: float = 0.0) -> tuple[np.ndarray, int]:
        """From y0 at t_start (a time-dependent model's; the others ignore it) -> (state after
        the steps completed, steps completed)."""
        if method not in self.fns:
            raise ValueError(f"unknown fixed-step method '{method}' (known: {', '.join(self.fns)})")
        y = np.array(y0, dtype=np.float64).reshape(-1)
        p = np.ascontiguousarray(p, dtype=np.float64)
        time = (float(t_start),) if self.timed else ()
        done = self.fns[method](*time, y.ctypes.data, p.ctypes.data, float(h), int(nsteps))
        return y, int(done)


@forget_on_model_change
@lru_cache(maxsize=None)
def fixed_library(model: str) -> FixedLibrary:
    return FixedLibrary(model)


@forget_on_model_change
@lru_cache(maxsize=None)
def throughput_library(model: str) -> ThroughputLibrary:
    return ThroughputLibrary(model)


@forget_on_model_change
@lru_cache(maxsize=None)
def throughput_numpy(model: str):
    return numpy_module(f"{model}_throughput")

