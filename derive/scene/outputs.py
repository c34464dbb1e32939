"""Write what a scene asks for: trajectory (CSV, NPZ), plots (PNG), animation (GIF)."""
from __future__ import annotations

import textwrap
import time
from pathlib import Path

import numpy as np

from ..derivation import derive
from ..derivation.lagrange import tree_geometry
from ..derivation.symbols import t as time_symbol
from ..model import load_model
from ..model.description import in_words
from ..model.atlas import find_atlas
from ..paths import replace_file, writable_dir
from ..runtime.simulate import normalise_params
from ..runtime.energy_error import relative_change
from ..runtime.power import gauss_converged, power_functions, trapezoid
from .stepped import run_inputs
from .scene import UNITS, SceneError
from .run import SCALE_TEXT, conservative, energy_error
from ..progress import Stage

def unit(o, quantity: str) -> str:
    """The unit the plots give a time, length or energy of a run: SI unless the scene's
    output.units says its numbers are in model units (scene.UNITS).

    Parameters
    ----------
    o : Outcome
        A scene's run.
    quantity : str
        "time", "length" or "energy".

    Returns
    -------
    str
    """
    return UNITS[o.scene.units][quantity]


def _time_label(o) -> str:
    return f"t ({unit(o, 'time')})"


def state_columns(model: str) -> list[str]:
    """The names of a model's state columns.  An atlas's rows are in different charts
    (the chart column says which): a column is named by its entry in every member chart,
    joined by "_or_" where they differ (theta1_or_vartheta1, ...).

    Parameters
    ----------
    model : str
        A model or an atlas.

    Returns
    -------
    list of str
    """
    atlas = find_atlas(model)
    if atlas is None:
        return list(load_model(model).state_names)
    per_chart = [load_model(chart).state_names for chart in atlas.charts]
    return ["_or_".join(dict.fromkeys(names)) for names in zip(*per_chart)]


def _state_names(o) -> list[str]:
    return state_columns(o.plan.model)


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


def _replace(path: Path, write) -> None:
    """An output file, written atomically (a planted link is replaced, not followed)."""
    replace_file(path, write, mode=0o644)


def output_dir(o) -> Path:
    out = Path(o.scene.output_dir)
    try:
        return writable_dir(out)
    except OSError as exc:
        raise SceneError(f"'output.directory': cannot write to '{out}': {exc.strerror}") from None


def _clock() -> tuple[float, float]:
    """(wall, CPU) seconds now: what writing a file took, and what of it was its own work."""
    return time.perf_counter(), time.process_time()


def _noted(o, path: Path | str, start: tuple[float, float], what: str = "") -> str:
    """Record what writing `path` took since `start` (:func:`_clock`), the summary prints it
    beside the file's name: the wall time a user waits and the CPU time that is the file's
    own cost (on a busy machine the two differ); returns the path as text."""
    wall, cpu = (now - then for now, then in zip(_clock(), start))
    cost = f"{cpu:.1f} s of CPU in {wall:.1f} s"
    o.file_notes[str(path)] = f"{what}, {cost}" if what else cost
    return str(path)


def write_outputs(o) -> list[str]:
    """Write the trajectory, plots and animation a scene asks for into its output folder.

    Parameters
    ----------
    o : Outcome
        A scene's run (derive.scene.run.run); ``o.file_notes`` gets what each file took.

    Returns
    -------
    list of str
        The files written.
    """
    wanted = o.scene.trajectory + o.scene.plots
    if not wanted:
        return []
    out = output_dir(o)
    stem = Path(o.scene.source).stem
    written = []
    names, data = _columns(o)
    start = _clock()
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
        written.append(_noted(o, path, start))
        if o.result.events is not None:
            start = _clock()
            written.append(_noted(o, _events_csv(o, out / f"{stem}_events.csv"), start))
    if "npz" in o.scene.trajectory:
        start = _clock()
        path = out / f"{stem}.npz"
        extra = {"chart": np.asarray(o.result.chart, dtype=str)} if o.result.chart is not None else {}
        arrays = dict(t=np.asarray(o.result.t, float), y=np.asarray(o.result.y, float),
                      positions=np.asarray(o.positions, float), velocities=np.asarray(o.velocities, float),
                      energy=np.asarray(o.energy, float),
                      state_names=np.array(_state_names(o)), **extra, **_event_arrays(o))
        _replace(path, lambda tmp: np.savez(tmp, **arrays))
        written.append(_noted(o, path, start))
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
        raise SceneError("'output.plots' needs matplotlib (derive's 'plot' extra): "
                         "pip install 'matplotlib>=3.7'") from None
    return plt


