"""The sweep's Zarr store: named coordinates, one variable per quantity, a flag per chunk.

Created once (metadata and coordinates only: every variable starts as its fill
value, NaN, and `status` as -1, "not run"), then filled chunk by chunk as tasks
finish: a chunk's values first, then its flag in `chunk_done`, so a sweep that is
stopped at any moment resumes with exactly the chunks whose flags are set.  The
store remembers which sweep it holds (a hash of everything that shapes the
numbers) and refuses to be resumed by another.
"""
from __future__ import annotations

import hashlib
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..paths import VERSION as __version__
from ..errors import UsageError
from .layout import Layout
from .sweep_file import SAMPLE_DIM, Sweep

DONE = "chunk_done"
NOT_RUN = -1                 # status of a trajectory whose chunk has not run


def identity(sweep: Sweep) -> str:
    """SHA-256 of what shapes the store's numbers (not of comments or layout of the file)."""
    s = sweep.scene
    h = hashlib.sha256()
    parts = {"version": __version__, "model": s.model, "model_text": sweep.model_text,
             "y0": sweep.y0.tolist(), "p": sweep.p.tolist(), "t": [s.t_start, s.t_stop, s.outputs],
             "accuracy": [s.method, s.rtol, s.atol, s.step], "record": sweep.record,
             "events": [(e.name, e.coordinate, e.level, e.accuracy) for e in sweep.events], "chunk": sweep.chunk,
             "axes": [(a.name, a.kind) for a in sweep.axes]}
    h.update(json.dumps(parts, sort_keys=True).encode())
    for a in sweep.axes:
        h.update(np.ascontiguousarray(a.values, float).tobytes())
    return h.hexdigest()


def _dataset(sweep: Sweep, layout: Layout, names: list[str]):
    import dask.array as da    # the sweep extra
    import xarray as xr    # the sweep extra
    coords = {a.name: (a.name, a.values, {"long_name": f"{a.name} ({a.target}, {a.kind})"})
              for a in sweep.grid_axes}
    if sweep.random_axes:
        coords[SAMPLE_DIM] = (SAMPLE_DIM, np.arange(sweep.shape[-1]))
        coords.update({a.name: (SAMPLE_DIM, a.values, {"long_name": f"{a.name} ({a.target}, {a.kind} samples)"})
                       for a in sweep.random_axes})
    data = {}
    for name in names:
        dtype, fill = (np.int8, NOT_RUN) if name == "status" else (np.float64, np.nan)
        data[name] = (sweep.dims, da.full(sweep.shape, fill, dtype=dtype, chunks=layout.chunks))
    done_dims = tuple(f"chunk_{d}" for d in sweep.dims)
    data[DONE] = (done_dims, da.zeros(layout.grid, dtype=np.int8, chunks=(1,) * len(layout.grid)))
    attrs = {"title": sweep.scene.title, "model": sweep.scene.model, "sweep_sha256": identity(sweep),
             "source": Path(sweep.source).name, "method": sweep.scene.method,
             "rtol": sweep.scene.rtol or 0.0, "t_start": sweep.scene.t_start, "t_stop": sweep.scene.t_stop,
             "derive_version": __version__, "variables": list(names),
             "status": "integrator status per trajectory: 0 ok, -1 not run (derive.codegen.contract)"}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _encoding(ds, names: list[str]) -> dict:
    enc = {name: {"_FillValue": NOT_RUN if name == "status" else np.nan} for name in names}
    enc[DONE] = {"_FillValue": 0}
    return enc


def open_store(path: Path, sweep: Sweep, layout: Layout, names: list[str]) -> set[int]:
    """Create the store at `path`, or reopen it to resume: -> the chunks already done."""
    path = Path(path)
    if path.exists():
        return done_chunks(path, sweep, layout)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}-", dir=path.parent))
    try:
        ds = _dataset(sweep, layout, names)
        ds.to_zarr(tmp / "store.zarr", mode="w", compute=False, encoding=_encoding(ds, names),
                  consolidated=False)
        (tmp / "store.zarr").rename(path)             # a reader never meets a half-made store
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return set()


def _group(path: Path, mode: str = "r"):
    import zarr    # the sweep extra
    try:
        return zarr.open_group(str(path), mode=mode)
    except Exception as exc:                # not a store, or a damaged one
        raise UsageError(f"'{path}' is not a sweep's Zarr store ({type(exc).__name__}: {exc}); "
                         f"give another --out or remove it") from None


def done_chunks(path: Path, sweep: Sweep, layout: Layout) -> set[int]:
    group = _group(path)
    held = group.attrs.get("sweep_sha256")
    if held != identity(sweep):
        raise UsageError(f"'{path}' holds another sweep (or one made by another derive version); "
                         f"give another --out or remove it")
    flags = np.asarray(group[DONE][...]).reshape(-1)
    if flags.size != layout.count:
        raise UsageError(f"'{path}' has {flags.size} chunks, this sweep {layout.count}; remove it")
    return {int(k) for k in np.flatnonzero(flags)}


class Writer:
    """Writes finished chunks into the store (values, then the chunk's flag)."""

    def __init__(self, path: Path, layout: Layout):
        self.group = _group(path, "r+")
        self.layout = layout

    def write(self, k: int, values: dict[str, np.ndarray]) -> None:
        where = self.layout.slices(k)
        for name, value in values.items():
            self.group[name][where] = value
        self.group[DONE][self.layout.block(k)] = 1


def load(path: Path):
    """The store as an xarray Dataset, read into memory."""
    import xarray as xr    # the sweep extra
    with xr.open_zarr(str(path), consolidated=False) as ds:
        ds = ds.load()
    order = [n for n in ds.attrs.get("variables", []) if n in ds] + [DONE]
    ds = ds[order + [n for n in ds.data_vars if n not in order]]
    for name in ("status", DONE):        # integers with a fill value come back as floats
        if name in ds:
            ds[name] = ds[name].fillna(NOT_RUN if name == "status" else 0).astype(np.int8)
    return ds
