"""A closed loop at run time (issue 23 item 5): the four-bar linkage through
derive.simulate, its constraint drift bounded over t = 100 and reported with the run, its
energy conserved, a start off the loop refused in one line (or projected on request)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.codegen.contract import CONSTRAINT_DRIFT_BOUND
from derive.runtime.result import summary_rows
from tests.derivation.test_closed_loop_against_mechanics import closed_state

ROOT = Path(__file__).resolve().parents[2]
FOUR_BAR = str(ROOT / "examples" / "models" / "four_bar.toml")
P = {"m1": 1.0, "m2": 2.0, "m3": 1.5, "l1": 0.5, "l2": 2.0, "l3": 1.5, "d": 2.0, "g": 9.81}
Y0 = closed_state(0.3, 1.0, list(P.values()), 1)


def independent_residuals(y) -> np.ndarray:
    """|Phi| and |J q'| of states y written out here, not read from the kernels."""
    th, w = y[:, :3], y[:, 3:]
    lengths = np.array([P["l1"], P["l2"], P["l3"]])
    phi = np.stack([(lengths * np.sin(th)).sum(1) - P["d"], -(lengths * np.cos(th)).sum(1)], 1)
    phi_dot = np.stack([(lengths * np.cos(th) * w).sum(1), (lengths * np.sin(th) * w).sum(1)], 1)
    return np.abs(phi).max(), np.abs(phi_dot).max()


def check_long_run(backend: str):
    r = derive.simulate(FOUR_BAR, Y0, np.linspace(0, 100, 1001), P, method="dop853", backend=backend)
    assert r.ok, r.message
    phi, phi_dot = independent_residuals(r.y)
    assert r.constraint_drift.phi == pytest.approx(phi, rel=1e-6)
    assert r.constraint_drift.phi_dot == pytest.approx(phi_dot, rel=1e-6)
    assert phi < CONSTRAINT_DRIFT_BOUND and phi_dot < CONSTRAINT_DRIFT_BOUND
    assert not r.constraint_drift.exceeded and "drift" not in r.message
    assert r.energy_error < 1e-7                       # conservative: the constraint forces do no work
    assert np.ptp(r.y[:, 0]) > 1.0                     # the crank moved: not a trivial run


@pytest.mark.slow
def test_the_drift_is_bounded_over_t_100_with_compiled_dop853():
    check_long_run("c")


@pytest.mark.slow
def test_the_drift_is_bounded_over_t_100_with_numpy_dop853():
    check_long_run("numpy")


def test_a_loose_run_reports_its_drift_in_its_message():
    r = derive.simulate(FOUR_BAR, Y0, np.linspace(0, 20, 21), P, rtol=1e-4, backend="numpy")
    assert r.ok and r.constraint_drift.exceeded
    assert f"the constraint drift exceeds {CONSTRAINT_DRIFT_BOUND:g}" in r.message and "\n" not in r.message
    assert dict(summary_rows(r))["constraint drift"].startswith("max |Phi| = ")


def test_an_open_chain_reports_no_drift():
    r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], [1, 1, 1, 1, 9.81], backend="numpy")
    assert r.constraint_drift is None and "constraint drift" not in dict(summary_rows(r))


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_a_start_off_the_loop_is_refused_in_one_line(backend):
    off = Y0 + np.array([0.0, 0.01, 0.0, 0.0, 0.0, 0.0])
    with pytest.raises(derive.SimulationInputError) as info:
        derive.simulate(FOUR_BAR, off, [0.0, 1.0], P, backend=backend)
    text = str(info.value)
    assert "\n" not in text and "off the loop's constraints: |Phi| = " in text
    assert "derive.consistent_state" in text


def test_a_start_with_rates_off_the_loop_is_refused():
    off = Y0 + np.array([0.0, 0.0, 0.0, 0.1, 0.0, 0.0])
    with pytest.raises(derive.SimulationInputError, match=r"\|J q'\| = "):
        derive.simulate(FOUR_BAR, off, [0.0, 1.0], P, backend="numpy")


def test_consistent_state_projects_onto_the_loop_on_request():
    off = Y0 + 0.05
    y = derive.consistent_state(FOUR_BAR, off, P)
    phi, phi_dot = independent_residuals(y[None, :])
    assert phi < 1e-14 and phi_dot < 1e-14
    assert np.abs(y - off).max() < 0.2                 # the nearby closed state, not another branch
    assert derive.simulate(FOUR_BAR, y, [0.0, 0.5], P, backend="numpy").ok


def test_consistent_state_of_an_open_chain_is_refused():
    with pytest.raises(derive.SimulationInputError, match="has no constraints"):
        derive.consistent_state("planar", [1.0, 0.5, 0, 0], [1, 1, 1, 1, 9.81])


