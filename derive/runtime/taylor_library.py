"""The generated Taylor integrator (<model>_taylor.c) at run time: compiled once per order
and precision.

The order follows the tolerance (p = ceil(-ln(tol)/2 + 1), Jorba & Zou; the same rule
as the C, derive/codegen/taylor.py), and derive compiles the integrator
with that order fixed (-D<MODEL>_TAYLOR_ORDER=p), which lets the compiler unroll the
recurrences (the generic build loops over an order read at run time).  Each order is one
cached library, built on first use with only the variant of the precision that runs
(compiling the four unrolled variants takes about four times as long); the generic file, compiled without the
macro, reads the order from options.rtol, for use in other projects.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .loader import build_fastest
from .vector_build import EXACT_FLAGS, simd_build
from ..codegen.sources import c_source
from ..errors import BuildError, SimulationInputError
from ..model.description import forget_on_model_change
from .build import OptionsCache, address, dtype_key, info_struct, options_struct, run_batch
from .shared_library import SUFFIX, TAYLOR_BATCH, TAYLOR_COEFFICIENTS, TAYLOR_COEFFICIENTS_TIMED, SharedLibrary
from .model_sizes import model_info
from ..codegen.contract import OPTIONS, PRECISION, SINE_MIN
from ..codegen.sources import kernels
from ..codegen.taylor import taylor_problem, taylor_skip_flags


class TaylorLibrary(SharedLibrary):
    """ctypes access to <model>_taylor_batch{,_f,_l}, one of them, compiled with a fixed order.

    Parameters
    ----------
    model : str
        A resolved model name.
    order : int
        The Taylor order compiled in (contract.taylor_order of the tolerance).
    dtype : str
        The hardware precision compiled in (a key of contract.PRECISION: float32,
        float64, longdouble); fns and coefficient_fns hold its entry points only.
    """

    def __init__(self, model: str, order: int, dtype: str = "float64"):
        info = model_info(model)
        self.model, self.order, self.n, self.dtype = model, order, info.n, dtype
        self.n_params = info.n_params + info.n_inputs
        source = c_source(model, f"{model}_taylor.c")
        if not source.is_file():
            raise SimulationInputError(f"model '{model}' has no Taylor integrator: {taylor_problem(model)}")
        extra = (f"-D{model.upper()}_TAYLOR_ORDER={order}", *taylor_skip_flags(model, PRECISION[dtype].ctype))
        path, self.flags = _build(f"{model}_taylor_p{order}{SUFFIX[dtype]}", source, extra)
        super().__init__(path)
        self.Info = info_struct(self.n)
        self.timed = kernels(model)[0].is_time_dependent
        self.fns = self.bind_precisions(TAYLOR_BATCH, dtypes=(dtype,), model=model)
        self.coefficient_fns = self.bind_precisions(TAYLOR_COEFFICIENTS_TIMED if self.timed else TAYLOR_COEFFICIENTS,
                                                    dtypes=(dtype,), model=model)

    def run(self, y0: np.ndarray, p: np.ndarray, t: np.ndarray, opt) -> tuple:
        """y0 (B, n), p (B, np) or (np,), t (nt,), opt: the integrators' options struct
        (from IntegratorLibrary.options: the same layout) -> y (B, nt, n), infos (B,)."""
        return run_batch(self.fns, self.Info, self.n, self.n_params, y0, p, t, opt)

    def coefficients(self, y: np.ndarray, p: np.ndarray, sine_min: float = 0.0, t: float = 0.0
                     ) -> tuple[int, np.ndarray]:
        """(status, the normalised Taylor coefficients (n, order + 1)) of the solution through
        y (at the time t: a time-dependent model's; an autonomous model's jet reads no t)."""
        dt = dtype_key(y.dtype)
        y = np.ascontiguousarray(y)
        p = np.ascontiguousarray(p, dtype=y.dtype)
        out = np.empty((self.n, self.order + 1), y.dtype)
        at = (address(np.array([t], y.dtype)),) if self.timed else ()
        st = self.coefficient_fns[dt](*at, address(y), address(p), int(self.order), address(out),
                                      float(sine_min))
        return int(st), out


def _build(stem: str, source, extra: tuple[str, ...]):
    """The library with this machine's vector instructions (the lanes' flags, as scalar code:
    three-operand instructions and twice the registers for the unrolled jet) and no
    contraction, as the lanes are built (so that each lane stays bit for bit this run);
    without them where the compiler refuses them."""
    simd = simd_build("float64")[0]
    if simd:
        try:
            return build_fastest(stem, [source], extra=(*simd, *EXACT_FLAGS, *extra))
        except BuildError:
            pass
    return build_fastest(stem, [source], extra=(*EXACT_FLAGS, *extra))


class TaylorOptions(OptionsCache):
    """The options struct of the Taylor integrator filled with the contract's defaults, as
    <model>_integrate_defaults fills it (codegen/contract.py OPTIONS: sine_min the model's
    SINE_MIN, cancel none): a time-dependent model's Taylor run takes it, so that it
    builds no RK library (<model>_integrate.c) to ask.  tests/runtime/test_taylor_explicit_time.py
    holds it equal to <model>_integrate_defaults."""

    def __init__(self):
        self.Options = options_struct()

    def defaults(self):
        opt = self.Options()
        for f in OPTIONS:
            value = float(SINE_MIN) if f.name == "sine_min" else f.default     # SINE_MIN: as C prints it
            if value is not None:
                setattr(opt, f.name, value)
        return opt


@lru_cache(maxsize=None)
def taylor_options() -> TaylorOptions:
    """The one TaylorOptions (the struct is the same for every model)."""
    return TaylorOptions()


@forget_on_model_change
@lru_cache(maxsize=None)
def taylor_library(model: str, order: int, dtype: str = "float64") -> TaylorLibrary:
    """The Taylor integrator of `model` at `order` in the hardware precision `dtype`, built
    on first use (cached on disk and in this process)."""
    return TaylorLibrary(model, order, dtype)
