"""The generated RK library passes each stage's own time t to a time-dependent model's rhs
(issue 23 item 3): every method of the C library, in float, double and long double, with
events, dense output, ensembles, held inputs and sweeps.  References: solve_ivp (DOP853,
rtol = atol = 1e-13) and mpmath's odefun on the ODEs written here by hand, independent of
the derivation (a pendulum driven by a torque F0 cos(wt) with damping, and one on a pivot
moved as a cos(wt) along x)."""
from __future__ import annotations

from pathlib import Path

import mpmath
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import derive
from derive.codegen.contract import METHODS
from derive.runtime.runner import MIN_BLOCK

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
PIVOT, FORCED = str(EXAMPLES / "driven_pivot.toml"), str(EXAMPLES / "forced_pendulum.toml")
PIVOT_P = {"m": 1.3, "l": 0.8, "g": 9.81, "a": 0.05, "w": 5.0}
FORCED_P = {"m": 1.0, "l": 1.2, "g": 9.81, "c": 0.2, "F0": 0.5, "w": 2.0}
Y0 = [0.3, 0.0]
TIMES = np.linspace(0.0, 6.0, 7)


def pivot_ode(t, y, m, l, g, a, w):
    """The bob at (a cos wt + l sin th, -l cos th): in the pivot's frame the bob feels
    m a w^2 cos(wt) along +x, a torque m a w^2 cos(wt) l cos(th)."""
    th, thd = y
    return [thd, -(g / l) * np.sin(th) + (a * w ** 2 / l) * np.cos(w * t) * np.cos(th)]


def forced_ode(t, y, m, l, g, c, F0, w):
    """m l^2 th'' = F0 cos(wt) - c th' - m g l sin th."""
    th, thd = y
    return [thd, (F0 * np.cos(w * t) - c * thd - m * g * l * np.sin(th)) / (m * l ** 2)]


CASES = {"forced": (FORCED, forced_ode, FORCED_P), "pivot": (PIVOT, pivot_ode, PIVOT_P)}


def reference(ode, params, y0, times, **kw):
    r = solve_ivp(lambda t, y: ode(t, y, *params.values()), (times[0], times[-1]), y0, method="DOP853",
                  t_eval=times, rtol=1e-13, atol=1e-13, **kw)
    assert r.success
    return r


def test_the_library_has_no_other_method():
    """The methods checked below are the C library's every method but Taylor (its own helper)."""
    assert set(METHODS) - {"taylor"} == {"rk4", "rk8", "abm12", "dopri5", "dop853", "midpoint", "gauss2"}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("method, rtol, bound", [("dopri5", 1e-10, 2e-8), ("dop853", 1e-10, 2e-8),
                                                 ("dopri5", 1e-6, 2e-4), ("dop853", 1e-6, 2e-4)])
def test_each_tolerance_method_meets_its_tolerance(case, method, rtol, bound):
    model, ode, params = CASES[case]
    r = derive.simulate(model, Y0, TIMES, params, method=method, rtol=rtol, atol=rtol)
    assert r.ok, r.message
    error = np.max(np.abs(r.y - reference(ode, params, Y0, TIMES).y.T))
    assert error < bound
    # the drive matters: the same run with the drive's time frozen at 0 is far off
    frozen = reference(lambda t, y, *a: ode(0.0, y, *a), params, Y0, TIMES).y.T
    assert np.max(np.abs(frozen - r.y)) > 1e-2


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("method, order, h", [("rk4", 4, 0.02), ("midpoint", 2, 0.01), ("gauss2", 4, 0.04),
                                              ("rk8", 8, 0.2)])
def test_each_fixed_step_method_converges_at_its_order(case, method, order, h):
    """Halving the step divides the error at the end by 2^order (16 for rk4): each stage
    takes its own time, or the order would fall to one."""
    model, ode, params = CASES[case]
    exact = reference(ode, params, Y0, TIMES).y[:, -1]
    errors = [np.max(np.abs(derive.simulate(model, Y0, TIMES, params, method=method, step=s).y[-1] - exact))
              for s in (h, h / 2)]
    ratio = errors[0] / errors[1]
    assert 2 ** (order - 0.5) < ratio < 2 ** (order + 0.7), (errors, ratio)


