"""Outputs a user can read: a spherical run's paths in two projections with equal axes, the
energy plot's axis from the run's unit roundoff, an animation with a title and a time
stamp, and backend = "numpy" running with no C compiler anywhere (the trust estimate too)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
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
from tests.in_process import derive_cli  # noqa: E402
from tests.parameters import named_double_pendulum  # noqa: E402

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
        assert [(a.get_xlabel(), a.get_ylabel()) for a in axes] == [("x (m)", "y (m)"), ("x (m)", "z (m)")]
        assert all(a.get_aspect() == 1.0 for a in axes)                   # equal axes
        pos = np.asarray(spherical.positions, float)
        for a, v in zip(axes, (1, 2)):          # each view draws both bobs' paths in its plane
            lines = [ln for ln in a.get_lines() if ln.get_label().startswith("bob")]
            assert len(lines) == 2
            assert np.allclose(lines[1].get_ydata(), pos[:, 1, v])
        assert fig.get_suptitle() == "Double spherical pendulum through the poles"
        paths_fill_their_figure(fig)
    finally:
        plt.close(fig)


def paths_fill_their_figure(fig):
    """Equal axes in a figure of the paths' shape: the title sits just above the views and
    the data areas span the width (no band of empty space above and below a wide swing)."""
    fig.canvas.draw()
    title = fig._suptitle.get_window_extent()
    tops = [a.get_tightbbox().y1 for a in fig.axes]
    assert title.y0 - max(tops) < 0.25 * fig.dpi, (title, tops)
    data_width = sum(a.get_window_extent().width for a in fig.axes)
    assert data_width > 0.7 * fig.bbox.width, (data_width, fig.bbox.width)


def test_a_planar_run_shows_its_plane(tmp_path):
    o = outcome(tmp_path, "default", SHORT_PLANAR)
    fig = paths_figure(plt, o)
    try:
        assert len(fig.axes) == 1 and fig.axes[0].get_aspect() == 1.0
        assert (fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()) == ("x (m)", "y (m)")
        paths_fill_their_figure(fig)
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
        assert [t.get_text() for t in ax.texts] == ["t = 0.00 s"]
        assert ax.get_aspect() == 1.0
    finally:
        plt.close(fig)


def test_the_animation_has_a_frame_per_output_and_is_cheap(spherical, tmp_path):
    """Blitted: the axes are drawn once, each frame only the chain (a full redraw per frame
    cost about 0.3 s of CPU a frame, 17 s for these 51)."""
    spherical.scene.plots = ("animation",)
    spherical.scene.trajectory = ()
    spherical.scene.output_dir = tmp_path
    start = time.process_time()
    files = write_outputs(spherical)
    cpu = time.process_time() - start
    from PIL import Image
    with Image.open(files[0]) as gif:
        assert gif.n_frames == 51 and gif.info["duration"] == 40          # 25 frames a second
        first = np.asarray(gif.convert("RGB"))
        gif.seek(50)
        last = np.asarray(gif.convert("RGB"))
    assert (first != last).any()                  # the chain moves
    assert cpu < 6.0, f"{cpu:.1f} s of CPU for 51 frames"


def test_a_long_title_is_wrapped_inside_every_figure(spherical):
    long = ("A double spherical pendulum released through the poles of its standard chart, "
            "with a title far longer than any figure is wide")
    spherical.scene.title = long
    try:
        made = [paths_figure(plt, spherical), energy_figure(plt, spherical), animation_figure(plt, spherical)[0]]
        for fig in made:
            fig.canvas.draw()
            titles = [t for t in (fig._suptitle, *(a.title for a in fig.axes)) if t is not None and t.get_text()]
            assert titles
            for t in titles:
                box = t.get_window_extent()
                assert box.x0 >= 0 and box.x1 <= fig.bbox.width, t.get_text()
        assert "\n" in made[-1].axes[0].get_title()        # 4 inches wide: broken into lines
    finally:
        spherical.scene.title = "Double spherical pendulum through the poles"
        plt.close("all")


# the example scene of the driven model (examples/scenes), shorter
DRIVEN = (ROOT / "examples" / "scenes" / "driven.toml").read_text().replace("stop = 10.0", "stop = 3.0")


@pytest.mark.parametrize("accuracy, how", [("target = 1e-8", "Gauss"),
                                           ('method = "rk4"\nstep = 0.005', "corrected trapezoid")])
def test_a_driven_damped_run_plots_its_energy_balance(tmp_path, accuracy, how):
    """Not conserved: the plot is E - E0 against the work of the torque minus the energy the
    damping dissipated (in J, over t in s), and what the balance leaves is the run's error."""
    (tmp_path / "driven.toml").write_text((ROOT / "examples" / "models" / "driven.toml").read_text())
    (tmp_path / "s.toml").write_text(DRIVEN.replace("../models/driven.toml", "driven.toml")
                                     .replace("target = 1e-8", accuracy))
    o = run(load_scene(tmp_path / "s.toml"), show_progress=False)
    fig = energy_figure(plt, o)
    try:
        top, low = fig.axes
        assert "not conserved: driven/damped" in " ".join(top.get_title().split())
        assert top.get_ylabel() == "energy (J)" and low.get_xlabel() == "t (s)"
        lines = {ln.get_label(): ln.get_ydata() for ln in top.get_lines()}
        assert {"E - E0", "W: work of the applied forces", "-D: energy dissipated", "W - D"} <= set(lines)
        change, balance = lines["E - E0"], lines["W - D"]
        assert np.ptp(change) > 0.5                                   # the energy changes a lot
        assert np.max(np.abs(change - balance)) < 1e-5 * np.ptp(change)   # ... by the work done
        assert np.max(lines["-D: energy dissipated"]) <= 0 and np.min(lines["-D: energy dissipated"]) < -0.1
        assert how in low.get_title()
        residual = low.get_lines()[0].get_ydata()
        assert np.allclose(residual[5:], np.maximum(np.abs(change - balance), low.get_ylim()[0])[5:])
        plt.close(fig)
        fig = paths_figure(plt, o)              # a swing twice as wide as deep
        paths_fill_their_figure(fig)
    finally:
        plt.close(fig)


