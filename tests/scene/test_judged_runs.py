"""A scene that fixes its method is judged as a scene with a target is: its final-state
error is measured against a reference run, a run past its trust horizon says so, and a
result that means nothing is no "ok" (one line, exit 1).  The planner's words say what
happened, abm12's stop names its guard, and the relative energy error is relative to a
scale that cannot vanish."""
from __future__ import annotations

import json

import pytest

from derive.scene import parse_scene
from derive.scene.run import choose

from tests.scene.scene_cli import DEFAULT, run_scene


def accuracy(text: str, table: str) -> str:
    """The default scene with another [accuracy] table."""
    return text.replace("[accuracy]\ntarget = 1e-8", "[accuracy]\n" + table)


def test_a_meaningless_result_is_not_ok_and_exits_1(tmp_path):
    """rk4 at step 0.2 on the chaotic case to t = 20 finishes, but its energy is off by more
    than the whole well: one line, exit 1, never "result ok"."""
    text = accuracy(DEFAULT, 'method = "rk4"\nstep = 0.2').replace("stop = 5.0", "stop = 20.0")
    run = run_scene(tmp_path, text)
    assert run.returncode == 1, run.stderr
    assert "result  ok" not in run.stdout and "result  meaningless at t = 20" in run.stdout
    reason = [line for line in run.stderr.splitlines() if not line.startswith("derive: warning:")]
    assert len(reason) == 1 and reason[0].startswith("derive: result meaningless: relative energy error ")
    assert "(above 1): rk4 at step 0.2 does not follow the motion" in reason[0]
    assert "Traceback" not in run.stderr
    s = json.loads(run_scene(tmp_path, text, "--json").stdout)
    assert s["ok"] is False and s["status"] == "meaningless" and s["exit_status"] == 1
    assert s["relative_energy_error"] > 1 and s["achieved_error"] > 1


def test_a_step_of_100_is_not_ok(tmp_path):
    """rk4 at step 100 on a small swing ends with a finite state 1e105 rad away and an
    energy that overflows: exit 1 and one line, not "result ok" (nor a refused reference)."""
    text = (accuracy(DEFAULT, 'method = "rk4"\nstep = 100')
            .replace("theta1 = 2.5, theta2 = 2.0", "theta1 = 0.1, theta2 = 0.1")
            .replace("stop = 5.0", "stop = 200.0").replace("outputs = 501", "outputs = 3"))
    run = run_scene(tmp_path, text)
    assert run.returncode == 1, run.stderr
    assert "result  meaningless at t = 200" in run.stdout
    assert "energy  relative error not finite (its scale 29.43 = max(|E0|, m g l))" in run.stdout
    assert run.stderr.strip().splitlines()[-1] == ("derive: result meaningless: the energy is not finite by "
                                                   "t = 200; give a smaller accuracy.step or an accuracy.target")


def test_an_explicit_method_reports_its_error_and_warns_past_its_horizon(tmp_path):
    """DOP853 at its default rtol to t = 30 (trust horizon about 0.7): the error is measured
    against the reference run and printed, and one warning line says where trust ends."""
    run = run_scene(tmp_path, accuracy(DEFAULT, 'method = "dop853"').replace("stop = 5.0", "stop = 30.0"))
    assert run.returncode == 0, run.stderr
    error = [line for line in run.stdout.splitlines() if line.startswith("error   ")]
    assert error and error[0].startswith("error   final-state error ")
    assert "(no target; reference dop853 at rtol 1e-12 in double)" in error[0]
    warnings = run.stderr.strip().splitlines()
    assert len(warnings) == 1 and warnings[0].startswith("derive: warning: t = 30 is past the trust horizon t = 0.")


def test_a_fixed_step_is_measured_against_dop853(tmp_path):
    """rk4 has no error estimate of its own: its reference is DOP853, a thousand times
    tighter than its local error h^4; its trust horizon for 1e-8 is none, said as such."""
    run = run_scene(tmp_path, accuracy(DEFAULT, 'method = "rk4"\nstep = 0.01'), "--json")
    assert run.returncode == 0, run.stderr
    s = json.loads(run.stdout)
    assert s["reference_method"] == "dop853" and s["reference_rtol"] == pytest.approx(1e-11)
    assert 1e-4 < s["achieved_error"] < 1            # chaotic: h = 0.01 is far from 1e-8 at t = 5
    assert "never within error 1e-08" in run.stderr and "t = 0 for error" not in run.stderr


