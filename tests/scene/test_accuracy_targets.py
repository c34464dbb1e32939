"""An accuracy target is met or reported missed: one line, exit status 3, `target_met` in
--json; never a crash on a tolerance the user did not write (the reference run's
tolerance stays inside what its precision can take), never "result ok" for a miss."""
from __future__ import annotations

import json

import pytest

from tests.scene.scene_cli import DEFAULT, run_scene


def test_just_inside_the_horizon_the_target_is_met(tmp_path):
    """t = 7 used to crash ("rtol = 3.14e-19 is outside [10 eps, 1)"): the run stays in
    long double, its reference climbs to the rung that takes a tolerance 1000 times
    tighter (double-double), and the target is met."""
    run = run_scene(tmp_path, DEFAULT.replace("stop = 5.0", "stop = 7.0"), "--json")
    assert run.returncode == 0, run.stderr
    s = json.loads(run.stdout)
    assert s["target_met"] is True and s["achieved_error"] <= 1e-8 and s["precision"] == "long double"
    roundoff = {"long double": 1.0842e-19, "double-double": 2.0 ** -104}[s["reference_precision"]]
    assert s["reference_rtol"] >= 10 * roundoff and s["reference_rtol"] <= s["rtol"] / 100


@pytest.mark.parametrize("edit", [lambda t: t.replace("stop = 5.0", "stop = 10.0"),
                                  lambda t: t.replace("target = 1e-8", "target = 1e-14")])
def test_past_long_doubles_horizon_the_run_climbs_and_meets_the_target(tmp_path, edit):
    """These missed in long double before the ladder; now the planner climbs to Taylor in
    double-double, says so, and the measured error meets the target."""
    run = run_scene(tmp_path, edit(DEFAULT), "--json")
    assert run.returncode == 0, run.stderr
    s = json.loads(run.stdout)
    assert s["target_met"] is True and s["achieved_error"] <= s["target"]
    assert s["precision"] == "double-double" and s["method"] == "taylor"
    assert "climbed the precision ladder to double-double" in s["note"]


@pytest.mark.parametrize("edit, fragment", [
    pytest.param(lambda t: t.replace("stop = 5.0", "stop = 30.0"), "out of reach after t = ",  # past double-double's
                 marks=pytest.mark.slow),                                                    # horizon: ~40 s
    # below what the top rung resolves: the precision, not the motion, is the cause
    (lambda t: t.replace("target = 1e-8", "target = 1e-40"),
     "out of reach with double-double at rtol 1e-27: its early error, about 2.5e-27, is above the target"),
    (lambda t: t.replace("g = 9.81", "g = 1e6"), "out of reach after t = "),
])
def test_a_missed_target_is_one_line_and_exit_3(tmp_path, edit, fragment):
    run = run_scene(tmp_path, edit(DEFAULT), "--quiet")
    assert run.returncode == 3, (run.returncode, run.stderr)
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0] and "Traceback" not in run.stderr
    assert run.stdout == ""                 # --quiet: only the reason, on stderr
    run = run_scene(tmp_path, edit(DEFAULT), "--json")
    s = json.loads(run.stdout)
    assert s["target_met"] is False and s["exit_status"] == 3 and fragment in s["reason"]
    assert s["note"].count("climbed") <= 1     # each rung's reason once, however often it reran


def test_a_loose_target_does_not_make_a_loose_tolerance(tmp_path):
    run = run_scene(tmp_path, DEFAULT.replace("target = 1e-8", "target = 1e300"), "--json")
    assert run.returncode == 0, run.stderr
    s = json.loads(run.stdout)
    assert s["rtol"] <= 1e-3 and s["target_met"] is True


def test_json_stays_json_on_bad_input(tmp_path):
    run = run_scene(tmp_path, DEFAULT.replace("l1 = 1.0", "l1 = -1.0"), "--json")
    assert run.returncode == 2
    s = json.loads(run.stdout)
    assert s["ok"] is False and "l1" in s["error"] and s["exit_status"] == 2


def test_json_of_a_regular_motion_is_strict_json(tmp_path):
    """A motion with no positive Lyapunov exponent has an infinite trust horizon: JSON
    says "beyond the run" (Python's json would otherwise write Infinity, which is no JSON)."""
    calm = DEFAULT.replace("theta1 = 2.5, theta2 = 2.0", "theta1 = 0.01, theta2 = 0.01")
    run = run_scene(tmp_path, calm, "--json")
    assert run.returncode == 0, run.stderr
    assert "Infinity" not in run.stdout and "NaN" not in run.stdout
    s = json.loads(run.stdout)
    assert s["trust_horizon"] == "beyond the run" or s["trust_horizon"] > 5
