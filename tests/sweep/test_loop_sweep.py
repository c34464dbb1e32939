"""The sweep of a closed loop over its free coordinate and a parameter: each start solved
onto the loop (derive/sweep/chunk.py), status 6 ("bad input") exactly where the linkage
cannot reach, the drift off the constraints stored beside the states.  The oracle of
the reach and of the starts is tests/oracles/four_bar.py's plane geometry; the runs are
checked against derive.simulate from the oracle's starts."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import derive
from derive.errors import SceneError
from derive.sweep.sweep_file import parse_sweep
from tests.oracles.four_bar import NAMES, closed_state

MODEL = str(Path(__file__).resolve().parents[2] / "examples" / "models" / "four_bar.toml")
LOCKED = dict(m1=1, m2=1, m3=1, l1=1.2, l2=1, l3=1, d=2, g=9.81)   # the crank reaches sin(theta1) >= 0.3 only

SWEEP = """
title = "four-bar over its crank angle"
record = ["final_state"]
[pendulum]
model = "{model}"
parameters = {{ m1 = 1, m2 = 1, m3 = 1, l1 = 1.2, l2 = 1, l3 = 1, d = 2, g = 9.81 }}
[initial]
{independent}
state = {{ theta1 = 1.0, theta2 = {theta2}, theta3 = {theta3} }}
rest = true
[time]
stop = 1.0
outputs = 11
[accuracy]
method = "dop853"
rtol = 1e-10
[axes]
{axes}
[sweep]
chunk = 7
"""
AXES = 'theta1 = { linspace = ["-pi", "pi"], num = 13 }\nm3 = { linspace = [1, 2], num = 2 }'


def sweep_text(independent='independent = ["theta1"]', axes=AXES):
    base = closed_state(1.0, 0.0, [LOCKED[k] for k in NAMES], 1)
    return SWEEP.format(model=MODEL, independent=independent, theta2=base[1], theta3=base[2], axes=axes)


def test_a_loops_sweep_closes_each_start_and_marks_the_unreachable(tmp_path):
    path = tmp_path / "loop.toml"
    path.write_text(sweep_text())
    ds = derive.sweep(path, out=tmp_path / "out", workers=0)
    theta1 = ds["theta1"].values
    names = ["final_" + s for s in ("theta1", "theta2", "theta3", "theta1_dot", "theta2_dot", "theta3_dot")]
    reachable = 0
    for j, m3 in enumerate(ds["m3"].values):
        p = dict(LOCKED, m3=float(m3))
        for i, a in enumerate(theta1):
            start = closed_state(a, 0.0, [p[k] for k in NAMES], 1)
            status = int(ds["status"].values[i, j])
            final = np.array([ds[n].values[i, j] for n in names])
            if np.isnan(start).any():           # the coupler and rocker cannot reach the crank's tip
                assert status == 6 and np.isnan(final).all() and np.isnan(ds["constraint_drift"].values[i, j])
                continue
            reachable += 1
            assert status == 0
            want = derive.simulate(MODEL, start, [0.0, 1.0], p, rtol=1e-10).y[-1]
            assert np.abs(final - want).max() < 1e-8
            assert 0 <= ds["constraint_drift"].values[i, j] < 1e-7
    assert 0 < reachable < ds["status"].size      # both kinds are in the sweep


@pytest.mark.parametrize("independent, axes, message", [
    ("", AXES, r"name its free coordinates in \[initial\], e.g. independent = \[\"theta1\"\]"),
    ('independent = ["theta1"]', 'theta2 = { linspace = [0, 1], num = 3 }',
     "the loop determines theta2 from its free coordinates"),
    ('independent = ["theta1"]', 'theta3_dot = { linspace = [0, 1], num = 3 }',
     "the loop determines theta3_dot"),
])
def test_a_loops_sweep_refuses_axes_the_loop_decides(independent, axes, message):
    with pytest.raises(SceneError, match=message):
        parse_sweep(sweep_text(independent, axes))
