"""The generated drivers' fixed-step grid, step-count guards, cancellation and abm12/rk8
(issue 13, item 2): a fixed step is the step taken, whatever the outputs."""
from __future__ import annotations

import ctypes
import importlib.util
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.runtime.loader import load, numpy_integrators
from derive.runtime.build import integrator_library
from derive.codegen.contract import METHODS, STATUS
from derive.runtime.simulate import numpy_module

from tests.parameters import UNIT_PARAMS as PLANAR, UNIT_VECTOR
P = np.array(UNIT_VECTOR)
Y0 = [1.0, 0.5, 0.0, 0.0]
ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("method", ["rk4", "midpoint", "gauss2", "rk8", "abm12"])
@pytest.mark.parametrize("h", [0.01, 0.03])
def test_a_fixed_step_result_does_not_depend_on_the_outputs(method, h, backend):
    """Outputs every 0.1 and every 0.05 (h = 0.03 divides neither): the same states at the
    common times, to roundoff, and the same as a run with the last time alone."""
    if method == "abm12":         # inside its stability region for this swing (|h omega| < 0.067)
        h = h / 3
    kw = dict(method=method, step=h, backend=backend, rtol=1e-5 if method == "abm12" else None)
    coarse = derive.simulate("planar", Y0, np.linspace(0, 2, 21), PLANAR, **kw)
    fine = derive.simulate("planar", Y0, np.linspace(0, 2, 41), PLANAR, **kw)
    alone = derive.simulate("planar", Y0, [0, 2], PLANAR, **kw)
    assert coarse.ok and fine.ok and alone.ok, (coarse.message, fine.message)
    assert np.max(np.abs(coarse.y - fine.y[::2])) <= 1e-13
    assert np.max(np.abs(alone.y[-1] - coarse.y[-1])) <= 1e-13
    assert coarse.step == h
    grid_steps = int(np.floor(2 / h + 1e-9))
    if abs(grid_steps * h - 2) < 1e-12:
        assert coarse.last_step is None and alone.nsteps == grid_steps
    else:                         # 66 steps of 0.03, then one of 0.02 to reach t = 2
        assert coarse.last_step == pytest.approx(2 - grid_steps * h, rel=1e-9)
        assert alone.nsteps == grid_steps + 1


