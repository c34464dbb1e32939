"""Sweeps on Dask (derive/sweep): a cluster of 2 worker processes computes what one process
does, bit for bit; a killed worker loses no chunk; a restarted sweep skips finished chunks;
event times agree with SciPy's event location on independent equations; bad sweep files
are one line and exit status 2."""
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.cli import main
from derive.errors import SceneError, UsageError
from derive.sweep import MISSING_EXTRA, level_crossings as events, run_sweep
from derive.sweep.chunk import variables
from derive.sweep.layout import Layout
from derive.sweep.store import open_store
from derive.sweep.sweep_file import load_sweep, parse_sweep

ROOT = Path(__file__).resolve().parents[2]
G = 9.81

SMALL = """
title = "small sweep"
record = {record}
[pendulum]
model = "planar"
parameters = {{ m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 9.81 }}
[initial]
state = {{ theta1 = 0.0, theta2 = 0.0 }}
rest = true
[time]
stop = {stop}
outputs = {outputs}
[axes]
theta1 = {{ linspace = ["-pi", "pi"], num = {n1} }}
theta2 = {{ linspace = [-3.0, 3.0], num = {n2} }}
[events.flip]
coordinate = "theta2"
level = "pi"
[sweep]
chunk = {chunk}
"""
ALL = '["flip_time", "final_state", "energy_error", "max_abs_theta2", "lyapunov_exponent"]'


def write(tmp_path, name="s.toml", record=ALL, stop=2.0, outputs=101, n1=6, n2=5, chunk=10):
    path = tmp_path / name
    path.write_text(SMALL.format(record=record, stop=stop, outputs=outputs, n1=n1, n2=n2, chunk=chunk))
    return path


def same(a, b) -> None:
    """Every variable and coordinate equal, bit for bit (NaN where NaN)."""
    assert list(a.data_vars) == list(b.data_vars)
    for name in list(a.data_vars) + list(a.coords):
        assert np.array_equal(a[name].values, b[name].values, equal_nan=True), name


@pytest.fixture(scope="module")
def cluster():
    from distributed import LocalCluster
    import logging
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as c:
        yield c


def test_two_worker_processes_equal_one_process(tmp_path, cluster):
    path = write(tmp_path)
    one = derive.sweep(path, out=tmp_path / "one", workers=0)
    report = run_sweep(path, out=tmp_path / "two", scheduler=cluster.scheduler_address)
    assert report.computed == report.chunks == 3 and report.workers == 2
    same(one, report.dataset)
    assert one.flip_time.dims == ("theta1", "theta2")
    assert np.isfinite(one.flip_time).any() and np.isnan(one.flip_time).any()
    assert (one.status == 0).all()
    # the store opens with xarray on its own, with the named coordinates
    import xarray as xr
    ds = xr.open_zarr(tmp_path / "one" / "s.zarr", consolidated=False)
    np.testing.assert_array_equal(ds.theta1.values, np.linspace(-np.pi, np.pi, 6))


@pytest.mark.slow     # kills a worker of the cluster and waits for its successor
def test_killed_worker_loses_no_chunk(tmp_path, cluster):
    """A worker killed (SIGKILL) while it runs a chunk: Dask runs its tasks again on the other
    (and on the worker the nanny restarts); every chunk is written once, as in one process."""
    path = write(tmp_path, record='["flip_time", "final_state"]', stop=10.0, outputs=251, n1=40, n2=100,
                 chunk=200)                                # 20 chunks of 200 full-length trajectories
    reference = derive.sweep(path, out=tmp_path / "ref", workers=0)
    killed = []

    def kill_busy_worker(k):
        if killed:
            return
        # the scheduler runs in this process (LocalCluster): its view of the workers
        busy = [w for w in list(cluster.scheduler.workers.values()) if w.processing]
        if busy:                                           # a worker with a chunk in flight
            os.kill(busy[0].pid, signal.SIGKILL)
            killed.append(len(busy[0].processing))

    report = run_sweep(path, out=tmp_path / "killed", scheduler=cluster.scheduler_address,
                       on_chunk=kill_busy_worker)
    assert killed and killed[0] >= 1
    assert report.computed == report.chunks == 20
    same(reference, report.dataset)
    assert (report.dataset.chunk_done == 1).all()


