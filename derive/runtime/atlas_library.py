"""The compiled chart atlas (<prefix>.c with its charts' integrators and kernels) at run
time, and its generated NumPy module: what derive/runtime/atlas_runner.py runs."""
from __future__ import annotations

import ctypes
from functools import lru_cache

import numpy as np

from ..codegen import contract
from .model_sizes import model_info
from ..codegen.sources import c_source
from ..model.atlas import ATLAS, load_atlas
from .build import OptionsCache, build_fastest, dtype_key, info_struct, options_struct
from .loader import numpy_module
from .shared_library import ATLAS_BATCH, ATLAS_CHOOSE_CHART, ATLAS_DEFAULTS, CTYPES, SharedLibrary


class AtlasLibrary(OptionsCache, SharedLibrary):
    """The compiled atlas `name` (its driver and its members' integrators and kernels).

    Parameters
    ----------
    name : str
        An atlas of derive/model/catalog/atlases.toml (or of a user's chain).
    """

    def __init__(self, name: str = ATLAS):
        self.atlas = load_atlas(name)
        P = self.atlas.prefix
        info = model_info(self.atlas.charts[0])
        self.n, self.n_params = info.n, info.n_params
        sources = [c_source(name, f"{P}.c")]       # the charts' files are beside it
        for ch in self.atlas.charts:
            sources += [c_source(name, f"{ch}_integrate.c"), c_source(name, f"{ch}.c")]
        path, self.flags = build_fastest(P, sources)
        super().__init__(path)
        self.Options = options_struct(contract.ATLAS_OPTIONS)
        self.Info = info_struct(self.n, contract.ATLAS_INFO)
        self._defaults = self.bind(ATLAS_DEFAULTS, model=P)
        self.choose_chart = self.bind_precisions(ATLAS_CHOOSE_CHART, model=P)
        self.fns = self.bind_precisions(ATLAS_BATCH, model=P)

    def run(self, method: int, charts0, y0: np.ndarray, p: np.ndarray, t: np.ndarray, opt):
        """y0 (B, n) in charts0 (B,) (-1: standard chart, rule picks) -> y, charts, infos."""
        dt = dtype_key(y0.dtype)
        ptr = ctypes.POINTER(CTYPES[dt])
        y0 = np.ascontiguousarray(y0)
        B = y0.shape[0]
        c0 = np.ascontiguousarray(np.broadcast_to(np.asarray(charts0, np.intc), (B,)))
        p = np.ascontiguousarray(p, dtype=y0.dtype)
        pstride = 0 if p.ndim == 1 else self.n_params
        t = np.ascontiguousarray(t, dtype=y0.dtype)
        out = np.empty((B, len(t), self.n), y0.dtype)
        charts = np.empty((B, len(t)), np.intc)
        infos = (self.Info * B)()
        ip = ctypes.POINTER(ctypes.c_int)
        self.fns[dt](B, method, c0.ctypes.data_as(ip), y0.ctypes.data_as(ptr), self.n,
                     p.ctypes.data_as(ptr), pstride, len(t), t.ctypes.data_as(ptr),
                     out.ctypes.data_as(ptr), charts.ctypes.data_as(ip), ctypes.addressof(opt),
                     ctypes.addressof(infos))
        return out, charts, infos


@lru_cache(maxsize=None)
def atlas_library(name: str = ATLAS) -> AtlasLibrary:
    return AtlasLibrary(name)


@lru_cache(maxsize=None)
def numpy_atlas(name: str = ATLAS):
    return numpy_module(load_atlas(name).prefix)
