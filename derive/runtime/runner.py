"""The one dispatch from (model, method, precision, backend) to compiled code.

A `Runner` owns what a caller of an integrator would otherwise choose for itself: the entry
point (the RK methods' library, Taylor's scalar integrator at the order for the
tolerance, its SIMD lanes for a batch, the extended-precision Taylor build, the chart
atlas' driver, the generated NumPy module), the options struct, the Taylor order (one
rule: contract.taylor_order) and the batch call (y0 batch, params batch, times -> y,
infos).  `derive.simulate` (its general path and its fast path alike), `derive.ensemble`,
the atlas and a sweep's runs call it:

    r = runner_for("planar", "dop853", "float64")
    y, infos, blocks = r.batch(y0s, p, t, r.options({"rtol": 1e-10}), threads=2)
    s = Settings(r, opt)                 # opt: simulate's run_options -> struct, entry point
    result = r.execute(s, s.struct, buf, nt)        # buf = (y0, p, t) -> SimulationResult

`Runner.settings` is the fast path's cache: its option arguments -> `Settings`.
"""
from __future__ import annotations

import ctypes
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache, partial

import numpy as np

from ..codegen.contract import (COUNTERS, LOCAL_ERROR_METHODS, METHODS, STATUS_NAMES, TAYLOR,
                                TOLERANCE_METHODS, taylor_order)
from .model_sizes import model_info
from ..codegen.sources import kernels
from ..model.atlas import find_atlas
from ..model.description import forget_on_model_change
from .atlas_library import atlas_library, numpy_atlas
from .build import address, integrator_library
from .extended import extended_taylor
from .loader import numpy_integrators
from .observables import _observables, _velocities
from . import compiled_call
from .result import LAZY, LOCAL_SUM, SimulationResult, result_factory
from .shared_library import info_state, stop_state
from .taylor_lanes_library import taylor_ensemble_library
from .taylor_library import taylor_library, taylor_options

# A batch run of Taylor's method (a sweep's) is not capped by hmax: the generated Taylor
# integrator caps its step's radius at hmax (the run's span when hmax is 0) before it
# applies the step factor (e^-2 ...), so a run shorter than a few steps would take ~8 steps
# of an eighth of the span.  An hmax past any span leaves Jorba and Zou's step as it is
# (the last step still ends on the run's end).
TAYLOR_HMAX = 1e300
MIN_BLOCK = 16          # trajectories per thread below which another thread does not pay

_addressof = ctypes.addressof


class Settings:
    """One validated set of options of a runner: the options dict, its ctypes struct and
    the pilot run's, and the single-trajectory entry point for them.

    Parameters
    ----------
    runner : Runner
    opt : dict
        The options as simulate's run_options makes them.
    pilot_steps : int or None
        The step budget of an adaptive run's pilot (None: no pilot struct).
    """
    __slots__ = ("opt", "struct", "pilot", "pilot_steps", "call", "Info", "step", "limit", "compiled")

    def __init__(self, runner: "Runner", opt: dict, pilot_steps: int | None = None):
        self.opt = opt
        self.struct = runner.options(opt)
        self.pilot_steps = pilot_steps
        self.pilot = None if pilot_steps is None else \
            runner.options(dict(opt, max_steps=min(pilot_steps, opt["max_steps"])))
        self.call, self.Info = runner.entry(opt["rtol"])
        # the step that bounds a run's step count (fixed: h; adaptive: hmax, 0: none)
        self.step = opt["hmax"] if runner.tolerance else opt["h"]
        self.limit = opt["max_steps"]
        self.compiled = None        # its compiled call (Runner.compiled_call), once made


