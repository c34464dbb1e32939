"""A model whose applied force divides by a state-dependent quantity, c θ̇1 / sin θ1.

Started where the divisor is zero, every method of both backends stops at once with the
non-finite status and t_stop = t0, the outputs after it NaN.  Started away from it, the
motion runs into the pole (θ1 → 0 in finite time, the force without bound): an adaptive
method and Taylor's method stop there, at the same time in C and NumPy, never a
trajectory continued through the pole and never a hang; Taylor's method, whose jet
divides by sin θ1 itself, says non-finite, the adaptive Runge-Kutta methods
non-finite or step-size underflow (their error estimate shrinks the step to nothing in
front of a derivative that is still finite).  A fixed step has no error estimate and
steps over a pole it does not land on, so it is tried only where the divisor is exactly
zero.  `derive run` of such a scene is one line
and exit status 1."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.codegen.contract import STATUS

ROOT = Path(__file__).resolve().parents[2]
NONFINITE, UNDERFLOW, OK = STATUS["NONFINITE"], STATUS["STEP_UNDERFLOW"], STATUS["OK"]

MODEL = """\
name = "pole"
title = "Double pendulum with a force dividing by sin(theta1)"
dimension = 2
parameters = ["m1", "m2", "l1", "l2", "g", "c"]
[forces]
theta1 = "c*theta1_dot/sin(theta1)"
[[links]]
chart = "planar"
length = "l1"
body = { kind = "point", mass = "m1" }
[[links]]
chart = "planar"
length = "l2"
body = { kind = "point", mass = "m2" }
"""
P = [1.0, 1.0, 1.0, 1.0, 9.81, 0.5]
T = np.linspace(0.0, 3.0, 31)
RUNS = [("c", "dop853"), ("c", "rk4"), ("c", "taylor"), ("numpy", "dop853"), ("numpy", "rk4")]

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def model(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("pole") / "pole.toml"
    path.write_text(MODEL)
    return path


def _simulate(model, y0, backend, method):
    kw = {"step": 1e-3} if method == "rk4" else {"rtol": 1e-9}
    return derive.simulate(str(model), y0, T, P, method=method, backend=backend, **kw)


@pytest.mark.parametrize("backend, method", RUNS, ids=[f"{b}-{m}" for b, m in RUNS])
def test_a_zero_divisor_at_the_start_is_a_nonfinite_stop_at_t0(model, backend, method):
    r = _simulate(model, [0.0, 0.3, 1.0, 0.0], backend, method)
    assert r.status == NONFINITE, (r.status, r.status_name)
    assert "non-finite" in r.status_name
    assert r.t_stop == 0.0
    y = np.asarray(r.y, float)
    assert np.array_equal(y[0], [0.0, 0.3, 1.0, 0.0])        # the initial state, as given
    assert np.isnan(y[1:]).all()                              # nothing computed after the stop


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_running_into_the_pole_stops_there(model, method):
    y0 = [0.5, 0.3, 0.0, 0.0]
    stops = {}
    for backend in ("c", "numpy") if method != "taylor" else ("c",):
        r = _simulate(model, y0, backend, method)
        assert r.status != OK, f"{backend} {method} went through the pole"
        assert r.status in ((NONFINITE,) if method == "taylor" else (NONFINITE, UNDERFLOW)), r.status_name
        assert 0 < r.t_stop < T[-1]
        y = np.asarray(r.y, float)
        before = T <= r.t_stop
        assert np.isfinite(y[before]).all() and np.isnan(y[~before]).all()
        assert abs(y[before][-1, 0]) < 0.5 and y[before][-1, 2] < 0      # swinging towards θ1 = 0
        stops[backend] = r.t_stop
    # the pole is where θ1 reaches 0: both backends (and the methods) find the same time
    assert max(stops.values()) - min(stops.values()) < 1e-9, stops
    assert 0.40 < stops["c"] < 0.43, stops


def test_derive_run_of_a_scene_into_the_pole_is_one_line(model, tmp_path):
    (tmp_path / "pole.toml").write_text(MODEL)
    for theta1 in (0.0, 0.5):
        scene = tmp_path / f"s{theta1}.toml"
        scene.write_text(f"""title = "pole"
[pendulum]
model = "pole.toml"
parameters = {{ m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 9.81, c = 0.5 }}
[initial]
state = {{ theta1 = {theta1}, theta2 = 0.3, theta1_dot = 0.0, theta2_dot = 0.0 }}
[time]
stop = 3.0
outputs = 31
[accuracy]
target = 1e-8
[output]
directory = "out"
trajectory = ["csv"]
""")
        run = subprocess.run([sys.executable, "-m", "derive", "run", str(scene), "--quiet"],
                             env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True,
                             timeout=600)
        assert run.returncode == 1, (run.returncode, run.stderr)
        assert run.stderr.count("\n") == 1 and "Traceback" not in run.stderr, run.stderr
        assert run.stderr.startswith("derive: run failed: integration stopped at t = ")
        if theta1 == 0.0:
            assert "t = 0:" in run.stderr and "non-finite" in run.stderr, run.stderr