def test_a_scene_in_model_units_says_so_on_every_axis(tmp_path):
    """output.units = "model" (g = 1, unit lengths: not SI numbers): times, lengths and
    energies are labelled in model units, angles stay radians; SI by default."""
    si = outcome(tmp_path, "default", SHORT_PLANAR)
    model = outcome(tmp_path, "default", SHORT_PLANAR + [("[output]\n", '[output]\nunits = "model"\n'),
                                                         ("g = 9.81", "g = 1.0")])
    labels = {}
    for o in (si, model):
        figs = [paths_figure(plt, o), energy_figure(plt, o), animation_figure(plt, o)[0]]
        try:
            labels[o.scene.units] = ([(a.get_xlabel(), a.get_ylabel()) for f in figs for a in f.axes],
                                     figs[2].axes[0].texts[0].get_text())
        finally:
            for f in figs:
                plt.close(f)
    assert labels["SI"] == ([("x (m)", "y (m)"), ("t (s)", "|E - E0| / max(|E0|, m g l)"), ("x (m)", "y (m)")],
                            "t = 0.00 s")
    assert labels["model"] == ([("x (model units)", "y (model units)"),
                                ("t (model units)", "|E - E0| / max(|E0|, m g l)"),
                                ("x (model units)", "y (model units)")], "t = 0.00")


def test_the_units_of_a_scene_are_checked(tmp_path):
    text = (SCENES / "default.toml").read_text().replace("[output]\n", '[output]\nunits = "imperial"\n')
    (tmp_path / "s.toml").write_text(text)
    run_ = derive_cli("run", tmp_path / "s.toml", cwd=tmp_path)
    assert run_.returncode == 2 and run_.stderr.strip().splitlines() == [
        f"derive: error: {tmp_path / 's.toml'}: 'output.units' must be one of SI, model; got 'imperial'"], \
        run_.stderr


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


