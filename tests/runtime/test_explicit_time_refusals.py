"""What the run time refuses of a time-dependent model (issue 23 item 3): the stages that
do not pass t to its kernels refuse in one line naming why and what runs it instead (exit
status 2 on the command line); derive.simulate runs it (test_explicit_time_simulate.py);
`derive verify` balances the power with Jacobi's energy and does not claim conservation."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.model import load_model
from derive.verification import physics

ROOT = Path(__file__).resolve().parents[2]
PIVOT = str(ROOT / "examples" / "models" / "driven_pivot.toml")
FORCED = str(ROOT / "examples" / "models" / "forced_pendulum.toml")
PIVOT_P = {"m": 1.0, "l": 1.0, "g": 9.81, "a": 0.01, "w": 3.0}
WHY = "explicit time in the model"


def test_the_atlas_refuses_in_one_line_naming_what_runs_it():
    with pytest.raises(derive.SimulationInputError, match=WHY) as info:
        derive.simulate(PIVOT, [0.1, 0.0], np.linspace(0, 1, 3), PIVOT_P, atlas=True)
    assert "\n" not in str(info.value) and "the chart atlas" in str(info.value) and "derive.simulate" in str(info.value)


def test_an_ensemble_of_a_forced_pendulum_runs_each_member_as_simulate_does():
    p = {"m": 1.0, "l": 1.0, "g": 9.81, "c": 0.1, "F0": 1.0, "w": 3.0}
    y0 = np.array([[0.1, 0.0], [0.5, -0.2], [1.0, 0.3]])
    times = np.linspace(0, 2, 5)
    ens = derive.ensemble(FORCED, y0, times, p, method="dopri5", rtol=1e-10)
    assert ens.y.shape == (3, 5, 2) and list(ens.status_names) == ["ok"] * 3
    for row, y in zip(y0, ens.y):
        assert np.array_equal(y, derive.simulate(FORCED, row, times, p, method="dopri5", rtol=1e-10).y)
    # Taylor's jet has t in it: its ensemble runs in C (tests/runtime/test_taylor_explicit_time.py)
    ens = derive.ensemble(FORCED, y0, times, p, method="taylor", rtol=1e-10)
    for row, y in zip(y0, ens.y):
        assert np.array_equal(y, derive.simulate(FORCED, row, times, p, method="taylor", rtol=1e-10).y)


def test_a_scene_of_a_time_dependent_model_with_taylor_exits_2_with_one_line(tmp_path):
    """A scene of the driven pivot runs (tests/scene/test_explicit_time_scenes.py); one
    that asks for Taylor's method, which does not pass t, is refused before any work."""
    scene = tmp_path / "pivot.toml"
    scene.write_text(f'[pendulum]\nmodel = "{PIVOT}"\nparameters = {{ m = 1.0, l = 1.0, g = 9.81, '
                     f'a = 0.01, w = 3.0 }}\n[initial]\nstate = {{ theta1 = 0.1, theta1_dot = 0.0 }}\n'
                     f'[time]\nstop = 1.0\noutputs = 11\n[accuracy]\nmethod = "taylor"\n'
                     f'[output]\ndirectory = "{tmp_path / "out"}"\n')
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-m", "derive", "run", str(scene)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("derive: error: ") and WHY in lines[0]
    assert "dop853" in lines[0] and not (tmp_path / "out").exists()


@pytest.mark.parametrize("model", [PIVOT, FORCED])
def test_verify_balances_the_power_and_claims_no_conservation(model):
    check = physics.energy_conservation(load_model(model))
    assert check.passed, check.detail
    assert "energy not conserved" in check.name and "conserved" not in check.name.replace("not conserved", "")


def test_the_power_balance_could_fail(monkeypatch):
    """T + V in place of Jacobi's h: the driven pivot's mechanical energy is not balanced
    by the same power, and the check says so (it is not a check that always passes)."""
    model = load_model(PIVOT)
    monkeypatch.setattr(physics, "jacobi_energy", lambda d: d.energy)
    assert not physics.energy_conservation(model).passed


def test_the_trust_horizon_of_a_time_dependent_run_is_refused_in_one_line():
    r = derive.simulate(PIVOT, [0.1, 0.0], np.linspace(0, 1, 3), PIVOT_P)
    with pytest.raises(derive.InputError, match="explicit time in the model") as info:
        derive.trust_horizon(r, 1e-6)
    assert "\n" not in str(info.value) and "rerun" in str(info.value)
