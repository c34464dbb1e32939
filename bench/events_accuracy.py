"""Accuracy of r.sol(t) and of events (needs scipy): `python3 bench/events_accuracy.py`.

1. r.sol at 500 random times of a run with 6 outputs, against long double at rtol 1e-15,
   next to the same run asked for outputs at those times (the run's own interpolant);
2. the zero crossings of a simple pendulum from rest at 2 rad against (2j+1) T/4 with the
   exact period T = 4 sqrt(l/g) K(sin^2(theta0/2));
3. the flips of link 2 (cos(theta2/2) = 0) against a brute-force search: solve_ivp DOP853
   at rtol 1e-12, its dense output on a 2e-5 s grid, brentq.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipk

import derive

PLANAR = {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}
SIMPLE = """name = "simple_pendulum"
dimension = 2
parameters = ["m", "l", "g"]
[[links]]
chart = "planar"
length = "l"
body = { kind = "point", mass = "m" }
"""


def dense_accuracy() -> None:
    rng = np.random.default_rng(1)
    for y0 in ([0.5, 0.3, 0, 0], [0.5, 0.0, 0, 9.0]):
        for method in ("dopri5", "dop853"):
            for rtol in (1e-6, 1e-9, 1e-12):
                t = np.linspace(0, 5, 6)
                tq = np.sort(rng.uniform(0, 5, 500))
                r = derive.simulate("planar", y0, t, PLANAR, method=method, rtol=rtol)
                own = derive.simulate("planar", y0, np.concatenate([[0], tq, [5]]), PLANAR, method=method,
                                      rtol=rtol).y[1:-1]
                ref = derive.simulate("planar", y0, np.concatenate([[0], tq]), PLANAR, method="dop853",
                                      rtol=1e-15, dtype="longdouble").y[1:].astype(float)
                es, eo = np.abs(r.sol(tq) - ref).max(), np.abs(own - ref).max()
                print(f"sol    y0={y0} {method} rtol {rtol:g}: error {es:.2e}, "
                      f"the run's own interpolant {eo:.2e} (ratio {es / eo:.2f})")


def pendulum_period() -> None:
    theta0, p = 2.0, {"m": 1.0, "l": 1.0, "g": 9.81}
    period = 4 * np.sqrt(p["l"] / p["g"]) * ellipk(np.sin(theta0 / 2) ** 2)
    with tempfile.TemporaryDirectory() as folder:
        model = Path(folder) / "simple_pendulum.toml"
        model.write_text(SIMPLE)
        for method in ("dopri5", "dop853"):
            for rtol in (1e-6, 1e-9, 1e-12):
                r = derive.simulate(str(model), [theta0, 0], np.linspace(0, 10, 11), p, method=method,
                                    rtol=rtol, events={"bottom": "theta1"})
                e = r.events["bottom"]
                exact = (2 * np.arange(len(e.t)) + 1) * period / 4
                print(f"period {method} rtol {rtol:g}: {len(e.t)} crossings, largest time error "
                      f"{np.abs(e.t - exact).max():.2e}")


def flips() -> None:
    y0, T = [0.5, 0.0, 0.0, 9.0], 4.0
    fun, _ = derive.scipy_rhs("planar", PLANAR)
    s = solve_ivp(fun, (0, T), y0, method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
    g = lambda t: np.cos(s.sol(t)[1] / 2)
    grid = np.linspace(0, T, 200_001)
    values = g(grid)
    ref = np.array([brentq(g, grid[i], grid[i + 1], xtol=1e-15)
                    for i in np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))])
    for rtol in (1e-8, 1e-10, 1e-12):
        for outputs in (5, 401):
            r = derive.simulate("planar", y0, np.linspace(0, T, outputs), PLANAR, rtol=rtol,
                                events={"flip": "cos(theta2/2)"})
            t = r.events["flip"].t
            err = f"{np.abs(t - ref).max():.2e}" if len(t) == len(ref) else f"found {t}, expected {ref}"
            print(f"flips  dop853 rtol {rtol:g}, {outputs} outputs: {len(t)} flips, largest time error {err}")


if __name__ == "__main__":
    dense_accuracy()
    pendulum_period()
    flips()
