"""A closed loop started from its free coordinates: derive.consistent_state(...,
independent=), a scene's `[initial] independent`, and the sweep of a loop (each start
solved onto it, a start where it cannot close stored as status 6, its drift stored).

The oracle is tests/oracles/four_bar.py's closed_state: the coupler-rocker joint where
two circles meet, by plane geometry (not derive's Newton), NaN where they do not meet.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import derive
from derive.errors import SceneError, SimulationInputError
from derive.scene.scene import parse_scene
from tests.oracles.four_bar import NAMES, closed_state

MODEL = str(Path(__file__).resolve().parents[2] / "examples" / "models" / "four_bar.toml")
CRANK = dict(m1=1, m2=2, m3=1.5, l1=0.5, l2=2, l3=1.5, d=2, g=9.81)       # Grashof: the crank turns fully
LOCKED = dict(m1=1, m2=1, m3=1, l1=1.2, l2=1, l3=1, d=2, g=9.81)          # the crank reaches only part of the circle


def p_of(params):
    return [params[k] for k in NAMES]


@pytest.mark.parametrize("branch", [1, -1])
def test_the_free_coordinates_are_kept_and_the_others_solved_as_the_geometry_gives(branch):
    rng = np.random.default_rng(7)
    for theta1, rate1 in zip(rng.uniform(-np.pi, np.pi, 6), rng.normal(0, 2, 6)):
        want = closed_state(theta1, rate1, p_of(CRANK), branch)
        guess = want + np.r_[0, 0.05, -0.05, 0, 3.0, -3.0]          # rates of the others: ignored
        got = derive.consistent_state(MODEL, guess, CRANK, independent=["theta1"])
        assert got[0] == theta1 and got[3] == rate1
        wrapped = np.angle(np.exp(1j * (got[:3] - want[:3])))
        assert np.abs(wrapped).max() < 1e-12
        assert np.abs(got[3:] - want[3:]).max() < 1e-11 * max(1, abs(rate1))


def test_a_crank_angle_the_linkage_cannot_reach_is_one_line():
    theta1 = -np.pi / 2                   # the crank's tip at (-1.2, 0): 3.2 from (2, 0), the coupler and rocker span 2
    assert np.isnan(closed_state(theta1, 0.0, p_of(LOCKED), 1)).any()
    with pytest.raises(SimulationInputError, match=r"does not close at theta1 = -1\.5708"):
        derive.consistent_state(MODEL, [theta1, 0.5, 2.5, 0, 0, 0], LOCKED, independent="theta1")


@pytest.mark.parametrize("independent, message", [
    (["theta9"], "'theta9' is no coordinate of model 'four_bar'"),
    (["theta1", "theta2"], "so 1 free coordinate; got 2"),
    (["theta1", "theta1"], "a coordinate named twice"),
])
def test_wrong_free_coordinates_are_refused(independent, message):
    with pytest.raises(SimulationInputError, match=message):
        derive.consistent_state(MODEL, [0.3, 2.6, 0.6, 0, 0, 0], CRANK, independent=independent)


SCENE = """
[pendulum]
model = "{model}"
parameters = {params}
[initial]
independent = ["theta1"]
state = {state}
rest = true
[time]
stop = 1.0
outputs = 11
"""


def scene_text(state="{ theta1 = 0.3, theta2 = 2.6, theta3 = 0.6 }", params=CRANK):
    inline = "{ " + ", ".join(f"{k} = {v}" for k, v in params.items()) + " }"
    return SCENE.format(model=MODEL, params=inline, state=state)


def test_a_scene_starts_a_loop_from_its_crank_angle():
    scene = parse_scene(scene_text())
    y = [scene.initial["state"][n] for n in ("theta1", "theta2", "theta3", "theta1_dot", "theta2_dot", "theta3_dot")]
    want = closed_state(0.3, 0.0, p_of(CRANK), 1)
    assert y[0] == 0.3 and np.abs(np.array(y) - want).max() < 1e-12
    r = derive.simulate(MODEL, y, np.linspace(0, 1, 11), CRANK)          # on the loop: simulate takes it
    assert r.ok and r.constraint_drift.phi < 1e-8


@pytest.mark.parametrize("state, message", [
    ("{ theta1 = 0.3, theta2 = 2.6, theta2_dot = 1.0 }", "'initial.state.theta2_dot': the loop determines it"),
    ("{ theta2 = 2.6 }", "misses the coordinate theta1"),
    ("{ theta1 = -1.5707963, theta2 = 0.5, theta3 = 2.5 }", "does not close at theta1 = -1.5708"),
])
def test_a_loops_scene_refuses_what_the_loop_decides_or_cannot_reach(state, message):
    with pytest.raises(SceneError, match=message):
        parse_scene(scene_text(state, LOCKED if "-1.5707963" in state else CRANK))