class Stop(Exception):
    pass


def test_restarted_sweep_skips_finished_chunks(tmp_path):
    path = write(tmp_path, record='["flip_time", "max_abs_theta2"]', chunk=5)     # 6 chunks
    seen = []

    def stop_after_two(k):
        seen.append(k)
        if len(seen) == 2:
            raise Stop

    with pytest.raises(Stop):
        run_sweep(path, out=tmp_path / "out", workers=0, on_chunk=stop_after_two)
    again = []
    report = run_sweep(path, out=tmp_path / "out", workers=0, on_chunk=again.append)
    assert (report.skipped, report.computed) == (2, 4)
    assert not set(again) & set(seen)
    same(derive.sweep(path, out=tmp_path / "fresh", workers=0), report.dataset)
    # another sweep into the same store is refused, not mixed in
    other = write(tmp_path, name="s.toml", record='["flip_time", "max_abs_theta2"]', chunk=5, stop=3.0)
    with pytest.raises(UsageError, match="holds another sweep"):
        run_sweep(other, out=tmp_path / "out", workers=0)


def test_cli_sweep_writes_store_and_images(tmp_path, capsys):
    path = write(tmp_path, record='["flip_time", "final_state"]')
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "0"]) == 0
    out = capsys.readouterr().out
    assert "3 computed on this process" in out and "s.zarr" in out
    images = sorted(p.name for p in (tmp_path / "o").glob("*.png"))
    assert images == ["s_final_theta1.png", "s_final_theta1_dot.png", "s_final_theta2.png",
                      "s_final_theta2_dot.png", "s_flip_time.png"]
    assert (tmp_path / "o" / "s_flip_time.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "0"]) == 0
    assert "0 computed on this process, 3 done before" in capsys.readouterr().out


def test_energy_error_has_no_outlier_where_the_energy_is_zero(tmp_path):
    """The grid holds theta1 = theta2 = pi/2 at rest, where E0 = 0 to rounding: relative to
    |E0| its energy error was an outlier by orders of magnitude; relative to max(|E0|, m g l)
    it is one of the others, and the store says what the variable is relative to."""
    path = tmp_path / "e.toml"
    path.write_text(SMALL.format(record='["energy_error"]', stop=2.0, outputs=101, n1=3, n2=3, chunk=9)
                    .replace('linspace = ["-pi", "pi"]', 'linspace = ["-pi/2", "pi/2"]')
                    .replace("linspace = [-3.0, 3.0]", 'linspace = ["-pi/2", "pi/2"]'))
    ds = derive.sweep(path, out=tmp_path / "o", workers=0)
    errors = ds.energy_error.values
    assert abs(ds.theta1.values[-1] - np.pi / 2) < 1e-15 and abs(ds.theta2.values[-1] - np.pi / 2) < 1e-15
    assert np.all(errors < 1e-8) and errors[-1, -1] < 100 * np.median(errors)
    assert "max(|E0|, m g l)" in ds.energy_error.attrs["long_name"]


# -- event location -------------------------------------------------------------------------

def _textbook_rhs(t, y):
    """The point-mass double pendulum, m = l = 1, absolute angles (the textbook closed form,
    written independently of derive's derivation)."""
    t1, t2, w1, w2 = y
    d = t1 - t2
    den = 3 - np.cos(2 * d)
    a1 = (-3 * G * np.sin(t1) - G * np.sin(t1 - 2 * t2) - 2 * np.sin(d) * (w2 * w2 + w1 * w1 * np.cos(d))) / den
    a2 = 2 * np.sin(d) * (2 * w1 * w1 + 2 * G * np.cos(t1) + w2 * w2 * np.cos(d)) / den
    return [w1, w2, a1, a2]


def _scipy_flip(y0, t_end):
    from scipy.integrate import solve_ivp
    up = lambda t, y: y[1] - np.pi
    down = lambda t, y: y[1] + np.pi
    up.terminal = down.terminal = True
    up.direction, down.direction = 1, -1
    r = solve_ivp(_textbook_rhs, (0, t_end), y0, method="DOP853", rtol=1e-12, atol=1e-14, events=(up, down))
    times = [e[0] for e in r.t_events if len(e)]
    return min(times) if times else np.nan


def test_flip_times_match_solve_ivp_events_to_1e_6():
    """The flip map's own settings (derive/scenes/flip_map.toml) on 24 random starts,
    against SciPy's DOP853 at rtol 1e-12 with event functions on the textbook equations."""
    from derive.sweep.chunk import integrate
    sweep = load_sweep("flip_map")
    rng = np.random.default_rng(7)
    y0 = np.zeros((24, 4))
    y0[:, :2] = rng.uniform(-np.pi, np.pi, (24, 2))
    ours = integrate(sweep, y0, np.repeat(sweep.p[None], 24, axis=0))["flip_time"]
    reference = np.array([_scipy_flip(y, 10.0) for y in y0])
    assert np.array_equal(np.isnan(ours), np.isnan(reference))
    assert np.isfinite(ours).sum() >= 8
    assert np.nanmax(np.abs(ours - reference)) < 1e-6


def test_verified_flip_time_beyond_double_precision():
    """A slow, late crossing (t = 8.73, theta2' = -0.10 there) whose flip time one double run
    misses by 2e-5 at DOP853's rtol 1e-12 (and by 2e-3 at the map's Taylor rtol 1e-9; still
    by 7e-6 at Taylor's 1e-12): the verification (accuracy = 1e-6) finds the disagreement and
    takes the long-double run, which agrees with DOP853 in long double at rtol 1e-17."""
    import dataclasses
    from derive.runtime.build import integrator_library
    from derive.sweep.chunk import integrate
    sweep = load_sweep("flip_map")
    assert sweep.events[0].accuracy == 1e-6
    y0 = np.array([[2.0431070807948766, -2.489298280594387, 0.0, 0.0]])
    p = sweep.p[None]
    lib = integrator_library("planar")
    opt = lib.defaults()
    opt.rtol, opt.atol = 1e-17, 1e-20
    pl, t = np.array(sweep.p, np.longdouble), np.linspace(0, 10, 1001).astype(np.longdouble)

    def run(rows, start, local):
        y, infos = lib.run(2, np.ascontiguousarray(start, dtype=np.longdouble), pl, np.asarray(local, np.longdouble), opt)
        return y, np.array([i.status for i in infos])

    reference = events.locate(run, lib.run(2, y0.astype(np.longdouble), pl, t, opt)[0], t, 1, np.pi)[0]
    unverified = dataclasses.replace(sweep, events=(dataclasses.replace(sweep.events[0], accuracy=None),))
    assert abs(integrate(unverified, y0, p)["flip_time"][0] - reference) > 1e-5
    out = integrate(sweep, y0, p)
    assert abs(out["flip_time"][0] - reference) < 1e-7
    assert 0 < out["flip_time_error"][0] < 1e-6


def test_locate_finds_crossings_and_grazes_between_samples():
    """q = A sin(t) sampled exactly: the first |q| = c is asin(c / A), also when the excursion
    beyond c lies wholly between two samples (a graze the samples alone would miss)."""
    c = 1.0

    def exact(A):
        def run(rows, start, local):
            t0 = np.arctan2(start[:, 0], start[:, 1])          # (A sin t0, A cos t0): its phase
            tt = t0[:, None] + local[None, :]
            y = np.stack([A[rows, None] * np.sin(tt), A[rows, None] * np.cos(tt)], axis=-1)
            return y, np.zeros(len(rows), int)
        return run

    A = np.array([2.0, 1.0 + 1e-4, 0.995])
    t = np.linspace(0.0, 2.8, 15)                # samples 0.2 apart: none near pi/2 for the graze
    tt = t[None, :]
    y = np.stack([A[:, None] * np.sin(tt), A[:, None] * np.cos(tt)], axis=-1)
    assert np.all(np.abs(y[1, :, 0]) < c)        # the samples never see the graze
    found = events.locate(exact(A), y, t, 0, c)
    expected = np.arcsin(c / A[:2])
    # the fine cubic's remainder: (0.2 / 32)^4 / 384 max|q^(4)| = 8e-12 in q, over |q'| at the
    # crossing (0.014 for the graze): at most 6e-10 in t
    np.testing.assert_allclose(found[:2], expected, rtol=0, atol=1e-9)
    assert np.isnan(found[2])                    # a candidate (within MARGIN of c) that never reaches it


def test_energy_bound_is_the_flip_criterion():
    """From the energy kernel alone: link 2 of the m = l = 1 pendulum can flip from rest only
    where 2 cos(theta1) + cos(theta2) <= 1 (V on |theta2| = pi is at least -g)."""
    from derive.sweep.bounds import floor, unreachable
    low = floor("planar", 1, np.pi, (1.0, 1.0, 1.0, 1.0, G))
    assert -G * (1 + 2e-6) < low < -G
    sweep = load_sweep("flip_map")
    rng = np.random.default_rng(3)
    y0 = np.zeros((2000, 4))
    y0[:, :2] = rng.uniform(-np.pi, np.pi, (2000, 2))
    mask = unreachable("planar", sweep, y0, np.repeat(sweep.p[None], 2000, axis=0))
    criterion = 2 * np.cos(y0[:, 0]) + np.cos(y0[:, 1])
    assert np.array_equal(mask[np.abs(criterion - 1) > 1e-5], (criterion > 1)[np.abs(criterion - 1) > 1e-5])
    assert 0.2 < mask.mean() < 0.4


def test_verification_keeps_every_flip_time_within_its_accuracy():
    """The map's settings on 40 random starts: every verified flip time within 1e-6 of DOP853 in
    long double at rtol 1e-16 (another method, far tighter), each error estimate below the
    accuracy, and far closer than one unverified pass at the map's tolerance."""
    import dataclasses
    from derive.sweep.chunk import integrate
    sweep = load_sweep("flip_map")
    rng = np.random.default_rng(11)
    y0 = np.zeros((40, 4))
    y0[:, :2] = rng.uniform(-np.pi, np.pi, (40, 2))
    p = np.repeat(sweep.p[None], 40, axis=0)
    out = integrate(sweep, y0, p)
    reference = _long_double_flips(sweep, y0, rtol=1e-16)
    assert np.array_equal(np.isnan(out["flip_time"]), np.isnan(reference))
    flips = np.isfinite(reference)
    assert flips.sum() >= 15
    verified = np.abs(out["flip_time"] - reference)[flips]
    assert verified.max() < 1e-6
    assert np.all(out["flip_time_error"][flips] < 1e-6)
    unverified = dataclasses.replace(sweep, events=(dataclasses.replace(sweep.events[0], accuracy=None),))
    assert np.abs(integrate(unverified, y0, p)["flip_time"] - reference)[flips].max() > 10 * verified.max()


def _long_double_flips(sweep, y0, rtol=1e-17):
    from derive.runtime.build import integrator_library
    lib = integrator_library("planar")
    opt = lib.defaults()
    opt.rtol, opt.atol = rtol, rtol * 1e-3
    pl, t = np.array(sweep.p, np.longdouble), np.linspace(0, 10, 1001).astype(np.longdouble)

    def run(rows, start, local):
        y, infos = lib.run(2, np.ascontiguousarray(start, dtype=np.longdouble), pl, np.asarray(local, np.longdouble), opt)
        return y, np.array([i.status for i in infos])

    return events.locate(run, lib.run(2, y0.astype(np.longdouble), pl, t, opt)[0], t, 1, np.pi)


# -- the mirror symmetry ------------------------------------------------------------------

@pytest.mark.slow     # the sweep twice, with and without mirror images: about 45 s
def test_mirror_images_equal_computing_every_chunk(tmp_path):
    """The flip map on a 40 x 40 grid: half the chunks computed and half written as their
    mirror images equals every chunk computed, bit for bit (the verified flip times and their
    error estimates, the final states negated)."""
    text = (ROOT / "scenes" / "flip_map.toml").read_text().replace("num = 1000", "num = 40")
    text = text.replace('record = ["flip_time"]', 'record = ["flip_time", "final_state", "max_abs_theta1"]')
    text = text.replace("stop = 10.0", "stop = 3.0").replace("outputs = 251", "outputs = 76")
    text = text.replace("chunk = 10000", "chunk = 160")
    (tmp_path / "m.toml").write_text(text)
    (tmp_path / "all.toml").write_text(text.replace("chunk = 160", "chunk = 160\nmirror = false"))
    mirrored = run_sweep(tmp_path / "m.toml", out=tmp_path / "m", workers=0)
    computed = run_sweep(tmp_path / "all.toml", out=tmp_path / "all", workers=0)
    assert (mirrored.mirrored, mirrored.chunks, computed.mirrored) == (5, 10, 0)
    assert mirrored.computed_trajectories == 800 and computed.computed_trajectories == 1600
    same(mirrored.dataset, computed.dataset)
    ds = mirrored.dataset
    assert np.isfinite(ds.flip_time).sum() > 100
    np.testing.assert_array_equal(ds.theta1.values, -ds.theta1.values[::-1])


def test_mirror_only_where_the_sweep_has_it(tmp_path):
    """No mirror for a grid that is not symmetric, a base state off zero, a quantity the mirror
    is not checked for, or a model that is not odd (a constant torque): the check on the
    integrator itself sees the last."""
    from derive.sweep.layout import Layout
    from derive.sweep.mirror import plan
    path = write(tmp_path, record='["flip_time", "final_state"]')
    assert plan(load_sweep(path), Layout(load_sweep(path))) is not None
    cases = [("theta2 = { linspace = [-3.0, 3.0]", "theta2 = { linspace = [-3.0, 2.9]"),
             ("theta1 = 0.0, theta2 = 0.0 }\nrest = true", "theta1 = 0.0, theta2 = 0.0, theta1_dot = 0.1, theta2_dot = 0.0 }"),
             ('record = ["flip_time", "final_state"]', 'record = ["flip_time", "energy_error"]')]
    for old, new in cases:
        text = path.read_text()
        assert old in text
        (tmp_path / "x.toml").write_text(text.replace(old, new))
        sweep = load_sweep(tmp_path / "x.toml")
        assert plan(sweep, Layout(sweep)) is None, new
    driven = (ROOT / "examples" / "models" / "driven.toml").resolve()
    text = path.read_text().replace('model = "planar"', f'model = "{driven}"').replace(
        "g = 9.81 }", "g = 9.81, c1 = 0.1, c2 = 0.1 }\ninputs = { tau1 = TAU, tau2 = 0.0 }")
    for tau, axis, odd in (("0.0", "", True), ("0.5", "", False), ("0.0", "tau1 = { list = [0.0, 0.5] }\n", False)):
        (tmp_path / "d.toml").write_text(text.replace("TAU", tau).replace("[axes]\n", "[axes]\n" + axis))
        sweep = load_sweep(tmp_path / "d.toml")
        assert (plan(sweep, Layout(sweep)) is not None) == odd, (tau, axis)


def test_taylor_in_a_sweep_file(tmp_path):
    """accuracy.method = "taylor" (a sweep's): its tolerance is rtol alone, an atol is one line."""
    path = write(tmp_path, record='["flip_time"]')
    text = path.read_text().replace("[axes]", '[accuracy]\nmethod = "taylor"\nrtol = 1e-9\n[axes]')
    path.write_text(text)
    sweep = load_sweep(path)
    assert (sweep.scene.method, sweep.scene.rtol, sweep.scene.atol) == ("taylor", 1e-9, None)
    path.write_text(text.replace("rtol = 1e-9", "rtol = 1e-9\natol = 1e-12"))
    with pytest.raises(SceneError, match="atol' does not apply to taylor"):
        load_sweep(path)


# -- sweep files ----------------------------------------------------------------------------

def test_parameter_and_random_axes(tmp_path):
    text = SMALL.format(record='["final_state", "lyapunov_exponent"]', stop=1.0, outputs=21, n1=1, n2=1,
                        chunk=7)
    text = text.replace('theta1 = { linspace = ["-pi", "pi"], num = 1 }\ntheta2 = { linspace = [-3.0, 3.0], num = 1 }',
                        'm2 = { logspace = [0.1, 10], num = 3 }\nl2 = { list = [0.5, 2] }\n'
                        'theta1 = { uniform = [0.5, 1.0], samples = 4, seed = 11 }\n'
                        'theta2_dot = { normal = [0.0, 0.1], samples = 4, seed = 12 }')
    (tmp_path / "p.toml").write_text(text)
    ds = derive.sweep(tmp_path / "p.toml", out=tmp_path, workers=0)
    assert ds.final_theta1.dims == ("m2", "l2", "sample")
    np.testing.assert_allclose(ds.m2.values, [0.1, 1.0, 10.0])
    np.testing.assert_array_equal(ds.theta1.values, np.random.default_rng(11).uniform(0.5, 1.0, 4))
    # one trajectory against derive.simulate and the Lyapunov exponent of trust.py
    from derive.measurement.trust import largest_lyapunov
    y0 = [float(ds.theta1[2]), 0.0, 0.0, float(ds.theta2_dot[2])]
    params = {"m1": 1.0, "m2": 10.0, "l1": 1.0, "l2": 0.5, "g": G}
    r = derive.simulate("planar", y0, np.linspace(0, 1, 11), params, rtol=1e-10, atol=1e-13)
    final = [float(ds[f"final_{s}"].sel(m2=10.0, l2=0.5)[2]) for s in ("theta1", "theta2", "theta1_dot", "theta2_dot")]
    np.testing.assert_allclose(final, r.y[-1], rtol=0, atol=1e-8)
    lam = largest_lyapunov("planar", y0, params, 1.0).exponent
    assert abs(float(ds.lyapunov_exponent.sel(m2=10.0, l2=0.5)[2]) - lam) < 1e-9


BAD = [
    ("unknown axis", ("theta1 = {", "theta9 = {"), "unknown axis"),
    ("empty axis", ("num = 6", "num = 0"), "the axis is empty"),
    ("empty list", ('theta1 = { linspace = ["-pi", "pi"], num = 6 }', "theta1 = { list = [] }"), "is empty"),
    ("unknown quantity", ('"flip_time", "final_state"', '"flip_time", "wobble"'), "unknown quantity 'wobble'"),
    ("undeclared event", ('"flip_time", "final_state"', '"spin_time", "final_state"'), "declare the event"),
    ("bad parameter", ("theta2 = {", 'l2 = { list = [1.0, -1.0] }\ntheta2 = {'), "l2 = -1"),
    ("bad number", ('["-pi", "pi"]', '["-pi", "tau"]'), "expression of pi"),
    ("bad accuracy", ('level = "pi"', 'level = "pi"\naccuracy = -1'), "accuracy must be positive"),
]


@pytest.mark.parametrize("what, edit, message", BAD, ids=[b[0] for b in BAD])
def test_bad_sweep_file_is_one_line_exit_2(tmp_path, capsys, what, edit, message):
    path = write(tmp_path, record='["flip_time", "final_state"]')
    text = path.read_text()
    assert edit[0] in text
    path.write_text(text.replace(edit[0], edit[1], 1))
    assert main(["sweep", str(path), "--workers", "0", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("derive: error:") and message in err[0], err
    assert str(path) in err[0]
    assert not (tmp_path / "o").exists()


def test_bad_sweep_file_from_the_shell_and_a_missing_extra(tmp_path):
    path = write(tmp_path, record='["nothing"]')
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "derive", "sweep", str(path)], capture_output=True, text=True, env=env)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "unknown quantity" in r.stderr
    hide = "import sys; sys.modules['zarr'] = None; from derive.cli import main; sys.exit(main(sys.argv[1:]))"
    r = subprocess.run([sys.executable, "-c", hide, "sweep", str(path)], capture_output=True, text=True, env=env)
    assert r.returncode == 2 and r.stderr.strip() == f"derive: error: {MISSING_EXTRA}"


@pytest.mark.slow     # a sweep of its own on a local cluster
def test_a_sweep_piped_to_a_log_says_how_far_it_is(tmp_path):
    """stdout not a terminal (a pipe, here): a plain line per chunk as it finishes, then the
    summary; --quiet prints none."""
    path = write(tmp_path, record='["flip_time"]', stop=0.5, outputs=26, n1=6, n2=5, chunk=5)   # 6 chunks
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "derive", "sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "0"]
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    progress = [line for line in lines if line.startswith("sweeping s: ")]
    assert progress[0] == "sweeping s: 0/6 chunks (0%), " + progress[0].split(", ")[1]
    assert [line.split(" chunks")[0] for line in progress] == [f"sweeping s: {k}/6" for k in range(7)]
    assert progress[-1].startswith("sweeping s: 6/6 chunks (100%)")
    assert lines.index(progress[-1]) < next(i for i, line in enumerate(lines) if line.startswith("sweep   "))
    assert "\r" not in r.stdout + r.stderr
    r = subprocess.run(cmd[:5] + ["--out", str(tmp_path / "q"), "--workers", "0", "--quiet"],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0 and r.stdout == "", r.stdout


def test_status_is_stored_as_an_integer(tmp_path):
    """status reads back as integers (0 ok, -1 not run) with xarray alone, and through
    derive's load; so does chunk_done."""
    import xarray as xr    # the sweep extra
    path = write(tmp_path, record='["flip_time"]', stop=0.5, outputs=26, n1=6, n2=5, chunk=5)
    sweep = load_sweep(path)
    open_store(tmp_path / "fresh.zarr", sweep, Layout(sweep), variables(sweep))   # no chunk run yet
    with xr.open_zarr(tmp_path / "fresh.zarr", consolidated=False) as ds:
        assert ds.status.dtype == np.int8 and (ds.status.values == -1).all()
        assert ds.chunk_done.dtype == np.int8 and (ds.chunk_done.values == 0).all()
    loaded = derive.sweep(path, out=tmp_path / "o", workers=0)
    assert loaded.status.dtype == np.int8 and (loaded.status == 0).all()
    with xr.open_zarr(tmp_path / "o" / "s.zarr", consolidated=False) as ds:
        assert ds.status.dtype == np.int8 and (ds.status.values == 0).all()
        assert ds.chunk_done.dtype == np.int8 and (ds.chunk_done.values == 1).all()
        assert ds.flip_time.dtype == np.float64


def test_sweep_file_is_not_a_scene():
    with pytest.raises(SceneError, match="derive sweep"):
        derive.scene.load_scene(ROOT / "scenes" / "flip_map.toml")
    with pytest.raises(SceneError, match="spherical_std"):
        parse_sweep((ROOT / "scenes" / "flip_map.toml").read_text().replace('"planar"', '"spherical"'))


@pytest.mark.slow
def test_killed_sweep_process_resumes(tmp_path):
    """A `derive sweep` process killed mid-way (SIGKILL): the rerun skips its finished chunks
    and the store ends equal to an uninterrupted run's."""
    import time
    path = write(tmp_path, record='["flip_time"]', stop=10.0, outputs=501, n1=40, n2=40, chunk=40)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "derive", "sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "0"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    import zarr
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        time.sleep(0.2)
        try:
            done = int(np.asarray(zarr.open_group(str(tmp_path / "o" / "s.zarr"), mode="r")["chunk_done"][...]).sum())
        except Exception:
            continue
        if done >= 3:
            break
    proc.kill()
    proc.wait()
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "done before" in r.stdout and ", 0 done before" not in r.stdout
    same(derive.sweep(path, out=tmp_path / "fresh", workers=0),
         __import__("derive.sweep.store", fromlist=["load"]).load(tmp_path / "o" / "s.zarr"))


@pytest.mark.slow
def test_ctrl_c_during_a_sweep_on_local_workers_is_one_line(tmp_path):
    """Ctrl-C reaches the terminal's whole process group, the local Dask workers too: the
    sweep still stops with one line and status 130 (no worker tracebacks), and its rerun
    resumes the store to the end."""
    import time
    import zarr
    path = write(tmp_path, record='["flip_time"]', stop=10.0, outputs=501, n1=40, n2=40, chunk=40)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "derive", "sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "2"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True,          # its own group, as a terminal's job
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline:
        time.sleep(0.2)
        try:
            if int(np.asarray(zarr.open_group(str(tmp_path / "o" / "s.zarr"), mode="r")["chunk_done"][...]).sum()):
                break
        except Exception:
            continue
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130 and err.strip().splitlines() == ["derive: interrupted"], (proc.returncode, err)
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    assert r.returncode == 0 and "done before" in r.stdout, r.stderr
