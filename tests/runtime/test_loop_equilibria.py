"""A closed loop's equilibria: derive.equilibria(..., independent=) and `derive linearize
--equilibria --independent`, against the four-bar's potential along its loop computed
here by plane geometry (tests/oracles/four_bar.py's closed_state): its critical points
on each branch, a minimum marginal and a maximum unstable, and the frequency of a small
swing sqrt(V''/m_r) with m_r = 2T at unit crank rate (T from the rods' velocities)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import derive
from derive.cli import main
from derive.errors import SimulationInputError
from tests.oracles.four_bar import NAMES, closed_state

MODEL = str(Path(__file__).resolve().parents[2] / "examples" / "models" / "four_bar.toml")
CASES = {"crank": dict(m1=1, m2=2, m3=1.5, l1=0.5, l2=2, l3=1.5, d=2, g=9.81),
         "rocker": dict(m1=1, m2=1, m3=1, l1=1.2, l2=1, l3=1, d=2, g=9.81)}


def centres(y, P):
    """The rods' centres and their velocities at state y."""
    joint, speed, out = np.zeros(2), np.zeros(2), []
    for i in range(3):
        q, w, l = y[i], y[3 + i], P[f"l{i + 1}"]
        e, de = np.array([np.sin(q), -np.cos(q)]), np.array([np.cos(q), np.sin(q)]) * w
        out.append((joint + l / 2 * e, speed + l / 2 * de))
        joint, speed = joint + l * e, speed + l * de
    return out


def potential(theta1, P, branch):
    y = closed_state(theta1, 0.0, [P[k] for k in NAMES], branch)
    return sum(P[f"m{i + 1}"] * P["g"] * c[1] for i, (c, _) in enumerate(centres(y, P)))


def reduced_mass(theta1, P, branch):
    y = closed_state(theta1, 1.0, [P[k] for k in NAMES], branch)
    w = y[3:]
    return sum(P[f"m{i + 1}"] * (v @ v + P[f"l{i + 1}"] ** 2 / 12 * w[i] ** 2)
               for i, (_, v) in enumerate(centres(y, P)))


def oracle_rests(P):
    """(theta1, branch, V'', m_r) of every critical point of V along the loop."""
    h = 1e-5
    dV = lambda a, b: (potential(a + h, P, b) - potential(a - h, P, b)) / (2 * h)
    rests = []
    for branch in (1, -1):
        grid = np.linspace(-np.pi, np.pi, 2001)
        values = np.array([dV(a, branch) for a in grid])
        for a, b, va, vb in zip(grid[:-1], grid[1:], values[:-1], values[1:]):
            if np.isfinite(va) and np.isfinite(vb) and va * vb < 0:
                root = brentq(dV, a, b, args=(branch,), xtol=1e-13)
                d2 = (potential(root + 1e-4, P, branch) - 2 * potential(root, P, branch)
                      + potential(root - 1e-4, P, branch)) / 1e-8
                rests.append((root, branch, d2, reduced_mass(root, P, branch)))
    return rests


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_loops_rests_are_the_critical_points_of_its_potential_along_the_loop(case):
    P = CASES[case]
    found = derive.equilibria(MODEL, P, independent=["theta1"])
    want = oracle_rests(P)
    assert len(found) == len(want) >= 2
    for theta1, branch, d2, m_r in want:
        y = closed_state(theta1, 0.0, [P[k] for k in NAMES], branch)
        match = [e for e in found
                 if np.abs(np.angle(np.exp(1j * (np.array([e["state"][f"theta{i}"] for i in (1, 2, 3)]) - y[:3])))).max() < 1e-7]
        assert len(match) == 1, (theta1, branch)
        e = match[0]
        assert e["stability"] == ("marginal" if d2 > 0 else "unstable")
        omega2 = np.max(np.abs(e["eigenvalues"])) ** 2
        assert omega2 == pytest.approx(abs(d2) / m_r, rel=1e-5)
        assert all(e["state"][f"theta{i}_dot"] == 0.0 for i in (1, 2, 3))


def test_the_command_line_lists_a_loops_rests(capsys):
    P = CASES["rocker"]
    args = ["linearize", MODEL, "--equilibria", "--independent", "theta1", "--json",
            "--param", ",".join(f"{k}={v}" for k, v in P.items())]
    assert main(args) == 0
    listed = json.loads(capsys.readouterr().out)["equilibria"]
    assert sorted(e["stability"] for e in listed) == ["marginal", "unstable"]


def test_a_loops_rests_need_its_free_coordinates_and_a_chain_takes_none():
    with pytest.raises(SimulationInputError, match=r"give independent="):
        derive.equilibria(MODEL, CASES["crank"])
    with pytest.raises(SimulationInputError, match="independent= is for a closed loop"):
        derive.equilibria("planar", dict(m1=1, m2=1, l1=1, l2=1, g=9.81), independent=["theta1"])
