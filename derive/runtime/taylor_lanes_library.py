"""The lane-parallel Taylor integrator (<model>_taylor_lanes.c) at run time.

Compiled like the scalar one (taylor_library.py: one cached library per order, the order
fixed with -D<MODEL>_TAYLOR_ORDER=p, the jet unrolled or compact: jet_form, with the lanes'
own size limit) plus the lanes (-D<MODEL>_TAYLOR_LANES=L), only the
scalar type asked for (-D<MODEL>_TAYLOR_LANES_ONLY: with the order unrolled, each
scalar type's variant is a long compile, the long double one longest) and the vector
instructions this machine has (vector_build.SIMD_LEVELS, by the CPU's flags; none known: the
portable build, whose lane loops are SSE2 pairs on x86-64, plain loops elsewhere).  The numbers are the scalar
integrator's: -ffp-contract=off (a fused multiply-add rounds otherwise).
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from .loader import PORTABLE_FLAGS, build_library
from ..codegen.sources import c_source
from ..errors import BuildError, SimulationInputError
from ..model.description import forget_on_model_change
from .build import info_struct, run_batch
from .shared_library import SUFFIX, TAYLOR_LANES_BATCH, SharedLibrary
from .model_sizes import model_info
from ..codegen.taylor import taylor_problem
from .taylor_library import form_flag, jet_form, size_flags, taylor_library
from ..codegen.taylor_lanes import variant_number
from .vector_build import EXACT_FLAGS, simd_build

# long double has no vector unit (x87): its lanes are slower than the scalar integrator,
# so its ensembles run the scalar one
LANE_TYPES = ("float64", "float32")
# the portable flags, loops peeled (a few lanes stay in registers), no contraction; GCC
# and clang spellings.  sin, cos and the radius' root are derive_taylor_math.h's, the scalar
# integrator's (libm's past their ranges, lane by lane: there sin and cos may fuse into
# glibc's sincos, which gives sin's and cos' numbers; the tests compare every lane with
# the scalar run bit for bit).
LANES_FLAGS = (*PORTABLE_FLAGS, "-fpeel-loops", *EXACT_FLAGS)


class TaylorLanesLibrary(SharedLibrary):
    """ctypes access to <model>_taylor_lanes_batch{,_f,_l} for one scalar type, compiled
    with a fixed order (only that type: unrolled, each takes a while to compile) and its
    jet in `form` (taylor_library.JET_FORMS)."""

    def __init__(self, model: str, order: int, dtype: str = "float64", lanes: int | None = None,
                 simd: tuple[str, ...] | None = None, form: str = "unrolled"):
        info = model_info(model)
        self.model, self.order, self.n, self.dtype, self.form = model, order, info.n, dtype, form
        self.n_params = info.n_params + info.n_inputs
        source = c_source(model, f"{model}_taylor_lanes.c")
        if not source.is_file():
            raise SimulationInputError(f"model '{model}' has no Taylor integrator: {taylor_problem(model)}")
        flags, default_lanes = simd_build(dtype)
        self.lanes = lanes or default_lanes
        simd = flags if simd is None else simd
        M = model.upper()
        extra = (f"-D{M}_TAYLOR_ORDER={order}", form_flag(model, self.form), *size_flags(model, order, form, True),
                 f"-D{M}_TAYLOR_LANES={self.lanes}", f"-D{M}_TAYLOR_LANES_ONLY={variant_number(SUFFIX[dtype])}")
        stem = f"{model}_taylor_lanes{SUFFIX[dtype]}_p{order}_l{self.lanes}"
        path, self.flags = _build(stem, source, simd, extra)
        super().__init__(path)
        self.Info = info_struct(self.n)
        self.fns = self.bind_precisions(TAYLOR_LANES_BATCH, (dtype,), model=model)

    def run(self, y0: np.ndarray, p: np.ndarray, t: np.ndarray, opt) -> tuple:
        """As TaylorLibrary.run (y0 of this library's dtype): y0 (B, n), p (B, np) or (np,),
        t (nt,), opt the integrators' options struct -> y (B, nt, n), infos (B,)."""
        return run_batch(self.fns, self.Info, self.n, self.n_params, y0, p, t, opt)


def _build(stem: str, source: Path, simd: tuple[str, ...], extra: tuple[str, ...]) -> tuple[Path, tuple]:
    """The library with the vector flags, or without them where the compiler refuses them."""
    flags = (*LANES_FLAGS, *simd, *extra)
    try:
        return build_library(stem, [source], None, flags), flags
    except BuildError:
        if not simd:
            raise
    flags = (*LANES_FLAGS, *extra)
    return build_library(stem, [source], None, flags), flags


def taylor_ensemble_library(model: str, order: int, dtype: str):
    """What derive.ensemble runs method="taylor" with: the lanes, or for a scalar type
    without vector instructions the scalar integrator (the same interface: .run)."""
    if dtype in LANE_TYPES:
        return taylor_lanes_library(model, order, dtype)
    return taylor_library(model, order, dtype)


def taylor_lanes_library(model: str, order: int, dtype: str = "float64", lanes: int | None = None,
                         simd: tuple[str, ...] | None = None, form: str | None = None) -> TaylorLanesLibrary:
    """The lanes' Taylor integrator of `model` at `order` in `dtype`, built on first use
    (cached on disk and in this process); `lanes`, `simd`: the machine's by default;
    `form`: the jet's (taylor_library.JET_FORMS), None for jet_form's choice."""
    return _taylor_lanes_library(model, order, dtype, lanes, simd, form or jet_form(model, order, lanes=True))


@forget_on_model_change
@lru_cache(maxsize=None)
def _taylor_lanes_library(model: str, order: int, dtype: str, lanes: int | None, simd: tuple[str, ...] | None,
                          form: str) -> TaylorLanesLibrary:
    return TaylorLanesLibrary(model, order, dtype, lanes, simd, form)
