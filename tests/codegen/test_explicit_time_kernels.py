"""A time-dependent model's kernels take the time t (issue 23 item 3): first, as a vector
of one slot, in C (`<m>_rhs(t, y, p, ydot)`) and NumPy (`rhs(t, y, p)`); a
time-independent model's signatures are unchanged (the golden generated/ tree shows it)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from derive.model import load_model
from derive.runtime.loader import load, numpy_module

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
POINTS = 20


def hand_written(t, y, p):
    """theta'' of the driven pivot from its Lagrangian, written by hand: the pivot at
    (a cos wt, 0) accelerates by -a w^2 cos(wt) along x, a force m a w^2 cos(wt) along +x
    in the pivot's frame, whose torque about the pivot is m a w^2 cos(wt) l cos(theta)."""
    m, l, g, a, w = p.T
    theta = y[:, 0]
    return -(g / l) * np.sin(theta) + (a * w ** 2 / l) * np.cos(w * t[:, 0]) * np.cos(theta)


def points(rng):
    t = rng.uniform(0, 20, (POINTS, 1))
    y = np.column_stack([rng.uniform(-np.pi, np.pi, POINTS), rng.uniform(-3, 3, POINTS)])
    p = np.column_stack([rng.uniform(0.5, 2, (POINTS, 2)), rng.uniform(5, 15, POINTS),
                         rng.uniform(0.5, 2, (POINTS, 2))])
    return t, y, p


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_the_driven_pivots_rhs_takes_t(backend):
    name = load_model(EXAMPLES / "driven_pivot.toml").name
    kernels = load(name) if backend == "c" else numpy_module(name)
    t, y, p = points(np.random.default_rng(5))
    ydot = kernels.rhs(t, y, p)
    assert np.max(np.abs(ydot[:, 0] - y[:, 1])) == 0
    expected = hand_written(t, y, p)
    assert np.max(np.abs(ydot[:, 1] - expected) / np.maximum(1, np.abs(expected))) < 1e-12
    # the bob's velocity has the pivot's: d/dt pos(t, y(t)) by a central difference
    h = 1e-6
    dpos = (kernels.positions(t + h, y + h * ydot, p) - kernels.positions(t - h, y - h * ydot, p)) / (2 * h)
    assert np.max(np.abs(kernels.velocities(t, y, p) - dpos)) < 1e-6


def test_only_the_kernels_that_use_t_take_it():
    module = numpy_module(load_model(EXAMPLES / "forced_pendulum.toml").name)
    assert module.TIME_NAMES == ("t",)
    t, y, p = np.array([[0.5]]), np.array([[0.2, 0.1]]), np.array([1.0, 1.0, 9.81, 0.3, 0.7, 2.0])
    assert module.forcing(t, y, p).shape == (1, 1)
    assert module.energy(y, p).shape == (1,)            # E = T + V has no t: no t argument
    with pytest.raises(TypeError):
        module.rhs(y, p)


def test_a_time_independent_model_has_no_time_argument():
    module = numpy_module("planar")
    assert not hasattr(module, "TIME_NAMES")
    assert module.rhs(np.zeros(4), np.ones(5)).shape == (4,)
