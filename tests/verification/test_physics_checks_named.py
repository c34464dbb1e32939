"""No physics check is left out silently: `derive verify MODEL` names each check that does
not apply to the model and why (verification.physics.not_applicable)."""
from __future__ import annotations

from pathlib import Path

import pytest

from derive.verification.physics import model_checks, not_applicable
from tests.parameters import named_double_pendulum

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"


@pytest.mark.parametrize("model, reason", [
    (str(EXAMPLES / "cart_pole.toml"), "a slider, a branch"),
    ("compound", "rotational inertia"),
    (str(EXAMPLES / "forced_pendulum.toml"), "applied forces, damping and explicit time"),
])
def test_a_model_without_the_cartesian_check_is_told_why(model, reason):
    (check, why), = not_applicable(model)
    assert check == "Cartesian constraint forces" and reason in why
    assert not any("Cartesian" in c.name for c in model_checks(model))


def test_a_conservative_chain_of_point_masses_runs_the_cartesian_check():
    assert not_applicable("planar") == []
    assert any("Cartesian" in c.name for c in model_checks("planar"))


SPRUNG = named_double_pendulum("sprung", ["m1", "m2", "l1", "l2", "k", "g"], '[[springs]]\nbetween = ["pivot", "lower"]\nstiffness = "k"\nrest_length = "1/2"\n')


def test_a_chain_with_a_spring_is_told_why_it_has_no_cartesian_check_and_passes(tmp_path):
    """A user's trial: a double pendulum with a spring FAILED the Cartesian check (that side
    knows gravity alone) though its equations were right."""
    path = tmp_path / "sprung.toml"
    path.write_text(SPRUNG)
    (check, why), = not_applicable(str(path))
    assert check == "Cartesian constraint forces" and "springs or potential" in why
    checks = model_checks(str(path))
    assert checks and all(c.passed for c in checks) and not any("Cartesian" in c.name for c in checks)
