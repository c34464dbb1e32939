"""The integrators as one C library (derive_integrators.h, included per model and type)
against the per-model rendering they replaced, in one run (a benchmark, not a test).

    PYTHONPATH=. python bench/integrator_library.py [--rounds N] [--before COMMIT]

Before: generated/c/planar_integrate.c (.h) and the kernels planar.c (.h) of COMMIT
(default 14a6c56, the last rendering of the whole method code per model), taken with
`git show` into a temporary folder.  After: the same files as this derive renders them
(the thin planar_integrate.c and the library headers beside it).  Both are compiled as
derive's loader compiles them (build_fastest: the vector-math flags where they work) and
called through <model>_integrate_batch (double, float, long double) with the same
inputs: the chaotic planar state y0 = (2.5, 2, 0, 0), t = 0..20, 201 output times.  The
chart atlas likewise (spherical_atlas.c and its three charts' files, whose stepping loop
is now derive_driver.h), on a spherical state that switches charts.
Every case runs once per round, old and new in alternating order, so both see the same
load; the figures are the median over the rounds and the ratio of the fastest calls
(the least disturbed by other work).  The outputs and the counters are
compared bit for bit.  Nothing is asserted.  The load average is printed: compare the
ratios of one run.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from derive.runtime.loader import build_fastest
from derive.codegen.sources import model_sources
from derive.codegen import contract
from derive.runtime.build import info_struct, options_struct

ROOT = Path(__file__).resolve().parents[1]
MODEL = "planar"
N, N_PARAMS = 4, 5
Y0 = (2.5, 2.0, 0.0, 0.0)
PARAMS = (1.0, 1.0, 1.0, 1.0, 9.81)
T = np.linspace(0.0, 20.0, 201)
BATCH = 4               # trajectories a call (broadcast y0): amortises the ctypes call
METHOD = {m.name: m.index for m in contract.METHOD_TABLE}
DTYPES = {"": (np.float64, ctypes.c_double), "_f": (np.float32, ctypes.c_float),
          "_l": (np.longdouble, ctypes.c_longdouble)}
# (label, method, suffix, options)
CASES = (
    ("dop853 rtol 1e-10", "dop853", "", dict(rtol=1e-10, atol=1e-10)),
    ("dopri5 rtol 1e-8", "dopri5", "", dict(rtol=1e-8, atol=1e-8)),
    ("rk4 h 1e-3", "rk4", "", dict(h=1e-3)),
    ("rk8 h 1e-2", "rk8", "", dict(h=1e-2)),
    ("abm12 h 1e-3", "abm12", "", dict(h=1e-3)),
    ("gauss2 h 1e-2", "gauss2", "", dict(h=1e-2)),
    ("midpoint h 1e-3", "midpoint", "", dict(h=1e-3)),
    ("dop853 float rtol 1e-5", "dop853", "_f", dict(rtol=1e-5, atol=1e-5)),
    ("dop853 long double rtol 1e-13", "dop853", "_l", dict(rtol=1e-13, atol=1e-13)),
    ("gauss2 long double h 1e-2", "gauss2", "_l", dict(h=1e-2)),
)
# the chart atlas: a spherical double pendulum whose links pass near the poles
ATLAS, ATLAS_PREFIX, ATLAS_CHARTS, ATLAS_N = "spherical", "spherical_atlas", ("spherical_std", "spherical_alt",
                                                                          "spherical_rot"), 8
ATLAS_Y0 = (0.3, 0.0, 2.8, 1.0, 0.0, 2.0, 0.5, -1.0)
ATLAS_CASES = (
    ("atlas dop853 rtol 1e-10", "dop853", "", dict(rtol=1e-10, atol=1e-10)),
    ("atlas rk4 h 1e-3", "rk4", "", dict(h=1e-3)),
)


def sources_of(prefix: str, models: tuple[str, ...]) -> list[str]:
    """The C files of a library: the entry file, then each model's integrators and kernels."""
    files = [f"{prefix}.c"] if prefix not in models else []
    for m in models:
        files += [f"{m}_integrate.c", f"{m}.c"]
    return files


