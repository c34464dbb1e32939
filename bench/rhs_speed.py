"""Speed of the generated planar rhs against hand-written peers (a benchmark, not a test).

    PYTHONPATH=. python bench/rhs_speed.py [--evals N] [--repeats R] [--batch B]

1. C: generated/c/planar.c against derive/measurement/c/planar_hand.c (seed 000 (1.34)-(1.35)
   written by hand), both compiled with `cc -std=c99 -O2` into one program
   (bench/harness.c) and called in a C loop; best of R repeats, calls to the
   two alternating.  Target: generated <= 1.1 x hand-written.  (A peer
   measurement on this kind of machine: hand-written 27 ns, SymPy cse+ccode
   33 ns, CasADi 34 ns per evaluation.)  The batch entry point
   planar_rhs_batch is timed too (per state, blocks of 1024 states).
2. NumPy: generated/numpy/planar.py `rhs` on B = 10^5 states against the same
   equations written by hand in NumPy (derive/measurement/peers.py, the benchmark's
   peer).  Target: generated faster.
Ratios are printed; nothing is asserted.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import timeit
from pathlib import Path

import numpy as np

from derive.measurement.peers import hand_numpy_rhs_batch

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"
HAND = ROOT / "derive" / "measurement" / "c"      # the hand-written peer, shipped for `derive bench`
GEN_C = ROOT / "generated" / "c"


def c_benchmark(evals: int, repeats: int) -> dict[str, float]:
    cc = os.environ.get("CC", "cc")
    with tempfile.TemporaryDirectory() as tmp:
        exe = Path(tmp) / "harness"
        cmd = [cc, "-std=c99", "-O2", "-I", str(GEN_C), "-I", str(HAND), str(BENCH / "harness.c"),
               str(HAND / "planar_hand.c"), str(GEN_C / "planar.c"), "-o", str(exe), "-lm"]
        subprocess.run(cmd, check=True)
        out = subprocess.run([str(exe), str(evals), str(repeats)], check=True, capture_output=True,
                             text=True).stdout
    return {k: float(v) for k, v in (line.split() for line in out.splitlines()) if k != "sink"}


def numpy_benchmark(batch: int, repeats: int) -> dict[str, float]:
    spec = importlib.util.spec_from_file_location("generated_planar", ROOT / "generated" / "numpy" / "planar.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    rng = np.random.default_rng(0)
    y = np.concatenate([rng.uniform(-np.pi, np.pi, (batch, 2)), rng.uniform(-3, 3, (batch, 2))], axis=1)
    p = np.array([1.0, 1.3, 0.9, 1.1, 9.81])
    assert np.allclose(gen.rhs(y, p), hand_numpy_rhs_batch(y, *p), rtol=1e-12, atol=1e-12)
    times = {"hand": [], "generated": []}
    for _ in range(repeats):            # alternate, keep the best of each
        times["hand"].append(min(timeit.repeat(lambda: hand_numpy_rhs_batch(y, *p), number=3, repeat=1)) / 3)
        times["generated"].append(min(timeit.repeat(lambda: gen.rhs(y, p), number=3, repeat=1)) / 3)
    result = {k: min(v) * 1e3 for k, v in times.items()}
    try:
        from derive.runtime.loader import load
        lib = load("planar")
        lib.rhs(y, p)
        result["c_batch_via_loader"] = min(timeit.repeat(lambda: lib.rhs(y, p), number=3, repeat=repeats)) / 3 * 1e3
    except Exception as exc:        # the loader needs a compiler; the benchmark does not
        print(f"(loader not timed: {exc})", file=sys.stderr)
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--evals", type=int, default=200_000, help="C evaluations per repeat")
    ap.add_argument("--repeats", type=int, default=40)
    ap.add_argument("--batch", type=int, default=100_000, help="NumPy batch size")
    args = ap.parse_args(argv)

    c = c_benchmark(args.evals, args.repeats)
    ratio = c["generated"] / c["hand"]
    print("C, planar rhs, ns per evaluation (best of %d x %d calls):" % (args.repeats, args.evals))
    print(f"  hand-written           {c['hand']:8.2f}")
    print(f"  generated planar_rhs   {c['generated']:8.2f}   ratio {ratio:.3f}  (target <= 1.10: "
          f"{'met' if ratio <= 1.10 else 'NOT met'})")
    print(f"  generated batch        {c['batch']:8.2f}   ratio {c['batch'] / c['hand']:.3f}")

    n = numpy_benchmark(args.batch, max(5, args.repeats // 4))
    nratio = n["generated"] / n["hand"]
    print(f"NumPy, planar rhs over {args.batch} states, ms per call (best of repeats):")
    print(f"  hand-written           {n['hand']:8.2f}")
    print(f"  generated rhs          {n['generated']:8.2f}   ratio {nratio:.3f}  (target < 1: "
          f"{'met' if nratio < 1 else 'NOT met'})")
    if "c_batch_via_loader" in n:
        print(f"  C batch via loader     {n['c_batch_via_loader']:8.2f}   ratio {n['c_batch_via_loader'] / n['hand']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
