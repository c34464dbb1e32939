"""What `derive bench` writes and prints: bench.csv, throughput.csv, summary.md (with the
plots of plots.py) and the console report."""
from __future__ import annotations

import csv
import math
from pathlib import Path

from .analysis import QUOTED_FIGURES, QUOTED_LAMBDIFY, QUOTED_THROUGHPUT, best_toolkit, series_times, targets
from .peer_series import IVP_CSE, IVP_DEFAULT
from .plots import write_plots
from .problems import BenchOptions
from .suite import BenchResult
from ...paths import BENCH_OUT

DEFAULT_OUT = BENCH_OUT          # `derive bench` writes here (its home: derive/paths.py, for the CLI's help)
CSV_COLUMNS = ("problem", "model", "kind", "series", "method", "backend", "dtype", "rtol", "step",
               "status", "final_error", "energy_error", "seconds", "cpu_seconds", "repeats", "nfev", "overhead",
               "e0", "horizon_target", "horizon_resolve", "note")
THROUGHPUT_COLUMNS = ("path", "batch", "threads", "steps", "rate", "repeats", "note")
HORIZON_RTOLS = (1e-3, 1e-5, 1e-8, 1e-11, 1e-13, 1e-16)


# -- CSV -----------------------------------------------------------------------------

def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.6g}"
    return str(v)


def _write_table(rows: list[dict], columns: tuple[str, ...], path: Path) -> Path:
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for r in rows:
            w.writerow([_fmt(r.get(c)) for c in columns])
    return path


def write_csv(result: BenchResult, path: Path) -> Path:
    """bench.csv: one line a configuration, the columns CSV_COLUMNS."""
    return _write_table(result.rows, CSV_COLUMNS, path)


def write_throughput_csv(result: BenchResult, path: Path) -> Path:
    """throughput.csv: one line a batched path and batch size."""
    return _write_table(result.throughput, THROUGHPUT_COLUMNS, path)


def write_all(result: BenchResult, out: Path, plots: bool = True) -> list[Path]:
    """Write bench.csv, throughput.csv (if measured), the plots (if asked) and summary.md.

    Parameters
    ----------
    result : BenchResult
    out : Path
        The folder (made if missing).
    plots : bool
        Draw the work-precision plots (needs matplotlib; the summary says when it is missing).

    Returns
    -------
    list of Path
        The files written.
    """
    out.mkdir(parents=True, exist_ok=True)
    files = [write_csv(result, out / "bench.csv")]
    if result.throughput:
        files.append(write_throughput_csv(result, out / "throughput.csv"))
    pngs = write_plots(result, out) if plots else []
    files += pngs
    md = out / "summary.md"
    md.write_text(summary_markdown(result, pngs))
    files.append(md)
    return files


# -- summary.md ----------------------------------------------------------------------

def _ms(t) -> str:
    return "not reached" if t is None else f"{t * 1e3:.3g}"


def _h(t: float, bare: bool = False) -> str:
    if math.isinf(t):
        return "inf"
    return f"{t:.3g}" if bare else f"t = {t:.3g}"


def _header(result: BenchResult, opts: BenchOptions) -> list[str]:
    m = result.machine
    lines = ["# Work-precision benchmark", "",
             f"Measured on {m.get('date')} on {m.get('cpu')} ({m.get('nproc')} cores), {m.get('platform')}; "
             f"Python {m.get('python')}, NumPy {m.get('numpy')}, SciPy {m.get('scipy')}, numba {m.get('numba')}, "
             f"SymPy {m.get('sympy')}; {m.get('compiler')}.  Load average when the run started: "
             f"{m.get('loadavg')} (the machine may be shared: timings are medians of repeats).",
             "", f"Command: `derive bench{' --quick' if opts.quick else ''} --repeats {opts.repeats}` "
             f"({result.seconds:.0f} s).  Every row of `bench.csv`: final-state error against the reference, "
             "largest relative energy error over 41 output times (peers: at t_end; relative to max(|E0|, m g l), "
             "m g l the potential well's depth), median wall time, "
             "rhs evaluations, trust horizons.  Timings call the compiled integrators directly.", ""]
    for n in result.notes:
        lines.append(f"- Note: {n}")
    if result.notes:
        lines.append("")
    return lines


