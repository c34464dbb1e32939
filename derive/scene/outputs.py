"""Write what a scene asks for: trajectory (CSV, NPZ), plots (PNG), animation (GIF)."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from ..model import load_model
from ..model.atlas import find_atlas
from ..paths import replace_file
from .scene import SceneError
from .run import conservative
from ..progress import Stage


def _state_names(o) -> list[str]:
    if find_atlas(o.plan.model) is not None:         # rows in different charts
        return [f"y{k}" for k in range(o.result.y.shape[1])]
    return list(load_model(o.plan.model).state_names)


def _columns(o) -> tuple[list[str], np.ndarray]:
    r = o.result
    pos = np.asarray(o.positions, float)
    dim = pos.shape[-1]
    vel = np.asarray(o.velocities, float)
    bobs = pos.shape[1]
    names = (["t"] + _state_names(o) + [f"x{k}_{a}" for k in range(1, bobs + 1) for a in "xyz"[:dim]]
             + [f"v{k}_{a}" for k in range(1, bobs + 1) for a in "xyz"[:dim]] + ["energy"])
    data = np.column_stack([np.asarray(r.t, float), np.asarray(r.y, float),
                            pos.reshape(len(pos), -1), vel.reshape(len(vel), -1), np.asarray(o.energy, float)])
    return names, data


def _number_format(o):
    """How a CSV writes one number: to the precision of the run's type.  A float32 run's
    values are written as the shortest decimal that reads back as that float32 (0.1, not
    0.10000000149011612, its float64 value to 17 digits); any other run's to 17 digits."""
    if np.asarray(o.result.y).dtype == np.float32:
        return lambda v: str(np.float32(v))
    return lambda v: f"{v:.17g}"


def writable_dir(path: Path) -> Path:
    """Create `path` if needed and prove it writable (OSError otherwise), before long work."""
    path.mkdir(parents=True, exist_ok=True)
    # a probe of its own (not a fixed name): concurrent runs into one folder do not race
    fd, probe = tempfile.mkstemp(dir=path, prefix=".derive-write-test-")
    os.close(fd)
    os.unlink(probe)
    return path


def _replace(path: Path, write) -> None:
    """An output file, written atomically (a planted link is replaced, not followed)."""
    replace_file(path, write, mode=0o644)


def output_dir(o) -> Path:
    out = Path(o.scene.output_dir)
    try:
        return writable_dir(out)
    except OSError as exc:
        raise SceneError(f"'output.directory': cannot write to '{out}': {exc.strerror}") from None


def write_outputs(o) -> list[str]:
    wanted = o.scene.trajectory + o.scene.plots
    if not wanted:
        return []
    out = output_dir(o)
    stem = Path(o.scene.source).stem
    written = []
    names, data = _columns(o)
    if "csv" in o.scene.trajectory:
        path = out / f"{stem}.csv"
        header = ",".join(names)
        number = _number_format(o)
        if o.result.chart is not None or np.asarray(o.result.y).dtype == np.float32:
            charts = o.result.chart
            header += ",chart" if charts is not None else ""
            rows = [",".join(number(v) for v in row) + (f",{charts[i]}" if charts is not None else "")
                    for i, row in enumerate(data)]
            _replace(path, lambda tmp: tmp.write_text(header + "\n" + "\n".join(rows) + "\n"))
        else:
            _replace(path, lambda tmp: np.savetxt(tmp, data, delimiter=",", header=header, comments="",
                                                  fmt="%.17g"))
        written.append(str(path))
        if o.result.events is not None:
            written.append(_events_csv(o, out / f"{stem}_events.csv"))
    if "npz" in o.scene.trajectory:
        path = out / f"{stem}.npz"
        extra = {"chart": np.asarray(o.result.chart, dtype=str)} if o.result.chart is not None else {}
        arrays = dict(t=np.asarray(o.result.t, float), y=np.asarray(o.result.y, float),
                      positions=np.asarray(o.positions, float), velocities=np.asarray(o.velocities, float),
                      energy=np.asarray(o.energy, float),
                      state_names=np.array(_state_names(o)), **extra, **_event_arrays(o))
        _replace(path, lambda tmp: np.savez(tmp, **arrays))
        written.append(str(path))
    if o.scene.plots:
        written += _plots(o, out, stem)
    return written


