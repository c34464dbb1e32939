"""derive.simulate runs a time-dependent model (issue 23 item 3): in the generated C and
NumPy integrators each stage's rhs takes its own time t (tests/runtime/test_rk_explicit_time.py
has every method and precision); with inputs u(t, y) at every stage the explicit RK
methods step in Python with each stage at its own time (derive/runtime/continuous_inputs.py),
events and dense output on those steps (derive/runtime/stage_solution.py).  References:
solve_ivp of the ODEs written here by hand, independent of the derivation."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import derive
from derive.runtime.continuous_inputs import CONTINUOUS_METHODS

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
PIVOT, FORCED = str(EXAMPLES / "driven_pivot.toml"), str(EXAMPLES / "forced_pendulum.toml")
PIVOT_P = {"m": 1.3, "l": 0.8, "g": 9.81, "a": 0.01, "w": 5.0}
FORCED_P = {"m": 1.0, "l": 1.2, "g": 9.81, "c": 0.2, "F0": 0.5, "w": 2.0}
OPTIONS = {"rk4": {"step": 1e-3}, "rk8": {"step": 1e-2}, "dopri5": {"rtol": 1e-12, "atol": 1e-14},
           "dop853": {"rtol": 1e-12, "atol": 1e-14}}


def pivot_ode(t, y, m, l, g, a, w):
    """x = (a cos wt + l sin th, -l cos th): the pivot's acceleration -a w^2 cos(wt) is a
    force m a w^2 cos(wt) along +x in its frame, a torque m a w^2 cos(wt) l cos(th)."""
    th, thd = y
    return [thd, -(g / l) * np.sin(th) + (a * w ** 2 / l) * np.cos(w * t) * np.cos(th)]


def forced_ode(t, y, m, l, g, c, F0, w):
    th, thd = y
    return [thd, (F0 * np.cos(w * t) - c * thd - m * g * l * np.sin(th)) / (m * l ** 2)]


def reference(ode, params, y0, times, **kw):
    r = solve_ivp(lambda t, y: ode(t, y, *params.values()), (times[0], times[-1]), y0, method="DOP853",
                  t_eval=times, rtol=1e-13, atol=1e-14, **kw)
    assert r.success
    return r


def test_every_explicit_method_of_the_contract_runs_time_dependent_models():
    assert set(CONTINUOUS_METHODS) == {"rk4", "rk8", "dopri5", "dop853"}


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("method", sorted(OPTIONS))
def test_the_driven_pivot_matches_the_hand_written_ode(method, backend):
    times = np.linspace(0.0, 5.0, 11)
    r = derive.simulate(PIVOT, [0.2, 0.0], times, PIVOT_P, method=method, backend=backend, **OPTIONS[method])
    assert r.ok, r.message
    expected = reference(pivot_ode, PIVOT_P, [0.2, 0.0], times).y.T
    assert np.max(np.abs(r.y - expected)) < 1e-9
    # the drive matters at this amplitude: without it the pendulum is far away
    still = reference(pivot_ode, dict(PIVOT_P, a=0.0), [0.2, 0.0], times).y.T
    assert np.max(np.abs(still - expected)) > 1e-3
    # the bob's position has the pivot's displacement a cos(wt) (the kernels took t)
    m, l, g, a, w = PIVOT_P.values()
    bob_x = a * np.cos(w * times) + l * np.sin(r.y[:, 0])
    assert np.max(np.abs(r.positions[:, 0, 0] - bob_x)) < 1e-12


def test_the_forced_pendulum_with_11_outputs_converges_at_rk4s_order():
    """Error at t = 10 against a tight solve_ivp, for h, h/2, h/4: the slope of log error
    against log h is the method's order (the inputs-held-per-output first-order error is gone)."""
    times = np.linspace(0.0, 10.0, 11)
    exact = reference(forced_ode, FORCED_P, [0.3, 0.0], times).y[:, -1]
    steps = np.array([0.1, 0.05, 0.025])
    errors = [np.max(np.abs(derive.simulate(FORCED, [0.3, 0.0], times, FORCED_P, method="rk4",
                                            step=h).y[-1] - exact)) for h in steps]
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert 3.8 < slope < 4.2, (errors, slope)
    assert errors[-1] < 1e-5          # held per output interval it was 1.64 (issue 23)


