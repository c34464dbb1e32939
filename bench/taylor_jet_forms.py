"""The Taylor jet's two forms against each other: unrolled and compact, per step and per build.

For each model (the two-link catalogue models by default, planar chains with --links) and
each tolerance, in one run: the time per step of `derive.simulate(model, ..., method=
"taylor", rtol=tol)` with the jet unrolled and compact (DERIVE_TAYLOR_JET), each in a
fresh process of its own (the build cache warm: the run alone), the forms interleaved and
repeated, the best of each; and the compiler's wall time and peak memory for each form's
build at that order (the compiler run by hand on the generated file, with derive's flags,
under /usr/bin/time).  The final states of the two forms are compared: they are the same
arithmetic, so the same bits.

    python3 bench/taylor_jet_forms.py [--models planar compound] [--links 3 5] [--rtol 1e-8 1e-14]

Prints a table and the ratios; nothing here is a test (the figures depend on the machine).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
from derive_scale import chain_file, initial_state, parameters          # noqa: E402

RUN = textwrap.dedent("""
    import sys, time, json
    import derive
    model, y0, p, t_end, rtol, repeats = sys.argv[1], json.loads(sys.argv[2]), json.loads(sys.argv[3]), \\
        float(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
    run = lambda: derive.simulate(model, y0, [0.0, t_end], p, method="taylor", rtol=rtol)
    r = run()
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = run()
        best = min(best, time.perf_counter() - t0)
    print(json.dumps({"step": best / r.nsteps, "steps": int(r.nsteps), "y": [float(v).hex() for v in r.y[-1]]}))
""")

ENSEMBLE = textwrap.dedent("""
    import sys, time, json
    import numpy as np
    import derive
    model, y0, p, t_end, rtol, repeats, states = sys.argv[1], json.loads(sys.argv[2]), json.loads(sys.argv[3]), \\
        float(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6]), int(sys.argv[7])
    rng = np.random.default_rng(1)
    y = np.array(y0) + rng.uniform(-0.1, 0.1, (states, len(y0)))
    run = lambda: derive.ensemble(model, y, [0.0, t_end], p, method="taylor", rtol=rtol, threads=1)
    r = run()
    steps = int(sum(int(s) for s in r.nsteps))
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = run()
        best = min(best, time.perf_counter() - t0)
    print(json.dumps({"step": best / steps, "steps": steps, "y": [float(v).hex() for v in r.y[:, -1].ravel()]}))
""")

CATALOGUE = {"planar": ((2.5, 2.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0, 9.81), 5.0),
             "compound": ((2.5, 2.0, 0.0, 0.0), (1.0, 1.0, 0.5, 0.5, 1.0, 1.0, 9.81), 5.0),
             # a double spherical pendulum off its chart's poles: (theta1, phi1, theta2, phi2, rates)
             "spherical_std": ((1.2, 0.3, 2.0, -0.5, 0.0, 0.8, 0.3, -0.6), (1.0, 1.0, 1.0, 1.0, 9.81), 2.0)}


def per_step(model: str, y0, p, t_end: float, rtol: float, form: str, env: dict, repeats: int,
             states: int = 0) -> dict:
    """One form's run in a fresh process: its best time per step, steps and final state;
    `states` > 0: an ensemble of that many states (the SIMD lanes), per trajectory step."""
    script, more = (ENSEMBLE, [str(states)]) if states else (RUN, [])
    out = subprocess.run([sys.executable, "-c", script, model, json.dumps(list(y0)), json.dumps(list(p)),
                          str(t_end), str(rtol), str(repeats), *more], env=dict(env, DERIVE_TAYLOR_JET=form),
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.splitlines()[-1])


def compile_cost(model: str, order: int, form: str, lanes: bool = False) -> tuple[float, int]:
    """(wall seconds, peak kB) of the compiler on <model>_taylor.c (`lanes`: _taylor_lanes.c)
    at `order` in `form`, with the flags derive builds it with (the double variant only)."""
    from derive.codegen.sources import c_source
    from derive.codegen.taylor import taylor_skip_flags
    from derive.runtime.loader import VECTOR_MATH_FLAGS, compiler_command, default_compiler
    from derive.runtime.taylor_lanes_library import LANES_FLAGS, simd_build
    M = model.upper()
    if lanes:
        source = c_source(model, f"{model}_taylor_lanes.c")
        simd, width = simd_build("float64")
        flags = (*LANES_FLAGS, *simd, f"-D{M}_TAYLOR_LANES={width}", f"-D{M}_TAYLOR_LANES_ONLY=1")
    else:
        source = c_source(model, f"{model}_taylor.c")
        flags = (*VECTOR_MATH_FLAGS, *taylor_skip_flags(model, "double"))
    with tempfile.TemporaryDirectory() as tmp:
        cmd = ["/usr/bin/time", "-f", "%e %M", *compiler_command(default_compiler()), *flags,
               f"-D{M}_TAYLOR_ORDER={order}", f"-D{M}_TAYLOR_COMPACT={int(form == 'compact')}",
               "-I", str(source.parent), str(source), "-o", f"{tmp}/lib.so", "-lm"]
        run = subprocess.run(cmd, capture_output=True, text=True, check=True)
    seconds, kb = run.stderr.split()[-2:]
    return float(seconds), int(kb)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", nargs="*", default=list(CATALOGUE))
    parser.add_argument("--links", type=int, nargs="*", default=[])
    parser.add_argument("--rtol", type=float, nargs="+", default=[1e-8, 1e-14])
    parser.add_argument("--chain-t", type=float, default=10.0)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--ensemble", type=int, default=0, metavar="B",
                        help="time derive.ensemble of B states (the SIMD lanes, one thread) instead of simulate")
    args = parser.parse_args(argv)
    import derive
    from derive.codegen.contract import taylor_order
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    print(f"load average {'/'.join(f'{v:.2f}' for v in os.getloadavg())}")
    with tempfile.TemporaryDirectory() as tmp:
        cases = []
        for name in args.models:
            y0, p, t_end = CATALOGUE[name]
            cases.append((name, name, y0, p, t_end))
        for n in args.links:
            path = str(chain_file(n, Path(tmp)))
            cases.append((f"chain{n}", path, initial_state(n), parameters(n), args.chain_t))
        print(f"{'model':>9} {'order':>5} {'steps':>6} {'unrolled/step':>14} {'compact/step':>13} {'ratio':>6} "
              f"{'compile unrolled':>17} {'compile compact':>16}  same bits")
        for label, model, y0, p, t_end in cases:
            name = derive.load_model(model).name
            for rtol in args.rtol:
                best = {}
                for _ in range(args.rounds):
                    for form in ("unrolled", "compact"):
                        r = per_step(model, y0, p, t_end, rtol, form, env, args.repeats, args.ensemble)
                        if form not in best or r["step"] < best[form]["step"]:
                            best[form] = r
                order = taylor_order(rtol)
                (cu, mu), (cc, mc) = (compile_cost(name, order, f, lanes=bool(args.ensemble))
                                      for f in ("unrolled", "compact"))
                u, c = best["unrolled"], best["compact"]
                print(f"{label:>9} {order:5d} {u['steps']:6d} {u['step'] * 1e6:11.2f} us {c['step'] * 1e6:10.2f} us "
                      f"{u['step'] / c['step']:5.2f}x {cu:7.2f} s {mu / 1024:5.0f} MB {cc:6.2f} s {mc / 1024:5.0f} MB  "
                      f"{u['y'] == c['y']}", flush=True)
    print(f"load average {'/'.join(f'{v:.2f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