def _events_csv(o, path: Path) -> str:
    """One row per crossing, in time order: event, t, direction, the state there."""
    rows = [(float(t), name, int(d), y) for name, e in o.result.events.items()
            for t, d, y in zip(e.t, e.direction, np.asarray(e.y, float))]
    rows.sort(key=lambda row: row[0] * (1 if o.result.t[-1] >= o.result.t[0] else -1))
    header = ",".join(["event", "t", "direction"] + _state_names(o))
    number = _number_format(o)
    lines = [f"{name},{number(t)},{d:+d}," + ",".join(number(v) for v in y) for t, name, d, y in rows]
    _replace(path, lambda tmp: tmp.write_text(header + "\n" + "".join(line + "\n" for line in lines)))
    return str(path)


def _event_arrays(o) -> dict:
    """NPZ arrays events_<name>_t, _y, _direction (SciPy's t_events, y_events by name)."""
    out = {}
    for name, e in (o.result.events or {}).items():
        out.update({f"events_{name}_t": np.asarray(e.t, float), f"events_{name}_y": np.asarray(e.y, float),
                    f"events_{name}_direction": np.asarray(e.direction, int)})
    return out


def _pyplot():
    try:
        import matplotlib    # the plot extra, imported when a figure is drawn
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt    # the plot extra, imported when a figure is drawn
    except ImportError:
        raise SceneError("'output.plots' needs matplotlib: pip install -e '.[plot]'") from None
    return plt


def _plots(o, out: Path, stem: str) -> list[str]:
    plt = _pyplot()
    pos = np.asarray(o.positions, float)
    horizontal = 0
    vertical = pos.shape[-1] - 1
    written = []
    for kind, figure in (("paths", paths_figure), ("energy", energy_figure)):
        if kind in o.scene.plots:
            fig = figure(plt, o)
            path = out / f"{stem}_{kind}.png"
            _replace(path, lambda tmp: fig.savefig(tmp, dpi=120, bbox_inches="tight"))
            plt.close(fig)
            written.append(str(path))
    if "animation" in o.scene.plots:
        with Stage("writing the animation", enabled=None if o.show_progress else False):
            gif = _animation(plt, o, pos, out, stem, horizontal, vertical)
            if gif is not None:
                written.append(gif)
    return written


# (horizontal axis, vertical axis, what the view is) of the paths plot: a planar pendulum in
# its plane; a spherical one from above and from the side (one view hides the other's motion)
VIEWS = {2: ((0, 1, None),), 3: ((0, 1, "from above (x-y)"), (0, 2, "from the side (x-z)"))}


def paths_figure(plt, o):
    """The bobs' paths with equal axes: one view of a planar run, two of a spherical one."""
    pos = np.asarray(o.positions, float)
    views = VIEWS[pos.shape[-1]]
    fig, axes = plt.subplots(1, len(views), figsize=(4.6 * len(views) + 0.4, 4.8), squeeze=False,
                             layout="constrained")
    for ax, (h, v, name) in zip(axes[0], views):
        for k in range(pos.shape[1]):
            ax.plot(pos[:, k, h], pos[:, k, v], lw=0.7, color=f"C{k}", label=f"bob {k + 1}")
        ax.plot([0], [0], "ko", ms=3)
        ax.set_aspect("equal")
        ax.set_xlabel("xyz"[h])
        ax.set_ylabel("xyz"[v])
        if name:
            ax.set_title(name, fontsize=8)
    axes[0][0].legend(fontsize=8)
    fig.suptitle(_plain(o.scene.title), fontsize=9)
    return fig