def _problems_section(result: BenchResult, opts: BenchOptions) -> list[str]:
    lines = ["## Problems, references and trust horizons", "",
             "| problem | model | t_end | largest Lyapunov exponent | e^(lambda t_end) | reference | "
             "stated accuracy | reference horizon (to 1e-10) |",
             "|---|---|---|---|---|---|---|---|"]
    for name, info in result.infos.items():
        lam = info.lyapunov.exponent
        lines.append(f"| {name} | {info.problem.model} | {info.problem.t_end:g} | {lam:.3g} "
                     f"({'variational' if 'variational' in info.lyapunov.method else 'finite difference'}) | "
                     f"{math.exp(max(lam, 0) * info.problem.t_end):.3g} | {info.reference.method} | "
                     f"{info.reference.accuracy:.2g} ({info.reference.check}) | "
                     f"{'covers' if info.reference_horizon >= info.problem.t_end else 'DOES NOT cover'} "
                     f"t_end ({_h(info.reference_horizon)}) |")
    for name, info in result.infos.items():
        if info.mpmath_error is not None:
            lines += ["", f"Independent check of the {name} reference: long double DOP853 against mpmath's "
                          f"Taylor solver (24 digits) at t = {info.mpmath_t:g}: difference {info.mpmath_error:.2g}."]
    lines += ["", f"A run's trust horizon is where its predicted error e0 exp(lambda t) reaches the target "
                  f"{opts.target:g} (e0: rtol or the per-step error of a fixed step, at least the unit roundoff, "
                  f"times the state's size).  Where the prediction reaches {opts.resolve:g} of the state's size "
                  "before t_end the run has decorrelated from the true trajectory: it is listed as `beyond "
                  "trust horizon` and its final state is not compared.", ""]
    return lines + _horizon_table(result, opts)


def _horizon_table(result: BenchResult, opts: BenchOptions) -> list[str]:
    """Trust horizons of the C dop853 runs: per problem and precision, at a few tolerances,
    `to the target / to resolve the trajectory`."""
    cells: dict[tuple[str, str], dict[float, str]] = {}
    runs = [r for r in result.rows if r["kind"] == "toolkit" and r["method"] == "dop853" and
            r["backend"] == "c" and r.get("horizon_target") is not None]
    wanted = set(HORIZON_RTOLS) & {r["rtol"] for r in runs} or {r["rtol"] for r in runs}
    for r in runs:
        if r["rtol"] in wanted:
            cells.setdefault((r["problem"], r["dtype"]), {})[r["rtol"]] = \
                f"{_h(r['horizon_target'], bare=True)} / {_h(r['horizon_resolve'], bare=True)}"
    if not cells:
        return []
    rtols = sorted(wanted, reverse=True)
    lines = [f"Trust horizons of dop853 (C) runs, `to {opts.target:g} / to resolve` (time units):", "",
             "| problem | scalar | " + " | ".join(f"rtol {t:.0e}" for t in rtols) + " |",
             "|---|---|" + "---|" * len(rtols)]
    for (prob, dtype), c in cells.items():
        lines.append(f"| {prob} | {dtype} | " + " | ".join(c.get(t, "") for t in rtols) + " |")
    return lines


def _missing(series: str, v: dict) -> str:
    extra = list(v["notes"])
    if v["beyond"]:
        extra.append(f"{v['beyond']} of {v['runs']} runs beyond the trust horizon")
    if v["failed"]:
        extra.append(f"{v['failed']} failed")
    return series + (f" ({'; '.join(extra)})" if extra else "")


