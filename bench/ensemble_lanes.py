"""derive.ensemble's Taylor lanes against the scalar Taylor path they replaced and heyoka's
batch mode, in one run (a benchmark, not a test).

    PYTHONPATH=. python bench/ensemble_lanes.py [--rounds N] [--states B]

The race's ensemble row (derive/measurement/race.py: B planar states, angles uniform in
[-1, 1], rates 0, to t = 10, every final error <= 1e-8 against a long double dop853
reference at rtol 2e-18, computed once and kept in the derive cache): derive.ensemble with
method="taylor" (the SIMD lanes), the same call with the scalar integrator over the same
threads (what ensemble ran before the lanes), and heyoka's taylor_adaptive_batch at its
recommended width and twice it.  Two settings:
  (a) threads = cores, wall time: the race's setting (heyoka as the race runs it, one
      batch integrator per thread);
  (b) one thread each, CPU time of the calling thread: less disturbed by other work on a
      shared machine.
Every setting runs once per round, round robin, so all see the same load; the figure is
the minimum over the rounds.  Nothing is asserted.  The load average is printed: compare
ratios of one run.
"""
from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

import derive
from derive.runtime import taylor_lanes_library as lanes_module
from derive.runtime.taylor_library import taylor_library
from derive.measurement.race import PARAMS, TARGET, _heyoka, _heyoka_ensemble, ensemble_states, heyoka_system
from derive.paths import cache_dir

T_END = 10.0
RTOLS = (1e-9, 1e-10)
TOLS = (1e-9, 1e-10)


def reference(y0: np.ndarray) -> np.ndarray:
    path = cache_dir() / f"bench-ensemble-reference-{len(y0)}.npy"
    if path.is_file():
        return np.load(path)
    ref = derive.ensemble("planar", y0, [0.0, T_END], PARAMS, method="dop853", rtol=2e-18, atol=1e-22,
                          dtype="longdouble").y[:, -1]
    np.save(path, ref)
    return ref


def derive_run(y0, rtol: float, threads: int, scalar: bool = False):
    def run():
        saved = lanes_module.taylor_ensemble_library
        if scalar:          # the path before the lanes: the scalar integrator per trajectory
            lanes_module.taylor_ensemble_library = lambda model, order, dtype: taylor_library(model, order, dtype)
        try:
            return derive.ensemble("planar", y0, [0.0, T_END], PARAMS, method="taylor", rtol=rtol,
                                   threads=threads).y[:, -1]
        finally:
            lanes_module.taylor_ensemble_library = saved
    return run


def heyoka_one_thread(hy, sys_, y0, tol: float, width: int):
    """The race's heyoka ensemble in the calling thread: one batch integrator, reset and
    propagated per block of `width` states."""
    pars = np.tile(np.array(PARAMS)[:, None], width)
    ta = hy.taylor_adaptive_batch(sys_, np.zeros((4, width)), pars=pars, tol=tol, compact_mode=False)
    out = np.empty_like(y0)

    def run():
        for a in range(0, len(y0), width):
            b = min(a + width, len(y0))
            block = np.zeros((4, width))
            block[:, :b - a] = y0[a:b].T
            ta.set_time(0.0)
            ta.state[:] = block
            ta.propagate_until(T_END)
            out[a:b] = ta.state[:, :b - a].T
        return out.copy()
    return run


def settings(hy, y0, threads: int) -> dict:
    sys_ = heyoka_system(hy)
    runs = {f"derive taylor lanes rtol={r:g}": derive_run(y0, r, threads) for r in RTOLS}
    runs[f"derive taylor scalar (before) rtol={RTOLS[0]:g}"] = derive_run(y0, RTOLS[0], threads, scalar=True)
    for width in sorted({hy.recommended_simd_size(), 2 * hy.recommended_simd_size()}):
        for tol in TOLS:
            runs[f"heyoka batch {width} tol={tol:g}"] = (
                _heyoka_ensemble(hy, sys_, y0, T_END, tol, width, threads) if threads > 1
                else heyoka_one_thread(hy, sys_, y0, tol, width))
    return runs


def race(runs: dict, ref: np.ndarray, clock, rounds: int) -> None:
    def worst(y):
        return float(np.max(np.abs(np.asarray(y, np.longdouble) - ref))) if np.all(np.isfinite(y)) else math.inf

    errors = {k: worst(run()) for k, run in runs.items()}        # also builds and warms up
    best = {k: math.inf for k in runs}
    for _ in range(rounds):
        for k, run in runs.items():
            t0 = clock()
            run()
            best[k] = min(best[k], clock() - t0)
    for k in runs:
        print(f"  {k:42s} {best[k] * 1e3:8.1f} ms   worst final error {errors[k]:.2e}")

    def fastest(prefix):
        return min((best[k], k) for k in runs if k.startswith(prefix) and errors[k] <= TARGET)
    lanes, before, heyoka = fastest("derive taylor lanes"), fastest("derive taylor scalar"), fastest("heyoka")
    print(f"  fastest to {TARGET:g}: {lanes[1]} {lanes[0] * 1e3:.1f} ms, {heyoka[1]} {heyoka[0] * 1e3:.1f} ms: "
          f"heyoka / derive = {heyoka[0] / lanes[0]:.2f}; before the lanes {before[0] * 1e3:.1f} ms "
          f"(heyoka / derive {heyoka[0] / before[0]:.2f}): the lanes {before[0] / lanes[0]:.2f}x faster")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--states", type=int, default=4096)
    args = ap.parse_args()
    hy = _heyoka()
    y0 = ensemble_states(args.states)
    ref = reference(y0)
    cores = os.cpu_count() or 1
    print(f"(a) {cores} threads, wall time; load average {os.getloadavg()}")
    race(settings(hy, y0, cores), ref, time.perf_counter, args.rounds)
    print(f"(b) 1 thread, CPU time of the thread; load average {os.getloadavg()}")
    race(settings(hy, y0, 1), ref, time.thread_time, args.rounds)
    print(f"load average at the end {os.getloadavg()}")


if __name__ == "__main__":
    main()
