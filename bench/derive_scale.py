"""How deriving, generating and building a model grows with its size, against the peers.

For planar chains of n point masses (n = 3, 5, 8, 12 by default), in one run:

1. **derive + generate, cold**: `derive generate chainN.toml --out DIR` in a fresh process
   with an empty cache (derivation, CSE, every C and NumPy file: kernels, Jacobian,
   linearisation, integrators, the Taylor jet in every precision), wall time, and the same
   with `--backend numpy` alone (NumPy's files: lambdify's kind of output); against
   sympy.physics.mechanics' KanesMethod + lambdify (cse=True) of the same chain (the
   PyDy n-pendulum), also a fresh process, wall time.  Both include the interpreter's
   start and the imports, each with its modules' bytecode as an installed package has it
   (pip compiles it at install; a checkout's may be stale, and none is written where
   PYTHONDONTWRITEBYTECODE is set): every process of the benchmark keeps it under one
   temporary PYTHONPYCACHEPREFIX, filled by a warm-up run of each side that is not
   counted.  Each side runs --repeat times (3), in turn, and the median is printed.  The growth exponent of each is fitted over the sizes run.
2. **the rhs**: the operations of derive's rhs kernel after CSE (its L D L^T solve
   included) against Kane's M and F after CSE plus a dense LU solve (2/3 n^3 + 2 n^2
   operations); and the time of one call of derive.scipy_rhs (the public API, compiled C)
   against Kane's lambdified M, F and numpy.linalg.solve.  The two rhs are first checked
   to agree at a random state.
3. **the first Taylor run** (rtol 1e-14, t = 0 to 1, cold cache: derive, generate,
   compile, run) through derive.simulate, against heyoka's `taylor_adaptive`
   construction (JIT included, parameters as par[]; its disk cache of compiled code,
   on by default since heyoka 7, off: cold too) and the same propagation.

    python3 bench/derive_scale.py [--links 3 5 8 12] [--taylor-links 3 5 8] [--taylor-only] [--repeat 3]

Prints a table and the ratios; nothing here is a test (the figures depend on the machine).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BYTECODE = tempfile.TemporaryDirectory(prefix="derive-scale-bytecode-")


def _env(**extra: str) -> dict:
    """The environment of every process the benchmark starts: the modules' bytecode written
    and read under one prefix of its own (module docstring), `extra` added."""
    env = dict(os.environ, PYTHONPYCACHEPREFIX=BYTECODE.name, **extra)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def chain_file(n: int, folder: Path) -> Path:
    """A planar chain of n point masses as a derive model file."""
    lines = [f'name = "chain{n}"', f'title = "Planar chain of {n} point masses"', "dimension = 2",
             "parameters = [" + ", ".join([f'"m{i}"' for i in range(1, n + 1)] +
                                          [f'"l{i}"' for i in range(1, n + 1)] + ['"g"']) + "]"]
    for i in range(1, n + 1):
        lines += ["[[links]]", 'chart = "planar"', f'length = "l{i}"', f'body = {{ kind = "point", mass = "m{i}" }}']
    path = folder / f"chain{n}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def parameters(n: int) -> np.ndarray:
    rng = np.random.default_rng(n)
    return np.concatenate([rng.uniform(0.5, 1.5, n), rng.uniform(0.5, 1.5, n), [9.81]])


def initial_state(n: int) -> np.ndarray:
    rng = np.random.default_rng(100 + n)
    return np.concatenate([rng.uniform(-1, 1, n), rng.uniform(-0.5, 0.5, n)])


KANE = textwrap.dedent("""
    import sys, time, json
    import sympy as sp
    import sympy.physics.mechanics as me
    n = int(sys.argv[1])
    t0 = time.perf_counter()
    q, u = me.dynamicsymbols(f"q:{n}"), me.dynamicsymbols(f"u:{n}")
    m, l = sp.symbols(f"m:{n}"), sp.symbols(f"l:{n}")
    g, t = sp.symbols("g t")
    A = me.ReferenceFrame("A")          # A.x points down, the chain hangs at q = 0
    P = me.Point("P"); P.set_vel(A, 0)
    particles, loads, kd, previous = [], [], [], P
    for i in range(n):
        Ai = A.orientnew(f"A{i}", "Axis", [q[i], A.z]); Ai.set_ang_vel(A, u[i] * A.z)
        Pi = previous.locatenew(f"P{i}", l[i] * Ai.x); Pi.v2pt_theory(previous, A, Ai)
        particles.append(me.Particle(f"Pa{i}", Pi, m[i])); loads.append((Pi, m[i] * g * A.x))
        kd.append(q[i].diff(t) - u[i]); previous = Pi
    kane = me.KanesMethod(A, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(particles, loads)
    M, F = kane.mass_matrix, kane.forcing
    f = sp.lambdify([list(q) + list(u), list(m) + list(l) + [g]], [M, F], cse=True)
    seconds = time.perf_counter() - t0
    qs, us = sp.symbols(f"x:{n}"), sp.symbols(f"v:{n}")
    plain = dict(zip(list(q) + list(u), list(qs) + list(us)))
    exprs = [e.xreplace(plain) for e in list(M) + list(F)]
    replacements, reduced = sp.cse(exprs)
    ops = int(sum(sp.count_ops(e) for _, e in replacements) + sum(sp.count_ops(e) for e in reduced))
    print(json.dumps({"seconds": seconds, "ops": ops}))
""")


def kane_cold(n: int) -> dict:
    """KanesMethod + lambdify in a fresh process: wall time, in-process time, ops after CSE."""
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-c", KANE, str(n)], capture_output=True, text=True, check=True,
                         env=_env())
    wall = time.perf_counter() - t0
    return {"wall": wall, **json.loads(run.stdout.splitlines()[-1])}


def kane_rhs(n: int):
    """Kane's rhs as a user of sympy.physics.mechanics would run it (in this process)."""
    namespace: dict = {}
    source = KANE.split("seconds = ")[0].replace("n = int(sys.argv[1])", f"n = {n}")
    exec(compile(source, "kane", "exec"), namespace)
    f = namespace["f"]

    def rhs(y, p):
        M, F = f(y, p)
        return np.concatenate([y[n:], np.linalg.solve(np.asarray(M, float), np.asarray(F, float).ravel())])
    return rhs


def derive_cold(model: Path, out: Path, *backends: str) -> float:
    """`derive generate FILE --out DIR [--backend B ...]` in a fresh process on an empty
    cache: wall time (every backend when none is named)."""
    with tempfile.TemporaryDirectory() as cache:
        env = _env(DERIVE_CACHE_DIR=cache, PYTHONPATH=str(ROOT))
        chosen = [arg for b in backends for arg in ("--backend", b)]
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "derive", "generate", str(model), "--out", str(out), *chosen],
                       check=True, env=env, capture_output=True)
        return time.perf_counter() - t0


