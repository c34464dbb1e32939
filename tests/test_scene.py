"""Scene files: the shipped scenes load; every kind of bad input names its key."""
from pathlib import Path

import pytest

from derive.scene import SceneError, load_scene, parse_scene

ROOT = Path(__file__).resolve().parent.parent
GOOD = (ROOT / "scenes" / "default.toml").read_text()


@pytest.mark.parametrize("path", sorted((ROOT / "scenes").glob("*.toml")), ids=lambda p: p.name)
def test_shipped_scenes_load(path):
    if "[axes]" in path.read_text():          # a sweep file (derive sweep): a scene plus axes
        from derive.sweep.spec import load_sweep
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