def energy_floor(dtype: str) -> float:
    """The unit roundoff of a run's precision: an energy error of 0 is "below rounding"."""
    return float(np.finfo({"float32": np.float32, "longdouble": np.longdouble}.get(dtype, np.float64)).eps) / 2


def energy_figure(plt, o):
    """|E - E0| / |E0| on a log axis that starts at the run's unit roundoff."""
    e = np.asarray(o.energy, float)
    fig, ax = plt.subplots(figsize=(6, 3))
    floor = energy_floor(o.choice.dtype)
    with np.errstate(invalid="ignore"):          # NaN after a run's stop stays NaN (not drawn)
        rel = np.maximum(np.abs(e - e[0]) / max(abs(e[0]), 1e-300), floor)
    ax.semilogy(o.result.t.astype(float), rel)
    top = float(np.nanmax(rel)) if np.isfinite(rel).any() else floor
    ax.set_ylim(floor, max(top * 10, floor * 100))     # a constant energy: a decade above the floor
    ax.set_xlabel("t")
    ax.set_ylabel("|E - E0| / |E0|")
    what = "energy error" if conservative(o) else "energy change (work of forces and damping)"
    ax.set_title(f"{_plain(o.scene.title)}: {what} ({o.choice.method}, {o.choice.dtype})", fontsize=9)
    return fig


def _plain(text: str) -> str:
    """A title as text: matplotlib would read $...$ as mathematics (and fail on a lone $)."""
    return text.replace("$", r"\$")


def _animation(plt, o, pos, out, stem, horizontal, vertical) -> str | None:
    from matplotlib.animation import PillowWriter    # the plot extra, imported when a figure is drawn
    made = animation_figure(plt, o, horizontal, vertical)
    if made is None:
        return None
    fig, anim = made
    path = out / f"{stem}.gif"
    _replace(path, lambda tmp: anim.save(tmp, writer=PillowWriter(fps=25)))
    plt.close(fig)
    return str(path)


def animation_figure(plt, o, horizontal: int = 0, vertical: int | None = None):
    """(figure, FuncAnimation) of the chain moving, titled, with a time stamp in each frame;
    None for a run with no state to show (it failed at its start)."""
    from matplotlib.animation import FuncAnimation    # the plot extra, imported when a figure is drawn
    pos = np.asarray(o.positions, float)
    vertical = pos.shape[-1] - 1 if vertical is None else vertical
    # only the part of the run that has a state (a run that stopped is NaN after its stop)
    alive = int(np.argmin(np.isfinite(pos).all(axis=(1, 2)))) if not np.isfinite(pos).all() else len(pos)
    if alive == 0:
        return None
    t = np.asarray(o.result.t, float)
    frames = np.linspace(0, alive - 1, min(alive, 150)).astype(int)
    scale = float(np.max(np.abs(pos[:alive]))) or 1.0        # scaled: |x| near 1e300 does not overflow
    reach = scale * float(np.max(np.linalg.norm(pos[:alive] / scale, axis=-1))) * 1.05
    fig, ax = plt.subplots(figsize=(4, 4.3), layout="constrained")
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_aspect("equal")
    ax.set_xlabel("xyz"[horizontal])
    ax.set_ylabel("xyz"[vertical])
    ax.set_title(_plain(o.scene.title), fontsize=9)
    line, = ax.plot([], [], "o-", lw=2, color="tab:blue")
    trail, = ax.plot([], [], lw=0.6, color="tab:red")
    stamp = ax.text(0.02, 0.96, "", transform=ax.transAxes, fontsize=8, va="top")

    def draw(i):
        k = frames[i]
        line.set_data([0, *pos[k, :, horizontal]], [0, *pos[k, :, vertical]])     # the whole chain
        trail.set_data(pos[:k + 1, -1, horizontal], pos[:k + 1, -1, vertical])    # its last bob
        stamp.set_text(f"t = {t[k]:.2f}")
        return line, trail, stamp

    draw(0)                                  # the first frame as the figure (and for a still)
    return fig, FuncAnimation(fig, draw, frames=len(frames), blit=True)