def _plots(o, out: Path, stem: str) -> list[str]:
    plt = _pyplot()
    pos = np.asarray(o.positions, float)
    horizontal = 0
    vertical = pos.shape[-1] - 1
    written = []
    for kind, figure in (("paths", paths_figure), ("energy", energy_figure)):
        if kind in o.scene.plots:
            start = _clock()
            fig = figure(plt, o)
            path = out / f"{stem}_{kind}.png"
            _replace(path, lambda tmp: fig.savefig(tmp, dpi=120))
            plt.close(fig)
            written.append(_noted(o, path, start))
    if "animation" in o.scene.plots:
        start = _clock()
        with Stage("writing the animation", enabled=None if o.show_progress else False):
            gif = _animation(plt, o, pos, out, stem, horizontal, vertical)
        if gif is not None:
            path, frames = gif
            written.append(_noted(o, path, start, f"{frames} frames at {FPS}/s"))
    return written


def fit_title(fig, set_title, text: str):
    """Set a title broken into lines that fit the figure's width: a layout engine makes
    room for a title's height, not for its width (a long line would be cut off).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    set_title : callable
        Sets the text (``ax.set_title``, ``fig.suptitle``) and returns the artist.
    text : str
        The title, as text ($ is no mathematics).

    Returns
    -------
    matplotlib.text.Text
    """
    text, chars = _plain(text), max(len(text), 1)
    while True:
        artist = set_title("\n".join(textwrap.wrap(text, chars)) or " ")
        fig.canvas.draw()                    # the layout places it: where it lands is known now
        box = artist.get_window_extent()
        if chars <= 16 or (box.x0 >= 0 and box.x1 <= fig.bbox.width):
            return artist
        chars = int(chars * 0.85)


def _axis_label(o, axis: int) -> str:
    return f"{'xyz'[axis]} ({unit(o, 'length')})"


# (horizontal axis, vertical axis, what the view is) of the paths plot: a planar pendulum in
# its plane; a spherical one from above and from the side (one view hides the other's motion)
VIEWS = {2: ((0, 1, None),), 3: ((0, 1, "from above (x-y)"), (0, 2, "from the side (x-z)"))}


PANEL_WIDTH = 4.6          # inches of one view of the paths plot
PANEL_MARGIN = 0.9         # inches of it left of the data: tick labels, axis name
PANEL_HEIGHTS = (2.2, 5.0)  # inches of its data area, at least and at most
PANEL_FRAME = 1.0          # inches above and below the data area: title, tick labels, axis name


def _paths_height(pos: np.ndarray, views) -> float:
    """The paths figure's height for its widest view's data to fill the width at equal axes
    (a figure of fixed shape left a wide path, a swing, in a band of empty space)."""
    finite = pos[np.isfinite(pos).all(axis=(1, 2))]
    ratios = []
    for h, v, _ in views:
        span = [max(np.ptp(np.append(finite[:, :, a], 0.0)), 1e-300) if len(finite) else 1.0 for a in (h, v)]
        ratios.append(span[1] / span[0])
    data = min(max((PANEL_WIDTH - PANEL_MARGIN) * max(ratios), PANEL_HEIGHTS[0]), PANEL_HEIGHTS[1])
    return data + PANEL_FRAME


def paths_figure(plt, o):
    """The bobs' paths with equal axes: one view of a planar run, two of a spherical one,
    the figure as tall as the paths need."""
    pos = np.asarray(o.positions, float)
    views = VIEWS[pos.shape[-1]]
    fig, axes = plt.subplots(1, len(views), figsize=(PANEL_WIDTH * len(views) + 0.4, _paths_height(pos, views)),
                             squeeze=False, layout="constrained")
    for ax, (h, v, name) in zip(axes[0], views):
        for k in range(pos.shape[1]):
            ax.plot(pos[:, k, h], pos[:, k, v], lw=0.7, color=f"C{k}", label=f"bob {k + 1}")
        ax.plot([0], [0], "ko", ms=3)
        ax.set_aspect("equal")
        ax.set_xlabel(_axis_label(o, h))
        ax.set_ylabel(_axis_label(o, v))
        if name:
            ax.set_title(name, fontsize=8)
    axes[0][0].legend(fontsize=8)
    fit_title(fig, lambda text: fig.suptitle(text, fontsize=9), o.scene.title)
    return fig


