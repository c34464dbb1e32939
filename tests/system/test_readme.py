"""The README's and the docs' promises stay true: the two commands, the pointers into the docs,
the angle convention and the chart poles are what the code does (the errata table, on
docs/errata.md, is made from the recorded errata: tests/system/test_docs.py)."""
from pathlib import Path

import numpy as np

import derive
from derive.runtime.loader import load

README = (Path(__file__).resolve().parents[2] / "README.md").read_text()


def test_readme_states_the_two_commands():
    assert "python3 -m pip install -q -e . && python3 -m derive all" in README
    assert "# the tests\nbash tests/run.sh\n" in README


CONVENTIONS = (Path(__file__).resolve().parents[2] / "docs" / "conventions.md").read_text()
MODELS = (Path(__file__).resolve().parents[2] / "docs" / "models.md").read_text()
CLI = (Path(__file__).resolve().parents[2] / "docs" / "cli.md").read_text()


def test_the_readme_points_to_the_conventions_and_the_list_of_examples():
    assert "[docs/conventions.md](docs/conventions.md)" in README and "derive run --list" in README
    assert "downward vertical, counterclockwise" in README and "θ = 0 hangs straight down" in CONVENTIONS
    assert "θ = 0 hangs straight down" in MODELS and "`chart = \"second\"`" in MODELS
    assert "derive run --list" in CLI


def test_the_readme_is_a_readme():
    """At most 150 lines: the manual is docs/, and the README links into it."""
    assert len(README.splitlines()) <= 150
    for page in ("install", "tutorial", "models", "cli", "python", "c-api", "errata", "performance"):
        assert f"(docs/{page}.md)" in README


def test_the_angle_convention_is_what_the_kernels_compute():
    """planar: (sin θ, -cos θ), absolute angles; standard: θ from the downward vertical."""
    pos = load("planar").positions(np.array([[np.pi / 2, 0.0, 0.0, 0.0]]), [1, 1, 1.0, 2.0, 9.81])[0]
    assert np.allclose(pos, [[1.0, 0.0], [1.0, -2.0]])        # link 1 along +x, link 2 hangs down
    pos = load("spherical_std").positions(np.array([[0.0, 0.3, np.pi / 2, np.pi / 2, 0, 0, 0, 0]]),
                                          [1, 1, 1.0, 1.0, 9.81])[0]
    assert np.allclose(pos, [[0.0, 0.0, -1.0], [0.0, 1.0, -1.0]])


def test_a_single_chart_stops_at_its_pole_and_the_atlas_runs_through():
    """docs/conventions.md: the standard chart is singular with a link hanging straight down
    (chart singular); the atlas starts there on another chart and runs through."""
    p = [1, 1, 1, 1, 9.81]
    r = derive.simulate("spherical_std", [0.0, 0.0, 0.6435, 0.0, 0.0, 0.0, 0.0, 0.0], [0, 1], p)
    assert r.status_name == "chart singular (polar sine below threshold)"
    assert "`chart singular (polar sine below threshold)`" in CONVENTIONS
    down = [0, 0, -1, 0.6, 0, -1.8, 1.5, 0.8, 0, 3.1, 1.8, 1.2]          # link 1 hanging straight down
    r = derive.simulate("spherical", {"cartesian": down}, [0, 1], p, method="dop853", rtol=1e-10)
    assert r.ok and r.chart[0] != "spherical_std"
    assert "`second`" in CONVENTIONS and "atlas=True" in CONVENTIONS


def test_a_state_is_the_coordinates_then_their_rates():
    """docs/conventions.md states the order; the models' state names are in it."""
    from derive.model import load_model
    for name in ("planar", "spherical_std"):
        names = list(load_model(name).state_names)
        assert f"`({', '.join(names[:4])}" in CONVENTIONS.replace("\n", " ")
        coordinates = names[:len(names) // 2]
        assert names[len(names) // 2:] == [c + "_dot" for c in coordinates]