@pytest.mark.parametrize("case", sorted(CASES))
def test_abm12_starts_with_rk8_and_then_follows_the_drive(case):
    model, ode, params = CASES[case]
    r = derive.simulate(model, Y0, TIMES, params, method="abm12", step=0.005)
    assert r.ok, r.message
    assert np.max(np.abs(r.y - reference(ode, params, Y0, TIMES).y.T)) < 1e-10


def test_float32_runs_to_its_precision():
    r = derive.simulate(FORCED, Y0, TIMES, FORCED_P, method="dop853", dtype="float32", rtol=1e-5, atol=1e-5)
    assert r.ok and r.y.dtype == np.float32
    error = np.max(np.abs(r.y.astype(float) - reference(forced_ode, FORCED_P, Y0, TIMES).y.T))
    assert 1e-8 < error < 1e-3
    fixed = derive.simulate(PIVOT, Y0, TIMES, PIVOT_P, method="rk4", step=0.01, dtype="float32")
    assert fixed.ok and np.max(np.abs(fixed.y - reference(pivot_ode, PIVOT_P, Y0, TIMES).y.T)) < 1e-4


def _mpmath_forced(t_end: float, digits: int = 30):
    """The forced pendulum at t_end by mpmath's Taylor series ODE solver (its own arithmetic),
    for the parameters and start derive is given: the doubles nearest the decimals (mpf of a
    float is exact at any precision; mpf of its decimal string would depend on mpmath's
    global precision, which another test may have raised, and differ from derive's problem
    by about 1e-16 at 30 digits)."""
    m, l, g, c, F0, w = (mpmath.mpf(float(v)) for v in FORCED_P.values())
    with mpmath.workdps(digits):
        f = mpmath.odefun(lambda t, y: [y[1], (F0 * mpmath.cos(w * t) - c * y[1] - m * g * l * mpmath.sin(y[0]))
                                        / (m * l ** 2)], 0, [mpmath.mpf(float(v)) for v in Y0])
        return [float(v) for v in f(mpmath.mpf(t_end))], f(mpmath.mpf(t_end))


def test_long_double_runs_beyond_double():
    """dop853 in long double at rtol 2e-18 against mpmath at 30 digits: closer than double's
    best run (rtol near its epsilon) gets."""
    if np.finfo(np.longdouble).eps >= np.finfo(np.float64).eps:
        pytest.skip("long double is double on this platform")
    t = np.array([0.0, 1.0, 2.0])
    _, exact = _mpmath_forced(2.0)
    ld = derive.simulate(FORCED, Y0, t.astype(np.longdouble), FORCED_P, method="dop853", dtype="longdouble",
                         rtol=2e-18, atol=2e-18)
    assert ld.ok and ld.y.dtype == np.longdouble
    err = max(abs(mpmath.mpf(str(ld.y[-1, k])) - exact[k]) for k in range(2))   # str: every digit
    double = derive.simulate(FORCED, Y0, t, FORCED_P, method="dop853", rtol=3e-15, atol=3e-15)
    err_double = max(abs(mpmath.mpf(double.y[-1, k]) - exact[k]) for k in range(2))
    assert err < 1e-16 and err < err_double / 10, (err, err_double)


