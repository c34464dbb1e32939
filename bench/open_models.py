"""The cost of a user's own model (issue: open models), measured in one run.

1. A cold `derive generate examples/models/triple.toml --out DIR`: a fresh process, an
   empty cache (derivation, CSE, rendering of every file of the model), wall time.
2. The generated triple-pendulum rhs in C (L D L^T solve emitted per model) against a
   hand-written L D L^T rhs of the same pendulum (derive/measurement/c/peers/
   triple_ldl_hand.c), both built as the integrators are (loader.build_fastest) and timed by
   the same C loop (derive/measurement/c/rhs_cost.c), chained (each evaluation waits for
   the one before, as in an integrator) and independent, over the same 10^4 random states;
   the two agree to rounding first.

    python3 bench/open_models.py [--repeats 7]

Prints the figures and the ratio generated / hand-written (target: at most 1.2).
"""
from __future__ import annotations

import argparse
import ctypes
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "models" / "triple.toml"
PARAMS = np.array([1.0, 2.0, 0.5, 1.0, 0.7, 1.2, 0.1, 9.81])     # m1 m2 m3 l1 l2 l3 L2 g


def cold_generate() -> float:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, DERIVE_CACHE_DIR=str(Path(tmp) / "cache"), PYTHONPATH=str(ROOT))
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "derive", "generate", str(MODEL), "--out", str(Path(tmp) / "gen")],
                       check=True, env=env, capture_output=True)
        return time.perf_counter() - t0


def loops():
    from derive.runtime.loader import PORTABLE_FLAGS, build_fastest, build_library
    from derive.codegen.sources import c_source
    from derive.model import load_model
    from derive.paths import bench_c_dir
    name = load_model(MODEL).name
    cost = bench_c_dir() / "rhs_cost.c"
    peers = bench_c_dir() / "peers"
    generated, flags = build_fastest(f"{name}_rhs_cost", [c_source(name, f"{name}.c"), cost],
                                     extra=(f"-DRHS={name}_rhs", "-include", f"{name}.h"))
    hand_extra = ("-DRHS=hand_triple_rhs", "-include", str(peers / "triple_ldl_hand.h"))
    # the peer at its best: the vector-math build (which keeps GCC from fusing sin and cos
    # into sincos) and the portable one (which fuses them); the faster one counts
    hand_vector, _ = build_fastest("triple_hand_rhs_cost", [peers / "triple_ldl_hand.c", cost], extra=hand_extra)
    hand_portable = build_library("triple_hand_rhs_cost", [peers / "triple_ldl_hand.c", cost],
                                  flags=(*PORTABLE_FLAGS, *hand_extra))
    generated_portable = build_library(f"{name}_rhs_cost", [c_source(name, f"{name}.c"), cost],
                                       flags=(*PORTABLE_FLAGS, f"-DRHS={name}_rhs", "-include", f"{name}.h"))
    out = {}
    for label, path in (("generated", generated), ("generated (portable build)", generated_portable),
                        ("hand-written (vector-math build)", hand_vector),
                        ("hand-written (portable build)", hand_portable)):
        fn = ctypes.CDLL(str(path)).rhs_cost_loop
        fn.restype = ctypes.c_double
        fn.argtypes = [ctypes.c_long, ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                       ctypes.c_long, ctypes.c_int, ctypes.c_double]
        out[label] = fn
    return out, flags


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    seconds = cold_generate()
    print(f"cold `derive generate {MODEL.relative_to(ROOT)} --out DIR` (empty cache): {seconds:.1f} s (target < 30 s)")

    fns, flags = loops()
    rng = np.random.default_rng(0)
    n = 10_000
    y = np.ascontiguousarray(np.column_stack([rng.uniform(-np.pi, np.pi, (n, 3)), rng.uniform(-3, 3, (n, 3))]))
    p = np.ascontiguousarray(PARAMS)
    outs = {}
    for label, fn in fns.items():
        o = np.empty_like(y)
        fn(n, 6, y.ctypes.data, p.ctypes.data, o.ctypes.data, 1, 0, 0.0)
        outs[label] = o
    hand = outs["hand-written (portable build)"]
    agree = float(np.max(np.abs(outs["generated"] - hand) / np.maximum(1, np.abs(hand))))
    print(f"generated and hand-written rhs agree to {agree:.2g} (relative, max over {n} states)")
    reps = 100
    results = {}
    for chained in (1, 0):
        for label, fn in fns.items():
            o = np.empty_like(y)
            call = (n, 6, y.ctypes.data, p.ctypes.data, o.ctypes.data, reps, chained, 0.0)
            fn(*call)
            times = []
            for _ in range(args.repeats):
                t0 = time.thread_time()
                fn(*call)
                times.append(time.thread_time() - t0)
            results[label, chained] = statistics.median(times) / (n * reps) * 1e9
    print(f"built with: {' '.join(flags)}")
    for chained, what in ((1, "chained (as in an integrator)"), (0, "independent")):
        g = results["generated", chained]
        hv, hp = (results["hand-written (vector-math build)", chained],
                  results["hand-written (portable build)", chained])
        h = min(hv, hp)
        gp = results["generated (portable build)", chained]
        print(f"rhs {what}: generated {g:.1f} ns ({gp:.1f} ns portable build), hand-written {hv:.1f} ns (vector-math build) / "
              f"{hp:.1f} ns (portable build); ratio to the faster {g / h:.2f} "
              f"(target <= 1.2: {'met' if g / h <= 1.2 else 'MISSED'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
