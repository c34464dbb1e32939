"""Events, dense output r.sol(t) and derive.scipy_rhs, against independent references:
the exact period of a simple pendulum (complete elliptic integral, scipy.special.ellipk),
SciPy's solve_ivp (its own DOP853 and Radau with its own dense output and root finder),
and long-double runs.  Bounds are stated in each test; measured figures in the messages.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import derive
from derive.runtime import SimulationInputError, simulate

scipy_integrate = pytest.importorskip("scipy.integrate")      # the test extra: pip install -e '.[test]'
from scipy.optimize import brentq          # noqa: E402
from scipy.special import ellipk           # noqa: E402

MODELS = Path(__file__).resolve().parents[2] / "examples" / "models"
from tests.parameters import UNIT_PARAMS as PLANAR
DRIVEN = {**PLANAR, "c1": 0.1, "c2": 0.05}
TRIPLE = {"m1": 1.0, "m2": 0.8, "m3": 0.6, "l1": 1.0, "l2": 0.9, "l3": 0.7, "L2": 0.9 * 0.81 / 12, "g": 9.81}
SIMPLE = """name = "simple_pendulum"
title = "Simple pendulum"
dimension = 2
parameters = ["m", "l", "g"]
[[links]]
chart = "planar"
length = "l"
body = { kind = "point", mass = "m" }
"""
SPIN = [0.5, 0.0, 0.0, 9.0]          # link 2 spins over the top: four flips in t < 4
FLIP = "cos(theta2/2)"                 # changes sign at theta2 = pi, 3 pi, ...


@pytest.fixture(scope="module")
def simple_model(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("models") / "simple_pendulum.toml"
    path.write_text(SIMPLE)
    return str(path)


# -- derive.scipy_rhs ------------------------------------------------------------------------

CASES = [("planar", PLANAR, [0.4, 0.3, 0.0, 0.0], None),
         (str(MODELS / "driven.toml"), DRIVEN, [0.4, 0.3, 0.0, 0.0], {"tau1": 0.5, "tau2": 0.1}),
         (str(MODELS / "triple.toml"), TRIPLE, [0.3, 0.2, 0.1, 0.0, 0.0, 0.0], None)]


@pytest.mark.parametrize("model, params, y0, inputs", CASES, ids=["planar", "driven", "triple"])
@pytest.mark.parametrize("method", ["Radau", "DOP853"])
def test_solve_ivp_with_scipy_rhs_agrees_with_simulate(model, params, y0, inputs, method):
    """solve_ivp (Radau with the generated Jacobian, DOP853) at rtol 1e-11 against
    derive.simulate at 1e-12: within 1e-8 at every output of 3 s."""
    fun, jac = derive.scipy_rhs(model, params, inputs=inputs)
    t = np.linspace(0.0, 3.0, 13)
    r = simulate(model, y0, t, params, rtol=1e-12, inputs=inputs)
    extra = {"jac": jac} if method == "Radau" else {}
    s = scipy_integrate.solve_ivp(fun, (0.0, 3.0), y0, method=method, t_eval=t, rtol=1e-11, atol=1e-13, **extra)
    assert s.success, s.message
    err = float(np.max(np.abs(s.y.T - r.y)))
    assert err < 1e-8, f"{method} on {Path(model).stem}: max difference {err:.2e}"


def test_scipy_rhs_jacobian_is_the_derivative_and_backends_agree():
    """jac against central differences of fun (within 1e-6); NumPy kernels equal the C ones
    to 1e-12; fun takes solve_ivp's vectorized (n, k) form."""
    fun, jac = derive.scipy_rhs(str(MODELS / "driven.toml"), DRIVEN, inputs={"tau1": 0.5, "tau2": 0.1})
    nfun, njac = derive.scipy_rhs(str(MODELS / "driven.toml"), DRIVEN, inputs={"tau1": 0.5, "tau2": 0.1},
                                  backend="numpy")
    y = np.array([0.7, -0.4, 1.1, 0.3])
    h = 1e-6
    fd = np.column_stack([(fun(0, y + h * e) - fun(0, y - h * e)) / (2 * h) for e in np.eye(4)])
    assert np.max(np.abs(jac(0, y) - fd)) < 1e-6
    assert np.max(np.abs(fun(0, y) - nfun(0, y))) < 1e-12
    assert np.max(np.abs(jac(0, y) - njac(0, y))) < 1e-12
    block = np.column_stack([y, 2 * y, -y])
    assert np.allclose(fun(0, block), np.column_stack([fun(0, c) for c in block.T]), rtol=1e-14, atol=0)