def energy_floor(dtype: str) -> float:
    """The unit roundoff of a run's precision: an energy error of 0 is "below rounding"."""
    return float(np.finfo({"float32": np.float32, "longdouble": np.longdouble}.get(dtype, np.float64)).eps) / 2


def energy_figure(plt, o):
    """What the energy says about the run.  Conservative: |E - E0| / max(|E0|, m g l) (the
    scale of the run's relative energy error, derive/model/energy_scale.py), the energy
    error, on a log axis that starts at the run's unit roundoff.  Driven or damped (the
    energy is not conserved): the energy balance, E - E0 against the work W of the applied
    forces minus the energy D dissipated, in J (or model units), and what is left of it."""
    if not conservative(o):
        return energy_balance_figure(plt, o)
    e = np.asarray(o.energy, float)
    fig, ax = plt.subplots(figsize=(6, 3), layout="constrained")
    floor = energy_floor(o.choice.dtype)
    scale = energy_error(o)[1]
    with np.errstate(invalid="ignore"):          # NaN after a run's stop stays NaN (not drawn)
        rel = np.maximum(relative_change(e, e[0], scale), floor)
    ax.semilogy(o.result.t.astype(float), rel)
    top = float(np.nanmax(rel)) if np.isfinite(rel).any() else floor
    ax.set_ylim(floor, max(top * 10, floor * 100))     # a constant energy: a decade above the floor
    ax.set_xlabel(_time_label(o))
    ax.set_ylabel(f"|E - E0| / {SCALE_TEXT}")
    fit_title(fig, lambda text: ax.set_title(text, fontsize=9),
               f"{o.scene.title}: energy error ({o.choice.method}, {o.choice.dtype})")
    return fig


def _power_functions(o):
    """f(t, y) -> (q'.Q, q'.dR/dq', -dL/dt|explicit) at the rows (t, y): the power of the
    applied forces, the power dissipated and the prescribed motion's (in W); g(t, y) = E - h;
    and which are present (derive/runtime/power.py), from the derivation of the model that ran."""
    p = normalise_params(o.plan.model, o.plan.params)
    inputs = run_inputs(o.scene)
    if isinstance(inputs, dict):
        inputs = [float(inputs[n]) for n in load_model(o.plan.model).inputs]
    return power_functions(o.plan.model, p, inputs)


def work_and_dissipation(o) -> tuple[np.ndarray, np.ndarray, str, tuple[bool, bool]]:
    """W(t) and D(t) at the output times: the work of the applied forces (and of a
    prescribed motion: a moving pivot's) and the energy dissipated since t0.  On the run's
    continuous solution by 3-point Gauss quadrature, each output interval cut until the
    sums converge (derive/runtime/power.py); else by the trapezoid rule with its end
    correction on the output rows (fourth order in the output interval).

    Parameters
    ----------
    o : Outcome
        A scene's run (derive.scene.run.run).

    Returns
    -------
    work, dissipated : numpy.ndarray
        In J, at each output time (0 at the first).
    how : str
        The quadrature used, in words.
    present : tuple of bool
        Whether the model has applied forces or explicit time, and dissipation.
    """
    t = np.asarray(o.result.t, float)
    power, gap, (forced, damped, timed) = _power_functions(o)
    if o.result.sol is not None and len(t) > 1:
        parts, pieces = gauss_converged(o.result, t, power)
        how = f"3-point Gauss on the continuous solution, {pieces} piece(s) per output interval"
    else:
        parts = trapezoid(t, power(t, o.result.y))
        how = "the corrected trapezoid rule on the output rows" if len(t) > 2 else "the trapezoid rule on the output rows"
    work, loss, motion = (np.concatenate([[0.0], np.cumsum(part)]) for part in parts)
    if timed:                        # the moving pivot's work joins the forces'
        g = gap(t, o.result.y)
        work = work + motion + (g - g[0])
    return work, loss, how, (forced or timed, damped)