def derive_ops(model: Path) -> int:
    """Operations of derive's rhs kernel (stages and outputs) after CSE."""
    import sympy as sp
    from derive.codegen.spec import model_spec
    from derive.derivation.derivation import derive
    rhs = next(k for k in model_spec(derive(str(model))).kernels if k.name == "rhs")
    exprs = [e for _, e in rhs.stages] + [e for out in rhs.outputs for e in out.exprs]
    replacements, reduced = sp.cse(exprs)
    return int(sum(sp.count_ops(e) for _, e in replacements) + sum(sp.count_ops(e) for e in reduced))


def per_call(f, *args, repeats: int = 5, number: int = 2000) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(number):
            f(*args)
        best = min(best, (time.perf_counter() - t0) / number)
    return best


def rhs_speed(n: int, model: Path) -> tuple[float, float, float]:
    """(derive s/call, Kane s/call, largest relative difference of the two rhs)."""
    import derive
    p, y = parameters(n), initial_state(n)
    ours = derive.scipy_rhs(str(model), list(p)).fun
    theirs = kane_rhs(n)
    a, b = np.asarray(ours(0.0, y)), theirs(y, p)
    diff = float(np.max(np.abs(a - b)) / np.max(np.abs(b)))
    return per_call(ours, 0.0, y), per_call(theirs, y, p), diff


TAYLOR = textwrap.dedent("""
    import sys, time, json
    import numpy as np
    import derive
    path, y0, p = sys.argv[1], json.loads(sys.argv[2]), json.loads(sys.argv[3])
    t0 = time.perf_counter()
    r = derive.simulate(path, y0, [0.0, 1.0], p, method="taylor", rtol=1e-14)
    print(json.dumps({"seconds": time.perf_counter() - t0, "ok": bool(r.ok), "y": [float(v) for v in r.y[-1]]}))
""")

HEYOKA = textwrap.dedent("""
    import sys, time, json
    import heyoka as hy
    n, y0, p = int(sys.argv[1]), json.loads(sys.argv[2]), json.loads(sys.argv[3])
    hy.llvm_state.set_diskcache_enabled(False)      # cold, as derive's run: no compiled code from a run before
    t0 = time.perf_counter()
    qs = hy.make_vars(*[f"q{i}" for i in range(n)]); vs = hy.make_vars(*[f"v{i}" for i in range(n)])
    m, l, g = [hy.par[i] for i in range(n)], [hy.par[n + i] for i in range(n)], hy.par[2 * n]
    x = y = xd = yd = hy.expression(0.0)
    T = V = hy.expression(0.0)
    for i in range(n):
        x, y = x + l[i] * hy.sin(qs[i]), y - l[i] * hy.cos(qs[i])
        xd, yd = xd + l[i] * hy.cos(qs[i]) * vs[i], yd + l[i] * hy.sin(qs[i]) * vs[i]
        T, V = T + m[i] * (xd * xd + yd * yd) / 2.0, V + m[i] * g * y
    sys_ = hy.lagrangian(T - V, qs, vs)
    ta = hy.taylor_adaptive(sys_, y0, pars=p, tol=1e-14)
    ta.propagate_until(1.0)
    print(json.dumps({"seconds": time.perf_counter() - t0, "y": [float(v) for v in ta.state]}))
""")


