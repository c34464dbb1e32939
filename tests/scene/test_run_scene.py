"""`derive run SCENE` end to end, as a user meets it."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

from derive import simulate
from derive.measurement import trust
from derive.scene import load_scene, parse_scene
from derive.scene.run import run
from tests import in_process

ROOT = Path(__file__).resolve().parents[2]
DEFAULT = (ROOT / "scenes" / "default.toml").read_text()


def derive_cli(*args, cwd=ROOT):
    """`derive *args` in `cwd`, in this process (tests/in_process.py): these tests check what
    a run prints, writes and returns; the process around it is tests/system/test_cli_errors.py's."""
    return in_process.derive_cli(*args, cwd=cwd)


def test_default_scene_meets_its_target_and_reuses_the_cache(tmp_path):
    first = derive_cli("run", "scenes/default.toml", "--json", "--output-dir", str(tmp_path))
    assert first.returncode == 0, first.stderr
    second = derive_cli("run", "scenes/default.toml", "--json", "--output-dir", str(tmp_path))
    s = json.loads(second.stdout)
    assert all("reused (cached)" in line for line in s["steps"]), s["steps"]
    assert s["ok"] and s["achieved_error"] <= s["target"]
    assert s["trust_horizon"] >= 5.0         # the run ends inside its trust horizon
    assert 1.0 < s["lyapunov_exponent"] < 4.0  # chaotic: the exponent is clearly positive
    data = np.loadtxt(tmp_path / "default.csv", delimiter=",", skiprows=1)
    assert data.shape == (501, 1 + 4 + 4 + 4 + 1)     # t, state, positions, velocities, energy
    np.testing.assert_allclose(data[-1, 1:5], s["final_state"], rtol=0, atol=1e-12)


def test_spherical_scene_in_a_plane_runs_planar_and_matches_the_atlas():
    scene = load_scene(ROOT / "scenes" / "spherical_in_plane.toml")
    outcome = run(scene, show_progress=False)
    assert outcome.plan.model == "planar"
    state = {k: v for k, v in scene.initial["state"].items() if k != "chart"}
    y0 = [state[n] for n in ("theta1", "phi1", "theta2", "phi2",
                             "theta1_dot", "phi1_dot", "theta2_dot", "phi2_dot")]
    t = np.linspace(scene.t_start, scene.t_stop, scene.outputs)
    direct = simulate("spherical", y0, t, scene.parameters, method="dop853", rtol=1e-11, atol=1e-13)
    assert direct.ok, direct.message
    assert np.max(np.abs(outcome.positions - direct.positions)) < 1e-6


def test_compound_equivalent_scene_runs_planar_and_matches_compound():
    scene = load_scene(ROOT / "scenes" / "compound_equivalent.toml")
    outcome = run(scene, show_progress=False)
    assert outcome.plan.model == "planar" and "derived" in outcome.plan.reason
    y0 = [scene.initial["state"][n] for n in ("theta1", "theta2", "theta1_dot", "theta2_dot")]
    t = np.linspace(scene.t_start, scene.t_stop, scene.outputs)
    direct = simulate("compound", y0, t, scene.parameters, method="dop853", rtol=1e-12, atol=1e-14)
    assert np.max(np.abs(outcome.positions - direct.positions)) < 1e-7
    assert np.max(np.abs(outcome.energy - direct.energy)) < 1e-7


def test_seed001_compound_is_not_reduced():
    outcome = run(load_scene(ROOT / "scenes" / "compound_seed001.toml"), show_progress=False)
    assert outcome.plan.model == "compound"


