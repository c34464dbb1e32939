"""Throughput of `derive sweep` on the flip-time map (a benchmark, not a test).

    PYTHONPATH=. python bench/sweep.py [--grid N] [--workers 1,2] [--check 200] [--image DIR]
                                       [--unverified] [--no-mirror]

Runs derive/scenes/flip_map.toml (Taylor's method at rtol 1e-9, every flip time verified
to 1e-6, half the chunks written as the mirror images of the others; --unverified: one
pass without the verification; --no-mirror: every chunk integrated) (theta1 x theta2 on
an N x N grid, default the full 1000 x 1000) on a local Dask cluster of 1 and of 2
worker processes, each into a fresh store, and prints per run: the wall time of the
chunks (the cluster's start-up is not in it; it is printed apart), trajectories per
second, per worker, and per CPU second (the CPU time the tasks themselves took: the
figure per core whatever else shares the machine; with the mirror, also the trajectories
integrated per CPU second, half the map's).  A grid smaller than 1000 is extrapolated to
the full map by trajectories per second, and the output says so.  The two runs' stores
must be equal bit for bit.

--check K: K random grid points of the map against SciPy's DOP853 at rtol 1e-12 with
event functions on the textbook equations of the m = l = 1 pendulum (independent of
derive's derivation), and against derive's DOP853 in long double at rtol 1e-17 (the same
equations, another method, 10^8 times tighter than the map's first pass): flip/no-flip
agreement and the largest flip-time difference.  (SciPy at 1e-12 is itself off by up to
a few 1e-6 on the latest, most chaotic flips; the long-double run is the sharper
reference there.)
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
FULL = 1000
G = 9.81


def sweep_file(folder: Path, grid: int, verified: bool = True, mirror: bool = True) -> Path:
    text = (ROOT / "derive" / "scenes" / "flip_map.toml").read_text()
    if not verified:
        assert "\naccuracy = 1e-6\n" in text
        text = text.replace("\naccuracy = 1e-6\n", "\n")
    if not mirror:
        assert "\n[sweep]\n" in text
        text = text.replace("\n[sweep]\n", "\n[sweep]\nmirror = false\n")
    if grid != FULL:
        text = text.replace(f"num = {FULL}", f"num = {grid}")
    path = folder / "flip_map.toml"
    path.write_text(text)
    return path


def run_once(path: Path, out: Path, workers: int):
    import logging
    from distributed import LocalCluster
    from derive.sweep import run_sweep
    t0 = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster:
        startup = time.perf_counter() - t0
        report = run_sweep(path, out=out, scheduler=cluster.scheduler_address, progress=True)
    return report, startup


def textbook_rhs(t, y):
    t1, t2, w1, w2 = y
    d = t1 - t2
    den = 3 - np.cos(2 * d)
    a1 = (-3 * G * np.sin(t1) - G * np.sin(t1 - 2 * t2) - 2 * np.sin(d) * (w2 * w2 + w1 * w1 * np.cos(d))) / den
    a2 = 2 * np.sin(d) * (2 * w1 * w1 + 2 * G * np.cos(t1) + w2 * w2 * np.cos(d)) / den
    return [w1, w2, a1, a2]


def scipy_flip(y0, t_end: float) -> float:
    from scipy.integrate import solve_ivp
    up = lambda t, y: y[1] - np.pi
    down = lambda t, y: y[1] + np.pi
    up.terminal = down.terminal = True
    up.direction, down.direction = 1, -1
    r = solve_ivp(textbook_rhs, (0, t_end), y0, method="DOP853", rtol=1e-12, atol=1e-14, events=(up, down))
    times = [e[0] for e in r.t_events if len(e)]
    return min(times) if times else np.nan


def long_double_flips(y0: np.ndarray) -> np.ndarray:
    """Flip times from derive's own DOP853 in long double at rtol 1e-17 (eps 1e-19), located
    by the same event search: a reference about 10^4 times tighter than the map's run."""
    from derive.runtime.build import integrator_library
    from derive.sweep import level_crossings as events
    lib = integrator_library("planar")
    opt = lib.defaults()
    opt.rtol, opt.atol = 1e-17, 1e-20
    p = np.array([1, 1, 1, 1, G], np.longdouble)
    t = np.linspace(0, 10, 1001).astype(np.longdouble)

    def run(rows, start, local):
        y, infos = lib.run(2, np.ascontiguousarray(start, dtype=np.longdouble), p, np.asarray(local, np.longdouble), opt)
        return y, np.array([i.status for i in infos])

    y, _ = lib.run(2, y0.astype(np.longdouble), p, t, opt)
    return events.locate(run, y, t, 1, np.longdouble(np.pi))