def test_scipy_rhs_inputs_as_a_function_of_t():
    """Inputs given as a function u(t, y) are evaluated at the t solve_ivp asks."""
    fun, _ = derive.scipy_rhs(str(MODELS / "driven.toml"), DRIVEN, inputs=lambda t, y: {"tau1": t, "tau2": 0.0})
    y = np.array([0.1, 0.2, 0.0, 0.0])
    assert not np.allclose(fun(0.0, y), fun(1.0, y))


def test_scipy_rhs_refuses_the_atlas_and_bad_parameters():
    with pytest.raises(SimulationInputError, match="chart atlas"):
        derive.scipy_rhs("spherical", {})
    with pytest.raises(SimulationInputError, match="missing parameter 'g'"):
        derive.scipy_rhs("planar", {k: v for k, v in PLANAR.items() if k != "g"})


# -- r.sol(t) --------------------------------------------------------------------------------

def test_sol_is_the_rows_at_output_times_and_has_solve_ivp_shapes():
    t = np.linspace(0.0, 2.0, 5)
    r = simulate("planar", [0.5, 0.3, 0, 0], t, PLANAR, method="dop853")
    assert np.array_equal(r.sol(t), r.y)
    assert r.sol(1.3).shape == (4,)
    assert r.sol([1.3, 0.2, 1.3]).shape == (3, 4)
    assert np.array_equal(r.sol([1.3, 0.2])[0], r.sol(1.3))
    with pytest.raises(SimulationInputError, match="outside the run's span"):
        r.sol(2.5)
    assert simulate("planar", [0.5, 0.3, 0, 0], t, PLANAR, method="rk4", step=0.01).sol is None


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
@pytest.mark.parametrize("y0", [[0.5, 0.3, 0, 0], SPIN], ids=["regular", "spinning"])
def test_sol_is_as_accurate_as_the_run(method, y0):
    """sol at 300 random times of a run with 6 outputs, against long double: within 3 times
    the error of the same run asked for outputs at those times (its own interpolant)."""
    t = np.linspace(0.0, 5.0, 6)
    tq = np.sort(np.random.default_rng(7).uniform(0.0, 5.0, 300))
    r = simulate("planar", y0, t, PLANAR, method=method, rtol=1e-9)
    own = simulate("planar", y0, np.concatenate([[0.0], tq, [5.0]]), PLANAR, method=method, rtol=1e-9).y[1:-1]
    ref = simulate("planar", y0, np.concatenate([[0.0], tq]), PLANAR, method="dop853", rtol=1e-15,
                   dtype="longdouble").y[1:].astype(float)
    e_sol, e_own = np.max(np.abs(r.sol(tq) - ref)), np.max(np.abs(own - ref))
    assert e_sol < 3 * e_own, f"sol error {e_sol:.2e}, the run's own interpolant {e_own:.2e}"


def test_sol_numpy_backend_backward_time_and_held_inputs():
    """The NumPy backend's sol equals the C one to 1e-10; a run backward in time has a sol;
    with inputs as a function of t (held per output interval) sol on interval k is the run
    from y_k with the inputs at t_k."""
    y0 = [0.5, 0.3, 0, 0]
    t = np.linspace(0.0, 2.0, 5)
    tq = np.array([0.1, 0.77, 1.9])
    c = simulate("planar", y0, t, PLANAR, method="dopri5", rtol=1e-10)
    n = simulate("planar", y0, t, PLANAR, method="dopri5", rtol=1e-10, backend="numpy")
    assert np.max(np.abs(c.sol(tq) - n.sol(tq))) < 1e-10
    back = simulate("planar", c.y[-1], t[::-1], PLANAR, method="dop853", rtol=1e-12)
    assert np.max(np.abs(back.sol(tq) - c.sol(tq))) < 1e-8
    model = str(MODELS / "driven.toml")
    held = simulate(model, y0, t, DRIVEN, method="dop853", rtol=1e-11, inputs=lambda s, y: {"tau1": s, "tau2": 0.0}, hold="zoh")
    k = 1                                                  # 0.77 is in [0.5, 1.0): inputs at 0.5
    direct = simulate(model, held.y[k], [t[k], 0.77], DRIVEN, method="dop853", rtol=1e-11,
                      inputs={"tau1": t[k], "tau2": 0.0}).y[-1]
    assert np.max(np.abs(held.sol(0.77) - direct)) < 1e-9


