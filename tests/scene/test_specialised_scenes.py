"""pendulum.specialise: a scene's run on kernels with its parameters folded in, measured
against a reference on the general kernels; a sweep folds only what it does not sweep."""
import dataclasses
import json

import numpy as np
import pytest

import derive
from derive.scene import SceneError, parse_scene
from derive.sweep.runners import model_name
from derive.sweep.sweep_file import parse_sweep

from .scene_cli import DEFAULT, run_scene

SPECIALISED = DEFAULT.replace("g = 9.81 }", "g = 9.81 }\nspecialise = true")


def test_a_specialised_scene_meets_its_target_on_the_folded_kernels(tmp_path):
    """The default scene (chaotic, to a 1e-8 target) with the key: its run names the
    specialised model, its error is measured against the general kernels' reference, and
    its final state is the general run's to within the target."""
    assert SPECIALISED != DEFAULT
    runs = []
    for folder, text in ((tmp_path / "specialised", SPECIALISED), (tmp_path / "general", DEFAULT)):
        folder.mkdir()
        runs.append(json.loads(run_scene(folder, text, "--json").stdout))
    ours, general = runs
    assert ours["specialised"].startswith("planar_s") and general["specialised"] is None
    assert ours["target_met"] and ours["achieved_error"] <= 1e-8
    assert np.max(np.abs(np.subtract(ours["final_state"], general["final_state"]))) <= 2e-8
    assert any(line.startswith(f"compiled C for {ours['specialised']}") for line in ours["steps"])


@pytest.mark.parametrize("edit,message", [
    (lambda t: t.replace("specialise = true", 'specialise = "yes"'), "'pendulum.specialise' must be true or false"),
    (lambda t: t.replace("[accuracy]", '[accuracy]\nbackend = "numpy"'), "accuracy.backend"),
])
def test_a_bad_key_names_itself(edit, message):
    with pytest.raises(SceneError, match=message) as info:
        parse_scene(edit(SPECIALISED), "scene.toml")
    assert "\n" not in str(info.value)


def test_the_chart_atlas_is_refused():
    atlas = (SPECIALISED.replace('model = "planar"', 'model = "spherical"')
             .replace("theta1 = 2.5, theta2 = 2.0, theta1_dot = 0.0, theta2_dot = 0.0",
                      "vartheta1 = 1.0, varphi1 = 0.5, vartheta2 = 1.2, varphi2 = 0.1")
             .replace("[initial]", "[initial]\nrest = true"))
    with pytest.raises(SceneError, match="not the chart atlas"):
        parse_scene(atlas, "scene.toml")


SWEEP = """
title = "m2 swept"
record = ["final_state"]
[pendulum]
model = "planar"
parameters = { m1 = 1.0, m2 = 1.0, l1 = 0.7, l2 = 1.3, g = 9.81 }
specialise = true
[initial]
state = { theta1 = 1.0, theta2 = 0.5 }
rest = true
[time]
stop = 1.0
outputs = 11
[axes]
theta1 = { list = [0.5, 1.0] }
m2 = { list = [0.5, 2.0] }
"""


def test_a_sweep_folds_the_parameters_it_does_not_sweep():
    """m2 is swept: it stays a run-time parameter (each trajectory its own), the rest are
    folded in; a chunk's task, which carries the sweep without its axes, makes the same model."""
    sweep = parse_sweep(SWEEP, "sweep.toml")
    name = model_name(sweep)
    assert name == model_name(dataclasses.replace(sweep, axes=()))
    folded = derive.load_model(name).title.split("specialised:")[1]
    assert "m2" not in folded and all(k in folded for k in ("m1", "l1", "l2", "g"))
    p = {**sweep.scene.parameters, "m2": 2.0}
    a = derive.simulate(name, [1.0, 0.5, 0, 0], [0.0, 1.0], p, method="rk4", step=1e-3)
    b = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], p, method="rk4", step=1e-3)
    assert np.max(np.abs(a.y - b.y)) <= 100 * np.finfo(float).eps
