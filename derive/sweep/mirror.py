"""The mirror symmetry of a sweep: half of it computed, the other half its mirror image.

Many pendulum models are odd: f(-y) = -f(y) (no constant torque, gravity along
the axis the angles are measured from), so the motion from -y0 is the mirror image
of the motion from y0, y(t) -> -y(t).  A sweep over initial angles on symmetric
grids, from zero rates (or with every state an axis), then holds each trajectory
twice: the flip map's value at (-theta1, -theta2) is its value at (theta1, theta2).
Where a sweep has the symmetry, each chunk's mirror image is a chunk too, and one
task computes the pair: its own values, and its mirror's by reversing the mirrored
axes (and negating final states; event times, their errors, maxima of |q| and the
status are the same).

Exact, not approximate: derive's integrators and kernels are odd to the bit (sin,
products and sums change sign exactly; norms, tolerances and step sizes see only
|y|), so the mirror of a computed chunk is what computing it gives, bit for bit;
the grids are made symmetric to the bit (spec.symmetric).  `plan` checks all of it
before using it, the oddness on the integrators themselves: trajectories of the sweep
(for each parameter row its axes make, at most MAX_PARAMETER_ROWS) and their mirror
images, integrated over the whole span by every integrator the sweep uses, must agree
to the bit, else the sweep is computed whole.  ([sweep] mirror = false turns it off.)
"""
from __future__ import annotations

import itertools

import numpy as np

from .layout import Layout, mirror_axes
from .runners import model_name, runner, scene_runner
from .sweep_file import Sweep
from .verify import rungs

MIRRORED = "final_"                 # the quantities that change sign: the final states
CHECKS = 6                          # trajectories integrated twice by plan (and their mirrors)
MAX_PARAMETER_ROWS = 64             # parameter rows the check covers; more: no mirror


def plan(sweep: Sweep, layout: Layout) -> dict[int, int] | None:
    """chunk -> its mirror chunk, or None (no mirror: compute every chunk).  Runs where
    the chunks run (a task on a cluster): it integrates a few trajectories."""
    if not sweep.mirror:
        return None
    dims = mirror_axes(sweep)
    if dims is None:
        return None
    for d in dims:                       # the chunk boundaries must be symmetric too
        if layout.shape[d] % layout.chunks[d]:
            return None
    pairs = {}
    for k in range(layout.count):
        block = list(layout.block(k))
        for d in dims:
            block[d] = layout.grid[d] - 1 - block[d]
        pairs[k] = int(np.ravel_multi_index(block, layout.grid))
    return pairs if _odd_to_the_bit(sweep, model_name(sweep)) else None


def _odd_to_the_bit(sweep: Sweep, model: str) -> bool:
    """Trajectories of the sweep and their mirror images, over the whole span with every
    integrator the sweep uses (its method, and the verification's runs): every sample the
    negative of the other's, to the bit.  Each parameter row the axes make is checked (a
    parameter may be a constant torque: odd at 0 only), at most MAX_PARAMETER_ROWS."""
    held = [a for a in sweep.grid_axes if a.target != "state"]
    states = [a for a in sweep.grid_axes if a.target == "state"]
    combos = list(itertools.islice(itertools.product(*(a.values for a in held)), MAX_PARAMETER_ROWS + 1))
    if len(combos) > MAX_PARAMETER_ROWS:
        return False
    rng = np.random.default_rng(0)
    y0, p = [], []
    for values in combos:
        row = sweep.p.copy()
        for a, v in zip(held, values):
            row[a.index] = v
        for _ in range(max(1, CHECKS // len(combos))):
            y = sweep.y0.copy()
            for a in states:
                y[a.index] = a.values[rng.integers(len(a.values))]
            y0.append(y)
            p.append(row)
    y0, p = np.array(y0), np.array(p)
    t = np.linspace(sweep.scene.t_start, sweep.scene.t_stop, sweep.scene.outputs)
    runs = [(scene_runner(sweep, model), np.float64)]
    if any(e.accuracy is not None for e in sweep.events):
        runs += [(runner(model, sweep.scene.method, rtol, atol), dtype) for rtol, atol, dtype in rungs(sweep.scene)]
    for run, dtype in runs:
        y, status = run(y0.astype(dtype), p.astype(dtype), t.astype(dtype))
        ym, status_m = run(-y0.astype(dtype), p.astype(dtype), t.astype(dtype))
        if not (np.array_equal(status, status_m) and np.array_equal(y, -ym, equal_nan=True)):
            return False
    return True


def mirrored(values: dict[str, np.ndarray], dims: tuple[int, ...]) -> dict[str, np.ndarray]:
    """The mirror chunk's values from a chunk's: the mirrored axes reversed, final states negated."""
    out = {}
    for name, value in values.items():
        flipped = np.flip(value, axis=dims) if dims else value
        out[name] = -flipped if name.startswith(MIRRORED) else flipped.copy()
    return out
