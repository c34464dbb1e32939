"""derive.scipy_rhs runs a time-dependent model (issue 23 item 3): fun(t, y) and
jac(t, y) pass the integrator's t to the kernels.  The driven pivot at small amplitude
and the forced pendulum against solve_ivp runs of their ODEs written by hand."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import derive

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
TIMES = np.linspace(0.0, 10.0, 101)
TOL = 1e-9


def pivot_ode(t, y, m, l, g, a, w):
    """From L = 1/2 m |x'|^2 - m g x_y with x = (a cos wt + l sin th, -l cos th): the
    pivot's acceleration -a w^2 cos(wt) along x is a force +m a w^2 cos(wt) in its frame."""
    th, thd = y
    return [thd, -(g / l) * np.sin(th) + (a * w ** 2 / l) * np.cos(w * t) * np.cos(th)]


def forced_ode(t, y, m, l, g, c, F0, w):
    th, thd = y
    return [thd, (F0 * np.cos(w * t) - c * thd - m * g * l * np.sin(th)) / (m * l ** 2)]


def solve(fun, y0):
    r = solve_ivp(fun, (TIMES[0], TIMES[-1]), y0, method="DOP853", t_eval=TIMES, rtol=1e-12, atol=1e-12)
    assert r.success
    return r.y


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("file, ode, params", [
    ("driven_pivot.toml", pivot_ode, {"m": 1.3, "l": 0.8, "g": 9.81, "a": 0.01, "w": 5.0}),
    ("forced_pendulum.toml", forced_ode, {"m": 1.0, "l": 1.2, "g": 9.81, "c": 0.2, "F0": 0.5, "w": 2.0}),
])
def test_solve_ivp_through_scipy_rhs_matches_the_hand_written_ode(backend, file, ode, params):
    fun, jac = derive.scipy_rhs(str(EXAMPLES / file), params, backend=backend)
    y0 = [0.2, 0.0]
    ours = solve(fun, y0)
    reference = solve(lambda t, y: ode(t, y, *params.values()), y0)
    assert np.max(np.abs(ours - reference)) < TOL
    # the drive matters: the same run with the drive switched off is far away
    still = dict(params, **{"a" if "a" in params else "F0": 0.0})
    assert np.max(np.abs(solve(lambda t, y: ode(t, y, *still.values()), y0) - reference)) > 1e-3
    # jac(t, y) is d fun / dy at that t (central differences)
    t, y, h = 1.7, np.array([0.3, -0.4]), 1e-6
    numeric = np.column_stack([(fun(t, y + h * e) - fun(t, y - h * e)) / (2 * h) for e in np.eye(2)])
    assert np.max(np.abs(jac(t, y) - numeric)) < 1e-6