@pytest.mark.parametrize("method, step", [("dop853", None), pytest.param("rk4", 0.01, marks=pytest.mark.slow)])
def test_projection_after_every_step_keeps_the_loop_closed(method, step):
    t = np.linspace(0, 5, 51)
    free = derive.simulate(FOUR_BAR, Y0, t, P, method=method, step=step, backend="numpy")
    held = derive.simulate(FOUR_BAR, Y0, t, P, method=method, step=step, backend="numpy", project=True)
    assert held.ok
    phi, phi_dot = independent_residuals(held.y)
    assert phi < 1e-13 and phi_dot < 1e-13
    between = held.sol(np.array([0.05, 1.234, 4.96]))      # dense output: projected as the outputs are
    assert max(independent_residuals(between)) < 1e-13
    assert held.constraint_drift.phi < 1e-13 and held.constraint_drift.phi < free.constraint_drift.phi / 100
    reference = derive.simulate(FOUR_BAR, Y0, t, P, rtol=1e-13, backend="numpy")
    assert np.abs(held.y - reference.y).max() < np.abs(free.y - reference.y).max()   # nearer the motion
    assert held.energy_error < 1e-7


@pytest.mark.parametrize("options, message", [
    ({"method": "gauss2", "step": 0.01}, "project=True runs rk4, dopri5, dop853 or rk8"),
    ({"events": {"crank": "theta1"}}, "with no events"),
    ({"error_estimate": "rerun"}, "with no rerun estimate"),
    ({"dtype": "double-double", "backend": "c"}, "with no dtype double-double"),
    ({"dtype": "float32"}, "with no dtype float32"),
    ({"project": "yes"}, "project must be True or False"),
])
def test_projection_refuses_what_it_cannot_do_in_one_line(options, message):
    options = {"project": True, "backend": "numpy", **options}
    with pytest.raises(derive.SimulationInputError, match=re.escape(message)) as info:
        derive.simulate(FOUR_BAR, Y0, [0.0, 1.0], P, **options)
    assert "\n" not in str(info.value)


def test_projection_of_an_open_chain_is_refused():
    with pytest.raises(derive.SimulationInputError, match="project=True is for a closed loop"):
        derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], [1, 1, 1, 1, 9.81], project=True)


@pytest.mark.slow
def test_projection_runs_the_compiled_rhs_over_t_100():
    r = derive.simulate(FOUR_BAR, Y0, np.linspace(0, 100, 1001), P, project=True)
    assert r.ok and r.backend == "c" and r.constraint_drift.phi < 1e-13 and r.energy_error < 1e-9


def test_a_loop_of_two_coordinates_runs(tmp_path):
    """One closure on two coordinates (the docs' example: the tip kept on the line x = d):
    the open chain's 2x2 M, solved in closed form elsewhere, is here a block of the 3x3
    augmented system; the run keeps the tip on the line and conserves the energy."""
    path = tmp_path / "pinned_double.toml"
    path.write_text('name = "pinned_double"\ndimension = 2\nparameters = ["m1", "m2", "l1", "l2", "d", "g"]\n'
                    'constraints = ["l1*sin(theta1) + l2*sin(theta2) - d"]\n'
                    '[[links]]\nchart = "planar"\nlength = "l1"\nbody = { kind = "point", mass = "m1" }\n'
                    '[[links]]\nchart = "planar"\nlength = "l2"\nbody = { kind = "point", mass = "m2" }\n')
    p = {"m1": 1.0, "m2": 1.5, "l1": 1.0, "l2": 0.8, "d": 1.2, "g": 9.81}
    y0 = derive.consistent_state(str(path), [0.5, 0.7, 0.3, 0.0], p)
    r = derive.simulate(str(path), y0, np.linspace(0, 20, 201), p, backend="numpy")
    assert r.ok and not r.constraint_drift.exceeded and r.energy_error < 1e-7
    tip_x = p["l1"] * np.sin(r.y[:, 0]) + p["l2"] * np.sin(r.y[:, 1])
    assert np.abs(tip_x - p["d"]).max() < 1e-6 and np.ptp(r.y[:, 0]) > 0.05      # it moved


PINNED = """name = "pinned_straight"
dimension = 2
parameters = ["m1", "m2", "l1", "l2", "d", "g"]
constraints = ["l1*sin(theta1) + l2*sin(theta2) - d"]   # the tip stays on the line x = d
[[links]]
chart = "planar"
length = "l1"
body = { kind = "point", mass = "m1" }
[[links]]
chart = "planar"
length = "l2"
body = { kind = "point", mass = "m2" }
"""


def test_a_start_at_a_singular_configuration_of_the_loop_is_refused_in_one_line(tmp_path):
    """A user's trial: stretched straight to x = d = l1 + l2 (dPhi/dq = 0 there) the run
    stopped at t = 3.5e-9 on a step-size underflow that never named the cause."""
    path = tmp_path / "pinned.toml"
    path.write_text(PINNED)
    p = dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, d=2.0, g=9.81)
    with pytest.raises(derive.SimulationInputError, match="a singular configuration of the loop"):
        derive.simulate(str(path), [np.pi / 2, np.pi / 2, 0, 0], [0, 1], p)
    p["d"] = 1.5                                   # away from it the same loop runs
    y0 = derive.consistent_state(str(path), [1.0, 1.0, 0, 0], p)
    assert derive.simulate(str(path), y0, [0, 1], p).ok
