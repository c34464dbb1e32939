"""examples/c: built with its own Makefile and run, as a user of another project would."""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "c"


def _numpy_planar():
    spec = importlib.util.spec_from_file_location("generated_numpy_planar_example",
                                                  ROOT / "generated" / "numpy" / "planar.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _rk4(rhs, y, p, t_end, steps):
    h = t_end / steps
    for _ in range(steps):
        k1 = rhs(y, p)
        k2 = rhs(y + 0.5 * h * k1, p)
        k3 = rhs(y + 0.5 * h * k2, p)
        k4 = rhs(y + h * k3, p)
        y = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return y


@pytest.mark.skipif(shutil.which("make") is None and not os.environ.get("CI"),
                    reason="make not installed (CI requires it)")
def test_example_builds_and_integrates_the_default_scene(tmp_path):
    build = tmp_path / "build"
    subprocess.run(["make", "-C", str(EXAMPLE), f"BUILD={build}"], check=True, capture_output=True)
    assert not (EXAMPLE / "build").exists()          # nothing written into the source tree

    scene = tomllib.loads((ROOT / "scenes" / "default.toml").read_text())
    assert scene["pendulum"]["model"] == "planar"
    mod = _numpy_planar()
    y0 = np.array([scene["initial"]["state"][n] for n in mod.STATE_NAMES])
    p = np.array([scene["pendulum"]["parameters"][n] for n in mod.PARAM_NAMES])
    t_end, steps = float(scene["time"]["stop"]), 5000
    args = [*(repr(float(v)) for v in y0), repr(t_end), str(steps), *(repr(float(v)) for v in p)]
    run = subprocess.run([str(build / "planar_rk4"), *args], capture_output=True, text=True, check=True)
    out = dict(line.split() for line in run.stdout.splitlines())
    assert out["status"] == "0"
    final = np.array([float(out[n]) for n in mod.STATE_NAMES])

    # the same RK4 in Python on the generated NumPy rhs: the motion is chaotic, so
    # last-bit differences (libm vs NumPy sin) grow, but stay far below 1e-6 by t = 5
    expected = _rk4(mod.rhs, y0, p, t_end, steps)
    assert np.max(np.abs(final - expected)) < 1e-6 * np.max(np.abs(expected))
    e0, e1 = float(out["energy_initial"]), float(out["energy_final"])
    assert e0 == pytest.approx(float(mod.energy(y0, p)), rel=1e-15)
    assert e1 == pytest.approx(float(mod.energy(final, p)), rel=1e-12)
    assert abs(e1 - e0) < 1e-8 * abs(e0)             # RK4 with h = 1e-3 conserves energy well

    # the default arguments are that scene
    run_default = subprocess.run([str(build / "planar_rk4")], capture_output=True, text=True, check=True)
    assert run_default.stdout == run.stdout
