"""A PNG per quantity of a 2-D sweep: the map, its colour bar and the axis names."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..paths import replace_file

SKIP = ("status", "chunk_done")


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
        da = ds[name]
        xdim, ydim = da.dims
        x, y = np.asarray(ds[xdim]), np.asarray(ds[ydim])
        z = np.asarray(da.values, float).T                 # rows along y
        fig, ax = plt.subplots(figsize=(6.4, 5.2), dpi=150)
        cmap = plt.get_cmap("viridis").with_extremes(bad="0.85")   # NaN (no event, a failed run): grey
        norm = _norm(name, z)
        if norm is not None:
            z = np.where(z > 0, z, np.nan)                 # a log scale: zero is shown as none
        if _uniform(x) and _uniform(y):
            image = ax.imshow(np.ma.masked_invalid(z), origin="lower", cmap=cmap, aspect="auto", norm=norm,
                              extent=(x[0], x[-1], y[0], y[-1]), interpolation="nearest")
        else:
            image = ax.pcolormesh(x, y, np.ma.masked_invalid(z), cmap=cmap, shading="nearest", norm=norm)
            for values, setter in ((x, ax.set_xscale), (y, ax.set_yscale)):
                if np.all(values > 0) and len(values) > 2 and not _uniform(values):
                    setter("log")
        bar = fig.colorbar(image, ax=ax)
        bar.set_label(name.replace("_", " ") + (" (grey: none)" if name.endswith("_time") else
                                                " (estimate)" if name.endswith("_time_error") else ""))
        ax.set_xlabel(xdim)
        ax.set_ylabel(ydim)
        ax.set_title(title)
        fig.tight_layout()
        path = Path(folder) / f"{stem}_{name}.png"
        replace_file(path, lambda tmp, fig=fig: fig.savefig(tmp), mode=0o644)
        plt.close(fig)
        files.append(path)
    return files