def energy_balance_figure(plt, o):
    """A driven or damped run's energy balance: above, E - E0 and W - D, the work of the
    applied forces (W) minus the energy dissipated (D) since t0, which it equals in an
    exact motion; below, on a log axis, what the balance leaves (the run's energy error)
    and how W and D were integrated (:func:`work_and_dissipation`).

    Parameters
    ----------
    plt : module
        matplotlib.pyplot.
    o : Outcome
        A scene's run.

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = np.asarray(o.result.t, float)
    e = np.asarray(o.energy, float)
    work, loss, how, (forced, damped) = work_and_dissipation(o)
    change = e - e[0]
    fig, (ax, low) = plt.subplots(2, 1, figsize=(6, 4.8), sharex=True, height_ratios=(3, 2),
                                  layout="constrained")
    # a wide pale band under the thin W - D: where the balance holds, both are seen
    ax.plot(t, change, lw=5, alpha=0.35, color="C0", solid_capstyle="butt", label="E - E0")
    if forced:
        drives = [w for w in load_model(o.plan.model).work_done_by if w != "the damping"]
        ax.plot(t, work, lw=0.8, ls="--", color="C1",
                label="W: work of " + (in_words(drives) or "the applied forces"))
    if damped:
        ax.plot(t, -loss, lw=0.8, ls=":", color="C2", label="-D: energy dissipated")
    ax.plot(t, work - loss, lw=0.8, color="k", label="W - D")
    ax.axhline(0.0, color="0.8", lw=0.5, zorder=0)
    ax.set_ylabel(f"energy ({unit(o, 'energy')})")
    ax.legend(fontsize=7, ncols=2, loc="lower left", framealpha=0.8)
    # what is left of the balance: the run's energy error (and the quadrature's)
    scale = np.nanmax(np.abs(np.concatenate([e, work, loss]))) if np.isfinite(e).any() else 1.0
    floor = energy_floor(o.choice.dtype) * max(float(scale), 1e-300)
    with np.errstate(invalid="ignore"):
        gap = np.maximum(np.abs(change - (work - loss)), floor)
    low.semilogy(t, gap, color="C3", lw=0.9)
    top = float(np.nanmax(gap)) if np.isfinite(gap).any() else floor
    low.set_ylim(floor, max(top * 10, floor * 100))
    low.set_ylabel(f"|E - E0 - (W - D)| ({unit(o, 'energy')})", fontsize=8)
    low.set_xlabel(_time_label(o))
    low.set_title(f"what the balance leaves (W, D by {how})", fontsize=7)
    fit_title(fig, lambda text: ax.set_title(text, fontsize=9),
               f"{o.scene.title}: energy balance (not conserved: driven/damped; "
               f"{o.choice.method}, {o.choice.dtype})")
    return fig


def _plain(text: str) -> str:
    """A title as text: matplotlib would read $...$ as mathematics (and fail on a lone $)."""
    return text.replace("$", r"\$")


FPS = 25                # frames per second of the animation
MAX_FRAMES = 150        # at most this many frames (6 s at FPS), spread over the outputs


def _animation(plt, o, pos, out, stem, horizontal, vertical) -> tuple[Path, int] | None:
    """The GIF and its number of frames, drawn by blitting: the axes, title and labels are
    rendered once, each frame redraws only the chain, its trail and the time stamp (a full
    redraw per frame, as matplotlib's writers do, is many times the cost)."""
    from PIL import Image    # matplotlib's own dependency: the plot extra, imported when drawn
    parts = _animation_parts(plt, o, horizontal, vertical)
    if parts is None:
        return None
    fig, frames, draw = parts
    canvas = fig.canvas
    canvas.draw()                            # the layout, settled once
    fig.set_layout_engine("none")
    ax = fig.axes[0]
    artists = draw(0)
    for a in artists:
        a.set_visible(False)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    for a in artists:
        a.set_visible(True)
    images = []
    for i in range(len(frames)):
        canvas.restore_region(background)
        for a in draw(i):
            ax.draw_artist(a)
        canvas.blit(fig.bbox)
        rgb = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba()).convert("RGB")
        images.append(rgb.quantize(colors=64, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE))
    plt.close(fig)
    path = out / f"{stem}.gif"
    _replace(path, lambda tmp: images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:],
                                             duration=round(1000 / FPS), loop=0))
    return path, len(images)


