"""A PNG per quantity of a 2-D sweep: the map, its colour bar and the axis names."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DeriveError
from ..model import load_model
from ..model.energy_scale import SCALE_TEXT
from ..paths import replace_file
from ..scene.outputs import fit_title

SKIP = ("status", "chunk_done")
MAX_TICKS = 8          # labelled ticks of an axis of listed values, at most


def _units(model_name: str):
    """name -> its unit ("" none, None unknown): the model's states and parameters and the
    recorded quantities (event times in s, the Lyapunov exponent in 1/s, the relative
    energy error none, max_abs_<q> and final_<state> the unit of q and of the state)."""
    try:
        model = load_model(model_name)
    except DeriveError:                      # a store whose model file has gone: no units
        model = None

    def unit(name: str) -> str | None:
        if name.endswith("_time") or name.endswith("_time_error"):
            return "s"
        if name == "lyapunov_exponent":
            return "1/s"
        if name == "energy_error":
            return ""
        if model is None:
            return None
        for prefix in ("max_abs_", "final_"):
            if name.startswith(prefix) and model.unit_of(name[len(prefix):]) is not None:
                return model.unit_of(name[len(prefix):])
        return model.unit_of(name)
    return unit


def _label(name: str, unit: str | None) -> str:
    return f"{name} ({unit})" if unit else name


def _list_ticks(axis, values: np.ndarray) -> None:
    """An axis of listed (not evenly spaced) values: ticks at the values themselves, at most
    MAX_TICKS of them labelled (:func:`_unclutter` drops the labels that would still touch,
    once the figure is laid out)."""
    from matplotlib.ticker import FixedLocator, NullLocator    # the plot extra, imported when drawn
    step = int(np.ceil(len(values) / MAX_TICKS))
    shown = values[::step]
    axis.set_major_locator(FixedLocator(shown))
    axis.set_minor_locator(NullLocator())
    axis.set_ticklabels([_tick_text(v) for v in shown])


def _tick_text(value: float) -> str:
    """A listed value as a tick label, with the minus sign matplotlib's own ticks use."""
    return f"{value:.4g}".replace("-", "\u2212")


GAP = 4                 # pixels between two tick labels, at least


def _unclutter(fig, axis) -> None:
    """Blank the labels of a listed axis that run into a label kept before them (values
    bunched together: 0, 0.05, 0.1), measured as drawn; the last value keeps its label."""
    fig.canvas.draw()
    labels = axis.get_ticklabels()
    along = (lambda b: (b.x0, b.x1)) if axis.axis_name == "x" else (lambda b: (b.y0, b.y1))
    spans = sorted(((along(label.get_window_extent()), label) for label in labels if label.get_text()),
                   key=lambda s: s[0][0] + s[0][1])      # in the order of the values (label centres)
    kept = []
    touches = lambda span: bool(kept) and span[0] < kept[-1][0][1] + GAP
    for span, label in spans:
        while label is spans[-1][1] and len(kept) > 1 and touches(span):
            kept.pop()[1].set_text("")              # the last value rather than those before
        if touches(span):
            label.set_text("")
            continue
        kept.append((span, label))
    axis.set_ticklabels([label.get_text() for label in labels])    # (a redraw reads the formatter)


def _uniform(values: np.ndarray) -> bool:
    d = np.diff(values)
    return len(values) > 1 and np.allclose(d, d[0], rtol=1e-9, atol=0)


def _norm(name: str, z: np.ndarray):
    """A logarithmic colour scale for errors (positive, over decades), else linear (None)."""
    from matplotlib.colors import LogNorm    # the plot extra, imported when a figure is drawn
    positive = z[np.isfinite(z) & (z > 0)]
    if not name.endswith("_error") or positive.size == 0 or positive.max() <= positive.min():
        return None
    return LogNorm(vmin=max(positive.min(), positive.max() * 1e-10), vmax=positive.max())


def write_images(ds, folder: Path, stem: str, title: str) -> list[Path]:
    """One image per data variable over the sweep's two dimensions (none for other sweeps)."""
    names = [n for n in ds.data_vars if n not in SKIP and ds[n].ndim == 2]
    if not names:
        return []
    import matplotlib    # the plot extra, imported when a figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt    # the plot extra, imported when a figure is drawn
    files = []
    for name in names:
        fig = image_figure(plt, ds, name, title)
        path = Path(folder) / f"{stem}_{name}.png"
        replace_file(path, lambda tmp, fig=fig: fig.savefig(tmp), mode=0o644)
        plt.close(fig)
        files.append(path)
    return files


def image_figure(plt, ds, name: str, title: str):
    """The map of one quantity over the sweep's two dimensions: axes and colour bar named
    with their units where known, listed values as the ticks, the title inside the figure.

    Parameters
    ----------
    plt : module
        matplotlib.pyplot.
    ds : xarray.Dataset
        The sweep's dataset (its ``model`` attribute gives the units).
    name : str
        A two-dimensional data variable of `ds`.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    unit = _units(ds.attrs.get("model", ""))
    da = ds[name]
    xdim, ydim = da.dims
    x, y = np.asarray(ds[xdim]), np.asarray(ds[ydim])
    z = np.asarray(da.values, float).T                 # rows along y
    fig, ax = plt.subplots(figsize=(6.4, 5.2), dpi=150, layout="constrained")
    cmap = plt.get_cmap("viridis").with_extremes(bad="0.85")   # NaN (no event, a failed run): grey
    norm = _norm(name, z)
    if norm is not None:
        z = np.where(z > 0, z, np.nan)                 # a log scale: zero is shown as none
    listed = []
    if _uniform(x) and _uniform(y):
        image = ax.imshow(np.ma.masked_invalid(z), origin="lower", cmap=cmap, aspect="auto", norm=norm,
                          extent=(x[0], x[-1], y[0], y[-1]), interpolation="nearest")
    else:
        image = ax.pcolormesh(x, y, np.ma.masked_invalid(z), cmap=cmap, shading="nearest", norm=norm)
        for values, setter, axis in ((x, ax.set_xscale, ax.xaxis), (y, ax.set_yscale, ax.yaxis)):
            if np.all(values > 0) and len(values) > 2 and not _uniform(values):
                setter("log")
            if not _uniform(values):
                _list_ticks(axis, values)
                listed.append(axis)
    bar = fig.colorbar(image, ax=ax)
    bar.set_label(_label(name.replace("_", " "), unit(name))
                  + (" (grey: none)" if name.endswith("_time") else
                     " (estimate)" if name.endswith("_time_error") else
                     f": |E - E0| / {SCALE_TEXT}" if name == "energy_error" else ""))
    ax.set_xlabel(_label(xdim, unit(xdim)))
    ax.set_ylabel(_label(ydim, unit(ydim)))
    fit_title(fig, lambda text: fig.suptitle(text), title)
    for axis in listed:
        _unclutter(fig, axis)
    return fig