def _time_to_target_section(result: BenchResult, opts: BenchOptions, times: dict) -> list[str]:
    lines = ["", f"## Time to reach a final-state error of {opts.target:g}", "",
             "Interpolated (log-log) on each series' work-precision front; ratio = the series' time over the "
             "best toolkit method's.  Toolkit series are `method backend scalar`.", ""]
    for name in result.infos:
        best = best_toolkit(times, name)
        lines += [f"### {name}", ""]
        if best:
            lines.append(f"Best toolkit method: **{best[0]}**, {_ms(best[1]['time'])} ms.")
            lines.append("")
        lines += ["| kind | series | time to 1e-8 (ms, wall) | (ms, CPU) | x best toolkit | "
                  "runs compared / beyond horizon / failed |", "|---|---|---|---|---|---|"]
        entries = sorted(((s, v) for (p, s), v in times.items() if p == name and v["time"] is not None),
                         key=lambda kv: kv[1]["time"])
        for s, v in entries:
            ratio = "" if best is None else f"{v['time'] / best[1]['time']:.1f}"
            lines.append(f"| {v['kind']} | {s} | {_ms(v['time'])} | {_ms(v['cpu'])} | {ratio} | "
                         f"{v['compared']} / {v['beyond']} / {v['failed']} |")
        missing = sorted(((s, v) for (p, s), v in times.items() if p == name and v["time"] is None),
                         key=lambda kv: (kv[1]["kind"], kv[0]))
        if missing:
            lines += ["", f"Not reaching {opts.target:g} within their sweep (or only past their trust "
                      "horizon): " + "; ".join(_missing(s, v) for s, v in missing) + "."]
        lines.append("")
    return lines


def _targets_section(result: BenchResult, times: dict) -> list[str]:
    lines = ["## Targets", "", "| what | target | measured | met |", "|---|---|---|---|"]
    for t in targets(result):
        lines.append(f"| {t['what']} | {t['target']} | {t['measured']} | {'yes' if t['met'] else '**no**'} |")
    lines += _quoted_table(result, times)
    lines += ["", "Overhead = CPU time of the run / (rhs evaluations x CPU time of one generated C rhs "
              "evaluation, double, timed in a C loop over the states each problem visits, each "
              "evaluation waiting for the one before as in an integrator, median; derive/measurement/c/rhs_cost.c): "
              + ", ".join(f"{k} {v:.1f} ns" for k, v in result.rhs_ns.items()) + ".  Evaluations that "
              "do not wait for each other (the CPU overlaps them): "
              + ", ".join(f"{k} {v:.1f} ns" for k, v in result.rhs_ns_independent.items()) + "."]
    return lines


def _quoted_table(result: BenchResult, times: dict) -> list[str]:
    rows = [(p, peer, fig, times.get((p, peer))) for (p, peer), fig in QUOTED_FIGURES.items()
            if p in result.infos]
    if not rows:
        return []
    lines = ["", "Peer figures quoted in the issue beside this run's (time to 1e-8, ms), and the best toolkit "
                 "method's speed-up against each:", "",
             "| problem | peer | issue | this run | best toolkit vs issue figure | vs this run |",
             "|---|---|---|---|---|---|"]
    for p, peer, fig, v in rows:
        best = best_toolkit(times, p)
        here = v["time"] if v else None
        b = best[1]["time"] if best else None
        lines.append(f"| {p} | {peer} | {fig * 1e3:.3g} | {_ms(here)} | "
                     f"{'' if not b else f'{fig / b:.0f}x'} | {'' if not (b and here) else f'{here / b:.0f}x'} |")
    lines += _closest_lambdify(times, result)
    lines.append("")
    lines.append("Throughput peers quoted in the issue (trajectory-steps/s): "
                 + ", ".join(f"{k} {v:.2g}" for k, v in QUOTED_THROUGHPUT) + ".")
    return lines


def _closest_lambdify(times: dict, result: BenchResult) -> list[str]:
    """Which lambdify variant of this run is closer to the quoted lambdify figure (log ratio)."""
    out = []
    for prob, fig in QUOTED_LAMBDIFY.items():
        if prob not in result.infos:
            continue
        here = {s: (times.get((prob, s)) or {}).get("time") for s in (IVP_DEFAULT, IVP_CSE)}
        here = {s: t for s, t in here.items() if t}
        if not here:
            continue
        close = min(here, key=lambda s: abs(math.log(here[s] / fig)))
        out.append(f"{prob}: the issue's {fig * 1e3:.3g} ms for `solve_ivp DOP853 + lambdify` is closest to "
                   f"this run's `{close}` ({here[close] * 1e3:.3g} ms, the issue's figure {fig / here[close]:.2g}x it"
                   + "".join(f"; `{s}` {t * 1e3:.3g} ms" for s, t in here.items() if s != close) + ").")
    if out:
        out = ["", "The issue does not say how its lambdify peer was built; plain `sympy.lambdify` (the default, "
                   "cse=False) is what a user gets without asking, cse=True is the stronger peer.  Both are "
                   "measured and both are in the targets."] + [""] + [f"- {x}" for x in out]
    return out