def before_sources(commit: str, folder: Path, files: list[str]) -> list[Path]:
    """The generated `files` (and their headers) of `commit`, written into `folder`."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in files:
        for part in (name, name[:-2] + ".h"):
            text = subprocess.run(["git", "show", f"{commit}:generated/c/{part}"], cwd=ROOT, check=True,
                                  capture_output=True, text=True).stdout
            (folder / part).write_text(text)
    return [folder / name for name in files]


class Library:
    """<model>_integrate_batch{,_f,_l} of one build (atlas=True: <atlas>_integrate_batch,
    which takes the starting charts and writes the chart of every output)."""

    def __init__(self, stem: str, sources: list[Path], atlas: bool = False):
        self.path, self.flags = build_fastest(stem, sources)
        self.lib = ctypes.CDLL(str(self.path))
        self.atlas, self.n = atlas, ATLAS_N if atlas else N
        self.prefix = ATLAS_PREFIX if atlas else MODEL
        self.Options = options_struct(contract.ATLAS_OPTIONS if atlas else ())
        self.Info = info_struct(self.n, contract.ATLAS_INFO if atlas else ())
        self.defaults = self.lib[f"{self.prefix}_defaults" if atlas else f"{MODEL}_integrate_defaults"]
        self.defaults.argtypes = [ctypes.POINTER(self.Options)]
        self.lines = len(sources[0].read_text().splitlines())

    def prepare(self, method: str, suffix: str, options: dict):
        """A call with its arrays bound: () -> (failed, y_out, infos)."""
        dtype, _ = DTYPES[suffix]
        opt = self.Options()
        self.defaults(ctypes.byref(opt))
        for k, v in options.items():
            setattr(opt, k, v)
        opt.max_steps = 10 ** 8
        y0, p, t = (np.ascontiguousarray(a, dtype) for a in ((ATLAS_Y0 if self.atlas else Y0), PARAMS, T))
        y = np.empty((BATCH, len(T), self.n), dtype)
        infos = (self.Info * BATCH)()
        fn = self.lib[f"{self.prefix}_integrate_batch{suffix}"]
        fn.restype = ctypes.c_long
        vp, long = ctypes.c_void_p, ctypes.c_long
        charts = np.full(BATCH, -1, np.intc)            # the rule picks the starting chart
        chart_out = np.empty((BATCH, len(T)), np.intc)
        head = (long(BATCH), ctypes.c_int(METHOD[method]))
        state = (vp(y0.ctypes.data), long(0), vp(p.ctypes.data), long(0), long(len(T)), vp(t.ctypes.data),
                 vp(y.ctypes.data))
        if self.atlas:
            args = (*head, vp(charts.ctypes.data), *state, vp(chart_out.ctypes.data))
        else:
            args = (*head, *state)
        args += (ctypes.byref(opt), ctypes.byref(infos))
        keep = (y0, p, t, opt, charts, chart_out)

        def call():
            assert keep
            failed = fn(*args)
            return failed, (y, chart_out) if self.atlas else (y,), infos
        return call


def catalogue_lines(commit: str, library: list[Path]) -> str:
    """The lines of integrator C of the whole catalogue before (every <model>_integrate.c
    of `commit`) and after (generated/c: the thin files, and the library once)."""
    listing = subprocess.run(["git", "ls-tree", "--name-only", f"{commit}:generated/c"], cwd=ROOT, check=True,
                             capture_output=True, text=True).stdout.split()
    before = {name: subprocess.run(["git", "show", f"{commit}:generated/c/{name}"], cwd=ROOT, check=True,
                                   capture_output=True, text=True).stdout.count("\n")
              for name in listing if name.endswith("_integrate.c")}
    after = {p.name: len(p.read_text().splitlines()) for p in sorted((ROOT / "generated" / "c").glob("*_integrate.c"))}
    shared = sum(len(h.read_text().splitlines()) for h in library)
    return (f"the catalogue ({len(before)} models): before {sum(before.values())} lines "
            f"({', '.join(f'{n} {k}' for n, k in before.items())}); after {sum(after.values()) + shared} "
            f"({', '.join(f'{n} {k}' for n, k in after.items())}, and the library {shared} once)")


def bits(a: np.ndarray) -> bytes:
    """The bytes of a's values: x86's long double is 80 bits stored in 16 bytes, whose 6
    padding bytes are whatever the stack held (not part of the value)."""
    if a.dtype == np.longdouble and a.dtype.itemsize == 16 and np.finfo(np.longdouble).nmant == 63:
        return a.view(np.uint8).reshape(-1, 16)[:, :10].tobytes()
    return a.tobytes()


def counters(infos) -> tuple:
    return tuple((i.status, i.nfev, i.njev, i.nsteps, i.naccepted, i.nrejected, i.nnewton, i.nout,
                  i.t, i.h, i.local_error, tuple(i.y), getattr(i, "nswitches", 0), getattr(i, "chart", 0))
                 for i in infos)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--before", default="14a6c56")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        model_files, atlas_files = sources_of(MODEL, (MODEL,)), sources_of(ATLAS_PREFIX, ATLAS_CHARTS)
        old = Library(f"{MODEL}_integrate_before", before_sources(args.before, Path(tmp) / "m", model_files))
        old_atlas = Library(f"{ATLAS_PREFIX}_before", before_sources(args.before, Path(tmp) / "a", atlas_files),
                            atlas=True)
        folder = model_sources(MODEL) / "c"
        new = Library(f"{MODEL}_integrate", [folder / f for f in model_files])
        atlas_folder = model_sources(ATLAS) / "c"
        new_atlas = Library(ATLAS_PREFIX, [atlas_folder / f for f in atlas_files], atlas=True)
        library = sorted(folder.glob("derive_*.h"))
        print(f"flags: {' '.join(old.flags)}")
        print(f"lines of integrator C for {MODEL}: before {old.lines} ({MODEL}_integrate.c); after "
              f"{new.lines} ({MODEL}_integrate.c) + "
              + " + ".join(f"{len(h.read_text().splitlines())} ({h.name})" for h in library)
              + " shared by every model")
        print(catalogue_lines(args.before, library))
        print(f"the atlas: before {old_atlas.lines} ({ATLAS_PREFIX}.c), after {new_atlas.lines} "
              f"(+ derive_driver.h)")
        cases = [(c, old, new) for c in CASES] + [(c, old_atlas, new_atlas) for c in ATLAS_CASES]
        calls = {}
        for (label, method, suffix, opts), before, after in cases:
            calls[(label, "old")] = before.prepare(method, suffix, opts)
            calls[(label, "new")] = after.prepare(method, suffix, opts)
        labels = [c[0][0] for c in cases]
        same = {}
        for label in labels:
            fo, yo, io = calls[(label, "old")]()
            fo2, yo2, io2 = calls[(label, "new")]()
            same[label] = (fo == fo2 and all(bits(a) == bits(b) for a, b in zip(yo, yo2))
                           and counters(io) == counters(io2), io[0].status, io[0].nfev)
        times = {key: [] for key in calls}
        for r in range(args.rounds):
            for label in labels:
                order = ("old", "new") if r % 2 == 0 else ("new", "old")
                for which in order:
                    call = calls[(label, which)]
                    t0 = time.perf_counter()
                    call()
                    times[(label, which)].append(time.perf_counter() - t0)
        print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}; {args.rounds} rounds, "
              f"{BATCH} trajectories a call; median ms a call, and new/old of the fastest calls")
        print(f"{'case':32s} {'old ms':>9s} {'new ms':>9s} {'new/old':>8s} {'min ratio':>9s}  {'nfev':>7s}  identical")
        for label in labels:
            o, n = (statistics.median(times[(label, w)]) * 1e3 for w in ("old", "new"))
            low = min(times[(label, "new")]) / min(times[(label, "old")])
            ok, status, nfev = same[label]
            print(f"{label:32s} {o:9.3f} {n:9.3f} {n / o:8.3f} {low:9.3f}  {nfev:7d}  {'yes' if ok else 'NO'}"
                  + (f" (status {status})" if status else ""))


if __name__ == "__main__":
    main()