def test_a_float_run_never_within_its_error_says_so(tmp_path):
    """Not "trust horizon t = 0 for error 1e-08" (trust nothing?) but what it means."""
    run = run_scene(tmp_path, accuracy(DEFAULT, 'method = "dop853"\nrtol = 1e-5\nscalar = "float"'))
    assert run.returncode == 0, run.stderr
    chaos = [line for line in run.stdout.splitlines() if line.startswith("chaos   ")][0]
    assert "trust horizon t = 0 " not in chaos
    assert "never within error 1e-08 (its early error, about 2.5e-05, is above it)" in chaos


def test_a_scene_that_asks_for_quad_is_planned_in_quad_and_says_so():
    """The planner's note names the precision that runs: quad, not double-double."""
    scene = parse_scene(accuracy(DEFAULT, 'target = 1e-31\nscalar = "quad"'), "<quad>")
    c = choose(scene, None)
    assert (c.method, c.dtype) == ("taylor", "quad") and c.rtol == pytest.approx(1e-30)
    assert "double-double" not in c.note
    assert c.note == ("target 1e-31 needs rtol 1e-32, beyond quad (IEEE binary128): run at its floor "
                      "rtol 1e-30, which reports what it achieves")
    reachable = choose(parse_scene(accuracy(DEFAULT, 'target = 1e-26\nscalar = "quad"'), "<quad>"), None)
    assert reachable.dtype == "quad" and reachable.rtol == pytest.approx(1e-27) and reachable.note == ""


def test_a_target_just_above_the_top_precisions_floor_names_its_early_error(tmp_path):
    """1e-26 with double-double at its floor rtol 1e-27: the early error (2.5e-27) is below
    the target at the start and the chaos carries it past: the line names the precision,
    its tolerance and that early error, not the motion alone."""
    run = run_scene(tmp_path, accuracy(DEFAULT, "target = 1e-26"), "--quiet")
    assert run.returncode == 3, run.stderr
    line, = run.stderr.strip().splitlines()
    assert line.startswith("derive: target 1e-26 out of reach after t = 0.")
    assert ("with double-double at rtol 1e-27: its early error, about 2.5e-27, grows past the target there "
            "(the trust horizon of the motion's largest Lyapunov exponent 2.") in line
    assert line.endswith(" at t = 5") and "achieved 1." in line


def test_abm12_names_its_guard_and_a_scene_can_loosen_it(tmp_path):
    """At h = 0.01 on the regular case the guard stops abm12 at t = 0.77: the line names it,
    its threshold and the key that loosens it; accuracy.rtol = 1e-6 then runs to t = 20."""
    regular = DEFAULT.replace("theta1 = 2.5, theta2 = 2.0", "theta1 = 1.0, theta2 = 0.5").replace(
        "stop = 5.0", "stop = 20.0")
    run = run_scene(tmp_path, accuracy(regular, 'method = "abm12"\nstep = 0.01'), "--quiet")
    assert run.returncode == 1
    line, = run.stderr.strip().splitlines()
    assert line.startswith("derive: run failed: integration stopped at t = 0.77")
    assert ("the guard: Milne's error estimate above atol + rtol |y| (rtol 1e-09, atol 1e-12): "
            "loosen rtol (and atol), or take a smaller step") in line
    run = run_scene(tmp_path, accuracy(regular, 'method = "abm12"\nstep = 0.01\nrtol = 1e-6'), "--json")
    assert run.returncode == 0, run.stderr
    s = json.loads(run.stdout)
    assert s["ok"] and s["t_stop"] == 20.0 and s["achieved_error"] < 1e-8


