"""The model grammar's time `t` (issue 23 item 3): in forces, dissipation and a
prescribed pivot motion; a model is time-dependent iff t occurs anywhere."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from derive.model import ModelError, load_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
LINK = '[[links]]\nchart = "{chart}"\nlength = "l"\nbody = {{ kind = "point", mass = "m" }}\n'


def model(tmp_path: Path, extra: str, name: str = "", dimension: int = 2,
          params: str = '"m", "l", "g", "a", "w"') -> Path:
    """A one-link model file; its name is the test's own (a model's name is taken per process)."""
    name = "timed_" + re.sub(r"\W", "_", tmp_path.name)[-40:] + name
    chart = "planar" if dimension == 2 else "second"
    path = tmp_path / f"{name}.toml"
    path.write_text(f'name = "{name}"\ndimension = {dimension}\nparameters = [{params}]\n{extra}\n'
                    + LINK.format(chart=chart))
    return path


def test_the_examples_are_time_dependent_and_the_catalogue_is_not():
    pivot = load_model(EXAMPLES / "driven_pivot.toml")
    assert pivot.pivot == ("a*cos(w*t)", "0") and pivot.is_time_dependent and not pivot.is_conservative
    assert load_model(EXAMPLES / "forced_pendulum.toml").is_time_dependent
    assert not load_model(EXAMPLES / "driven.toml").is_time_dependent
    assert not load_model("planar").is_time_dependent and load_model("planar").is_conservative


@pytest.mark.parametrize("extra", ['[forces]\ntheta1 = "a*sin(w*t)"',
                                   'dissipation = "a*(1 + cos(w*t))*theta1_dot**2/2"',
                                   'pivot = ["0", "a*sin(w*t)"]'])
def test_t_is_accepted_where_the_issue_asks(tmp_path, extra):
    assert load_model(model(tmp_path, extra)).is_time_dependent


def test_a_fixed_pivot_offset_is_not_time_dependent(tmp_path):
    m = load_model(model(tmp_path, 'pivot = ["a", "0"]'))
    assert not m.is_time_dependent and m.is_conservative


def test_a_spherical_pivot_has_three_entries(tmp_path):
    m = load_model(model(tmp_path, 'pivot = ["a*cos(w*t)", "a*sin(w*t)", "0"]', name="sph", dimension=3))
    assert m.is_time_dependent
    with pytest.raises(ModelError, match=r"'pivot' must be a list of 3 expressions"):
        load_model(model(tmp_path, 'pivot = ["a*cos(w*t)", "0"]', name="sph2", dimension=3))


@pytest.mark.parametrize("extra, message", [
    ('pivot = ["theta1", "0"]', r"pivot x: the name 'theta1' is not declared"),   # prescribed: no state
    ('pivot = "a*t"', r"'pivot' must be a list of 2 expressions"),
    ('pivot = ["a*tt", "0"]', r"the name 'tt' is not declared"),
    ('pivot = ["a*t", "0"]\nforms = ["lagrangian", "hamiltonian"]', r"this one has explicit time"),
])
def test_bad_time_input_is_one_line_naming_the_key(tmp_path, extra, message):
    with pytest.raises(ModelError, match=message) as info:
        load_model(model(tmp_path, extra))
    assert "\n" not in str(info.value)


def test_t_is_reserved_for_the_time(tmp_path):
    with pytest.raises(ModelError, match=r"'t' is reserved"):
        load_model(model(tmp_path, "", params='"m", "l", "g", "t"'))
