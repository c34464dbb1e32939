"""A closed loop's linearisation in its free coordinates (issue 23 item 6, for the loops of
item 5), against sympy.physics.mechanics' Linearizer.

The reference: LagrangesMethod with the four-bar's closure as `hol_coneqs`
(tests/oracles/four_bar.py), `to_linearizer` with q1 independent and q2, q3 dependent,
linearized at the point with the accelerations and multipliers LagrangesMethod solves
for there (`solve_multipliers`).  derive computes A from the reduction q = g(z) on the
loop (derive/runtime/linearize.py); the two share no code and no formula.
"""
from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import dynamicsymbols

import derive
from derive.errors import SimulationInputError
from tests.in_process import derive_cli
from tests.oracles.four_bar import NAMES, closed_state, lagranges_method

FOUR_BAR = str(Path(__file__).resolve().parents[2] / "examples" / "models" / "four_bar.toml")


@lru_cache(maxsize=None)
def linearizer():
    lm, q, qd, params = lagranges_method()
    return lm, lm.to_linearizer(q_ind=[q[0]], qd_ind=[qd[0]], q_dep=q[1:], qd_dep=qd[1:]), q, qd, params


def reference_A(y, p) -> np.ndarray:
    """The Linearizer's A at a state y on the loop (its rows and columns: q1, q1')."""
    lm, lin, q, qd, params = linearizer()
    op = dict(zip(q, y[:3])) | dict(zip(qd, y[3:])) | dict(zip(params, p))
    x = np.linalg.solve(np.array(lm.mass_matrix_full.subs(op), dtype=float),
                        np.array(lm.forcing_full.subs(op), dtype=float).ravel())
    accelerations = dict(zip(dynamicsymbols("q1:4", 2), x[3:6]))
    multipliers = lm.solve_multipliers(op_point=[op, accelerations])
    A, _ = lin.linearize(op_point=[op, accelerations, multipliers], A_and_B=True, simplify=False)
    return np.array(A, dtype=float)


def rest_cases(count: int, seed: int = 6):
    """Rest states on the loop of random crank-rockers (at rest, generally not in equilibrium)."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        l1, l3, l2, d = rng.uniform(0.3, 0.6), rng.uniform(1.2, 1.8), rng.uniform(1.8, 2.4), rng.uniform(1.8, 2.2)
        p = np.array([*rng.uniform(0.5, 3.0, 3), l1, l2, l3, d, rng.uniform(1.0, 20.0)])
        yield closed_state(rng.uniform(-np.pi, np.pi), 0.0, p, rng.choice([-1, 1])), p


def test_rest_points_agree_with_sympys_linearizer():
    for y, p in rest_cases(4):
        A, B = derive.linearize(FOUR_BAR, y, dict(zip(NAMES, p)), independent=["theta1"])
        ref = reference_A(y, p)
        assert A.shape == (2, 2) and B.shape == (2, 0)
        assert np.abs(A - ref).max() < 1e-9 * max(1.0, np.abs(ref).max()), (A, ref)


def test_the_hanging_rest_swings_at_the_frequency_of_A():
    """At the rest where the loop hangs (found by bisection on the reference's own q''),
    A = [[0, 1], [-w^2, 0]] is the Linearizer's, and a small swing simulated by
    derive.simulate has the period 2 pi / w."""
    from scipy.optimize import brentq
    from tests.derivation.test_closed_loop_against_mechanics import reference_qdd
    p = np.array([1.0, 2.0, 1.5, 0.45, 2.1, 1.5, 2.0, 9.81])
    params = dict(zip(NAMES, p))

    def accel(z):
        return reference_qdd(closed_state(z, 0.0, p, 1), p)[0]
    grid = np.linspace(-np.pi, np.pi, 73)
    values = [accel(z) for z in grid]
    stable = [brentq(accel, a, b) for a, b, fa, fb in zip(grid, grid[1:], values, values[1:]) if fa > 0 > fb]
    assert stable, "no stable rest found"
    rest = closed_state(stable[0], 0.0, p, 1)
    A, _ = derive.linearize(FOUR_BAR, rest, params, independent="theta1")
    ref = reference_A(rest, p)
    assert np.abs(A - ref).max() < 1e-9 * np.abs(ref).max()
    assert A[1, 1] == 0 and A[1, 0] < 0
    period = 2 * np.pi / np.sqrt(-A[1, 0])
    t = np.linspace(0, 2.6 * period, 5201)
    r = derive.simulate(FOUR_BAR, closed_state(stable[0] + 1e-3, 0.0, p, 1), t, params, rtol=1e-11, atol=1e-14)
    swing = r.y[:, 0] - stable[0]
    up = np.flatnonzero((swing[:-1] < 0) & (swing[1:] >= 0))
    crossings = t[up] - swing[up] * (t[up + 1] - t[up]) / (swing[up + 1] - swing[up])
    assert len(crossings) >= 2
    assert abs(crossings[1] - crossings[0] - period) < 1e-4 * period, (crossings, period)


@pytest.mark.parametrize("kwargs,words", [
    ({}, "give independent= (--independent: the coordinates it leaves free, of theta1, theta2, theta3)"),
    ({"independent": ["theta1", "theta2"]}, "its 2 constraints leave 1 of its 3 coordinates free; independent= names 2"),
    ({"independent": ["phi"]}, "independent: 'phi' is no coordinate of model"),
    ({"moving": True, "independent": ["theta1"]}, "a closed loop is linearized at rest (q' = 0), got theta1_dot"),
    ({"off": True, "independent": ["theta1"]}, "the state is off the loop (|Phi| ="),
])
def test_refusals_are_one_line(kwargs, words):
    y, p = next(rest_cases(1))
    y = y.copy()
    if kwargs.pop("moving", False):
        y = closed_state(y[0], 0.5, p, 1)
    if kwargs.pop("off", False):
        y[1] += 0.1
    with pytest.raises(SimulationInputError) as info:
        derive.linearize(FOUR_BAR, y, dict(zip(NAMES, p)), **kwargs)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_an_open_chain_refuses_independent():
    with pytest.raises(SimulationInputError, match="has no constraints: independent= is for a closed loop"):
        derive.linearize("planar", [0, 0, 0, 0], dict(m1=1, m2=1, l1=1, l2=1, g=9.81), independent=["theta1"])


def test_the_command_line_projects_and_prints_the_reduced_matrices():
    p = np.array([1.0, 2.0, 1.5, 0.45, 2.1, 1.5, 2.0, 9.81])
    params = ",".join(f"{n}={v}" for n, v in zip(NAMES, p))
    at = "theta1=-0.26,theta2=2.6,theta3=0.6"
    done = derive_cli("linearize", FOUR_BAR, "--at", at, "--param", params, "--independent", "theta1",
                      "--project", "--json")
    out = json.loads(done.stdout)
    assert done.returncode == 0 and out["state_names"] == ["theta1", "theta1_dot"]
    y = np.array([out["state"][n] for n in ("theta1", "theta2", "theta3", "theta1_dot", "theta2_dot", "theta3_dot")])
    ref = reference_A(y, p)
    assert np.abs(np.array(out["A"]) - ref).max() < 1e-9 * np.abs(ref).max()
    refused = derive_cli("linearize", FOUR_BAR, "--at", at, "--param", params, "--independent", "theta1")
    assert refused.returncode == 2 and "off the loop" in refused.stderr and "--project" in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1
