"""Scene files: the shipped scenes load; every kind of bad input names its key."""
from pathlib import Path

import pytest

from derive.scene import SceneError, load_scene, parse_scene
from tests.in_process import derive_cli

ROOT = Path(__file__).resolve().parents[2]
GOOD = (ROOT / "scenes" / "default.toml").read_text()


@pytest.mark.parametrize("path", sorted((ROOT / "scenes").glob("*.toml")), ids=lambda p: p.name)
def test_shipped_scenes_load(path):
    if "[axes]" in path.read_text():          # a sweep file (derive sweep): a scene plus axes
        from derive.sweep.sweep_file import load_sweep
        scene = load_sweep(path).scene
        with pytest.raises(SceneError, match="a sweep file"):
            load_scene(path)
    else:
        scene = load_scene(path)
    assert scene.t_stop > scene.t_start


def test_default_scene_contents():
    scene = parse_scene(GOOD)
    assert scene.model == "planar"
    assert scene.initial["state"]["theta1"] == 2.5
    assert scene.target == 1e-8 and scene.method is None


def test_state_as_list_and_spherical_atlas_state():
    s = parse_scene(GOOD.replace("state = { theta1 = 2.5, theta2 = 2.0, theta1_dot = 0.0, theta2_dot = 0.0 }",
                                 "state = [2.5, 2.0, 0.0, 0.0]"))
    assert s.initial["state"]["theta2"] == 2.0
    sph = parse_scene(GOOD.replace('model = "planar"', 'model = "spherical"')
                      .replace("theta1 = 2.5, theta2 = 2.0, theta1_dot = 0.0, theta2_dot = 0.0",
                               "vartheta1 = 1.0, varphi1 = 0.5, vartheta2 = 1.2, varphi2 = 0.1")
                      .replace("[initial]", "[initial]\nrest = true"))
    assert sph.initial["state"]["chart"] == "spherical_alt"


BAD = [
    ("unknown top-level key", lambda t: t + "\ncolour = 'red'\n", "unknown key 'colour'"),
    ("unknown parameter", lambda t: t.replace("g = 9.81", "g = 9.81, k = 2"), "pendulum.parameters.k"),
    ("negative length", lambda t: t.replace("l1 = 1.0", "l1 = -1.0"), "'pendulum.parameters.l1' must be positive"),
    ("zero mass", lambda t: t.replace("m2 = 1.0", "m2 = 0"), "'pendulum.parameters.m2' must be positive"),
    ("NaN", lambda t: t.replace("theta1 = 2.5", "theta1 = nan"), "'initial.state.theta1' must be finite"),
    ("infinity", lambda t: t.replace("stop = 5.0", "stop = inf"), "'time.stop' must be finite"),
    ("wrong type", lambda t: t.replace("m1 = 1.0", 'm1 = "heavy"'), "'pendulum.parameters.m1' must be a number"),
    ("missing parameter", lambda t: t.replace("m1 = 1.0, ", ""), "'pendulum.parameters.m1' is missing"),
    ("state of wrong size", lambda t: t.replace(
        "state = { theta1 = 2.5, theta2 = 2.0, theta1_dot = 0.0, theta2_dot = 0.0 }", "state = [1, 2, 3]"),
     "'initial.state' has 3 values; 'planar' needs 4"),
    ("unknown state name", lambda t: t.replace("theta2_dot", "omega"), "'initial.state.omega'"),
    ("unknown model", lambda t: t.replace('model = "planar"', 'model = "no_such_pendulum"'), "unknown model 'no_such_pendulum'"),
    ("unknown chart state", lambda t: t.replace('model = "planar"', 'model = "spherical"')
     .replace("theta1 = 2.5", "psi1 = 2.5"),
     "not the state of one spherical chart"),
    ("unknown method", lambda t: t.replace("target = 1e-8", 'method = "euler"'), "'accuracy.method' must be one of"),
    ("method without step", lambda t: t.replace("target = 1e-8", 'method = "rk4"'), "method 'rk4' needs 'step'"),
    ("target and method", lambda t: t.replace("target = 1e-8", 'target = 1e-8\nmethod = "rk4"'),
     "either 'target' or 'method'"),
    ("backwards time", lambda t: t.replace("stop = 5.0", "stop = -1.0"), "'time.stop' (-1) must be after"),
    ("bad outputs", lambda t: t.replace("outputs = 501", "outputs = 1.5"), "'time.outputs' must be a whole number"),
    ("bad scalar", lambda t: t.replace("target = 1e-8", 'target = 1e-8\nscalar = "half"'), "'accuracy.scalar'"),
    ("bad trajectory format", lambda t: t.replace('trajectory = ["csv"]', 'trajectory = ["xls"]'),
     "'output.trajectory' must be one of"),
    ("not TOML", lambda t: t + "\n[[[", "not valid TOML"),
    ("missing table", lambda t: t.replace("[time]", "[tme]"), "unknown key 'tme'"),
]


