"""The sweep's Zarr store: named coordinates, one variable per quantity, a flag per chunk.

Created once (metadata and coordinates only: every variable starts as its fill
value, NaN, and `status` as -1, "not run"), then filled chunk by chunk as tasks
finish: a chunk's values first, then its flag in `chunk_done`, so a sweep that is
stopped at any moment resumes with exactly the chunks whose flags are set.  The
store remembers which sweep it holds (a hash of everything that shapes the
numbers) and refuses to be resumed by another.

A flag alone could lie (a chunk file deleted or damaged after its flag was set reads
back as fill values, or fails to decode): so before its flag, every chunk's SHA-256 of
its values as stored is written, atomically, to `<store>.sha256/<k>` beside it; on resume
and on opening (`load`) every chunk marked done is read back and checked against it,
and one that is missing, undecodable or different is named in one line and recomputed
(`load` refuses a store with one).  A process killed between the values and the flag
leaves the flag unset: the chunk is computed again.  One sweep writes a store at a
time: a second is refused (an exclusive flock on `<store>.lock` beside it).
"""
from __future__ import annotations

from types import SimpleNamespace

import fcntl
import hashlib
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..paths import VERSION as __version__
from ..errors import UsageError
from .layout import Layout
from ..model.energy_scale import SCALE_TEXT
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
    if s.guard is not None:              # abm12's guard (only where given: older stores keep their hash)
        parts["guard"] = list(s.guard)
    h.update(json.dumps(parts, sort_keys=True).encode())
    for a in sweep.axes:
        h.update(np.ascontiguousarray(a.values, float).tobytes())
    return h.hexdigest()


# what a variable is, where its name does not say it all
VARIABLE_ATTRS = {"energy_error": {"long_name": f"largest |E - E0| / {SCALE_TEXT} over the samples "
                                                f"(m g l: the depth of the potential well, derive.model.energy_scale)"},
                  "constraint_drift": {"long_name": "a closed loop's largest |Phi| or |J q'| over the samples "
                                                    "(its drift off the constraints)"}}


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
        data[name] = (sweep.dims, da.full(sweep.shape, fill, dtype=dtype, chunks=layout.chunks),
                      VARIABLE_ATTRS.get(name, {}))
    done_dims = tuple(f"chunk_{d}" for d in sweep.dims)
    data[DONE] = (done_dims, da.zeros(layout.grid, dtype=np.int8, chunks=(1,) * len(layout.grid)))
    attrs = {"title": sweep.scene.title, "model": sweep.scene.model, "sweep_sha256": identity(sweep),
             "source": Path(sweep.source).name, "method": sweep.scene.method,
             "rtol": sweep.scene.rtol or 0.0, "t_start": sweep.scene.t_start, "t_stop": sweep.scene.t_stop,
             "derive_version": __version__, "variables": list(names),
             "status": "integrator status per trajectory: 0 ok, -1 not run (derive.codegen.contract)"
                       + ("; 6 bad input: a start where the loop does not close" if sweep.free else "")}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _encoding(ds, names: list[str]) -> dict:
    """NaN marks a value not computed; the integer arrays (status, chunk_done) have no CF
    _FillValue, which would make xarray read them back as floats: open_store writes their
    initial values (-1: not run; 0: not done) instead."""
    enc = {name: {"_FillValue": None if name == "status" else np.nan} for name in names}
    enc[DONE] = {"_FillValue": None}
    return enc


def open_store(path: Path, sweep: Sweep, layout: Layout, names: list[str]) -> set[int]:
    """Create the store at `path`, or reopen it to resume: -> the chunks already done."""
    path = Path(path)
    if path.exists():
        return done_chunks(path, sweep, layout)
    path.parent.mkdir(parents=True, exist_ok=True)
    shutil.rmtree(digests(path), ignore_errors=True)      # of a store removed before
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}-", dir=path.parent))
    try:
        ds = _dataset(sweep, layout, names)
        ds.to_zarr(tmp / "store.zarr", mode="w", compute=False, encoding=_encoding(ds, names),
                  consolidated=False)
        group = _group(tmp / "store.zarr", "r+")
        if "status" in names:
            group["status"][...] = NOT_RUN
        group[DONE][...] = 0
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
    done = {int(k) for k in np.flatnonzero(flags)}
    bad = damaged_chunks(path, group, layout, done)
    if bad:
        print(f"derive: {path}: {len(bad)} chunk{'s' * (len(bad) != 1)} marked done "
              f"{'are' if len(bad) != 1 else 'is'} missing or damaged ({_listed(bad)}): "
              f"computing {'them' if len(bad) != 1 else 'it'} again", file=sys.stderr)
        writable = _group(path, "r+")
        for k in bad:
            writable[DONE][layout.block(k)] = 0
            _digest_path(path, k).unlink(missing_ok=True)
    return done - set(bad)