def test_sol_past_a_failed_runs_stop_is_nan():
    """A chart model stops at its singularity: sol is NaN past t_stop, finite before."""
    r = simulate("spherical_std", [0.5, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0], np.linspace(0, 3, 7),
                 {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}, method="dop853")
    assert not r.ok and r.status_name.startswith("chart singular"), r.message
    before, after = r.sol(0.9 * r.t_stop), r.sol(min(r.t_stop + 0.2, 3.0))
    assert np.all(np.isfinite(before)) and np.all(np.isnan(after))


# -- events ----------------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["dopri5", "dop853"])
@pytest.mark.parametrize("rtol", [1e-6, 1e-9, 1e-12])
def test_simple_pendulum_zero_crossings_at_the_elliptic_period(simple_model, method, rtol):
    """From rest at 2 rad, theta = 0 at (2j + 1) T/4, T = 4 sqrt(l/g) K(sin^2(theta0/2)):
    all 8 crossings in 10 s found, alternately falling and rising, each within 100 rtol."""
    theta0, p = 2.0, {"m": 1.0, "l": 1.0, "g": 9.81}
    period = 4 * np.sqrt(p["l"] / p["g"]) * ellipk(np.sin(theta0 / 2) ** 2)
    r = simulate(simple_model, [theta0, 0.0], np.linspace(0, 10, 11), p, method=method, rtol=rtol,
                 events={"bottom": "theta1"})
    e = r.events["bottom"]
    exact = (2 * np.arange(len(e.t)) + 1) * period / 4
    assert len(e.t) == int((10 - period / 4) // (period / 2)) + 1 == 8
    err = float(np.max(np.abs(e.t - exact)))
    assert err < 100 * rtol, f"{method} rtol {rtol:g}: event times off by {err:.2e}"
    assert list(e.direction) == [-1, 1] * 4
    assert np.max(np.abs(e.y[:, 0])) < 1e3 * rtol          # the state there: theta1 = 0


@pytest.fixture(scope="module")
def flips() -> np.ndarray:
    """The flips of link 2 by brute force: solve_ivp DOP853 at rtol 1e-12, its dense output
    sampled every 2e-5 s, sign changes refined by brentq."""
    fun, _ = derive.scipy_rhs("planar", PLANAR)
    s = scipy_integrate.solve_ivp(fun, (0.0, 4.0), SPIN, method="DOP853", rtol=1e-12, atol=1e-12,
                                  dense_output=True)
    g = lambda t: np.cos(s.sol(t)[1] / 2)
    grid = np.linspace(0.0, 4.0, 200_001)
    values = g(grid)
    i = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
    return np.array([brentq(g, grid[j], grid[j + 1], xtol=1e-15) for j in i])


@pytest.mark.parametrize("outputs", [5, 401])
@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_double_pendulum_flips_match_a_brute_force_search(flips, outputs, backend):
    """Every flip found whether outputs are coarse (1 s) or fine (0.01 s), within 1e-8 s
    at rtol 1e-10 (measured: 4e-10)."""
    assert len(flips) == 4
    r = simulate("planar", SPIN, np.linspace(0, 4, outputs), PLANAR, method="dop853", rtol=1e-10,
                 backend=backend, events={"flip": FLIP})
    e = r.events["flip"]
    assert len(e.t) == len(flips), f"found {e.t}, brute force {flips}"
    err = float(np.max(np.abs(e.t - flips)))
    assert err < 1e-8, f"flip times off by {err:.2e}"
    assert np.allclose(np.cos(e.y[:, 1] / 2), 0, atol=1e-9)
    assert r.t_events[0] is e.t and r.y_events[0] is e.y


def test_direction_filters_crossings(flips):
    """direction +1 keeps the rising crossings of the expression, -1 the falling ones."""
    r = simulate("planar", SPIN, np.linspace(0, 4, 41), PLANAR, rtol=1e-10,
                 events={"any": FLIP, "up": {"expression": FLIP, "direction": 1},
                         "down": {"expression": FLIP, "direction": -1}})
    ev = r.events
    assert len(ev["up"]) + len(ev["down"]) == len(ev["any"]) == len(flips)
    assert np.all(ev["up"].direction == 1) and np.all(ev["down"].direction == -1)
    assert np.array_equal(np.sort(np.concatenate([ev["up"].t, ev["down"].t])), ev["any"].t)
    y = ev["any"].y                                      # d/dt cos(theta2/2) = -sin(theta2/2) theta2_dot / 2
    assert np.array_equal(np.sign(-np.sin(y[:, 1] / 2) * y[:, 3]), ev["any"].direction)


@pytest.mark.parametrize("terminal, index", [(True, 0), (2, 1)])
def test_terminal_event_stops_the_run(flips, terminal, index):
    """terminal = true stops at the first crossing, terminal = 2 at the second: status ok,
    t_stop the event, outputs after it NaN, other events only up to it, sol NaN past it."""
    t = np.linspace(0, 4, 41)
    r = simulate("planar", SPIN, t, PLANAR, rtol=1e-10,
                 events={"flip": {"expression": FLIP, "terminal": terminal}, "bottom": "theta1"})
    stop = flips[index]
    assert r.ok and r.terminal_event == "flip" and abs(r.t_stop - stop) < 1e-8, r.message
    assert "terminal event 'flip'" in r.message
    assert len(r.events["flip"]) == index + 1
    assert np.all(r.events["bottom"].t <= r.t_stop)
    after = t > r.t_stop
    assert np.all(np.isnan(r.y[after])) and np.all(np.isfinite(r.y[~after]))
    assert np.all(np.isnan(r.energy[after]))
    assert np.array_equal(r.y_stop, r.events["flip"].y[-1])
    assert np.all(np.isnan(r.sol(r.t_stop + 0.05)))


@pytest.mark.parametrize("events, message", [
    ({"flip": "cos(theta3)"}, "events.flip.expression: the name 'theta3' is not declared"),
    ({"boom": "__import__('os').system('true')"}, "events.boom.expression: the construct 'Attribute'"),
    ({"boom": "__import__('os')"}, "events.boom.expression: the function '__import__'"),
    ({"x": "theta1.real"}, "events.x.expression: the construct 'Attribute'"),
    ({"x": {"expression": "theta1", "direction": 2}}, "events.x.direction must be -1, 0 or +1"),
    ({"x": {"expression": "theta1", "terminal": -1}}, "events.x.terminal must be true, false"),
    ({"x": {"expr": "theta1"}}, "events.x: unknown key 'expr'"),
    ("theta1", "events must be a mapping"),
    ({"a/b": "theta1"}, "events: the event name 'a/b' is not an identifier"),
])
def test_bad_events_are_one_line(events, message):
    with pytest.raises(SimulationInputError) as exc:
        simulate("planar", [0.1, 0, 0, 0], [0, 1], PLANAR, events=events)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_events_need_an_adaptive_chart_method():
    with pytest.raises(SimulationInputError, match="adaptive method"):
        simulate("planar", [0.1, 0, 0, 0], [0, 1], PLANAR, method="rk4", step=0.01, events={"e": "theta1"})
    with pytest.raises(SimulationInputError, match="chart atlas"):
        simulate("spherical", [0.5, 0, 0.5, 0, 0, 0.3, 0, 0], [0, 1],
                 {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}, events={"e": "theta1"})


def test_events_as_a_list_with_parameters_and_inputs():
    """A list of events is named event1, event2; parameters and inputs may appear."""
    model = str(MODELS / "driven.toml")
    r = simulate(model, [0.5, 0.3, 0, 0], np.linspace(0, 3, 7), DRIVEN, rtol=1e-10, inputs={"tau1": 0.0, "tau2": 0.0},
                 events=["l1*sin(theta1)", {"name": "bob", "expression": "theta1 - tau1 + c1 - c1"}])
    assert list(r.events) == ["event1", "bob"]
    assert np.allclose(r.events["event1"].t, r.events["bob"].t, atol=1e-9) and len(r.events["bob"]) >= 2


def test_events_backward_in_time(flips):
    """Run back from t = 4: the same flips in reverse order, each direction reversed (the
    direction is in the order of integration, as SciPy's)."""
    t = np.linspace(0, 4, 41)
    forward = simulate("planar", SPIN, t, PLANAR, rtol=1e-11, events={"flip": FLIP})
    back = simulate("planar", forward.y[-1], t[::-1], PLANAR, rtol=1e-11, events={"flip": FLIP})
    assert np.max(np.abs(back.events["flip"].t[::-1] - flips)) < 1e-8
    assert np.array_equal(back.events["flip"].direction[::-1], -forward.events["flip"].direction)