def test_the_grid_steps_are_classical_rk4_steps_of_the_requested_size():
    """Independent of the driver: RK4 written here on the generated rhs, h = 0.03 exactly."""
    kernels = load("planar")
    f = lambda y: np.asarray(kernels.rhs(y, P), float).reshape(-1)
    y, h = np.array(Y0), 0.03
    for _ in range(10):
        k1 = f(y)
        k2 = f(y + h / 2 * k1)
        k3 = f(y + h / 2 * k2)
        k4 = f(y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    r = derive.simulate("planar", Y0, np.linspace(0, 0.3, 7), PLANAR, method="rk4", step=h)
    assert np.max(np.abs(r.y[-1] - y)) <= 1e-14


@pytest.mark.parametrize("suffix", ["", "_f", "_l"])
def test_c_refuses_more_than_2_53_grid_steps_without_undefined_behaviour(suffix):
    """step = 1e-30: once (long)ceil(|dt| / h), undefined; now BAD_INPUT from the check."""
    lib = integrator_library("planar")
    dtype = {"": np.float64, "_f": np.float32, "_l": np.longdouble}[suffix]
    o = lib.defaults()
    o.h = 1e-30
    y, infos = lib.run(METHODS.index("rk4"), np.array([Y0], dtype), P.astype(dtype),
                       np.array([0.0, 1.0], dtype), o)
    assert infos[0].status == STATUS["BAD_INPUT"] and infos[0].nsteps == 0 and np.isnan(y[0, 1]).all()


def test_numpy_refuses_more_than_2_53_grid_steps():
    st, _, info = numpy_module("planar_integrate").integrate("rk4", Y0, P, [0.0, 1.0], h=1e-30)
    assert st == STATUS["BAD_INPUT"] and info["nsteps"] == 0
    assert info["reason"] == "h = 1e-30 makes more than 2^53 steps over the span of t"


def _generated(name):
    """A module of the checkout's generated/numpy, imported by path as a user would."""
    path = ROOT / "generated" / "numpy" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"user_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_generated_numpy_integrators_say_what_is_wrong():
    """A misspelt option is refused, naming it and the options; a fixed-step method without
    h is BAD_INPUT with a reason saying so (the atlas alike)."""
    mod, atlas = _generated("planar_integrate"), _generated("spherical_atlas")
    with pytest.raises(TypeError, match=re.escape("unknown option 'rtoll' (options: rtol, atol, h, hmin, "
                                                  "hmax, max_steps, newton_tol, newton_max, sine_min, "
                                                  "cancel); did you mean 'rtol'?")):
        mod.integrate("dop853", Y0, P, [0.0, 1.0], rtoll=1e-10)
    with pytest.raises(TypeError, match="unknown option 'steps'"):
        mod.integrate_batch("rk4", [Y0, Y0], P, [0.0, 1.0], steps=0.01)
    st, y, info = mod.integrate("rk4", Y0, P, [0.0, 1.0])
    assert mod.STATUS_NAMES[st] == "bad input" and np.isnan(y[1]).all()
    assert info["reason"].startswith("rk4 is a fixed-step method: it needs the option h, the step")
    st, _, info = mod.integrate("rk4", Y0, P, [0.0, 1.0], h=0.01)
    assert st == 0 and info["reason"] is None
    y0 = [0.3, 0.2, 0.4, 0.1, 0.0, 0.0, 0.0, 0.0]
    with pytest.raises(TypeError, match="unknown option 'sine_swich' .*; did you mean 'sine_switch'"):
        atlas.integrate("dop853", -1, y0, P, [0.0, 1.0], sine_swich=0.2)
    assert atlas.integrate("rk8", -1, y0, P, [0.0, 1.0], h=0.01)[3]["reason"] == "the atlas has no rk8"
    assert "fixed-step method" in atlas.integrate("rk4", -1, y0, P, [0.0, 1.0])[3]["reason"]


def test_the_numpy_backend_integrates_the_kernels_the_observables_use():
    """derive's NumPy runs bind the library to numpy_module(model), the one copy of the
    kernels in a session, with the same numbers as the generated <model>_integrate.py."""
    bound = numpy_integrators("planar")
    assert bound.system.kernels is numpy_module("planar")
    t = np.linspace(0, 1, 5)
    r = derive.simulate("planar", Y0, t, PLANAR, method="rk4", step=0.01, backend="numpy")
    _, y, _ = numpy_module("planar_integrate").integrate("rk4", Y0, P, t, h=0.01)
    assert np.array_equal(r.y, y)


@pytest.mark.parametrize("kwargs, fragment", [
    (dict(method="rk4", step=1e-9), "means 5e+09 steps, more than max_steps = 1e+08"),
    (dict(t=[0, 1e300]), "needs about"),
    (dict(t=[0, 1e300], backend="numpy"), "needs about"),
    (dict(t=[0, 1e300], y0=[1, 0.5, 0.3, 0.2, 0, 0, 0, 0], model="spherical"), "needs about"),
])
def test_runs_longer_than_the_step_budget_are_refused_with_the_figure(kwargs, fragment):
    args = dict(model="planar", y0=[1, 0.5, 0, 0], t=[0, 5], params=PLANAR)
    args.update(kwargs)
    start = time.perf_counter()
    with pytest.raises(derive.SimulationInputError, match=re.escape(fragment)) as err:
        derive.simulate(**args)
    assert "\n" not in str(err.value) and time.perf_counter() - start < 30


def test_an_explicit_step_budget_is_the_users_choice():
    r = derive.simulate("planar", Y0, [0, 5], PLANAR, method="rk4", step=1e-9, max_steps=10)
    assert r.status == STATUS["MAX_STEPS"] and r.nsteps == 10


@pytest.mark.parametrize("method", ["rk4", "dop853"])
def test_a_set_cancellation_flag_stops_the_c_loop(method):
    lib = integrator_library("planar")
    o = lib.defaults()
    o.h = 0.01
    flag = ctypes.c_int(1)
    o.cancel = ctypes.pointer(flag)
    _, infos = lib.run(METHODS.index(method), np.array([Y0]), P, np.array([0.0, 10.0]), o)
    assert infos[0].status == STATUS["CANCELLED"] and infos[0].nsteps == 0
    flag.value = 0
    _, infos = lib.run(METHODS.index(method), np.array([Y0]), P, np.array([0.0, 1.0]), o)
    assert infos[0].status == STATUS["OK"]


def _interrupt_after(code: list[str], seconds: float = 1.0, ready: str | None = None):
    """SIGINT `seconds` after the start, or after the program printed the line `ready`
    (then `seconds` more: on a loaded machine the imports alone can take seconds)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    # SIGINT's default action in the child: a pytest-xdist worker runs with SIGINT ignored,
    # and an ignored signal stays ignored across exec (the child would never see Ctrl-C)
    proc = subprocess.Popen(code, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            cwd=str(ROOT), preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    before = ""
    if ready is not None:
        for line in proc.stdout:
            before += line
            if line.strip() == ready:
                break
    time.sleep(seconds)
    sent = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    return proc.returncode, before + out, err, time.perf_counter() - sent


def test_ctrl_c_stops_a_long_c_run_of_the_api():
    """A run of minutes (a budget given, so no estimate refuses it) in a subprocess."""
    code = textwrap.dedent("""
        import derive
        derive.simulate("planar", [1, 0.5, 0, 0], [0, 20], {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81})
        print("warm", flush=True)
        try:
            derive.simulate("planar", [1, 0.5, 0, 0], [0, 1e7], {"m1": 1, "m2": 1, "l1": 1, "l2": 1,
                            "g": 9.81}, rtol=1e-12, max_steps=10**12)
        except KeyboardInterrupt as exc:
            print("KeyboardInterrupt", exc)
    """)
    code_, out, err, waited = _interrupt_after([sys.executable, "-c", code], seconds=1.0, ready="warm")
    assert "KeyboardInterrupt run cancelled at t = " in out, (out, err)
    assert waited < 5, waited


def test_ctrl_c_stops_derive_run_with_one_line(tmp_path):
    scene = tmp_path / "long.toml"
    scene.write_text(textwrap.dedent("""
        title = "long"
        [pendulum]
        model = "planar"
        parameters = { m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 9.81 }
        [initial]
        state = { theta1 = 1.0, theta2 = 0.5, theta1_dot = 0.0, theta2_dot = 0.0 }
        [time]
        stop = 900.0
        outputs = 11
        [accuracy]
        method = "rk4"
        step = 1e-5
        [output]
        directory = "out"
        trajectory = ["csv"]
    """))
    code, out, err, waited = _interrupt_after([sys.executable, "-m", "derive", "run", str(scene),
                                               "--quiet"], seconds=2.0)
    assert code == 130 and err.strip().splitlines() == ["derive: interrupted"], (code, out, err)
    assert waited < 5, waited


def test_abm12_and_rk8_reach_their_orders():
    ref = derive.simulate("planar", Y0, [0, 2], PLANAR, rtol=1e-13, atol=1e-15).y[-1]
    error = lambda method, h: np.max(np.abs(derive.simulate("planar", Y0, [0, 2], PLANAR, method=method,
                                                           step=h, rtol=1e-5).y[-1] - ref))
    assert error("rk8", 0.1) / error("rk8", 0.05) > 2 ** 6          # order 8: 256
    # abm12 inside its stability region is at the roundoff floor of double already
    assert error("abm12", 0.005) < 1e-12 and error("abm12", 0.01 / 3) < 1e-12


def test_abm12_is_accurate_or_says_it_is_unstable():
    """200 random planar states (angles in [-pi, pi], rates in [-2, 2]) at h = 0.01, the
    default rtol: each run is either within 1e-6 of DOP853 at rtol 1e-12 or stopped with
    'multistep unstable'.  (h = 0.01 is outside abm12's stability region for fast states.)"""
    rng = np.random.default_rng(13)
    states = np.column_stack([rng.uniform(-np.pi, np.pi, (200, 2)), rng.uniform(-2, 2, (200, 2))])
    kinds = {"accurate": 0, "unstable": 0}
    for y0 in states:
        r = derive.simulate("planar", y0, [0, 1], PLANAR, method="abm12", step=0.01)
        if not r.ok:
            assert r.status == STATUS["MULTISTEP_UNSTABLE"], r.message
            kinds["unstable"] += 1
            continue
        ref = derive.simulate("planar", y0, [0, 1], PLANAR, method="dop853", rtol=1e-12, atol=1e-14)
        assert np.max(np.abs(r.y[-1] - ref.y[-1])) < 1e-6, y0
        kinds["accurate"] += 1
    assert kinds["accurate"] > 10 and kinds["unstable"] > 10, kinds


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_abm12_stopped_by_its_guard_names_it_and_how_to_loosen_it(backend):
    """The regular case at h = 0.01 (the benchmark's step): at the default rtol the guard
    stops it at t = 0.77, and the message says which guard, its threshold and the option
    that loosens it; loosened (rtol = 1e-6) it reaches t = 20."""
    y0, t = [1.0, 0.5, 0.0, 0.0], np.linspace(0, 20, 201)
    r = derive.simulate("planar", y0, t, PLANAR, method="abm12", step=0.01, backend=backend)
    assert not r.ok and r.t_stop == pytest.approx(0.77) and r.guard == pytest.approx((1e-9, 1e-12))
    assert r.message.endswith("; the guard: Milne's error estimate above atol + rtol |y| (rtol 1e-09, "
                              "atol 1e-12): loosen rtol (and atol), or take a smaller step"), r.message
    loose = derive.simulate("planar", y0, t, PLANAR, method="abm12", step=0.01, rtol=1e-6, backend=backend)
    assert loose.ok and loose.guard == pytest.approx((1e-6, 1e-9)), loose.message


def test_abm12_numpy_and_c_agree():
    c = derive.simulate("planar", Y0, np.linspace(0, 1, 11), PLANAR, method="abm12", step=0.005)
    n = derive.simulate("planar", Y0, np.linspace(0, 1, 11), PLANAR, method="abm12", step=0.005,
                        backend="numpy")
    assert c.ok and n.ok and np.max(np.abs(c.y - n.y)) < 1e-12


def test_the_atlas_refuses_the_methods_it_does_not_have():
    with pytest.raises(derive.SimulationInputError, match="the chart atlas has no method 'rk8'"):
        derive.simulate("spherical", [1, 0.5, 0.3, 0.2, 0, 0, 0, 0], [0, 1], PLANAR, method="rk8", step=0.01)
