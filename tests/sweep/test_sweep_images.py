"""A sweep's image as a reader sees it: axes and colour bar with their units, an axis of
listed values ticked at those values without labels running into each other, a long title
inside the figure."""
import matplotlib
import numpy as np
import pytest
import xarray as xr

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from derive.sweep.images import MAX_TICKS, image_figure, write_images  # noqa: E402

MASSES = [0.1234, 0.2, 0.35, 0.5, 0.75, 1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.5, 7.25, 9.0, 12.5]
TITLE = ("The largest swing of the lower link of the planar double pendulum over the release "
         "angle and a listed set of lower masses")


@pytest.fixture
def ds():
    theta1 = np.linspace(-3, 3, 7)
    z = np.abs(np.sin(theta1))[:, None] * np.asarray(MASSES)[None, :]
    return xr.Dataset({"max_abs_theta2": (("m2", "theta1"), z.T)},
                      coords={"m2": MASSES, "theta1": theta1}, attrs={"model": "planar"})


def test_a_listed_axis_is_ticked_at_its_values_and_every_axis_has_units(ds):
    fig = image_figure(plt, ds, "max_abs_theta2", TITLE)
    try:
        ax, bar = fig.axes
        assert ax.get_xlabel() == "m2 (kg)" and ax.get_ylabel() == "theta1 (rad)"
        assert bar.get_ylabel() == "max abs theta2 (rad)"
        ticks = ax.get_xticks()
        assert len(ticks) <= MAX_TICKS and set(ticks) <= set(MASSES)        # the listed values
        assert not ax.xaxis.get_minor_ticks() or not any(t.label1.get_text() for t in ax.xaxis.get_minor_ticks())
        fig.canvas.draw()
        boxes = sorted((lab.get_window_extent() for lab in ax.get_xticklabels() if lab.get_text()),
                       key=lambda b: b.x0)
        assert all(a.x1 < b.x0 for a, b in zip(boxes, boxes[1:])), "tick labels overlap"
        title = fig._suptitle.get_window_extent()
        assert title.x0 >= 0 and title.x1 <= fig.bbox.width and "\n" in fig._suptitle.get_text()
    finally:
        plt.close(fig)


def test_the_images_are_written(ds, tmp_path):
    files = write_images(ds, tmp_path, "s", TITLE)
    assert [f.name for f in files] == ["s_max_abs_theta2.png"]
    assert files[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_energy_error_says_what_it_is_relative_to():
    """Not a bare "energy error": relative to max(|E0|, m g l), a scale that cannot vanish."""
    theta1 = np.linspace(-3, 3, 7)
    data = xr.Dataset({"energy_error": (("m2", "theta1"), np.full((3, 7), 1e-9))},
                      coords={"m2": [0.5, 1.0, 2.0], "theta1": theta1}, attrs={"model": "planar"})
    fig = image_figure(plt, data, "energy_error", "energy error")
    try:
        assert fig.axes[1].get_ylabel() == "energy error: |E - E0| / max(|E0|, m g l)"
    finally:
        plt.close(fig)


def labelled_ticks_apart(fig, axis):
    """The labels of an axis as drawn: none touches the next (matplotlib's text extents)."""
    fig.canvas.draw()
    spans = sorted(((b.x0, b.x1) if axis.axis_name == "x" else (b.y0, b.y1))
                   for b in (lab.get_window_extent() for lab in axis.get_ticklabels() if lab.get_text()))
    assert all(a[1] < b[0] for a, b in zip(spans, spans[1:])), f"tick labels overlap: {spans}"
    return len(spans)


def test_bunched_listed_values_keep_their_labels_apart():
    """Listed values bunched together on a linear axis (0, 0.05, ... among -2 and 2): the
    labels that would run into each other are left out, the ends and the first of a bunch
    kept, the minus sign matplotlib's own."""
    bunched = [-2.0, 0.0, 0.05, 0.1, 0.15, 0.2, 2.0]
    theta1 = np.linspace(-3, 3, 7)
    z = np.add.outer(np.asarray(bunched), theta1)
    data = xr.Dataset({"max_abs_theta2": (("theta2", "theta1"), z)},
                      coords={"theta2": bunched, "theta1": theta1}, attrs={"model": "planar"})
    fig = image_figure(plt, data, "max_abs_theta2", "bunched")
    try:
        ax = fig.axes[0]
        assert labelled_ticks_apart(fig, ax.xaxis) >= 3
        shown = [lab.get_text() for lab in ax.get_xticklabels() if lab.get_text()]
        assert shown[0] == "\u22122" and shown[-1] == "2" and "0" in shown, shown
        assert list(ax.get_xticks()) == bunched                   # a tick at every value still
    finally:
        plt.close(fig)
