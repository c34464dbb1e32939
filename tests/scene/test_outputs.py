"""Outputs a user can read: a spherical run's paths in two projections with equal axes, the
energy plot's axis from the run's unit roundoff, an animation with a title and a time
stamp, and backend = "numpy" running with no C compiler anywhere (the trust estimate too)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from derive.scene import load_scene  # noqa: E402
from derive.scene.outputs import animation_figure, energy_figure, paths_figure, write_outputs  # noqa: E402
from derive.scene.run import run  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "derive" / "scenes"


def outcome(tmp_path: Path, name: str, edits=(), **_):
    text = (SCENES / f"{name}.toml").read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return run(load_scene(path), show_progress=False)


SHORT_SPHERICAL = [("stop = 10.0", "stop = 0.5"), ("outputs = 1001", "outputs = 51")]
SHORT_PLANAR = [("stop = 5.0", "stop = 1.0"), ("outputs = 501", "outputs = 101")]


@pytest.fixture(scope="module")
def spherical(tmp_path_factory):
    return outcome(tmp_path_factory.mktemp("sph"), "spherical_pole", SHORT_SPHERICAL)


def test_a_spherical_run_shows_two_projections_with_equal_axes(spherical):
    fig = paths_figure(plt, spherical)
    try:
        axes = fig.axes
        assert len(axes) == 2
        assert [(a.get_xlabel(), a.get_ylabel()) for a in axes] == [("x", "y"), ("x", "z")]
        assert all(a.get_aspect() == 1.0 for a in axes)                   # equal axes
        pos = np.asarray(spherical.positions, float)
        for a, v in zip(axes, (1, 2)):          # each view draws both bobs' paths in its plane
            lines = [ln for ln in a.get_lines() if ln.get_label().startswith("bob")]
            assert len(lines) == 2
            assert np.allclose(lines[1].get_ydata(), pos[:, 1, v])
        assert fig.get_suptitle() == "Double spherical pendulum through the poles"
    finally:
        plt.close(fig)


def test_a_planar_run_shows_its_plane(tmp_path):
    o = outcome(tmp_path, "default", SHORT_PLANAR)
    fig = paths_figure(plt, o)
    try:
        assert len(fig.axes) == 1 and fig.axes[0].get_aspect() == 1.0
        assert (fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()) == ("x", "y")
    finally:
        plt.close(fig)


@pytest.mark.parametrize("scalar, eps", [("double", np.finfo(np.float64).eps),
                                         ("long double", np.finfo(np.longdouble).eps),
                                         ("float", np.finfo(np.float32).eps)])
def test_the_energy_axis_starts_at_the_unit_roundoff(tmp_path, scalar, eps):
    target = "1e-8" if scalar != "float" else "1e-3"
    o = outcome(tmp_path, "default", SHORT_PLANAR + [("target = 1e-8", f'target = {target}\nscalar = "{scalar}"')])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = energy_figure(plt, o)
    try:
        bottom, top = fig.axes[0].get_ylim()
        assert bottom == pytest.approx(float(eps) / 2, rel=1e-12) and top > bottom
    finally:
        plt.close(fig)


def test_a_constant_energy_still_has_an_axis(tmp_path):
    """g = 0 from rest: the energy does not change at all; the plot is the floor, no warning."""
    o = outcome(tmp_path, "default", SHORT_PLANAR + [("g = 9.81", "g = 0.0")])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = energy_figure(plt, o)
    try:
        bottom, top = fig.axes[0].get_ylim()
        assert bottom == pytest.approx(np.finfo(np.float64).eps / 2) and top >= 100 * bottom
    finally:
        plt.close(fig)


def test_the_animation_has_a_title_and_a_time_stamp(spherical):
    fig, anim = animation_figure(plt, spherical)
    try:
        ax = fig.axes[0]
        assert ax.get_title() == "Double spherical pendulum through the poles"
        assert [t.get_text() for t in ax.texts] == ["t = 0.00"]
        assert ax.get_aspect() == 1.0
    finally:
        plt.close(fig)


@pytest.mark.slow
def test_the_animation_has_a_frame_per_output(spherical, tmp_path):
    spherical.scene.plots = ("animation",)
    spherical.scene.trajectory = ()
    spherical.scene.output_dir = tmp_path
    files = write_outputs(spherical)
    from PIL import Image
    with Image.open(files[0]) as gif:
        assert gif.n_frames == 51


def _no_compiler_env(tmp_path: Path) -> dict:
    empty = tmp_path / "bin"
    empty.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "CC"}
    env.update(PATH=str(empty), PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(tmp_path / "cache"))
    return env


@pytest.mark.parametrize("name, edits", [
    ("default", SHORT_PLANAR),
    ("compound_equivalent", [("stop = 10.0", "stop = 1.0")]),     # run as the planar model
    pytest.param("spherical_pole", SHORT_SPHERICAL, marks=pytest.mark.slow),
])
def test_the_numpy_backend_needs_no_compiler(tmp_path, name, edits):
    """PATH without cc, gcc or clang and CC unset: backend = "numpy" runs the scene, its
    Lyapunov estimate and its reference run, with the result the C backend gives."""
    text = (SCENES / f"{name}.toml").read_text()
    for old, new in edits:
        text = text.replace(old, new)
    text = text.replace("[accuracy]\n", '[accuracy]\nbackend = "numpy"\n')
    (tmp_path / "s.toml").write_text(text)
    env = _no_compiler_env(tmp_path)
    run_ = subprocess.run([sys.executable, "-W", "error", "-m", "derive", "run", str(tmp_path / "s.toml"),
                           "--json", "--output-dir", str(tmp_path / "out")], env=env, cwd=tmp_path,
                          capture_output=True, text=True, timeout=1200)
    assert run_.returncode == 0, run_.stderr
    s = json.loads(run_.stdout)
    assert s["backend"] == "numpy" and s["target_met"] is True and s["lyapunov_exponent"] is not None
    assert not (tmp_path / "cache" / "c-build").exists()                # nothing was compiled
    scene_c = text.replace('backend = "numpy"\n', "")
    (tmp_path / "c.toml").write_text(scene_c)
    c = subprocess.run([sys.executable, "-m", "derive", "run", str(tmp_path / "c.toml"), "--json",
                        "--output-dir", str(tmp_path / "out-c")], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                       cwd=tmp_path, capture_output=True, text=True, timeout=1200)
    assert c.returncode == 0, c.stderr
    sc = json.loads(c.stdout)
    target = s["target"]
    assert np.max(np.abs(np.subtract(s["final_state"], sc["final_state"]))) <= 2 * target


def test_the_trust_horizon_of_a_numpy_run_needs_no_compiler(tmp_path, monkeypatch):
    """derive.measurement.trust on a NumPy result: the estimate runs on NumPy too."""
    from derive import simulate
    from derive.runtime import loader
    from derive.measurement.trust import trust_horizon_of
    r = simulate("planar", [2.5, 2.0, 0.0, 0.0], np.linspace(0, 2, 21), [1, 1, 1, 1, 9.81],
                 backend="numpy", rtol=1e-10)

    def no_compiler(*args, **kwargs):
        raise AssertionError("the C backend was used")
    monkeypatch.setattr(loader, "load", no_compiler)
    monkeypatch.setattr(loader, "build_library", no_compiler)
    horizon = trust_horizon_of(r)
    assert 2.0 < horizon < 30.0                  # chaotic: lambda ~ 2, e0 ~ 1e-10


def test_a_float32_runs_csv_has_no_noise_digits(tmp_path):
    """Written to float32's precision: 0.1 reads 0.1 (not 0.10000000149011612), and every
    value reads back as the float32 the run computed."""
    o = outcome(tmp_path, "default", SHORT_PLANAR + [("target = 1e-8", 'method = "dop853"\nrtol = 1e-5\nscalar = "float"'),
                                                     ("theta1 = 2.5", "theta1 = 0.1")])
    write_outputs(o)
    rows = (Path(o.scene.output_dir) / "default.csv").read_text().splitlines()
    first = rows[1].split(",")
    assert first[:2] == ["0.0", "0.1"] and all(len(v.lstrip("-").replace(".", "").lstrip("0")) <= 10 for v in first)
    data = np.loadtxt(rows[1:], delimiter=",", dtype=np.float32)
    assert np.array_equal(data[:, 1:5], np.asarray(o.result.y))
