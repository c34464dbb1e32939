"""The work-precision plots: final-state error against wall time, one figure a problem,
toolkit series coloured by method and styled by backend and precision, peers dashed."""
from __future__ import annotations

from pathlib import Path

from .problems import TARGET
from .suite import BenchResult

METHOD_COLOR = {"rk4": "tab:blue", "dopri5": "tab:orange", "dop853": "tab:green", "midpoint": "tab:purple",
                "gauss2": "tab:brown", "rk8": "tab:cyan"}
DTYPE_STYLE = {"float64": "-", "float32": ":", "longdouble": "-."}


def rows_kind(rows, series) -> str:
    """The kind (toolkit or peer) of a series among rows."""
    return next(r["kind"] for r in rows if r["series"] == series)


def _toolkit_style(series: str) -> dict:
    method, backend, dtype = series.split()
    return dict(ls=DTYPE_STYLE[dtype] if backend == "C" else "-",
                marker={"C": "o", "NumPy": "^", "C-loop": "D"}[backend],
                color=METHOD_COLOR.get(method, "gray"),
                lw=2.0 if dtype == "float64" and backend != "NumPy" else 1.0,
                alpha=0.6 if backend == "NumPy" else 1.0)


def _draw_series(ax, plt, rows: list[dict]) -> None:
    series = sorted({r["series"] for r in rows}, key=lambda s: (rows_kind(rows, s) != "toolkit", s))
    peer_colors = plt.get_cmap("Set1")
    peers_seen = 0
    for s in series:
        pts = sorted((r["seconds"], max(r["final_error"], 1e-17)) for r in rows if r["series"] == s)
        if rows_kind(rows, s) == "peer":
            color = "black" if s.startswith("hand-written C") else peer_colors(peers_seen % 9)
            peers_seen += 1
            style = dict(ls="--", marker="s", color=color, lw=1.2)
            label = "peer: " + s
        else:
            style, label = _toolkit_style(s), s
        ax.loglog([t * 1e3 for t, _ in pts], [e for _, e in pts], ms=3.5, label=label, **style)


def _plot_problem(plt, result: BenchResult, name: str, info, rows: list[dict], target: float, out: Path) -> Path:
    fig, ax = plt.subplots(figsize=(11, 6.5))
    _draw_series(ax, plt, rows)
    ax.axhline(target, color="gray", lw=0.8)
    ax.axhline(max(info.reference.accuracy, 1e-17), color="gray", lw=0.5, ls=":")
    ax.set_xlabel("wall time per run (ms, median)")
    ax.set_ylabel("final-state error (max norm) vs long double reference")
    ax.set_title(f"{info.problem.title}\n(lambda = {info.lyapunov.exponent:.3g}; runs beyond their "
                 "trust horizon are not shown)", fontsize=9)
    ax.legend(fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(True, which="both", lw=0.3)
    ax.text(0.99, 0.01, f"{result.machine.get('cpu', '')}, {result.machine.get('nproc', '')} cores, "
            f"{result.machine.get('date', '')}", transform=ax.transAxes, ha="right", va="bottom", fontsize=6,
            color="gray")
    fig.tight_layout()
    path = out / f"work_precision_{name}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_plots(result: BenchResult, out: Path) -> list[Path]:
    """One log-log work-precision plot (error against time) per problem; needs matplotlib.

    Parameters
    ----------
    result : BenchResult
    out : Path
        The folder of the figures, work_precision_<problem>.png.

    Returns
    -------
    list of Path
        The figures written; none without matplotlib (a note of the result says so).
    """
    try:
        import matplotlib    # the plot extra, imported when a figure is drawn
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt    # the plot extra, imported when a figure is drawn
    except ImportError:
        result.notes.append("matplotlib not installed: no plots (pip install derive[plot])")
        return []
    paths = []
    target = result.options.target if result.options else TARGET
    for name, info in result.infos.items():
        rows = [r for r in result.rows if r["problem"] == name and r.get("status") == "ok"
                and r.get("final_error") is not None and r.get("seconds")]
        if rows:
            paths.append(_plot_problem(plt, result, name, info, rows, target, out))
    return paths