def _compare(name: str, ours: np.ndarray, ref: np.ndarray) -> None:
    agree = np.isnan(ours) == np.isnan(ref)
    both = np.isfinite(ours) & np.isfinite(ref)
    err = np.abs(ours - ref)[both]
    late = (ref[both] > 5)
    print(f"check   against {name}: flip/no-flip agree at {agree.sum()}/{len(ours)}; {both.sum()} flips "
          f"({late.sum()} after t = 5), largest |difference| {err.max() if err.size else float('nan'):.2g}, "
          f"within 1e-6: {(err <= 1e-6).sum()}/{err.size}")


def check(ds, k: int) -> None:
    rng = np.random.default_rng(2026)
    t1, t2 = ds.theta1.values, ds.theta2.values
    i, j = rng.integers(1, len(t1) - 1, k), rng.integers(1, len(t2) - 1, k)     # |theta2| < pi
    ours = ds.flip_time.values[i, j]
    y0 = np.array([[t1[a], t2[b], 0.0, 0.0] for a, b in zip(i, j)])
    _compare("solve_ivp DOP853 rtol 1e-12 with events (textbook equations)",
             ours, np.array([scipy_flip(y, 10.0) for y in y0]))
    _compare("derive DOP853 in long double, rtol 1e-17", ours, long_double_flips(y0))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", type=int, default=FULL, help=f"points per axis (default {FULL})")
    ap.add_argument("--workers", default="1,2", help="worker counts to run (default 1,2)")
    ap.add_argument("--check", type=int, default=0, help="grid points to check against solve_ivp")
    ap.add_argument("--image", help="keep the last run's store and image in this folder")
    ap.add_argument("--unverified", action="store_true",
                    help="without the flip times' verification (events.flip.accuracy): one pass")
    ap.add_argument("--no-mirror", action="store_true",
                    help="every chunk integrated ([sweep] mirror = false), none as a mirror image")
    args = ap.parse_args()
    from derive.sweep import store
    total = args.grid ** 2
    print(f"machine {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start")
    with tempfile.TemporaryDirectory() as tmp:
        path = sweep_file(Path(tmp), args.grid, verified=not args.unverified, mirror=not args.no_mirror)
        print(f"flip map, {'without' if args.unverified else 'with'} the verification of each flip time, "
              f"{'without' if args.no_mirror else 'with'} the mirror symmetry")
        previous = None
        for n in (int(w) for w in args.workers.split(",")):
            out = Path(args.image) if args.image and n == int(args.workers.split(",")[-1]) else Path(tmp) / f"w{n}"
            if (out / "flip_map.zarr").exists():
                import shutil
                shutil.rmtree(out / "flip_map.zarr")
            report, startup = run_once(path, out, n)
            rate = total / report.seconds
            per_cpu = total / report.cpu_seconds
            line = (f"workers {n}: {total:,} trajectories in {report.seconds:.1f} s "
                    f"(cluster start-up {startup:.1f} s apart): {rate:,.0f}/s, {rate / n:,.0f}/s per worker, "
                    f"{per_cpu:,.0f} per CPU second")
            if report.mirrored:
                line += (f" ({report.mirrored} of {report.chunks} chunks the mirror image of another: "
                         f"{report.computed_trajectories / report.cpu_seconds:,.0f} integrated per CPU second)")
            if args.grid != FULL:
                line += (f"; extrapolated to the {FULL} x {FULL} map: {FULL ** 2 / rate:.0f} s "
                         f"(by trajectories per second; the grid's mix of flip times differs a little)")
            print(line, flush=True)
            ds = store.load(report.store)
            if previous is not None:
                same = all(np.array_equal(ds[v].values, previous[v].values, equal_nan=True) for v in ds.data_vars)
                print(f"stores  of {n} and the previous worker count equal bit for bit: {same}")
            previous = ds
            print(f"        load average now {os.getloadavg()[0]:.1f} (other work on the machine slows the wall "
                  f"time, not the CPU-second figure)")
        if args.check:
            check(previous, args.check)
    return 0


if __name__ == "__main__":
    sys.exit(main())