def test_the_energy_error_of_a_motion_with_zero_energy_is_relative_to_the_well(tmp_path):
    """Released at rest with both links horizontal, E0 = 0 (to rounding): |E - E0| / |E0|
    would be enormous; relative to max(|E0|, m g l) = 9.81 (1 + 2) it is the run's error,
    and the line says what it is relative to."""
    text = DEFAULT.replace("theta1 = 2.5, theta2 = 2.0", "theta1 = 1.5707963267948966, theta2 = 1.5707963267948966")
    run = run_scene(tmp_path, text)
    assert run.returncode == 0, run.stderr
    energy = [line for line in run.stdout.splitlines() if line.startswith("energy  ")][0]
    assert energy.startswith("energy  relative error ") and energy.endswith(" of 29.43 = max(|E0|, m g l)")
    assert float(energy.split()[3]) < 1e-7
    s = json.loads(run_scene(tmp_path, text, "--json").stdout)
    assert s["energy_scale"] == pytest.approx(29.43) and s["energy_scale_is"] == "max(|E0|, m g l)"


def test_a_double_double_energy_error_is_a_figure_not_zero(tmp_path):
    """Above long double the energy is evaluated from the exact states: the drift of the run
    itself (about 1e-25 here), not 0 (its long double energies rounded to double)."""
    text = accuracy(DEFAULT, 'target = 1e-20\nscalar = "double-double"').replace("stop = 5.0", "stop = 1.0")
    run = run_scene(tmp_path, text, "--json")
    assert run.returncode == 0, run.stderr
    s = json.loads(run.stdout)
    assert s["precision"] == "double-double" and 0 < s["relative_energy_error"] < 1e-20


USER_CHAIN = """name = "my_chain"
title = "A user's double spherical chain"
dimension = 3
parameters = ["m1", "m2", "l1", "l2", "g"]
[[links]]
chart = "standard"
length = "l1"
body = { kind = "point", mass = "m1" }
[[links]]
chart = "standard"
length = "l2"
body = { kind = "point", mass = "m2" }
"""

USER_CHAIN_SCENE = """title = "my chain"
[pendulum]
model = "my_chain.toml"
parameters = { m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 9.81 }
[initial]
state = { theta1 = 0.4, phi1 = 0.0, theta2 = 0.8, phi2 = 1.0, theta1_dot = -2.0, phi1_dot = 0.5, theta2_dot = 1.0, phi2_dot = 0.3 }
[time]
stop = 3.0
outputs = 31
[accuracy]
target = 1e-8
"""


@pytest.mark.slow      # derives the three charts of a new chain: about 150 s with a cold cache
def test_a_users_spherical_chain_runs_through_its_charts_pole_on_its_atlas(tmp_path):
    """A model file of the user's own in the standard chart, whose motion meets theta1 = 0 at
    t = 1.61: the scene runs again on the chain's chart atlas, as the catalogue's spherical
    does, and says why; asked for one chart, it stops there and names the way out."""
    (tmp_path / "my_chain.toml").write_text(USER_CHAIN)
    run = run_scene(tmp_path, USER_CHAIN_SCENE, "--json")
    assert run.returncode == 0, run.stderr
    s = json.loads(run.stdout)
    assert s["model"] == "my_chain_atlas" and s["ok"] and s["t_stop"] == 3.0 and s["chart_switches"] >= 1
    assert s["model_reason"] == "my_chain's chart meets its pole at t = 1.611: ran on its chart atlas"
    assert s["achieved_error"] <= s["target"]
    one_chart = run_scene(tmp_path, USER_CHAIN_SCENE.replace("[pendulum]", "[pendulum]\natlas = false"))
    assert one_chart.returncode == 1 and "Traceback" not in one_chart.stderr
    stopped = [line for line in one_chart.stdout.splitlines() if line.startswith("stopped ")]
    assert stopped and "at t = 1.61" in stopped[0] and "simulate(" not in stopped[0]
    error = [line for line in one_chart.stdout.splitlines() if line.startswith("error   ")][0]
    assert error.endswith("achieved not measured: the run stopped (reference dop853 at rtol 1e-12 in double)")
    reason, = one_chart.stderr.strip().splitlines()
    assert reason.startswith("derive: run failed: integration stopped at t = 1.61")
    assert reason.endswith("(the motion meets a pole of my_chain's chart; the scene asked for one chart: "
                           "pendulum.atlas = true runs it on the chart atlas, which switches charts there)")