def test_dense_output_is_the_run_between_its_rows():
    times = np.linspace(0.0, 5.0, 6)
    r = derive.simulate(PIVOT, [0.2, 0.0], times, PIVOT_P, method="dop853", rtol=1e-12, atol=1e-14)
    assert np.array_equal(r.sol(times[1:-1]), r.y[1:-1])
    between = np.linspace(0.05, 4.95, 37)
    expected = reference(pivot_ode, PIVOT_P, [0.2, 0.0], np.concatenate([[0.0], between])).y.T[1:]
    assert np.max(np.abs(r.sol(between) - expected)) < 1e-9
    # continuous across an output row, where the next interval's run starts at its own t
    knot = times[3]
    assert np.max(np.abs(r.sol(knot - 1e-12) - r.sol(knot + 1e-12))) < 1e-10
    # on the NumPy backend: the same re-integration from each row's own t
    numpy_run = derive.simulate(PIVOT, [0.2, 0.0], times, PIVOT_P, method="dop853", rtol=1e-12, atol=1e-14,
                                backend="numpy")
    assert np.max(np.abs(numpy_run.sol(between) - expected)) < 1e-9


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_events_of_a_time_dependent_run_match_solve_ivps(method):
    times = np.linspace(0.0, 6.0, 4)

    def crossing(t, y, *args):
        return y[0]

    expected = reference(pivot_ode, PIVOT_P, [0.2, 0.0], times, events=crossing).t_events[0]
    r = derive.simulate(PIVOT, [0.2, 0.0], times, PIVOT_P, method=method, rtol=1e-12, atol=1e-14,
                        events={"down": "theta1"})
    assert len(expected) >= 4 and len(r.events["down"]) == len(expected)
    assert np.max(np.abs(r.events["down"].t - expected)) < 1e-8
    assert np.max(np.abs(r.events["down"].y[:, 0])) < 1e-9
    # terminal: the run stops at the second crossing, outputs after it are NaN
    stop = derive.simulate(PIVOT, [0.2, 0.0], times, PIVOT_P, method=method, rtol=1e-12, atol=1e-14,
                           events={"down": {"expression": "theta1", "terminal": 2}})
    assert stop.terminal_event == "down" and abs(stop.t_stop - expected[1]) < 1e-8
    assert np.isnan(stop.y[-1]).all() and np.isnan(stop.sol(expected[1] + 0.1)).all()


FORCED_INPUT = """name = "forced_u"
title = "Forced damped pendulum with a torque input"
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


@pytest.mark.parametrize("kw, word", [({"method": "gauss2", "step": 0.01}, "gauss2"),
                                      ({"method": "abm12", "step": 0.01}, "abm12"),
                                      ({"dtype": "float32"}, "float64")])
def test_inputs_at_every_stage_step_in_python_and_refuse_the_rest_in_one_line(tmp_path, kw, word):
    """Inputs u(t, y) at every stage step the explicit one-step methods in float64 in
    Python; the rest is refused, naming hold='zoh', which runs them."""
    model = tmp_path / "forced_u.toml"
    model.write_text(FORCED_INPUT)
    with pytest.raises(derive.SimulationInputError, match="every stage") as info:
        derive.simulate(str(model), [0.2, 0.0], [0.0, 1.0], FORCED_P, inputs=lambda t, y: [0.0], **kw)
    text = str(info.value)
    assert "\n" not in text and word in text and "hold='zoh'" in text


def test_a_rerun_estimate_bounds_the_error_of_a_time_dependent_run():
    times = np.linspace(0.0, 5.0, 6)
    r = derive.simulate(FORCED, [0.3, 0.0], times, FORCED_P, method="rk4", step=0.05, error_estimate="rerun")
    actual = np.abs(r.y - reference(forced_ode, FORCED_P, [0.3, 0.0], times).y.T)
    assert np.max(actual) > 0 and np.allclose(r.error_y, actual, rtol=0.1, atol=1e-12)


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_an_adaptive_runs_steps_do_not_depend_on_its_outputs(method):
    """The outputs are reached inside the steps (one step from the step's start), not by
    shortening them: 11 or 1001 outputs, the same steps and the same final state."""
    coarse = derive.simulate(PIVOT, [0.2, 0.0], np.linspace(0, 10, 11), PIVOT_P, method=method, rtol=1e-9)
    fine = derive.simulate(PIVOT, [0.2, 0.0], np.linspace(0, 10, 1001), PIVOT_P, method=method, rtol=1e-9)
    assert coarse.naccepted == fine.naccepted and np.array_equal(coarse.y[-1], fine.y[-1])
    assert np.max(np.abs(fine.y[::100] - coarse.y)) < 1e-8