def _write(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("edit,message", [
    (lambda t: t.replace("l1 = 1.0", "l1 = -1.0"), "must be positive"),
    (lambda t: t.replace("theta1 = 2.5", "theta1 = nan"), "must be finite"),
    (lambda t: t.replace("g = 9.81", "g = 9.81, q = 1"), "unknown parameter"),
    (lambda t: t.replace('model = "planar"', 'model = "quadruple"'), "unknown model"),
    (lambda t: t.replace("state = { theta1 = 2.5, theta2 = 2.0, theta1_dot = 0.0, theta2_dot = 0.0 }",
                         "state = [1.0, 2.0]"), "has 2 values"),
    (lambda t: t.replace('directory = "out/default"', 'directory = "/proc/forbidden"'), "cannot write"),
])
def test_bad_scene_exits_2_with_one_line(tmp_path, edit, message):
    run_ = derive_cli("run", _write(tmp_path, edit(DEFAULT)))
    assert run_.returncode == 2, run_.stdout + run_.stderr
    assert message in run_.stderr and len(run_.stderr.strip().splitlines()) == 1, run_.stderr


def test_missing_scene_file():
    run_ = derive_cli("run", "scenes/no-such-scene.toml")
    assert run_.returncode == 2 and "does not exist" in run_.stderr


def test_scene_outputs_csv_npz_and_plots(tmp_path):
    run_ = derive_cli("run", "scenes/compound_seed001.toml", "--quiet", "--output-dir", str(tmp_path))
    assert run_.returncode == 0, run_.stderr
    assert run_.stdout == ""                       # --quiet prints nothing
    names = {p.name for p in tmp_path.iterdir()}
    assert {"compound_seed001.csv", "compound_seed001.npz", "compound_seed001_paths.png",
            "compound_seed001_energy.png"} <= names
    data = np.load(tmp_path / "compound_seed001.npz")
    assert data["y"].shape == (1001, 4) and data["positions"].shape == (1001, 2, 2)
    assert data["velocities"].shape == (1001, 2, 2)
    # the velocities are the time derivative of the positions (central differences)
    dt = float(data["t"][1] - data["t"][0])
    fd = (data["positions"][2:] - data["positions"][:-2]) / (2 * dt)
    assert np.max(np.abs(fd - data["velocities"][1:-1])) < 2e-2 * np.max(np.abs(data["velocities"]))   # O(dt^2)
    assert (tmp_path / "compound_seed001_paths.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow      # a long atlas run through the poles, its reference and a GIF
def test_spherical_atlas_scene_reports_error_and_trust_horizon(tmp_path):
    run_ = derive_cli("run", "scenes/spherical_pole.toml", "--json", "--output-dir", str(tmp_path))
    assert run_.returncode == 0, run_.stderr
    s = json.loads(run_.stdout)
    assert s["model"] == "spherical" and s["chart_switches"] >= 1
    assert s["achieved_error"] <= s["target"]
    assert s["lyapunov_exponent"] is not None and s["trust_horizon"] > 10.0
    assert (tmp_path / "spherical_pole.gif").read_bytes()[:3] == b"GIF"


def test_simulation_result_states_its_trust_horizon():
    p = {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}
    chaotic = simulate("planar", [2.5, 2.0, 0, 0], np.linspace(0, 5, 101), p, rtol=1e-12)
    regular = simulate("planar", [1.0, 0.5, 0, 0], np.linspace(0, 20, 101), p, rtol=1e-12)
    assert 1.0 < trust.lyapunov_exponent(chaotic) < 4.0
    assert trust.lyapunov_exponent(regular) < 0.3
    # e0 = 1e-12 x |y| grows by e^(lambda t): the chaotic run resolves 1e-8 for a few seconds only
    assert 2.0 < trust.trust_horizon_of(chaotic, 1e-8) < 6.0 < trust.trust_horizon_of(regular, 1e-8)
    assert trust.trust_horizon_of(chaotic, 1e-4) > trust.trust_horizon_of(chaotic, 1e-8)


AT_THE_POLE = DEFAULT.replace('model = "planar"', 'model = "spherical_std"').replace(
    "theta1 = 2.5, theta2 = 2.0, theta1_dot = 0.0, theta2_dot = 0.0",
    "theta1 = 0.05, phi1 = 0.3, theta2 = 1.0, phi2 = 0.0, phi1_dot = 1.0").replace(
    "[initial]", "[initial]\nrest = true")


def test_a_scene_asking_for_one_chart_stops_at_its_pole_and_names_the_way_out(tmp_path):
    text = AT_THE_POLE.replace("[pendulum]", "[pendulum]\natlas = false")
    run_ = derive_cli("run", _write(tmp_path, text), "--output-dir", str(tmp_path))
    assert run_.returncode == 1 and "Traceback" not in run_.stderr
    assert "chart singular" in run_.stdout and "theta1=0.05" in run_.stdout
    error = [line for line in run_.stdout.splitlines() if line.startswith("error   ")][0]
    assert error.count("not measured") == 1 and "achieved not measured: the run stopped (reference " in error
    energy = [line for line in run_.stdout.splitlines() if line.startswith("energy  ")][0]
    assert energy.endswith(", over the outputs before the stop")
    reason = run_.stderr.strip().splitlines()
    assert len(reason) == 1 and "pendulum.atlas = true runs it on the chart atlas" in reason[0], reason


def test_a_one_chart_scene_through_its_pole_runs_on_the_chart_atlas(tmp_path):
    """No `pendulum.atlas`: the scene's chart meets its pole at the start, so the scene runs
    again on the atlas and says why."""
    run_ = derive_cli("run", _write(tmp_path, AT_THE_POLE), "--json", "--output-dir", str(tmp_path))
    assert run_.returncode == 0, run_.stderr
    s = json.loads(run_.stdout)
    assert s["model"] == "spherical" and s["ok"] and s["achieved_error"] <= s["target"]
    assert "spherical_std's chart meets its pole at t = 0: ran on its chart atlas" in s["model_reason"]


def test_scene_edge_cases_get_a_clean_answer(tmp_path):
    """Titles matplotlib would misread, a run that stops (NaN after the stop) with an
    animation, output folders relative to the scene file, forgotten initial values."""
    scene = tmp_path / "sub" / "odd.toml"
    scene.parent.mkdir()
    text = DEFAULT.replace('title = "Chaotic planar double pendulum"', 'title = "Cost $5 and 100% \\\\alpha"')
    text = text.replace('trajectory = ["csv"]', 'trajectory = ["csv"]\nplots = ["paths", "energy", "animation"]')
    scene.write_text(text)
    run_ = derive_cli("run", str(scene), cwd=tmp_path)
    assert run_.returncode == 0, run_.stderr
    assert sorted(p.name for p in (tmp_path / "sub" / "out" / "default").iterdir()) == \
        ["odd.csv", "odd.gif", "odd_energy.png", "odd_paths.png"]
    # each file says what writing it took; the GIF, the slow one, its frames too
    wrote = dict(re.findall(r"^wrote   .*/(\S+) \((.*)\)$", run_.stdout, re.M))
    assert set(wrote) == {"odd.csv", "odd.gif", "odd_energy.png", "odd_paths.png"}, run_.stdout
    assert re.fullmatch(r"150 frames at 25/s, \d+\.\d s of CPU in \d+\.\d s", wrote["odd.gif"]), wrote
    assert all(re.fullmatch(r"\d+\.\d s of CPU in \d+\.\d s", wrote[f]) for f in wrote if f != "odd.gif"), wrote
    forgot = DEFAULT.replace("theta1_dot = 0.0, ", "")
    (tmp_path / "forgot.toml").write_text(forgot)
    run_ = derive_cli("run", str(tmp_path / "forgot.toml"), cwd=tmp_path)
    assert run_.returncode == 2 and "misses theta1_dot" in run_.stderr and "initial.rest = true" in run_.stderr
    (tmp_path / "rest.toml").write_text(forgot.replace("[initial]", "[initial]\nrest = true"))
    assert derive_cli("run", str(tmp_path / "rest.toml"), "--quiet", cwd=tmp_path).returncode == 0
    huge = DEFAULT.replace("outputs = 501", "outputs = 9223372036854775807")
    (tmp_path / "huge.toml").write_text(huge)
    run_ = derive_cli("run", str(tmp_path / "huge.toml"), cwd=tmp_path)
    assert run_.returncode == 2 and "more than 10,000,000 output times" in run_.stderr
