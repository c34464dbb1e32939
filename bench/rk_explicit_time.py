"""Time-dependent models in the generated RK library, before and after (issue 23 item 3).

Before, a model with explicit time (t in a force, a moving pivot) was stepped in Python:
each stage one call of the compiled rhs (derive/runtime/continuous_inputs.py
run_continuous, the path inputs u(t, y) still take), and an ensemble ran its members
one after another that way.  Now derive.simulate and derive.ensemble run it in the
generated C, every stage's own t passed to the rhs, an ensemble in threads.  In one run:

1. forced_pendulum, t = 0 to 100 (101 outputs), dop853 at rtol 1e-10: the Python-stepped
   path (run_continuous, as derive.simulate ran it before) against derive.simulate now,
   the best of --repeat calls each (the library built and loaded first), with the two
   final states' difference and each one's error against solve_ivp (DOP853, rtol 1e-13)
   on the ODE written out here;
2. an ensemble of --members driven_pivot members (theta1 spread over [-1, 1], w over
   [2, 8]), t = 0 to 10, dop853 at rtol 1e-10: the members stepped in Python one after
   another (as derive.ensemble ran them before) against derive.ensemble now (C, --threads).

    python3 bench/rk_explicit_time.py [--members 1000] [--threads 2] [--repeat 5]

Prints the figures; nothing here is a test (they depend on the machine).
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import derive
from derive.runtime import continuous_inputs
from derive.runtime.simulate import resolve_model, run_options

ROOT = Path(__file__).resolve().parents[1]
FORCED = str(ROOT / "examples" / "models" / "forced_pendulum.toml")
PIVOT = str(ROOT / "examples" / "models" / "driven_pivot.toml")
FORCED_P = {"m": 1.0, "l": 1.0, "g": 9.81, "c": 0.1, "F0": 0.5, "w": 1.3}
PIVOT_P = {"m": 1.0, "l": 1.0, "g": 9.81, "a": 0.05, "w": 5.0}
RTOL = 1e-10


def best(run, repeat: int) -> tuple[float, object]:
    """The least wall time of `repeat` calls, and the last call's result."""
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - start)
    return min(times), out


def stepped(model: str, y0, ts: np.ndarray, params: dict) -> np.ndarray:
    """The Python-stepped path: each stage one call of the compiled rhs at its own t."""
    opt = run_options("dop853", np.dtype(np.float64), ts, rtol=RTOL, atol=RTOL)
    r = continuous_inputs.run_continuous(resolve_model(model, explicit_time=True), "dop853", np.asarray(y0, float), ts,
                                         np.array(list(params.values()), float), opt, "c")
    assert r.ok, r.message
    return r


def forced_ode(t, y, m, l, g, c, F0, w):
    th, thd = y
    return [thd, (F0 * np.cos(w * t) - c * thd - m * g * l * np.sin(th)) / (m * l ** 2)]


def single(repeat: int) -> None:
    ts = np.linspace(0.0, 100.0, 101)
    y0 = [0.5, 0.0]
    derive.simulate(FORCED, y0, ts, FORCED_P, method="dop853", rtol=RTOL, atol=RTOL)     # build, load
    before, old = best(lambda: stepped(FORCED, y0, ts, FORCED_P), repeat)
    after, new = best(lambda: derive.simulate(FORCED, y0, ts, FORCED_P, method="dop853", rtol=RTOL, atol=RTOL),
                      repeat)
    ref = solve_ivp(lambda t, y: forced_ode(t, y, *FORCED_P.values()), (0.0, 100.0), y0, method="DOP853",
                    rtol=1e-13, atol=1e-13).y[:, -1]
    print(f"1. forced_pendulum t = 0..100, dop853 rtol {RTOL:g} (best of {repeat}):")
    print(f"   before (stepped in Python): {before * 1e3:9.3f} ms  nfev {old.nfev}  "
          f"error at t = 100 {np.max(np.abs(old.y[-1] - ref)):.2e}")
    print(f"   after  (generated C):       {after * 1e3:9.3f} ms  nfev {new.nfev}  "
          f"error at t = 100 {np.max(np.abs(new.y[-1] - ref)):.2e}")
    print(f"   speed-up {before / after:.1f}x; |before - after| at t = 100: "
          f"{np.max(np.abs(old.y[-1] - new.y[-1])):.2e}")


def ensemble(members: int, threads: int) -> None:
    ts = np.linspace(0.0, 10.0, 11)
    y0 = np.column_stack([np.linspace(-1.0, 1.0, members), np.zeros(members)])
    w = np.linspace(2.0, 8.0, members)
    params = {**{k: np.full(members, v) for k, v in PIVOT_P.items()}, "w": w}
    derive.ensemble(PIVOT, y0[:2], ts, {k: v[:2] for k, v in params.items()}, method="dop853", rtol=RTOL,
                    atol=RTOL, threads=1)                                                    # build, load
    start = time.perf_counter()
    old = np.array([stepped(PIVOT, y0[i], ts, dict(PIVOT_P, w=w[i])).y for i in range(members)])
    before = time.perf_counter() - start
    start = time.perf_counter()
    new = derive.ensemble(PIVOT, y0, ts, params, method="dop853", rtol=RTOL, atol=RTOL, threads=threads)
    after = time.perf_counter() - start
    assert new.all_ok
    print(f"2. ensemble of {members} driven_pivot members, t = 0..10, dop853 rtol {RTOL:g}:")
    print(f"   before (each member stepped in Python): {before:8.3f} s")
    print(f"   after  (derive.ensemble, C, {new.threads} thread(s)): {after:8.3f} s")
    print(f"   speed-up {before / after:.0f}x; largest |before - after| over every row: "
          f"{np.max(np.abs(old - new.y)):.2e}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=1000)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    single(args.repeat)
    ensemble(args.members, args.threads)


if __name__ == "__main__":
    main()