def _throughput_section(result: BenchResult) -> list[str]:
    if not result.throughput:
        return []
    lines = ["", "## Throughput: batched fixed-step RK4, planar", "",
             "| path | trajectories | threads | steps | trajectory-steps/s | note |", "|---|---|---|---|---|---|"]
    for r in sorted(result.throughput, key=lambda r: -(r["rate"] if r["rate"] == r["rate"] else 0)):
        lines.append(f"| {r['path']} | {r['batch']:,} | {r['threads']} | {r['steps']} | {r['rate']:.3g} | "
                     f"{r['note']} |")
    if result.numpy_trig:
        t = result.numpy_trig
        lines += ["", f"NumPy float64 per element here (best of 50, 10,000 angles): sin {t['sin']:.2g} ns, "
                      f"cos {t['cos']:.2g} ns, tan {t['tan']:.2g} ns.  The generated NumPy code takes each "
                      "sin/cos pair from one tangent of the half angle and five array operations "
                      "(derive/codegen/emit.py, half_angle_sincos); the hand-written peer calls sin and cos."]
    a = result.agreement
    if a:
        lines += ["", f"Agreement with the scalar generated RK4 over {a['n']:,} random states, {a['steps']} "
                      f"steps (t = {a['t']:g}): C batch max difference {a['c_max']:.2g} ({a['c_over']} "
                      f"above 1e-12), NumPy batch {a['numpy_max']:.2g} ({a['numpy_over']} above 1e-12)."]
    return lines


def summary_markdown(result: BenchResult, plots: list[Path] | None = None) -> str:
    """summary.md: the machine, the problems and their references, each series' time to the
    target, the targets, the throughput and the plots.

    Parameters
    ----------
    result : BenchResult
    plots : list of Path, optional
        The plots to show (beside summary.md).

    Returns
    -------
    str
        Markdown.
    """
    opts = result.options or BenchOptions()
    times = series_times(result.rows, opts.target)
    lines = _header(result, opts) + _problems_section(result, opts)
    lines += _time_to_target_section(result, opts, times)
    lines += _targets_section(result, times)
    lines += _throughput_section(result)
    if plots:
        lines += ["", "## Work-precision plots", ""]
        for p in plots:
            lines.append(f"![{p.stem}]({p.name})")
    return "\n".join(lines) + "\n"


# -- the console ---------------------------------------------------------------------

def console_report(result: BenchResult) -> str:
    """What `derive bench` prints: time to target per problem with ratios, targets, throughput."""
    opts = result.options or BenchOptions()
    times = series_times(result.rows, opts.target)
    lines = []
    for n in result.notes:
        lines.append(f"note: {n}")
    for name, info in result.infos.items():
        best = best_toolkit(times, name)
        lines.append(f"{name}: lambda {info.lyapunov.exponent:.3g}, reference accuracy "
                     f"{info.reference.accuracy:.2g}; time to {opts.target:g}:")
        entries = sorted(((s, v) for (p, s), v in times.items() if p == name and v["time"] is not None),
                         key=lambda kv: kv[1]["time"])
        for s, v in entries:
            ratio = "" if best is None else f"  {v['time'] / best[1]['time']:7.1f}x best"
            lines.append(f"  {v['kind']:7s} {s:45s} {_ms(v['time']):>9s} ms{ratio}")
        missing = sorted(s for (p, s), v in times.items() if p == name and v["time"] is None)
        if missing:
            lines.append(f"  not reached: {', '.join(missing)}")
    lines.append("targets:")
    for t in targets(result):
        lines.append(f"  [{'met' if t['met'] else 'NOT met'}] {t['what']}: {t['measured']} (target {t['target']})")
    for r in result.throughput:
        lines.append(f"throughput {r['path']}: {r['rate']:.3g} trajectory-steps/s "
                     f"(B = {r['batch']:,}, {r['threads']} threads)")
    lines.append(f"bench finished in {result.seconds:.0f} s")
    return "\n".join(lines)