def _checked(cmd: list[str], env: dict | None = None) -> subprocess.CompletedProcess:
    """A run of cmd that succeeded; a failure ends the benchmark with its error output."""
    run = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"{cmd[0]} {cmd[1]} {cmd[2].strip()[:40]}... failed:\n{run.stderr[-3000:]}")
    return run


def taylor_first_runs(n: int, model: Path) -> tuple[float, float, float]:
    """(derive s, heyoka s, relative difference of the final states)."""
    y0, p = json.dumps(list(initial_state(n))), json.dumps(list(parameters(n)))
    with tempfile.TemporaryDirectory() as cache:
        env = _env(DERIVE_CACHE_DIR=cache, PYTHONPATH=str(ROOT))
        t0 = time.perf_counter()
        ours = _checked([sys.executable, "-c", TAYLOR, str(model), y0, p], env=env)
        ours_wall = time.perf_counter() - t0
    t0 = time.perf_counter()
    theirs = _checked([sys.executable, "-c", HEYOKA, str(n), y0, p], env=_env())
    theirs_wall = time.perf_counter() - t0
    a, b = (np.array(json.loads(r.stdout.splitlines()[-1])["y"]) for r in (ours, theirs))
    return ours_wall, theirs_wall, float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _load() -> str:
    return "/".join(f"{v:.2f}" for v in os.getloadavg())


def exponent(ns, seconds) -> float:
    """Least-squares slope of log(seconds) against log(n)."""
    return float(np.polyfit(np.log(ns), np.log(seconds), 1)[0])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--links", type=int, nargs="+", default=[3, 5, 8, 12])
    parser.add_argument("--taylor-links", type=int, nargs="*", default=[3, 5, 8])
    parser.add_argument("--repeat", type=int, default=3,
                        help="cold runs of each side per size (their median is printed)")
    parser.add_argument("--taylor-only", action="store_true",
                        help="only the first Taylor runs (no derive-vs-Kane rows)")
    args = parser.parse_args(argv)
    if args.taylor_only:
        args.links = []
    rows, ours_t, theirs_t = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if args.links:
            print(f"{'n':>3} {'derive+generate':>16} {'numpy only':>11} {'Kane+lambdify':>14} {'ratio':>12}   {'ops derive':>10} "
                  f"{'ops Kane+LU':>11}   {'rhs derive':>10} {'rhs Kane':>9} {'ratio':>6} {'agree':>8}")
        if args.links:          # the warm-up: each side's bytecode written (_env), not counted
            derive_cold(chain_file(3, folder), folder / "warm-up")
            kane_cold(3)
        for n in args.links:
            model = chain_file(n, folder)
            # each side args.repeat times, taken in turn (derive, numpy only, Kane, derive, ...)
            # so that a drift of the machine's speed falls on all three; the medians are printed
            runs = [(derive_cold(model, folder / f"gen{n}"), derive_cold(model, folder / f"numpy{n}", "numpy"),
                     kane_cold(n)) for _ in range(args.repeat)]
            ours = statistics.median(r[0] for r in runs)
            numpy_only = statistics.median(r[1] for r in runs)
            kane = dict(runs[0][2], wall=statistics.median(r[2]["wall"] for r in runs))
            ops = derive_ops(model)
            kane_ops = kane["ops"] + round(2 * n ** 3 / 3 + 2 * n ** 2)
            call, kane_call, diff = rhs_speed(n, model)
            ours_t.append(ours), theirs_t.append(kane["wall"])
            print(f"{n:3d} {ours:14.2f} s {numpy_only:9.2f} s {kane['wall']:12.2f} s "
                  f"{kane['wall'] / ours:5.2f}x/{kane['wall'] / numpy_only:4.2f}x   {ops:10d} "
                  f"{kane_ops:11d}   {call * 1e6:7.1f} us {kane_call * 1e6:6.1f} us {kane_call / call:5.2f}x "
                  f"{diff:8.1e}", flush=True)
            rows.append(n)
        if len(rows) > 1:
            print(f"growth: derive + generate ~ n^{exponent(rows, ours_t):.2f}, "
                  f"Kane + lambdify ~ n^{exponent(rows, theirs_t):.2f} (over n = {', '.join(map(str, rows))})")
        for n in args.taylor_links:
            model = chain_file(n, folder)
            ours, theirs, diff = taylor_first_runs(n, model)
            print(f"first Taylor run, {n} links (rtol 1e-14, t = 1, cold): derive {ours:.1f} s, heyoka build + JIT "
                  f"+ run {theirs:.1f} s, ratio {theirs / ours:.2f}x; final states agree to {diff:.1e} "
                  f"(load average {_load()})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
