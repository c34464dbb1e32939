"""How a sweep partitions: the product of its axes as an N-D array, cut into chunks.

A chunk is a block of the array (whole trailing dimensions, a slab of the leading
ones) of about `chunk` trajectories (a little fewer where that makes the chunks their
own mirror image, mirror.py).  It is both one Dask task and one chunk of
every variable in the Zarr store, so a finished task writes whole store chunks
(no two tasks ever touch the same chunk) and its completion is one flag.
"""
from __future__ import annotations

import math

import numpy as np

from .sweep_file import Sweep


def chunk_shape(shape: tuple[int, ...], target: int) -> tuple[int, ...]:
    """Whole trailing dimensions while they fit in `target` trajectories, then a part
    of the next one, then 1 along the rest (C order: a chunk is contiguous)."""
    out, room = [], max(target, 1)
    for size in reversed(shape):
        take = min(size, max(room, 1))
        out.append(take)
        room //= max(size, 1)
    return tuple(reversed(out))


def mirror_chunks(shape: tuple[int, ...], chunks: tuple[int, ...], dims: tuple[int, ...]) -> tuple[int, ...]:
    """Chunks whose boundaries are their own mirror image along `dims` (so the mirror of a
    chunk is a chunk, mirror.py): a divisor of the dimension for its chunk size, the largest
    not above the size asked for, unless that is less than half of it (then as asked)."""
    out = list(chunks)
    for d in dims:
        if shape[d] % out[d]:
            divisor = max(c for c in range(1, out[d] + 1) if shape[d] % c == 0)
            out[d] = divisor if 2 * divisor >= out[d] else out[d]
    return tuple(out)


def _quantities_allow(sweep: Sweep) -> bool:
    """Every recorded quantity is one the mirror maps (not the Lyapunov exponent nor the
    energy error: their algorithms are not checked to be odd)."""
    return all(q == "final_state" or q.startswith("max_abs_")
               or (q.endswith("_time") and q[:-5] in {e.name for e in sweep.events}) for q in sweep.record)


def mirror_axes(sweep: Sweep) -> tuple[int, ...] | None:
    """The dimensions the mirror reverses (the state axes), or None when the sweep's
    grid is not its own mirror image."""
    if sweep.random_axes or not sweep.axes or not _quantities_allow(sweep):
        return None
    if sweep.free:                  # a loop's starts are solved onto it: not checked odd, computed whole
        return None
    states = {a.index for a in sweep.axes if a.target == "state"}
    if not states:
        return None
    base_zero = all(sweep.y0[i] == 0 for i in range(len(sweep.y0)) if i not in states)
    if not base_zero:
        return None
    dims = []
    for d, a in enumerate(sweep.grid_axes):
        if a.target == "state":
            if not np.array_equal(a.values, -a.values[::-1]):
                return None
            dims.append(d)
    return tuple(dims)


class Layout:
    def __init__(self, sweep: Sweep):
        self.shape = sweep.shape
        self.chunks = chunk_shape(self.shape, sweep.chunk)
        dims = mirror_axes(sweep)                 # the grid is its own mirror image along these
        if dims:
            self.chunks = mirror_chunks(self.shape, self.chunks, dims)
        self.grid = tuple(math.ceil(s / c) for s, c in zip(self.shape, self.chunks))
        self.count = math.prod(self.grid)

    def block(self, k: int) -> tuple[int, ...]:
        return tuple(int(i) for i in np.unravel_index(k, self.grid))

    def slices(self, k: int) -> tuple[slice, ...]:
        return tuple(slice(b * c, min((b + 1) * c, s))
                     for b, c, s in zip(self.block(k), self.chunks, self.shape))

    def block_shape(self, k: int) -> tuple[int, ...]:
        return tuple(s.stop - s.start for s in self.slices(k))


def chunk_inputs(sweep: Sweep, layout: Layout, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The initial states y0 (B, n) and parameter rows p (B, np) of chunk k, C order."""
    slices = layout.slices(k)
    index = np.meshgrid(*[np.arange(s.start, s.stop) for s in slices], indexing="ij")
    flat = [i.ravel() for i in index]
    B = flat[0].size if flat else 1
    y0 = np.repeat(sweep.y0[None, :], B, axis=0)
    p = np.repeat(sweep.p[None, :], B, axis=0)
    grid = sweep.grid_axes
    for axis in sweep.axes:
        dim = grid.index(axis) if not axis.random else len(grid)      # random: the sample dimension
        values = axis.values[flat[dim]]
        (y0 if axis.target == "state" else p)[:, axis.index] = values
    return y0, p
