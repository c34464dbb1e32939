"""`derive sweep` on a local Dask cluster killed with SIGKILL to its whole process group
(the driver, the scheduler in it, the nannies and the workers) in the middle of the run,
then run again into the same store: it computes only the chunks that were not done, every
chunk of the finished store verifies against its digest, and the values equal those of an
uninterrupted sweep bit for bit.  (test_sweep.py kills one worker of a live cluster, and a
driver that runs its chunks in its own process.)"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("zarr")

import derive
from derive.sweep.store import DONE, digests, load

ROOT = Path(__file__).resolve().parents[2]
SWEEP = """
title = "killed sweep"
record = ["flip_time", "max_abs_theta2"]
[pendulum]
model = "planar"
parameters = { m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 9.81 }
[initial]
state = { theta1 = 0.0, theta2 = 0.0 }
rest = true
[time]
stop = 10.0
outputs = 501
[axes]
theta1 = { linspace = ["-pi", "pi"], num = 40 }
theta2 = { linspace = [-3.0, 3.0], num = 40 }
[events.flip]
coordinate = "theta2"
level = "pi"
[sweep]
chunk = 40
mirror = false
"""
CHUNKS = 40


def _done(store: Path) -> int:
    import zarr    # the sweep extra
    try:
        return int(np.asarray(zarr.open_group(str(store), mode="r")[DONE][...]).sum())
    except Exception:        # not created yet, or being created
        return 0


def _group_alive(pgid: int) -> list[int]:
    """The processes still in process group `pgid` (zombies excluded)."""
    alive = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            alive.append(int(entry.name))
    return alive


@pytest.mark.slow
def test_a_cluster_sweep_killed_mid_run_resumes_to_the_same_values(tmp_path):
    path = tmp_path / "k.toml"
    path.write_text(SWEEP)
    store = tmp_path / "o" / "k.zarr"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("DASK_SCHEDULER_ADDRESS", None)
    cmd = [sys.executable, "-m", "derive", "sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "2",
           "--quiet"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)
    deadline = time.monotonic() + 600
    while _done(store) < 2 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    assert proc.poll() is None, f"the sweep ended before it was killed: {proc.stderr.read()}"
    assert _done(store) >= 2, "no chunk was finished in time"
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)
    deadline = time.monotonic() + 30
    while _group_alive(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _group_alive(proc.pid), "a process of the killed sweep survived"
    finished = _done(store)
    assert 2 <= finished < CHUNKS, finished              # really killed in the middle

    again = subprocess.run(cmd[:-1], env=env, capture_output=True, text=True, timeout=1200)
    assert again.returncode == 0, again.stderr
    m = re.search(r"(\d+) done before\)", again.stdout)
    assert m, again.stdout
    assert 1 <= int(m.group(1)) <= finished, (again.stdout, finished)   # flags the digests vouch for
    assert _done(store) == CHUNKS

    ds = load(store)          # checks every chunk marked done against its digest, refuses a bad one
    assert (ds[DONE] == 1).all()
    assert sorted(int(p.name) for p in digests(store).iterdir()) == list(range(CHUNKS))
    reference = derive.sweep(path, out=tmp_path / "fresh", workers=0)
    assert list(reference.data_vars) == list(ds.data_vars)
    for name in list(reference.data_vars) + list(reference.coords):
        assert np.array_equal(reference[name].values, ds[name].values, equal_nan=True), name
