"""The fixed cost of one derive.simulate call, per method, beside heyoka's (a benchmark, not a test).

    PYTHONPATH=. python bench/overhead.py [--calls N] [--model planar] [--no-heyoka]

Each method runs `simulate(model, y0, [0, 1e-6], params, method=...)` N times (fixed-step
methods at step=1e-3: one shortened step; adaptive ones at their default rtol), each call
timed alone with time.perf_counter; "call" is the minimum and the median over the calls.
"C" is the same run through the generated entry point alone (ctypes, arrays and options
made beforehand), and "overhead" = call - C: what simulate costs around the integration
(issue 15 item 1: at most 20 us).  heyoka's one call is the race's (derive bench --race):
taylor_adaptive on the same pendulum (tol 1e-15), time and state reset, propagate_until(1e-6).
The ratio is derive's call over heyoka's (below 1: derive is cheaper).  CPU time per call
(time.process_time over all N calls) is printed too: above the wall time means another
thread worked, below means the process waited.  Nothing is asserted.  Figures taken
while other work runs are noisy: the load average is printed; compare ratios of one run.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import statistics
import time

import numpy as np

import derive
from derive.runtime.build import address, integrator_library
from derive.codegen.contract import METHODS, TAYLOR, TOLERANCE_METHODS
from derive.codegen.contract import taylor_order
from derive.runtime.taylor_library import taylor_library

PARAMS = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
Y0 = [1.0, 0.5, 0.0, 0.0]
SPAN = [0.0, 1e-6]
STEP = 1e-3
ORDER = ("rk4", "rk8", "abm12", "dopri5", "dop853", "midpoint", "gauss2", "taylor")


def timed(call, n: int) -> tuple[float, float, float]:
    """(min, median) of n single-call wall times, and the CPU time per call (seconds)."""
    for _ in range(min(n // 10, 200)):          # warm: libraries loaded, caches filled
        call()
    times = []
    cpu0 = time.process_time()
    for _ in range(n):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    cpu = (time.process_time() - cpu0) / n
    return min(times), statistics.median(times), cpu


def c_alone(model: str, method: str, rtol: float = 1e-9):
    """The run of a simulate call through the C entry point alone: one call() per run."""
    lib = integrator_library(model)
    opt = {"rtol": rtol, "atol": rtol * 1e-3} if method in TOLERANCE_METHODS else {"h": STEP}
    struct = lib.options(opt)
    y0, t = np.array([Y0]), np.array(SPAN)
    p = np.array(list(PARAMS.values()))
    out = np.empty((1, len(t), lib.n))
    if method == TAYLOR:
        taylor = taylor_library(model, taylor_order(rtol))
        fn, info = taylor.fns["float64"], (taylor.Info * 1)()
        head = (1,)
    else:
        fn, info = lib.fns["float64"], (lib.Info * 1)()
        head = (1, METHODS.index(method))
    args = (*head, address(y0), lib.n, address(p), 0, len(t), address(t), address(out),
            ctypes.addressof(struct), ctypes.addressof(info))
    keep = (y0, p, t, out, struct, info)        # the pointers in args are into these

    def call():
        fn(*args)
        return keep
    return call


def heyoka_call():
    """heyoka's one call on a trivial span, as `derive bench --race` times it; None without heyoka."""
    try:
        import heyoka as hy
    except ImportError:
        return None, None
    from derive.measurement.race import heyoka_system
    ta = hy.taylor_adaptive(heyoka_system(hy), np.array(Y0), pars=np.array(list(PARAMS.values())), tol=1e-15)
    start = np.array(Y0)

    def call():
        ta.time = 0.0
        ta.state[:] = start
        ta.propagate_until(SPAN[1])
    return call, hy.__version__


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20000)
    ap.add_argument("--model", default="planar")
    ap.add_argument("--no-heyoka", action="store_true")
    args = ap.parse_args()
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}; {args.calls} calls each; "
          f"derive from {os.path.dirname(derive.__file__)}")
    theirs = None
    if not args.no_heyoka:
        call, version = heyoka_call()
        if call is not None:
            theirs = timed(call, args.calls)
            print(f"heyoka {version}: one call min {theirs[0] * 1e6:.2f} us, median {theirs[1] * 1e6:.2f} us, "
                  f"CPU {theirs[2] * 1e6:.2f} us")
        else:
            print("heyoka is not installed (pip install heyoka): no ratio")
    print(f"{'method':9s} {'call min':>9s} {'median':>8s} {'C min':>7s} {'overhead min':>12s} {'median':>8s} "
          f"{'CPU':>7s} {'/ heyoka':>8s}   (us)")
    for method in ORDER:
        kw = {} if method in TOLERANCE_METHODS else {"step": STEP}
        call = timed(lambda: derive.simulate(args.model, Y0, SPAN, PARAMS, method=method, **kw), args.calls)
        c = timed(c_alone(args.model, method), args.calls)
        ratio = f"{call[0] / theirs[0]:8.2f}" if theirs else f"{'-':>8s}"
        print(f"{method:9s} {call[0] * 1e6:9.2f} {call[1] * 1e6:8.2f} {c[0] * 1e6:7.2f} "
              f"{(call[0] - c[0]) * 1e6:12.2f} {(call[1] - c[1]) * 1e6:8.2f} {call[2] * 1e6:7.2f} {ratio}")
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