def test_an_ensembles_rows_are_simulates_runs_in_c_with_threads():
    B = 2 * MIN_BLOCK                                     # two blocks of members, run at once
    rng = np.random.default_rng(7)
    y0 = np.column_stack([rng.uniform(-1, 1, B), rng.uniform(-0.5, 0.5, B)])
    w = np.linspace(1.0, 8.0, B)
    params = {**{k: np.full(B, v) for k, v in PIVOT_P.items()}, "w": w}
    for dtype, kw in (("float64", {"method": "dop853", "rtol": 1e-10}), ("float32", {"method": "rk4", "step": 0.01}),
                      ("longdouble", {"method": "gauss2", "step": 0.02})):
        ens = derive.ensemble(PIVOT, y0, TIMES, params, dtype=dtype, threads=2, **kw)
        assert ens.threads == 2 and ens.all_ok and ens.y.dtype == np.dtype(dtype)
        for i in (0, 1, B // 2, B - 1):
            one = derive.simulate(PIVOT, y0[i], TIMES, dict(PIVOT_P, w=w[i]), dtype=dtype, **kw)
            assert np.array_equal(ens.y[i], one.y), (dtype, i)
    # and the members are the drive's: each against the hand-written ODE
    ens = derive.ensemble(PIVOT, y0, TIMES, params, method="dop853", rtol=1e-11, atol=1e-11, threads=2)
    for i in (0, B // 2, B - 1):
        expected = reference(pivot_ode, dict(PIVOT_P, w=w[i]), y0[i], TIMES).y.T
        assert np.max(np.abs(ens.y[i] - expected)) < 1e-8


FORCED_INPUT = """name = "forced_input"
title = "Forced damped pendulum with a feedback torque u"
dimension = 2
parameters = ["m", "l", "g", "c", "F0", "w"]
inputs = ["u"]
dissipation = "c*theta1_dot**2/2"
[forces]
theta1 = "F0*cos(w*t) + u"
[[links]]
chart = "planar"
length = "l"
body = { kind = "point", mass = "m" }
"""


def test_held_inputs_of_a_time_dependent_model_run_in_c(tmp_path):
    """hold='zoh': u(t, y) sampled at each output time and held to the next, the drive at
    every stage's own t; against solve_ivp interval by interval with u held."""
    model = tmp_path / "forced_input.toml"
    model.write_text(FORCED_INPUT)
    gain = 0.8

    def u(t, y):
        return [-gain * y[1] + 0.3 * np.sin(t)]

    times = np.linspace(0.0, 4.0, 21)
    r = derive.simulate(str(model), Y0, times, FORCED_P, method="dop853", rtol=1e-12, atol=1e-12,
                        inputs=u, hold="zoh")
    assert r.ok, r.message
    y, expected = np.array(Y0, float), [np.array(Y0, float)]
    for a, b in zip(times[:-1], times[1:]):
        held = u(a, y)[0]
        part = solve_ivp(lambda t, z: np.add(forced_ode(t, z, *FORCED_P.values()),
                                             [0.0, held / (FORCED_P["m"] * FORCED_P["l"] ** 2)]),
                         (a, b), y, method="DOP853", rtol=1e-13, atol=1e-13)
        y = part.y[:, -1]
        expected.append(y)
    assert np.max(np.abs(r.y - np.array(expected))) < 1e-9
    # in float32 and with an implicit method too (the Python-stepped path takes neither)
    r32 = derive.simulate(str(model), Y0, times, FORCED_P, method="gauss2", step=0.01, dtype="float32",
                          inputs=u, hold="zoh")
    assert r32.ok and np.max(np.abs(r32.y - np.array(expected))) < 1e-3


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_an_event_is_located_as_solve_ivps(method):
    """theta1 crossing 0, on the compiled run's dense output (each interval from its own t)."""
    times = np.linspace(0.0, 6.0, 4)

    def crossing(t, y, *args):
        return y[0]

    expected = reference(pivot_ode, PIVOT_P, Y0, times, events=crossing).t_events[0]
    r = derive.simulate(PIVOT, Y0, times, PIVOT_P, method=method, rtol=1e-12, atol=1e-13,
                        events={"down": "theta1"})
    assert len(expected) >= 4 and len(r.events["down"]) == len(expected)
    assert np.max(np.abs(r.events["down"].t - expected)) < 1e-8
    between = np.linspace(0.05, 5.95, 40)
    dense = reference(pivot_ode, PIVOT_P, Y0, np.concatenate([[0.0], between])).y.T[1:]
    assert np.max(np.abs(r.sol(between) - dense)) < 1e-9


def test_a_sweep_over_the_drive_frequency(tmp_path):
    """driven_pivot over w: each case's final state is the hand-written ODE's, and its
    largest |theta1| (found between the samples too) at least the samples' largest."""
    pytest.importorskip("xarray")
    path = tmp_path / "pivot_w.toml"
    path.write_text(f'title = "driven pivot over w"\nrecord = ["final_state", "max_abs_theta1"]\n'
                    f'[pendulum]\nmodel = "{PIVOT}"\n'
                    f'parameters = {{ m = 1.3, l = 0.8, g = 9.81, a = 0.05, w = 5.0 }}\n'
                    f'[initial]\nstate = {{ theta1 = 0.3, theta1_dot = 0.0 }}\n'
                    f'[time]\nstop = 4.0\noutputs = 41\n'
                    f'[accuracy]\nmethod = "dop853"\nrtol = 1e-11\natol = 1e-13\n'
                    f'[axes]\nw = {{ linspace = [1.0, 8.0], num = 8 }}\n[sweep]\nchunk = 3\n')
    ds = derive.sweep(path, out=tmp_path / "out", workers=0)
    assert (ds["status"].values == 0).all()
    for k, w in enumerate(ds["w"].values):
        expected = reference(pivot_ode, dict(PIVOT_P, w=float(w)), Y0, np.linspace(0.0, 4.0, 41)).y
        assert abs(ds["final_theta1"].values[k] - expected[0, -1]) < 1e-8
        assert abs(ds["final_theta1_dot"].values[k] - expected[1, -1]) < 1e-8
        assert ds["max_abs_theta1"].values[k] >= np.max(np.abs(expected[0])) - 1e-8


@pytest.mark.parametrize("dtype", ["float32", "float64", "longdouble"])
@pytest.mark.parametrize("kw", [{"method": "dop853", "rtol": 1e-5}, {"method": "rk4", "step": 0.01}])
def test_a_repeated_call_by_name_takes_the_compiled_call_and_gives_the_general_paths_result(monkeypatch, dtype, kw):
    """A model file read before, called by its name: repeated plain calls run the compiled
    call (runtime/compiled_call.py), whose result (energy and positions at the rows' t
    included) is the general path's bit for bit."""
    import importlib
    simulate_module = importlib.import_module("derive.runtime.simulate")
    name = derive.load_model(PIVOT).name
    runs = [derive.simulate(name, Y0, TIMES, PIVOT_P, dtype=dtype, **kw) for _ in range(3)]
    with monkeypatch.context() as m:
        m.setattr(simulate_module, "FAST_PATH", False)
        general = derive.simulate(name, Y0, TIMES, PIVOT_P, dtype=dtype, **kw)
    assert simulate_module.run_plan(name, kw["method"], dtype) is not None
    from derive.runtime import compiled_call
    if compiled_call.available():
        key = compiled_call.call_key(name, kw["method"], dtype, kw.get("rtol"), None, kw.get("step"), None, None,
                                     None, None, None)
        assert compiled_call.lookup(key) is not None      # the repeated call is the compiled one
    for r in runs:
        for field in ("y", "energy", "positions", "velocities", "t_stop", "nfev", "status"):
            a, b = getattr(r, field), getattr(general, field)
            assert np.array_equal(np.asarray(a), np.asarray(b)), field
    bob_x = PIVOT_P["a"] * np.cos(PIVOT_P["w"] * TIMES) + PIVOT_P["l"] * np.sin(runs[-1].y[:, 0].astype(float))
    assert np.max(np.abs(runs[-1].positions[:, 0, 0] - bob_x)) < (1e-5 if dtype == "float32" else 1e-12)


@pytest.mark.parametrize("method", sorted(set(METHODS) - {"taylor"}))
def test_the_numpy_integrators_pass_t_too(method):
    """The NumPy library (generated/numpy/derive_integrators.py) passes each stage's t as
    the C does: every method agrees with the C run and with the hand-written ODE."""
    kw = {"rtol": 1e-10, "atol": 1e-10} if method in ("dopri5", "dop853") else {"step": 0.005}
    expected = reference(pivot_ode, PIVOT_P, Y0, TIMES).y.T
    c = derive.simulate(PIVOT, Y0, TIMES, PIVOT_P, method=method, **kw)
    numpy_run = derive.simulate(PIVOT, Y0, TIMES, PIVOT_P, method=method, backend="numpy", **kw)
    assert numpy_run.ok and np.max(np.abs(numpy_run.y - c.y)) < 1e-12
    assert np.max(np.abs(numpy_run.y - expected)) < (1e-3 if method == "midpoint" else 1e-7)


def test_inputs_at_every_stage_of_a_time_dependent_model_step_in_python(tmp_path):
    """Inputs u(t, y) evaluated at every stage (no hold): the Python-stepped path, the drive
    and u each at the stage's own t; against solve_ivp with u inside the ODE."""
    model = tmp_path / "forced_input.toml"
    model.write_text(FORCED_INPUT)

    def u(t, y):
        return [-0.8 * y[1] + 0.3 * np.sin(t)]

    r = derive.simulate(str(model), Y0, TIMES, FORCED_P, method="dop853", rtol=1e-12, atol=1e-12, inputs=u)
    ml2 = FORCED_P["m"] * FORCED_P["l"] ** 2
    expected = reference(lambda t, y, *a: np.add(forced_ode(t, y, *a), [0.0, u(t, y)[0] / ml2]),
                         FORCED_P, Y0, TIMES).y.T
    assert r.ok and np.max(np.abs(r.y - expected)) < 1e-9


GLIDE = """name = "glide"
title = "Pendulum on a pivot gliding at constant speed"
dimension = 2
parameters = ["m", "l", "g", "v"]
pivot = ["v*t", "0"]
[[links]]
chart = "planar"
length = "l"
body = { kind = "point", mass = "m" }
"""


def test_a_model_whose_motion_has_no_t_gets_the_autonomous_integrators(tmp_path):
    """A pivot gliding at constant speed: the model is time-dependent (its positions and
    energy have t) but its rhs is not (Galilean invariance), so its integrators are the
    autonomous ones, and its swing is a fixed pivot's."""
    model = tmp_path / "glide.toml"
    model.write_text(GLIDE)
    out = tmp_path / "gen"
    derive.load_model(model).generate(out)
    text = (out / "c" / "glide_integrate.c").read_text()
    from derive.model import load_model
    assert "DERIVE_TIMED" not in text and load_model(model).is_time_dependent
    params = {"m": 1.0, "l": 0.9, "g": 9.81, "v": 0.7}
    r = derive.simulate(str(model), Y0, TIMES, params, method="dop853", rtol=1e-11, atol=1e-11)
    fixed = reference(lambda t, y, m, l, g, v: [y[1], -(g / l) * np.sin(y[0])], params, Y0, TIMES).y.T
    assert np.max(np.abs(r.y - fixed)) < 1e-8
    assert np.max(np.abs(r.positions[:, 0, 0] - (0.7 * TIMES + 0.9 * np.sin(r.y[:, 0])))) < 1e-12


def test_the_inlined_loops_pass_t_and_agree_with_simulate():
    """<model>_fixed (rk4, rk8, abm12) and <model>_throughput (batched rk4, C and NumPy) of
    a time-dependent model take the start time t_start and each stage's own t: from a start
    off zero they give simulate's grid runs (rk4 and rk8 bit for bit)."""
    from derive.runtime.simulate import resolve_model
    from derive.runtime.throughput import fixed_library, throughput_library, throughput_numpy
    name = resolve_model(PIVOT, explicit_time=True)
    p = np.array(list(PIVOT_P.values()))
    start, h, n = 0.7, 0.01, 300
    span = np.array([start, start + n * h])
    for method in ("rk4", "rk8", "abm12"):
        y, done = fixed_library(name).run(method, Y0, p, h, n, t_start=start)
        r = derive.simulate(PIVOT, Y0, span, PIVOT_P, method=method, step=h)
        assert done == n and np.max(np.abs(y - r.y[-1])) <= (1e-13 if method == "abm12" else 0.0), method
    y0 = np.array([[0.3, 0.0], [0.1, 0.2], [-0.5, 0.4]])
    y, status, steps = throughput_library(name).rk4(y0, p, h, n, t_start=start)
    yn, status_n, _ = throughput_numpy(name).rk4(y0.T, p, h, n, t_start=start)
    assert (status == 0).all() and (status_n == 0).all() and (steps == n).all()
    for i, row in enumerate(y0):
        r = derive.simulate(PIVOT, row, span, PIVOT_P, method="rk4", step=h)
        assert np.max(np.abs(y[i] - r.y[-1])) < 1e-13 and np.max(np.abs(yn[:, i] - r.y[-1])) < 1e-13
    expected = reference(pivot_ode, PIVOT_P, Y0, span).y[:, -1]
    assert np.max(np.abs(fixed_library(name).run("rk8", Y0, p, h, n, t_start=start)[0] - expected)) < 1e-9