def test_an_atlas_run_names_its_columns_and_its_final_state(tmp_path, capsys):
    """The atlas's rows are in different charts: the CSV names each state column by its
    entry in every chart (no y0..y7) beside the chart column, the NPZ says the same, and
    --json names the final state's entries in the chart it ends in (a list of names beside the
    values, and a name -> value map)."""
    text = (SCENES / "spherical_pole.toml").read_text()
    for old, new in [("stop = 10.0", "stop = 2.0"), ("outputs = 1001", "outputs = 201"),
                     ('trajectory = ["csv"]', 'trajectory = ["csv", "npz"]'),
                     ('plots = ["paths", "energy", "animation"]', "plots = []")]:
        assert old in text, old
        text = text.replace(old, new)
    (tmp_path / "s.toml").write_text(text)
    run_ = derive_cli("run", tmp_path / "s.toml", "--json", "--output-dir", tmp_path / "out", cwd=tmp_path)
    assert run_.returncode == 0, run_.stderr
    s = json.loads(run_.stdout)
    lines = (tmp_path / "out" / "s.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert header[:9] == ["t", "theta1_or_vartheta1", "phi1_or_varphi1", "theta2_or_vartheta2",
                          "phi2_or_varphi2", "theta1_dot_or_vartheta1_dot", "phi1_dot_or_varphi1_dot",
                          "theta2_dot_or_vartheta2_dot", "phi2_dot_or_varphi2_dot"]
    assert header[-1] == "chart" and not any(c.startswith("y") and c[1:].isdigit() for c in header)
    charts = [line.rsplit(",", 1)[1] for line in lines[1:]]
    assert set(charts) <= {"spherical_std", "spherical_alt", "spherical_rot"}
    changes = sum(a != b for a, b in zip(charts, charts[1:]))
    assert changes >= 1 and s["chart_switches"] >= changes        # every change of chart is counted
    from derive.model import load_model
    assert s["final_chart"] == charts[-1]
    assert s["state_names"] == load_model(charts[-1]).state_names
    last = [float(v) for v in lines[-1].split(",")[1:9]]
    np.testing.assert_allclose(s["final_state"], last, rtol=0, atol=1e-15)
    assert list(s["final_state_by_name"]) == s["state_names"]             # by name, in state order
    assert list(s["final_state_by_name"].values()) == s["final_state"]
    with np.load(tmp_path / "out" / "s.npz") as npz:
        assert list(npz["state_names"]) == header[1:9] and list(npz["chart"]) == charts
    from derive.cli import _print_run
    _print_run(s)
    state = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("state "))
    first = s["state_names"][0]
    assert state.startswith(f"state   {first} = ") and state.endswith(f"(chart {charts[-1]})")


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


def test_the_energy_balance_does_not_depend_on_the_output_grid(tmp_path):
    """W and D on a coarse grid (31 outputs over a fast driven swing) are the integrals of
    the power, not the quadrature's own error: they agree with a composite Simpson rule on
    20,001 points of the continuous solution, computed here, to 1e-9 J (one Gauss rule per
    output interval was 1e-5 J off: the plot showed that as the run's error)."""
    from derive.scene.outputs import _power_functions, work_and_dissipation
    (tmp_path / "driven.toml").write_text((ROOT / "examples" / "models" / "driven.toml").read_text())
    (tmp_path / "s.toml").write_text(DRIVEN.replace("../models/driven.toml", "driven.toml")
                                     .replace("outputs = 501", "outputs = 31")
                                     .replace("tau1 = 0.5", "tau1 = 3.0"))
    o = run(load_scene(tmp_path / "s.toml"), show_progress=False)
    work, loss, how, _ = work_and_dissipation(o)
    assert "pieces per output interval" in how or "piece(s) per output interval" in how
    fine = np.linspace(o.result.t[0], o.result.t[-1], 20_001)
    powers = _power_functions(o)[0](fine, o.result.sol(fine))
    h = fine[1] - fine[0]
    simpson = [h / 3 * (q[0] + q[-1] + 4 * q[1:-1:2].sum() + 2 * q[2:-1:2].sum()) for q in powers]
    assert abs(work[-1] - simpson[0]) < 1e-9 and abs(loss[-1] - simpson[1]) < 1e-9, \
        (work[-1], simpson[0], loss[-1], simpson[1])
    assert np.ptp(o.result.energy) > 1.0                # a motion that gains energy, fast


