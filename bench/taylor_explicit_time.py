"""Taylor's method with explicit time against DOP853, on the forced pendulum.

    python3 bench/taylor_explicit_time.py [--repeat 5] [--outputs 1001]

examples/models/forced_pendulum.toml (m l^2 theta'' = F0 cos(w t) - m g l sin(theta) -
c theta') from (0.4, -0.3) to t = 100 at rtol = 1e-12, through derive.simulate with
method="taylor" (the generated C: t in the jet) and method="dop853" (what runs a
time-dependent model's RK methods in this checkout), and heyoka beside them where it is
installed (hy.time in its jet, tol = 1e-12, propagate_grid).  Each is timed as the best
of --repeat runs after a first one (which builds the library / JIT-compiles); the error
of each, the largest over the outputs, is against SciPy's DOP853 at rtol 3e-14 (its floor) on the equation
written here by hand.  Prints every figure, measured in this run, and the ratio.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import derive

ROOT = Path(__file__).resolve().parents[1]
MODEL = str(ROOT / "examples" / "models" / "forced_pendulum.toml")
PARAMS = {"m": 1.2, "l": 0.9, "g": 9.81, "c": 0.15, "F0": 1.1, "w": 2.3}
Y0 = [0.4, -0.3]
T_END, RTOL = 100.0, 1e-12


def hand_rhs(t, y):
    m, l, g, c, F0, w = (PARAMS[k] for k in ("m", "l", "g", "c", "F0", "w"))
    return [y[1], (F0 * np.cos(w * t) - m * g * l * np.sin(y[0]) - c * y[1]) / (m * l * l)]


def best_of(run, repeat: int) -> tuple[float, object]:
    """(the fastest of `repeat` timed calls after one untimed, the last result)."""
    out = run()
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        out = run()
        best = min(best, time.perf_counter() - start)
    return best, out


def heyoka_run(times: np.ndarray, repeat: int):
    """heyoka's Taylor integrator on the same equation (hy.time in the jet), or None."""
    try:
        import heyoka as hy
    except ImportError:
        return None
    x, v = hy.make_vars("x", "v")
    m, l, g, c, F0, w = (PARAMS[k] for k in ("m", "l", "g", "c", "F0", "w"))
    sys_ = [(x, v), (v, (F0 * hy.cos(w * hy.time) - m * g * l * hy.sin(x) - c * v) / (m * l * l))]
    start = time.perf_counter()
    ta = hy.taylor_adaptive(sys_, Y0, tol=RTOL)
    jit = time.perf_counter() - start

    def run():
        ta.time, ta.state[:] = 0.0, Y0
        return ta.propagate_grid(times)[-1]
    best, y = best_of(run, repeat)
    return best, y, jit


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--outputs", type=int, default=1001)
    args = ap.parse_args()
    times = np.linspace(0.0, T_END, args.outputs)
    ref = solve_ivp(hand_rhs, (0, T_END), Y0, method="DOP853", rtol=3e-14, atol=1e-16, t_eval=times).y.T

    rows = []
    for method in ("taylor", "dop853"):
        seconds, r = best_of(lambda: derive.simulate(MODEL, Y0, times, PARAMS, method=method, rtol=RTOL),
                             args.repeat)
        assert r.ok, r.status_name
        rows.append((f"derive {method}", seconds, float(np.abs(r.y - ref).max()), r.nsteps))
    hy_out = heyoka_run(times, args.repeat)
    if hy_out is not None:
        seconds, y, jit = hy_out
        rows.append((f"heyoka (JIT {jit:.2f} s, not timed)", seconds, float(np.abs(y - ref).max()), None))

    print(f"forced_pendulum to t = {T_END:g}, rtol {RTOL:g}, {args.outputs} outputs, best of {args.repeat}")
    print(f"{'run':38s} {'seconds':>10s} {'max error':>10s} {'steps':>7s}")
    for name, seconds, err, steps in rows:
        print(f"{name:38s} {seconds:10.5f} {err:10.2e} {steps if steps is not None else '-':>7}")
    taylor, dop = rows[0][1], rows[1][1]
    print(f"dop853 / taylor time: {dop / taylor:.1f}x")
    if hy_out is not None:
        print(f"taylor / heyoka time: {taylor / hy_out[0]:.2f}x")
    print("(error: max over the outputs against SciPy DOP853 at rtol 3e-14 on the hand-written equation)")


if __name__ == "__main__":
    main()
