"""A sweep store that cannot lie: every chunk marked done is checked against the digest
written with it (on resume and on opening), a missing or damaged chunk is named and
recomputed, one sweep writes a store at a time, and hopeless sweeps are refused at once."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("zarr")

import derive
from derive.errors import SceneError, UsageError
from derive.sweep import run_sweep
from derive.sweep.store import Lock, load

ROOT = Path(__file__).resolve().parents[2]
SMALL = """
title = "small sweep"
record = ["flip_time", "max_abs_theta2"]
[pendulum]
model = "planar"
parameters = { m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 9.81 }
[initial]
state = { theta1 = 0.0, theta2 = 0.0 }
rest = true
[time]
stop = 2.0
outputs = 101
[axes]
theta1 = { linspace = ["-pi", "pi"], num = NUM }
theta2 = { linspace = [-3.0, 3.0], num = 5 }
[events.flip]
coordinate = "theta2"
level = "pi"
[sweep]
chunk = 5
mirror = false
"""


def write(tmp_path, num="6"):
    path = tmp_path / "s.toml"
    path.write_text(SMALL.replace("NUM", num))
    return path


def same(a, b) -> None:
    for name in list(a.data_vars) + list(a.coords):
        assert np.array_equal(a[name].values, b[name].values, equal_nan=True), name


def cli(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "derive", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def chunk_files(store: Path, name: str) -> list[Path]:
    return sorted(p for p in (store / name).rglob("*") if p.is_file() and not p.name.startswith("zarr"))


@pytest.fixture()
def finished(tmp_path):
    path = write(tmp_path)
    report = run_sweep(path, out=tmp_path / "o", workers=0, progress=False)
    assert report.computed == report.chunks == 6
    return path, tmp_path / "o" / "s.zarr", report.dataset


def test_a_deleted_chunk_is_named_and_recomputed(finished, capfd):
    path, store, before = finished
    files = chunk_files(store, "max_abs_theta2")
    assert len(files) == 6
    files[2].unlink()
    with pytest.raises(UsageError, match=r"1 chunk marked done is missing or damaged \(chunk \d\)"):
        load(store)                                      # never read back as if it were right
    capfd.readouterr()
    report = run_sweep(path, out=store.parent, workers=0, progress=False)
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "missing or damaged (chunk" in err[0] and "computing it again" in err[0]
    assert (report.computed, report.skipped) == (1, 5)
    same(before, report.dataset)
    same(before, load(store))


def test_random_bytes_in_a_chunk_are_healed(finished, capfd):
    path, store, before = finished
    victim = chunk_files(store, "max_abs_theta2")[-1]
    victim.write_bytes(os.urandom(victim.stat().st_size or 64))
    with pytest.raises(UsageError, match="missing or damaged"):
        load(store)
    report = run_sweep(path, out=store.parent, workers=0, progress=False)
    assert report.computed == 1 and "missing or damaged" in capfd.readouterr().err
    same(before, report.dataset)


def test_a_chunk_without_its_digest_is_not_counted_done(finished):
    """A process killed after a chunk's values but before its digest and flag: the chunk is
    computed again (the flag set without a digest is treated the same)."""
    path, store, before = finished
    (store.with_name(store.name + ".sha256") / "0").unlink()
    report = run_sweep(path, out=store.parent, workers=0, progress=False)
    assert report.computed == 1
    same(before, report.dataset)


def test_two_sweeps_into_one_store_the_second_is_refused(tmp_path):
    path = write(tmp_path)
    store = tmp_path / "o" / "s.zarr"
    held = Lock(store)                 # a sweep writing it (in another process: the same flock)
    try:
        with pytest.raises(UsageError, match="being written by another sweep"):
            run_sweep(path, out=tmp_path / "o", workers=0, progress=False)
        r = cli("sweep", str(path), "--out", "o", "--workers", "0", cwd=tmp_path)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and "being written by another sweep" in lines[0]
    finally:
        held.release()
    assert run_sweep(path, out=tmp_path / "o", workers=0, progress=False).computed == 6


def test_a_closed_scheduler_port_is_one_line_exit_2(tmp_path):
    import socket
    with socket.socket() as s:                     # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    r = cli("sweep", str(write(tmp_path)), "--scheduler", f"tcp://127.0.0.1:{port}", "--out", "o", cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "cannot reach the Dask scheduler" in lines[0], r.stderr


@pytest.mark.parametrize("axes", ["theta1 = { linspace = [0, 1], num = 1000000000000 }",
                                  "theta1 = { linspace = [0, 1], num = 1000000 }\n"
                                  "theta2 = { linspace = [0, 1], num = 1000000 }"])
def test_a_sweep_of_10_12_points_is_refused_before_allocation(tmp_path, axes):
    text = SMALL.replace('theta1 = { linspace = ["-pi", "pi"], num = NUM }\ntheta2 = { linspace = [-3.0, 3.0], num = 5 }', axes)
    (tmp_path / "big.toml").write_text(text)
    from derive.sweep.sweep_file import load_sweep
    import resource
    with pytest.raises(SceneError, match="split it"):
        load_sweep(tmp_path / "big.toml")
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss < 4 << 20     # KiB: nothing of terabytes