@pytest.mark.parametrize("what,edit,message", BAD, ids=[b[0] for b in BAD])
def test_bad_scene_names_the_problem(what, edit, message):
    with pytest.raises(SceneError) as info:
        parse_scene(edit(GOOD), "scene.toml")
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_unreadable_scene(tmp_path):
    with pytest.raises(SceneError, match="does not exist"):
        load_scene(tmp_path / "nope.toml")
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe\x00")
    with pytest.raises(SceneError, match="cannot read scene file"):
        load_scene(tmp_path / "bin.toml")


# -- [events] ------------------------------------------------------------------------------

EVENTS = GOOD + '\n[events]\nflip = "cos(theta2/2)"\nbottom = { expression = "theta1", direction = 1, terminal = 2 }\n'


def test_events_table_is_read():
    scene = parse_scene(EVENTS)
    assert scene.events["flip"] == "cos(theta2/2)"
    assert scene.events["bottom"]["terminal"] == 2


BAD_EVENTS = [
    ("unknown name", 'flip = "cos(theta3)"', "events.flip.expression: the name 'theta3' is not declared"),
    ("Python", "flip = \"__import__('os').system('x')\"", "events.flip.expression: the construct 'Attribute'"),
    ("import call", 'flip = "__import__(1)"', "events.flip.expression: the function '__import__'"),
    ("direction", 'flip = { expression = "theta1", direction = 3 }', "events.flip.direction must be -1, 0 or +1"),
    ("terminal", 'flip = { expression = "theta1", terminal = "yes" }', "events.flip.terminal must be"),
    ("unknown key", 'flip = { expression = "theta1", when = 1 }', "events.flip: unknown key 'when'"),
    ("missing expression", "flip = { direction = 1 }", "events.flip: missing key 'expression'"),
]


@pytest.mark.parametrize("what,line,message", BAD_EVENTS, ids=[b[0] for b in BAD_EVENTS])
def test_bad_events_name_the_key(what, line, message):
    with pytest.raises(SceneError) as info:
        parse_scene(GOOD + "\n[events]\n" + line + "\n", "scene.toml")
    assert message in str(info.value) and "\n" not in str(info.value)


def test_events_need_an_adaptive_method_and_no_atlas():
    with pytest.raises(SceneError, match="adaptive method"):
        parse_scene(EVENTS.replace("target = 1e-8", 'method = "rk4"\nstep = 0.01'))
    atlas = (GOOD.replace('model = "planar"', 'model = "spherical"')
             .replace("theta1 = 2.5, theta2 = 2.0, theta1_dot = 0.0, theta2_dot = 0.0",
                      "vartheta1 = 1.0, varphi1 = 0.5, vartheta2 = 1.2, varphi2 = 0.1")
             .replace("[initial]", "[initial]\nrest = true"))
    with pytest.raises(SceneError, match="chart atlas"):
        parse_scene(atlas + '\n[events]\ne = "vartheta1"\n')


