"""The energy report of a time-dependent model (issue 23 item 3): E = T + V changes by the
work of its drives, E - E0 = W - D + M (derive/runtime/power.py), and what the balance
leaves is the run's energy error.  The moving pivot's work M against the power of the rod's
force at the pivot, written here by hand and integrated along a solve_ivp reference."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.integrate import quad, solve_ivp

import derive
from derive.runtime.power import energy_balance
from derive.runtime.result import summary_rows

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
PIVOT, FORCED = str(EXAMPLES / "driven_pivot.toml"), str(EXAMPLES / "forced_pendulum.toml")
PIVOT_P = {"m": 1.0, "l": 1.0, "g": 9.81, "a": 0.1, "w": 3.0}      # a strong drive: E changes by ~7 J
FORCED_P = {"m": 1.0, "l": 1.2, "g": 9.81, "c": 0.2, "F0": 0.5, "w": 2.0}
TIMES = np.linspace(0.0, 10.0, 11)
TIGHT = {"method": "dop853", "rtol": 1e-12, "atol": 1e-14}


def pivot_ode(t, y, m, l, g, a, w):
    th, thd = y
    return [thd, -(g / l) * np.sin(th) + (a * w ** 2 / l) * np.cos(w * t) * np.cos(th)]


def pivot_power(t, y, m, l, g, a, w):
    """The rod pulls the bob with F = m a_bob + m g e_y; the pivot, moving at
    v_p = (-a w sin wt, 0), delivers F . v_p = m a_bob_x v_p."""
    th, thd = y
    thdd = pivot_ode(t, y, m, l, g, a, w)[1]
    a_bob_x = -a * w ** 2 * np.cos(w * t) + l * (thdd * np.cos(th) - thd ** 2 * np.sin(th))
    return m * a_bob_x * (-a * w * np.sin(w * t))


def test_the_driven_pivots_balance_closes_with_the_work_of_the_moving_pivot():
    r = derive.simulate(PIVOT, [0.3, 0.0], TIMES, PIVOT_P, **TIGHT)
    b = energy_balance(r)
    assert np.max(np.abs(b.change)) > 1.0                       # the pivot does work
    assert np.max(b.residual) / r.energy_scale < 1e-11
    # without M the balance is far from closing: M is the pivot's work, not a detail
    assert np.max(np.abs(b.change - (b.work - b.dissipated))) > 1.0
    # M against the hand-written power of the pivot's force, along a reference solution
    ref = solve_ivp(lambda t, y: pivot_ode(t, y, *PIVOT_P.values()), (0, 10), [0.3, 0.0], method="DOP853",
                    rtol=1e-13, atol=1e-14, dense_output=True)
    steps = [quad(lambda s: pivot_power(s, ref.sol(s), *PIVOT_P.values()), a, c, limit=200, epsabs=1e-13)[0]
             for a, c in zip(TIMES[:-1], TIMES[1:])]
    assert np.max(np.abs(b.motion - np.concatenate([[0.0], np.cumsum(steps)]))) < 1e-8


def test_the_balance_shows_a_loose_runs_error():
    """The same balance on a run at rtol 1e-6 leaves about that run's error (it is not a
    check that always closes)."""
    loose = derive.simulate(PIVOT, [0.3, 0.0], TIMES, PIVOT_P, method="dopri5", rtol=1e-6)
    tight = derive.simulate(PIVOT, [0.3, 0.0], TIMES, PIVOT_P, **TIGHT)
    left = np.max(energy_balance(loose).residual)
    assert left > 1e3 * np.max(energy_balance(tight).residual) and left > 1e-8


def test_the_forced_pendulums_balance_takes_the_drive_at_its_time():
    r = derive.simulate(FORCED, [0.3, 0.0], TIMES, FORCED_P, **TIGHT)
    b = energy_balance(r)
    assert np.max(np.abs(b.work)) > 0.1 and np.max(b.dissipated) > 0.1 and np.max(np.abs(b.motion)) == 0
    assert np.max(b.residual) / r.energy_scale < 1e-11
    # a fixed-step run has no continuous solution (as an autonomous model's): the corrected
    # trapezoid rule on its output rows, fourth order in their spacing
    rows = np.linspace(TIMES[0], TIMES[-1], 1001)
    fixed = energy_balance(derive.simulate(FORCED, [0.3, 0.0], rows, FORCED_P, method="rk4", step=1e-3))
    assert "trapezoid" in fixed.how and np.max(fixed.residual) / r.energy_scale < 1e-7


def test_the_summary_reports_the_balance():
    row = dict(summary_rows(derive.simulate(PIVOT, [0.3, 0.0], TIMES, PIVOT_P, **TIGHT)))["energy balance"]
    assert float(row.split()[0]) < 1e-11 and "prescribed motion" in row