class Runner:
    """The compiled run of one (model, method, precision, backend).

    Parameters
    ----------
    model : str
        A resolved model name, or an atlas' key.
    method : str
        One of contract.RUN_METHODS.
    dtype : str
        A precision key: float32, float64, longdouble, or (Taylor's method only)
        double-double or quad.
    backend : str
        "c" (the compiled generated C) or "numpy" (the generated NumPy modules).
    """

    def __init__(self, model: str, method: str, dtype: str = "float64", backend: str = "c"):
        self.model, self.method, self.dtype, self.backend = model, method, dtype, backend
        self.atlas = find_atlas(model)
        info = model_info(self.atlas.charts[0] if self.atlas is not None else model)
        self.n, self.n_params, self.n_inputs = info.n, info.n_params, info.n_inputs
        self.single_chart = self.atlas is None and info.nguards > 0
        self.timed = self.atlas is None and kernels(model)[0].is_time_dependent
        self.tolerance = method in TOLERANCE_METHODS
        self.local_error = method in LOCAL_ERROR_METHODS
        self.index = METHODS.index(method) if method in METHODS else None
        self.settings: dict[tuple, Settings] = {}     # the fast path's: option arguments -> Settings
        if dtype in ("float32", "float64", "longdouble"):
            self.dt = np.dtype(dtype)
            self.make_result = result_factory(
                model=model, method=method, backend=backend, dtype=dtype, energy=LAZY, positions=LAZY,
                velocities=LAZY, switches=0, chart_stop=model if self.single_chart else None,
                error_kind=LOCAL_SUM if self.local_error else None)

    # -- what runs ------------------------------------------------------------------------

    @property
    def lib(self):
        """The library whose options struct the run takes (the atlas': its own driver's; a
        Taylor run: the contract's defaults, TaylorOptions, so that it builds no RK library
        it does not run: only the jet's library is compiled)."""
        if self.method == TAYLOR:
            return taylor_options()
        return _rk_library(self.model, self.atlas)

    def order(self, rtol: float) -> int:
        """The Taylor order for a tolerance (contract.taylor_order, as the generated C)."""
        return taylor_order(rtol)

    def options(self, values: dict, uncapped: bool = False):
        """The options of a run: on the C backend the options struct for `values` over the
        C defaults, on the NumPy backend the values themselves (its integrators take them
        as keywords); `uncapped`: a Taylor run's step not capped by hmax (TAYLOR_HMAX, a
        batch of a sweep)."""
        if uncapped and self.method == TAYLOR:
            values = dict(values, hmax=TAYLOR_HMAX)
        if self.backend == "numpy":
            return dict(values)
        return self.lib.options(values)

    def entry(self, rtol: float) -> tuple:
        """(the single-trajectory entry point with its leading arguments bound, its info
        struct): one trajectory of the RK library's method, or Taylor's scalar integrator."""
        fn, index, Info = self.entry_point(rtol)
        return (partial(fn, 1) if index is None else partial(fn, 1, index)), Info

    def entry_point(self, rtol: float) -> tuple:
        """(the batch entry point, its method argument or None for Taylor's, which has
        none, its info struct)."""
        if self.method == TAYLOR:
            taylor = taylor_library(self.model, self.order(rtol), self.dtype)
            return taylor.fns[self.dtype], None, taylor.Info
        lib = self.lib
        return lib.fns[self.dtype], self.index, lib.Info

    def batch_library(self, rtol: float):
        """The library a batch runs in (its .run(y0, p, t, opt)): Taylor's SIMD lanes
        (bit for bit the scalar integrator's numbers), or the RK library."""
        if self.method == TAYLOR:
            return taylor_ensemble_library(self.model, self.order(rtol), self.dtype)
        return _MethodBound(self.lib, self.index)

    def numpy_integrator(self):
        """The generated NumPy module the numpy backend runs (its integrate)."""
        if self.atlas is not None:
            return numpy_atlas(self.model)
        return numpy_integrators(self.model)

    def exact_library(self, rtol: float):
        """The extended-precision Taylor build (double-double, quad) for a tolerance."""
        return extended_taylor(self.model, self.dtype, self.order(rtol))

    # -- the calls ------------------------------------------------------------------------

    def batch(self, y0: np.ndarray, p: np.ndarray, t: np.ndarray, opt, threads: int = 1) -> tuple:
        """B trajectories in `threads` contiguous blocks at once (ctypes releases the GIL);
        on the NumPy backend one call of the generated integrate_batch, in this thread.

        Parameters
        ----------
        y0 : ndarray (B, n)
            In the runner's dtype.
        p : ndarray (np,) or (B, np)
            The parameters (with the inputs), one vector for all or one row per trajectory.
        t : ndarray (nt,)
        opt : options struct or dict
            From `options` (its rtol sets a Taylor run's order).
        threads : int

        Returns
        -------
        y : ndarray (B, nt, n)
        infos : list of info structs (C) or of dicts (NumPy), one per trajectory
        blocks : int
            How many blocks ran.
        """
        if self.backend == "numpy":
            _, y, infos = self.numpy_integrator().integrate_batch(self.method, y0, p, t, self.dt, **opt)
            return y, list(infos), 1
        library = self.batch_library(opt.rtol)
        B = len(y0)
        blocks = max(1, min(threads, B // MIN_BLOCK))
        p = np.ascontiguousarray(p)
        if blocks == 1:
            y, infos = library.run(y0, p, t, opt)
            return y, list(infos), 1
        edges = np.linspace(0, B, blocks + 1).astype(int)
        shared = p.ndim == 1

        def block(ab):
            a, b = ab
            return library.run(y0[a:b], p if shared else p[a:b], t, opt)
        with ThreadPoolExecutor(max_workers=blocks) as pool:
            parts = list(pool.map(block, zip(edges[:-1], edges[1:])))
        return np.concatenate([y for y, _ in parts]), [i for _, infos in parts for i in infos], blocks

    def atlas_batch(self, charts0, y0: np.ndarray, p: np.ndarray, t: np.ndarray, opt) -> tuple:
        """The chart atlas from y0 (B, n) in charts0 (B,) -> y, charts, infos."""
        return atlas_library(self.model).run(self.index, charts0, y0, p, t, opt)

    def execute(self, s: Settings, struct, buf: np.ndarray, nt: int):
        """One C run: buf holds y0, then the parameters (with the inputs), then the nt
        output times (in the runner's dtype, contiguous): one pointer for all three.

        Returns
        -------
        SimulationResult
        """
        n, n_p, isz = self.n, self.n_params, self.dt.itemsize
        n_all = n_p + self.n_inputs
        out = np.empty((nt, n), self.dt)
        info = s.Info()
        base = address(buf)
        s.call(base, n, base + n * isz, 0, nt, base + (n + n_all) * isz, address(out),
               _addressof(struct), _addressof(info))
        status = info.status
        t = buf[n + n_all:]
        p = buf[n:n + n_p]
        h_end = info.h_end
        return self.make_result(
            t=t, y=out, status=status, status_name=STATUS_NAMES[status], t_stop=info.t,
            y_stop=info_state(info, n, self.dt), params=p,
            chart=np.array([self.model] * nt, dtype=object) if self.single_chart else None,
            observe=partial(_observe, self.model, out, p, self.dt, "c", t if self.timed else None),
            last_step=h_end if h_end and not self.tolerance else None,
            nfev=info.nfev, njev=info.njev, nsteps=info.nsteps, naccepted=info.naccepted,
            nrejected=info.nrejected, nnewton=info.nnewton,
            error_estimate=info.local_error if self.local_error else None)

    def compiled_call(self, s: Settings, struct, checks: dict, finish: dict):
        """The run of `execute` with the settings `s` and options `struct`, compiled with
        its argument checks and its result (derive/runtime/compiled_call.py): a callable
        (y0, t, params) -> SimulationResult or None, or None where there is none (the
        extension not built; a chart model, whose results name their chart).

        Parameters
        ----------
        s : Settings
        struct : options struct
            The one the run passes (s.pilot or s.struct).
        checks : dict
            The argument checks of the call (RunPlan.compiled_checks).
        finish : dict
            The result's fields simulate's _finish sets (rtol or step and guard, sol).

        Returns
        -------
        compiled_call.Call or None
        """
        if self.backend != "c" or self.single_chart or self.atlas is not None or self.n_inputs or \
                self.dtype not in compiled_call.REALS or not compiled_call.available():
            return None
        fn, index, Info = self.entry_point(s.opt["rtol"])
        offsets = {name: getattr(Info, name).offset for name in ("status", "t", "h_end", "local_error", "y", *COUNTERS)}
        spec = dict(checks, entry=ctypes.cast(fn, ctypes.c_void_p).value, method=-1 if index is None else index,
                    n=self.n, n_params=self.n_params, real=compiled_call.REALS[self.dtype],
                    tolerance=int(self.tolerance), local_error=int(self.local_error),
                    info_size=ctypes.sizeof(Info), offsets=offsets, options=_addressof(struct),
                    options_owner=struct, step=s.step, limit=s.limit, status_names=STATUS_NAMES,
                    cls=SimulationResult, prototype={**self.make_result.prototype, **finish},
                    partial=partial, observe=_observe, model=self.model, dtype=self.dt, backend="c")
        return compiled_call.make_call(spec)

    def numpy_run(self, y0: np.ndarray, p: np.ndarray, pm: np.ndarray, t: np.ndarray, opt: dict):
        """One run of the generated NumPy module (p with the inputs, pm without).

        Returns
        -------
        SimulationResult
        """
        dt = self.dt
        status, y, inf = self.numpy_integrator().integrate(self.method, y0, p, t, dt, **opt)
        h_end = float(inf["h_end"])
        nt = len(t)
        return self.make_result(
            t=t, y=y, status=status, status_name=STATUS_NAMES[status], t_stop=float(inf["t"]),
            y_stop=stop_state(inf["y"], dt), params=pm,
            chart=np.array([self.model] * nt, dtype=object) if self.single_chart else None,
            observe=partial(_observe, self.model, y, pm, dt, "numpy", t),
            last_step=h_end if h_end and not self.tolerance else None,
            error_estimate=float(inf["local_error"]) if self.local_error else None,
            **{k: int(inf[k]) for k in COUNTERS})


class _MethodBound:
    """The RK library with its method chosen: the batch interface of the Taylor libraries."""

    def __init__(self, lib, index: int):
        self.lib, self.index = lib, index

    def run(self, y0, p, t, opt):
        return self.lib.run(self.index, y0, p, t, opt)


def _observe(model: str, y: np.ndarray, p: np.ndarray, dt: np.dtype, backend: str, t=None) -> tuple:
    """A run's energy, positions and velocities (on first access of one: result.py); t, the
    output times, for a time-dependent model's kernels (a moving pivot's positions)."""
    return (*_observables(model, y, p, backend, dt, t), _velocities(model, y, p, backend, dt, t))


def _rk_library(model: str, atlas):
    """The library the RK methods of `model` run in: an atlas' driver, or the model's
    integrator library (built on first use)."""
    return atlas_library(model) if atlas is not None else integrator_library(model)


def library_path(model: str):
    """The compiled library the RK methods of `model` (a resolved model name or an atlas'
    key) run in, built now if it is not in the build cache: the library every runner of
    the model takes its options struct from.

    Returns
    -------
    pathlib.Path
    """
    return _rk_library(model, find_atlas(model)).path


@forget_on_model_change
@lru_cache(maxsize=256)
def runner_for(model: str, method: str, dtype: str = "float64", backend: str = "c") -> Runner:
    """The runner of (model, method, dtype, backend), made once (a resolved model name)."""
    return Runner(model, method, dtype, backend)


assert set(COUNTERS) == {"nfev", "njev", "nsteps", "naccepted", "nrejected", "nnewton"}, \
    "Runner.execute reads these counters by name"