DIGESTS = ".sha256"           # <store>.sha256/<chunk>: beside the store (Zarr lists what is in it)


def _listed(chunks: list[int]) -> str:
    shown = ", ".join(str(k) for k in chunks[:10])
    return f"chunk{'s' * (len(chunks) != 1)} {shown}" + (f" and {len(chunks) - 10} more" if len(chunks) > 10 else "")


def _digest_path(path: Path, k: int) -> Path:
    return digests(path) / str(k)


def digests(path: Path) -> Path:
    return Path(path).with_name(Path(path).name + DIGESTS)


def _digest(arrays) -> str:
    h = hashlib.sha256()
    for name, value in arrays:
        h.update(name.encode() + b"\0")
        h.update(np.ascontiguousarray(value).tobytes())
    return h.hexdigest()


def _chunk_names(group) -> list[str]:
    return sorted(n for n in group.array_keys() if n != DONE and n not in group.attrs.get("coords", ()))


def damaged_chunks(path: Path, group, layout: Layout, done: set[int]) -> list[int]:
    """The chunks marked done whose values, read back, are missing, undecodable or not
    the ones written (their digest)."""
    names = [n for n in group.attrs.get("variables", []) if n in group]
    bad = []
    for k in sorted(done):
        try:
            held = _digest_path(path, k).read_text().strip()
            where = layout.slices(k)
            arrays = [(n, np.asarray(group[n][where])) for n in names]
        except Exception:                   # no digest, a chunk that does not decode
            bad.append(k)
            continue
        if _digest(arrays) != held:
            bad.append(k)
    return bad


class Lock:
    """An exclusive lock on a store (flock on `<store>.lock`): one writer at a time."""

    def __init__(self, path: Path):
        self.path = Path(path).with_name(Path(path).name + ".lock")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(self.fd)
            raise UsageError(f"'{path}' is being written by another sweep (it holds {self.path}); "
                             f"wait for it, or give another --out") from None

    def release(self) -> None:
        if self.fd is not None:
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
            self.fd = None


class Writer:
    """Writes finished chunks into the store (values, then the chunk's flag)."""

    def __init__(self, path: Path, layout: Layout):
        self.path = Path(path)
        self.group = _group(path, "r+")
        self.layout = layout
        self.names = [n for n in self.group.attrs.get("variables", []) if n in self.group]

    def write(self, k: int, values: dict[str, np.ndarray]) -> None:
        """The chunk's values, then their digest (atomically), then its flag."""
        where = self.layout.slices(k)
        for name, value in values.items():
            self.group[name][where] = value
        arrays = [(n, np.asarray(self.group[n][where])) for n in self.names]     # as stored
        digest = _digest_path(self.path, k)
        digest.parent.mkdir(exist_ok=True)
        tmp = digest.with_name(f".{k}.tmp")
        tmp.write_text(_digest(arrays) + "\n")
        os.replace(tmp, digest)
        self.group[DONE][self.layout.block(k)] = 1


def load(path: Path):
    """The store as an xarray Dataset, read into memory; a chunk marked done that is
    missing or damaged is refused, by name (`derive sweep` into the store recomputes it)."""
    import xarray as xr    # the sweep extra
    group = _group(Path(path))
    if DONE in group and digests(path).is_dir():
        flags = np.asarray(group[DONE][...])
        grid = flags.shape
        shape = group[group.attrs["variables"][0]].shape
        blocks = group[group.attrs["variables"][0]].chunks

        def slices(k):
            idx = np.unravel_index(k, grid)
            return tuple(slice(i * b, min((i + 1) * b, n)) for i, b, n in zip(idx, blocks, shape))
        layout = SimpleNamespace(slices=slices)
        bad = damaged_chunks(Path(path), group, layout, {int(k) for k in np.flatnonzero(flags.reshape(-1))})
        if bad:
            raise UsageError(f"'{path}': {len(bad)} chunk{'s' * (len(bad) != 1)} marked done "
                             f"{'are' if len(bad) != 1 else 'is'} missing or damaged ({_listed(bad)}); "
                             f"run the sweep into it again to recompute them")
    with xr.open_zarr(str(path), consolidated=False) as ds:
        ds = ds.load()
    order = [n for n in ds.attrs.get("variables", []) if n in ds] + [DONE]
    ds = ds[order + [n for n in ds.data_vars if n not in order]]
    for name in ("status", DONE):        # integers with a _FillValue (older stores) come back as floats
        if name in ds:
            ds[name] = ds[name].fillna(NOT_RUN if name == "status" else 0).astype(np.int8)
    return ds
