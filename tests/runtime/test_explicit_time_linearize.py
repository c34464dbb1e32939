"""derive.linearize of a time-dependent model at a time t (issue 23 item 6 with item 3):
the driven pivot's A at t against its Jacobian written here by hand; without t, and for
equilibria, one line."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import derive

ROOT = Path(__file__).resolve().parents[2]
PIVOT = str(ROOT / "examples" / "models" / "driven_pivot.toml")
P = {"m": 1.3, "l": 0.8, "g": 9.81, "a": 0.2, "w": 5.0}


def hand_written_A(t, theta, m, l, g, a, w):
    """theta'' = -(g/l) sin th + (a w^2 / l) cos(wt) cos th: d/d theta at (t, theta)."""
    return np.array([[0.0, 1.0], [-(g / l) * np.cos(theta) - (a * w ** 2 / l) * np.cos(w * t) * np.sin(theta), 0.0]])


@pytest.mark.parametrize("t, when", [(0.0, 0.0), (0.3, 0.3), (1.7, 1.7), ("pi/5", np.pi / 5)])
def test_the_driven_pivot_linearized_at_t(t, when):
    theta = 0.4
    A, B = derive.linearize(PIVOT, {"theta1": theta}, P, t=t)
    assert B.shape == (2, 0)
    assert np.max(np.abs(A - hand_written_A(when, theta, *P.values()))) < 1e-12
    # it depends on t: another time gives another A
    other, _ = derive.linearize(PIVOT, {"theta1": theta}, P, t=when + 0.2)
    assert abs(other[1, 0] - A[1, 0]) > 1e-3


def test_a_time_dependent_model_without_t_is_refused_in_one_line():
    with pytest.raises(derive.SimulationInputError, match="give t=") as info:
        derive.linearize(PIVOT, {"theta1": 0.0}, P)
    assert "\n" not in str(info.value) and "explicit time" in str(info.value)
    with pytest.raises(derive.SimulationInputError, match="explicit time") as info:
        derive.equilibria(PIVOT, P)
    assert "\n" not in str(info.value) and "t=" in str(info.value)


def test_an_autonomous_models_linearisation_does_not_depend_on_t():
    params = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
    A0, _ = derive.linearize("planar", {"theta1": 0.3}, params)
    A1, _ = derive.linearize("planar", {"theta1": 0.3}, params, t=5.0)
    assert np.array_equal(A0, A1)


@pytest.mark.slow          # two processes, each deriving the model: about 10 s
def test_the_command_line_takes_the_time():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    args = [sys.executable, "-m", "derive", "linearize", PIVOT, "--at", "theta1=0.4", "--json"] + \
        [a for n, v in P.items() for a in ("--param", f"{n}={v}")]
    done = subprocess.run(args + ["--time", "1.7"], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    A = np.array(json.loads(done.stdout)["A"])
    assert np.max(np.abs(A - hand_written_A(1.7, 0.4, *P.values()))) < 1e-12
    refused = subprocess.run(args, env=env, capture_output=True, text=True, timeout=600)
    lines = refused.stderr.strip().splitlines()
    assert refused.returncode == 2 and len(lines) == 1 and "give t=" in lines[0]
