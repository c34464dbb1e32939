"""The generated Taylor integrator (<model>_taylor.c) at run time: compiled once per order
and precision.

The order follows the tolerance (p = ceil(-ln(tol)/2 + 1), Jorba & Zou; the same rule
as the C, derive/codegen/taylor.py), and derive compiles the integrator
with that order fixed (-D<MODEL>_TAYLOR_ORDER=p).  Each order is one cached library, built
on first use with only the variant of the precision that runs, and with the jet in one of
its two forms (jet_form: -D<MODEL>_TAYLOR_COMPACT): unrolled by the compiler at that order
while the jet is small (it steps fastest there), compact past it (one loop per segment of
alike operations: faster per step for a large jet, and compiled in about a second where
the unrolled one takes minutes and gigabytes).  Only this library is compiled for a run.
The generic file, compiled without the order macro, reads the order from options.rtol,
for use in other projects.
"""
from __future__ import annotations

import os
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
from ..codegen.taylor import (LANES_UNROLL_COST, UNROLL_COST, jet_cost, rhs_decomposition, taylor_problem,
                              taylor_skip_flags, unroll_max)

# The jet's forms (templates/c/taylor.c.jinja): unrolled at the fixed order, or compact
# (a loop per segment of alike operations over index tables).  DERIVE_TAYLOR_JET picks one
# for every build; unset or "auto", jet_form chooses by size.
JET_FORMS = ("unrolled", "compact")
JET_ENV = "DERIVE_TAYLOR_JET"


def jet_form(model: str, order: int | None, lanes: bool = False) -> str:
    """The form of `model`'s jet a build at `order` compiles (None: the generic build, the
    order read at run time; `lanes`: of the SIMD lanes' file): $DERIVE_TAYLOR_JET if set
    (unrolled, compact or auto), else (auto) unrolled while the unrolled jet's cost at the
    order is within codegen.taylor.UNROLL_COST (LANES_UNROLL_COST for the lanes), compact
    past it; the generic build compact (its statements are not unrolled: the same speed)."""
    forced = os.environ.get(JET_ENV, "").strip().lower()
    if forced in JET_FORMS:
        return forced
    if forced not in ("", "auto"):
        raise SimulationInputError(f"{JET_ENV} must be unrolled, compact or auto, got {forced!r}")
    if order is None:
        return "compact"
    return "unrolled" if order <= _unroll_max(model, lanes) else "compact"


@forget_on_model_change
@lru_cache(maxsize=None)
def _unroll_max(model: str, lanes: bool) -> int:
    """The last order jet_form unrolls for `model` (once per model and process)."""
    return unroll_max(rhs_decomposition(model), LANES_UNROLL_COST if lanes else UNROLL_COST)


# An unrolled jet the rule would not choose (forced by DERIVE_TAYLOR_JET) past these costs
# (jet_cost) is compiled at -O1, which does not unroll it: at -O2 GCC's time and memory
# grow faster than the jet (a five-link chain at order 18, cost 50762: 67 s and 2.2 GB
# for the scalar jet, 299 s and 8.8 GB for the lanes'; a three-link chain, 16303: 5.6 s
# and 290 MB, lanes 28.5 s and 1.05 GB), at -O1 they stay near the compact jet's build
# (the five-link chain's scalar jet: 1.4 s, 115 MB).
O2_COST = 20000
LANES_O2_COST = 10000


def size_flags(model: str, order: int, form: str, lanes: bool = False) -> tuple[str, ...]:
    """The optimisation flags a build of `model`'s jet at `order` in `form` adds to the
    defaults (-O2): -O1 for an unrolled jet past O2_COST (LANES_O2_COST for the lanes)."""
    if form != "unrolled" or jet_cost(rhs_decomposition(model), order) <= (LANES_O2_COST if lanes else O2_COST):
        return ()
    return ("-O1",)


def form_flag(model: str, form: str) -> str:
    """-D<M>_TAYLOR_COMPACT=0|1: the jet's form in a build of <model>_taylor{,_quad}.c."""
    if form not in JET_FORMS:
        raise ValueError(f"unknown Taylor jet form {form!r} (known: {', '.join(JET_FORMS)})")
    return f"-D{model.upper()}_TAYLOR_COMPACT={int(form == 'compact')}"


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
    form : str
        The jet's form, unrolled or compact (JET_FORMS; taylor_library chooses it by size).
    """

    def __init__(self, model: str, order: int, dtype: str = "float64", form: str = "unrolled"):
        info = model_info(model)
        self.model, self.order, self.n, self.dtype, self.form = model, order, info.n, dtype, form
        self.n_params = info.n_params + info.n_inputs
        source = c_source(model, f"{model}_taylor.c")
        if not source.is_file():
            raise SimulationInputError(f"model '{model}' has no Taylor integrator: {taylor_problem(model)}")
        extra = (f"-D{model.upper()}_TAYLOR_ORDER={order}", form_flag(model, form), *size_flags(model, order, form),
                 *taylor_skip_flags(model, PRECISION[dtype].ctype))
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
    SINE_MIN, cancel none): a Taylor run takes it, so that it builds no RK library
    (<model>_integrate.c) to ask.  tests/runtime/test_taylor_explicit_time.py
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


def taylor_library(model: str, order: int, dtype: str = "float64", form: str | None = None) -> TaylorLibrary:
    """The Taylor integrator of `model` at `order` in the hardware precision `dtype`, built
    on first use (cached on disk and in this process); `form`: its jet's (JET_FORMS), None
    for jet_form's choice."""
    return _taylor_library(model, order, dtype, form or jet_form(model, order))


@forget_on_model_change
@lru_cache(maxsize=None)
def _taylor_library(model: str, order: int, dtype: str, form: str) -> TaylorLibrary:
    return TaylorLibrary(model, order, dtype, form)
