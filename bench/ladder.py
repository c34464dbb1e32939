"""The precision ladder on the chaotic planar double pendulum: error against time, float to quad.

    python3 bench/ladder.py [--out bench/results]

The case of issue 16 (m = l = 1, g = 9.81, y0 = (2.5, 2, 0, 0)) to t = 20, on every
rung at its tightest tolerance: float and double (DOP853, Taylor), long double,
double-double and quad (Taylor), and heyoka beside them in double, long double and
real128 (Taylor, tol = eps of each).  Every run's error at t = 0, 0.5, ..., 20 is taken
against tests/data/chaotic_planar_reference.json (an mpmath Taylor integration at 60
digits, independent of derive: tests/oracles/make_chaotic_reference.py), and each derive
result states its trust horizon for 1e-8 (derive.trust_horizon(r): the early error, tolerance
or unit roundoff, grown by the motion's largest Lyapunov exponent).  Writes ladder.png
(error against t, a line per run, the horizons marked) and ladder.md (the table), and
prints both figures' numbers.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import mpmath
import numpy as np

import derive

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "data" / "chaotic_planar_reference.json"
TARGET = 1e-8

# (label, simulate keywords): each rung at its tightest tolerance
DERIVE_RUNS = [
    ("derive float (dop853)", {"method": "dop853", "rtol": 2e-6, "dtype": "float32"}),
    ("derive double (taylor)", {"method": "taylor", "rtol": 3e-15, "dtype": "float64"}),
    ("derive long double (taylor)", {"method": "taylor", "rtol": 2e-18, "dtype": "longdouble"}),
    ("derive double-double (taylor)", {"rtol": 1e-30, "dtype": "double-double"}),
    ("derive quad (taylor)", {"rtol": 2e-33, "dtype": "quad"}),
]


def reference():
    data = json.loads(REFERENCE.read_text())
    with mpmath.workdps(50):
        states = [[mpmath.mpf(v) for v in s] for s in data["states"]]
    return data, np.array(data["times"]), states


def errors(values, states) -> np.ndarray:
    """max-norm error at each output time (mpmath: below what long double resolves)."""
    out = []
    with mpmath.workdps(50):
        for row, ref in zip(values, states):
            vals = [mpmath.mpf(str(v)) if not isinstance(v, mpmath.mpf) else v for v in row]
            out.append(float(max(abs(a - b) for a, b in zip(vals, ref)))
                       if all(mpmath.isfinite(v) for v in vals) else math.inf)
    return np.array(out)


def derive_runs(data, times, states) -> list[dict]:
    runs = []
    for label, kw in DERIVE_RUNS:
        start = time.perf_counter()
        r = derive.simulate("planar", data["y0"], times, data["parameters"], **kw)
        seconds = time.perf_counter() - start
        values = r.y_exact if r.y_exact is not None else np.asarray(r.y, np.longdouble)
        err = errors([[str(v) for v in row] if r.y_exact is None else list(row) for row in values], states)
        runs.append({"label": label, "seconds": seconds, "errors": err, "horizon": derive.trust_horizon(r, TARGET),
                     "ok": r.ok, "setting": f"rtol {kw['rtol']:g}"})
    return runs


def heyoka_runs(data, times, states) -> list[dict]:
    import heyoka as hy
    from derive.measurement.race import heyoka_system
    runs = []
    q = hy.real128
    for label, fp, tol in (("heyoka double", float, 2.2e-16), ("heyoka long double", np.longdouble, 1.1e-19),
                           ("heyoka real128", q, "1e-33")):
        ta = hy.taylor_adaptive(heyoka_system(hy), np.array([fp(v) for v in data["y0"]]),
                                pars=np.array([fp(data["parameters"][k]) for k in ("m1", "m2", "l1", "l2", "g")]),
                                tol=fp(tol) if fp is not q else q(tol), fp_type=fp)
        start = time.perf_counter()
        out = ta.propagate_grid(np.array([fp(t) for t in times]))
        seconds = time.perf_counter() - start
        grid = out[-1] if isinstance(out, tuple) else out
        runs.append({"label": label, "seconds": seconds, "setting": f"tol {tol}",
                     "errors": errors([[str(v) for v in row] for row in grid], states), "horizon": None,
                     "ok": True})
    return runs


def last_good(times, err) -> float:
    """The last output time up to which the error stays at most TARGET."""
    bad = np.nonzero(~(err <= TARGET))[0]
    return float(times[-1] if bad.size == 0 else times[max(bad[0] - 1, 0)])


def table(runs, times) -> str:
    lines = ["| run | setting | wall time (t = 0..20, 41 outputs) | error at t = 10 | error at t = 20 | "
             "error <= 1e-8 until | trust horizon (1e-8) |", "|---|---|---|---|---|---|---|"]
    i10, i20 = int(np.argmin(abs(times - 10))), len(times) - 1
    for r in runs:
        horizon = "-" if r["horizon"] is None else ("beyond t = 20" if r["horizon"] > 1e6 else f"{r['horizon']:.1f}")
        lines.append(f"| {r['label']} | {r['setting']} | {r['seconds'] * 1e3:.3g} ms | {r['errors'][i10]:.1e} | "
                     f"{r['errors'][i20]:.1e} | {last_good(times, r['errors']):g} | {horizon} |")
    return "\n".join(lines) + "\n"


def plot(runs, times, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8.5, 5.2))
    for i, r in enumerate(runs):
        err = np.maximum(np.where(np.isfinite(r["errors"]), r["errors"], np.nan), 1e-40)
        heyoka = r["label"].startswith("heyoka")
        ax.semilogy(times[1:], err[1:], "s:" if heyoka else "o-", ms=3 if heyoka else 2.5,
                    color=f"C{i}", label=r["label"], alpha=0.8 if heyoka else 1.0)
        if r["horizon"] is not None and r["horizon"] < 25:
            ax.axvline(r["horizon"], color=f"C{i}", lw=0.8, ls="--")
    ax.axhline(TARGET, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("t")
    ax.set_ylabel("max-norm error against the 60-digit mpmath reference")
    ax.set_title("Chaotic planar double pendulum, y0 = (2.5, 2, 0, 0): each precision's error\n"
                 "(dashed: derive's trust horizon for 1e-8 at that precision)", fontsize=10)
    ax.set_ylim(1e-36, 1e2)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "bench" / "results"))
    args = ap.parse_args()
    data, times, states = reference()
    for _, kw in DERIVE_RUNS:                 # build every library first: no compile in the timings
        derive.simulate("planar", data["y0"], [0.0, 0.5], data["parameters"], **kw)
    runs = derive_runs(data, times, states) + heyoka_runs(data, times, states)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    text = table(runs, times)
    (out / "ladder.md").write_text("# The precision ladder: chaotic planar case to t = 20\n\n" + text)
    plot(runs, times, out / "ladder.png")
    print(text)
    print(f"wrote {out / 'ladder.md'} and {out / 'ladder.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
