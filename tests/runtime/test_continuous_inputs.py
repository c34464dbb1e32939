"""simulate(..., inputs=u) with u(t, y) at every stage: a forced, damped pendulum converges
at the method's order against a tight solve_ivp of its equation written here; hold="zoh"
keeps the zero-order hold (first order in the output interval, whatever the step)."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import derive

FORCED = """
name = "forced_test"
title = "A damped pendulum driven by a torque tau"
dimension = 2
parameters = ["m", "l", "g", "c"]
inputs = ["tau"]
dissipation = "c*m*l**2*theta1_dot**2/2"
[forces]
theta1 = "tau"
[[links]]
chart = "planar"
length = "l"
body = { kind = "point", mass = "m" }
"""
P = {"m": 0.8, "l": 1.3, "g": 9.81, "c": 0.2}
F0, W = 1.5, 2.3
Y0 = [0.4, 0.0]
T = np.linspace(0.0, 10.0, 11)


def drive(t, y):
    return [F0 * np.cos(W * t)]


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    path = tmp_path_factory.mktemp("forced") / "forced_test.toml"
    path.write_text(FORCED)
    return str(path)


@pytest.fixture(scope="module")
def reference():
    m, l, g, c = P["m"], P["l"], P["g"], P["c"]

    def f(t, y):     # theta'' = -(g/l) sin theta - c theta' + F0 cos(w t) / (m l^2)
        return [y[1], -g / l * np.sin(y[0]) - c * y[1] + F0 * np.cos(W * t) / (m * l * l)]

    sol = solve_ivp(f, (0, 10), Y0, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=T)
    assert sol.success
    return sol.y.T


def test_rk4_converges_at_fourth_order(model, reference):
    errors = []
    for h in (0.1, 0.05, 0.025):
        r = derive.simulate(model, Y0, T, P, method="rk4", step=h, inputs=drive)
        assert r.ok
        errors.append(np.abs(r.y - reference).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 13) & (ratios < 19)), (errors, ratios)


@pytest.mark.parametrize("method, backend", [("dopri5", "c"), ("dopri5", "numpy"), ("dop853", "c")])
def test_adaptive_methods_meet_their_tolerance(model, reference, method, backend):
    r = derive.simulate(model, Y0, T, P, method=method, rtol=1e-10, atol=1e-10, inputs=drive, backend=backend)
    assert r.ok and r.naccepted > 20 and r.rtol == 1e-10 and r.error_estimate > 0
    assert np.abs(r.y - reference).max() < 1e-7
    loose = derive.simulate(model, Y0, T, P, method=method, rtol=1e-6, atol=1e-6, inputs=drive, backend=backend)
    assert np.abs(loose.y - reference).max() > np.abs(r.y - reference).max()    # the tolerance steers it


def test_rk8_is_far_more_accurate_than_rk4_at_the_same_step(model, reference):
    r8 = derive.simulate(model, Y0, T, P, method="rk8", step=0.1, inputs=drive)
    r4 = derive.simulate(model, Y0, T, P, method="rk4", step=0.1, inputs=drive)
    e8, e4 = np.abs(r8.y - reference).max(), np.abs(r4.y - reference).max()
    assert r8.ok and r8.step == 0.1 and e8 < 1e-8 and e8 < 1e-4 * e4, (e8, e4)


def test_zero_order_hold_stays_wrong_at_any_step(model, reference):
    errors = [np.abs(derive.simulate(model, Y0, T, P, method="rk4", step=h, inputs=drive, hold="zoh").y
                     - reference).max() for h in (0.05, 0.025)]
    assert min(errors) > 1e-2 and errors[1] > 0.5 * errors[0]      # the hold's error, not the step's


def test_continuous_inputs_refuse_an_implicit_method_in_one_line(model):
    with pytest.raises(derive.SimulationInputError, match="hold='zoh'"):
        derive.simulate(model, Y0, T, P, method="gauss2", step=0.1, inputs=drive)
    with pytest.raises(derive.SimulationInputError, match="unknown hold"):
        derive.simulate(model, Y0, T, P, method="rk4", step=0.1, inputs=drive, hold="foh")
    with pytest.raises(derive.SimulationInputError, match="unknown hold"):     # the fast path too
        derive.simulate("planar", [0.1, 0, 0, 0], [0, 1], [1, 1, 1, 1, 9.81], hold="foh")