def test_scene_events_reach_the_outputs(tmp_path):
    """`derive run` of a scene with a terminal event: the JSON names the event, the run stops
    there with exit 0, the CSV of crossings and the NPZ arrays agree with the API."""
    import json

    import numpy as np

    from derive import simulate
    spin = GOOD.replace("theta1 = 2.5, theta2 = 2.0, theta1_dot = 0.0, theta2_dot = 0.0",
                        "theta1 = 0.5, theta2 = 0.0, theta1_dot = 0.0, theta2_dot = 9.0")
    events = '\n[events]\nbottom = "theta1"\nflip = { expression = "cos(theta2/2)", terminal = 4 }\n'
    text = ((spin + events).replace("target = 1e-8", 'method = "dop853"\nrtol = 1e-10')
            .replace('trajectory = ["csv"]', 'trajectory = ["csv", "npz"]')
            .replace('directory = "out/default"', f'directory = "{tmp_path}"'))
    path = tmp_path / "ev.toml"
    path.write_text(text)
    run_ = derive_cli("run", path, "--json")
    assert run_.returncode == 0, run_.stderr
    s = json.loads(run_.stdout)
    direct = simulate("planar", [0.5, 0.0, 0, 9.0], np.linspace(0, 5, 501),
                      {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}, rtol=1e-10,
                      events={"bottom": "theta1", "flip": {"expression": "cos(theta2/2)", "terminal": 4}})
    assert s["terminal_event"] == direct.terminal_event == "flip"
    assert abs(s["t_stop"] - direct.t_stop) < 1e-8        # 20 chunks vs one run: within the tolerance
    assert len(s["events"]["flip"]["t"]) == 4 and s["events"]["flip"]["direction"] == [-1, 1, -1, 1]
    assert len(s["events"]["bottom"]["t"]) == len(direct.events["bottom"]) >= 1
    assert np.allclose(s["events"]["bottom"]["t"], direct.events["bottom"].t, atol=1e-8)
    rows = (tmp_path / "ev_events.csv").read_text().splitlines()
    assert rows[0] == "event,t,direction,theta1,theta2,theta1_dot,theta2_dot"
    assert len(rows) - 1 == sum(len(e["t"]) for e in s["events"].values())
    data = np.load(tmp_path / "ev.npz")
    assert np.array_equal(data["events_flip_t"], s["events"]["flip"]["t"])
    assert np.all(np.isnan(data["y"][data["t"] > s["t_stop"]]))
    text_run = derive_cli("run", path)
    assert "event   flip (cos(theta2/2)): 4 crossings" in text_run.stdout and "terminal" in text_run.stdout


@pytest.mark.parametrize("name, expression", [("compound_equivalent", "cos(theta2/2)*L1/L1"),
                                              ("spherical_in_plane", "theta2 - 2")])
def test_a_scene_with_events_runs_its_own_model(name, expression):
    """The planner would run these as planar; their events are in their own model's names
    (the compound's L1, a spherical chart's theta2), so they run their own model."""
    from derive.scene.plan import plan
    text = (ROOT / "scenes" / f"{name}.toml").read_text().replace('model = "spherical"', 'model = "spherical_std"')
    plain, with_events = plan(parse_scene(text)), plan(parse_scene(text + f'\n[events]\ne = "{expression}"\n'))
    assert plain.model == "planar" and with_events.model == parse_scene(text).model
    assert "events" in with_events.reason


def test_a_bad_event_in_a_scene_exits_2_with_one_line(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(GOOD + "\n[events]\nflip = \"__import__('os')\"\n")
    run_ = derive_cli("run", path)
    assert run_.returncode == 2 and run_.stdout == ""
    assert len(run_.stderr.strip().splitlines()) == 1
    assert "events.flip.expression: the function '__import__'" in run_.stderr