def _tree_drawing(o, pos: np.ndarray):
    """The points a tree's frames draw (outputs, points, dimension): each link a segment
    from its joint to its tip, a joint at an offset joined to its parent's joint (or the
    pivot), NaN between segments; None for a serial chain (drawn pivot, tip, tip, ...)."""
    if find_atlas(o.scene.model) is not None:
        return None
    model = load_model(o.scene.model)
    if model.is_chain:
        return None
    d = derive(model)
    s = d.symbols
    joints = sp.lambdify([time_symbol, *s.state, *s.params], sp.Matrix.hstack(*tree_geometry(model, s).joints),
                         "numpy")
    p = [float(o.scene.parameters[x.name]) for x in s.params]
    gap = np.full(pos.shape[-1], np.nan)
    frames = []
    for k, (tk, yk) in enumerate(zip(np.asarray(o.result.t, float), np.asarray(o.result.y, float))):
        at = np.asarray(joints(tk, *yk[:len(s.state)], *p), float).T
        points = []
        for i, link in enumerate(model.links):
            base = at[link.parent] if link.parent >= 0 else np.zeros(pos.shape[-1])
            if link.offset is not None:
                points += [base, at[i], gap]
            points += [at[i], pos[k, i], gap]
        frames.append(points)
    return np.asarray(frames, float)


def _animation_parts(plt, o, horizontal: int = 0, vertical: int | None = None):
    """(figure, frame rows, draw) of the chain moving: draw(i) puts frame i into the
    chain, trail and time-stamp artists and returns them; None for a run with no state
    to show (it failed at its start)."""
    pos = np.asarray(o.positions, float)
    vertical = pos.shape[-1] - 1 if vertical is None else vertical
    # only the part of the run that has a state (a run that stopped is NaN after its stop)
    alive = int(np.argmin(np.isfinite(pos).all(axis=(1, 2)))) if not np.isfinite(pos).all() else len(pos)
    if alive == 0:
        return None
    t = np.asarray(o.result.t, float)
    frames = np.linspace(0, alive - 1, min(alive, MAX_FRAMES)).astype(int)
    scale = float(np.max(np.abs(pos[:alive]))) or 1.0        # scaled: |x| near 1e300 does not overflow
    reach = scale * float(np.max(np.linalg.norm(pos[:alive] / scale, axis=-1))) * 1.05
    fig, ax = plt.subplots(figsize=(4, 4.3), dpi=100, layout="constrained")
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_aspect("equal")
    ax.set_xlabel(_axis_label(o, horizontal))
    ax.set_ylabel(_axis_label(o, vertical))
    fit_title(fig, lambda text: ax.set_title(text, fontsize=9), o.scene.title)
    line, = ax.plot([], [], "o-", lw=2, color="tab:blue")
    trail, = ax.plot([], [], lw=0.6, color="tab:red")
    tree = _tree_drawing(o, pos)
    stamp = ax.text(0.02, 0.96, "", transform=ax.transAxes, fontsize=8, va="top")

    def draw(i):
        k = frames[i]
        if tree is None:
            line.set_data([0, *pos[k, :, horizontal]], [0, *pos[k, :, vertical]])     # the whole chain
        else:
            line.set_data(tree[k, :, horizontal], tree[k, :, vertical])
        trail.set_data(pos[:k + 1, -1, horizontal], pos[:k + 1, -1, vertical])    # its last bob
        stamp.set_text(f"t = {t[k]:.2f}" + (" s" if o.scene.units == "SI" else ""))
        return line, trail, stamp

    draw(0)                                  # the first frame as the figure (and for a still)
    return fig, frames, draw


def animation_figure(plt, o, horizontal: int = 0, vertical: int | None = None):
    """(figure, FuncAnimation) of the chain moving, titled, with a time stamp in each frame;
    None for a run with no state to show (it failed at its start)."""
    from matplotlib.animation import FuncAnimation    # the plot extra, imported when a figure is drawn
    parts = _animation_parts(plt, o, horizontal, vertical)
    if parts is None:
        return None
    fig, frames, draw = parts
    return fig, FuncAnimation(fig, draw, frames=len(frames), blit=True)
