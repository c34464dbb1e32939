"""No physics check is left out silently: `derive verify MODEL` names each check that does
not apply to the model and why (verification.physics.not_applicable)."""
from __future__ import annotations

from pathlib import Path

import pytest

from derive.verification.physics import model_checks, not_applicable

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