KAPITZA = """\
name = "kapitza"
dimension = 2
parameters = ["m", "l", "g", "a", "w"]
pivot = ["0", "a*cos(w*t)"]
[[links]]
chart = "planar"
length = "l"
body = { kind = "point", mass = "m" }
"""

DP_LOAD = named_double_pendulum("dp_load", ["m1", "m2", "l1", "l2", "g", "F0", "w"], '[[loads]]\npoint = "lower"\nforce = ["F0*cos(w*t)", "0"]\n')

TIMED_SCENE = """\
title = "{name}"
[pendulum]
model = "{name}.toml"
parameters = {{ {parameters} }}
[initial]
state = {{ {state} }}
rest = true
[time]
stop = 1.0
outputs = 51
[output]
plots = ["energy"]
"""


def timed_scene(tmp_path: Path, name: str) -> Path:
    model, parameters, state = {
        "kapitza": (KAPITZA, "m = 1.0, l = 1.0, g = 9.81, a = 0.1, w = 3.0", "theta1 = 0.3"),
        "dp_load": (DP_LOAD, "m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 9.81, F0 = 1.0, w = 3.0",
                    "theta1 = 0.3, theta2 = 0.1")}[name]
    (tmp_path / f"{name}.toml").write_text(model)
    (tmp_path / "s.toml").write_text(TIMED_SCENE.format(name=name, parameters=parameters, state=state))
    return tmp_path / "s.toml"


@pytest.mark.parametrize("name, does_work", [("kapitza", "the moving pivot"), ("dp_load", "the loads")])
def test_the_energy_texts_name_what_does_the_work(tmp_path, name, does_work):
    """A moving pivot without forces or damping, a load without a moving pivot: the scene's
    energy line and the energy plot's W name only what the model has."""
    scene = timed_scene(tmp_path, name)
    run_ = derive_cli("run", scene, "--output-dir", tmp_path / "out", cwd=tmp_path)
    assert run_.returncode == 0, run_.stdout + run_.stderr
    energy = next(ln for ln in run_.stdout.splitlines() if ln.startswith("energy"))
    assert f"relative change (the work of {does_work}) " in energy, energy
    assert "forces and damping" not in energy
    o = run(load_scene(scene), show_progress=False)
    fig = energy_figure(plt, o)
    try:
        labels = {ln.get_label() for ln in fig.axes[0].get_lines()}
        assert f"W: work of {does_work}" in labels, labels
    finally:
        plt.close(fig)


def test_a_summary_table_names_what_does_the_work():
    """derive.SimulationResult's summary of a driven, damped model (inputs): its energy change
    is the work of the applied forces and the damping, the words from the model."""
    import derive
    from derive.runtime.result import summary_rows
    r = derive.simulate(str(ROOT / "examples" / "models" / "driven.toml"), [1.0, 0.5, 0, 0], [0.0, 0.5],
                        [1, 1, 1, 1, 9.81, 0.1, 0.1], inputs=[0.5, 0.0], backend="numpy")
    rows = dict(summary_rows(r))
    assert "the work of the applied forces and the damping, not an error" in rows["energy change"], rows
