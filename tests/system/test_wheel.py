"""The wheel is the product: built, installed into a fresh venv and run from an empty
folder outside the checkout, it works, and writes only into that folder and the cache.

The venv sees the test machine's numpy, sympy and jinja2 through a path line (a .pth
that adds the system site-packages to sys.path without running its .pth files, so an
editable install of this checkout cannot shadow the wheel), so nothing is downloaded
but the build backend.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODEL = """
name = "rodtip"
title = "A rod with a point mass at its tip"
dimension = 2
parameters = ["m1", "m2", "l1", "l2", "L1", "g"]

[[links]]
chart = "planar"
length = "l1"
body = { kind = "rod", mass = "m1", com = "1/2", inertia = "L1" }

[[links]]
chart = "planar"
length = "l2"
body = { kind = "point", mass = "m2" }
"""

pytestmark = pytest.mark.slow


def _tree_digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and "__pycache__" not in p.parts}


def _checkout_state() -> tuple[str, dict[str, str]]:
    status = subprocess.run(["git", "status", "--porcelain", "--ignored", "--untracked-files=all"],
                            cwd=ROOT, capture_output=True, text=True).stdout
    return status, _tree_digest(ROOT / "generated")


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """A venv with the freshly built wheel of this checkout installed (not editable)."""
    base = tmp_path_factory.mktemp("wheel")
    wheels = base / "dist"
    # built from a copy of the tree: pip builds in-tree (build/), which two test workers
    # building at once would race on, and which would write into the checkout
    source = base / "source"
    shutil.copytree(ROOT, source, symlinks=True, ignore=shutil.ignore_patterns(
        ".git", "build", "*.egg-info", ".venv", "__pycache__", ".pytest_cache", "derive-bench", "out"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(wheels), str(source)],
                   check=True, timeout=600)
    (wheel,) = wheels.glob("derive-*.whl")
    env_dir = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(env_dir)], check=True, timeout=300)
    py = env_dir / "bin" / "python"
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (Path(site) / "test-machine-packages.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", str(wheel)], check=True, timeout=300)
    return env_dir, Path(site)


def _derive(env_dir: Path, cwd: Path, cache: Path, *args):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "DERIVE_CACHE_DIR")}
    env["DERIVE_CACHE_DIR"] = str(cache)
    return subprocess.run([str(env_dir / "bin" / "derive"), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=900)


def test_the_wheel_runs_a_scene_and_writes_only_where_told(venv, tmp_path):
    env_dir, site = venv
    work, cache = tmp_path / "empty", tmp_path / "cache"
    work.mkdir()
    where = subprocess.run([str(env_dir / "bin" / "python"), "-c", "import derive; print(derive.__file__)"],
                           cwd=work, capture_output=True, text=True, check=True).stdout
    assert where.startswith(str(site)), f"the venv imports derive from {where}, not from the wheel"
    before_site, before_checkout = _tree_digest(site / "derive"), _checkout_state()

    run = _derive(env_dir, work, cache, "run", "default")
    assert run.returncode == 0, run.stderr
    assert "final-state error" in run.stdout or "achieved" in run.stdout
    assert (work / "out" / "default" / "default.csv").is_file()
    assert any((cache / "generated").glob("planar-*/c/planar_integrate.c"))
    assert any((cache / "c-build").glob("*/*.so"))

    assert _tree_digest(site / "derive") == before_site, "the scene run changed site-packages"
    assert _checkout_state() == before_checkout, "the scene run changed the checkout"
    assert sorted(p.name for p in work.iterdir()) == ["out"]


def test_the_wheel_generates_a_model_file_and_knows_its_version(venv, tmp_path):
    env_dir, _ = venv
    work, cache = tmp_path / "empty", tmp_path / "cache"
    work.mkdir()
    (work / "mine.toml").write_text(MODEL)
    version = _derive(env_dir, work, cache, "--version")
    assert version.returncode == 0 and version.stdout.startswith("derive ")
    gen = _derive(env_dir, work, cache, "generate", "mine.toml", "--out", "gen")
    assert gen.returncode == 0, gen.stderr
    c = (work / "gen" / "c" / "rodtip.c").read_text()
    assert f"{version.stdout.split()[1]} from templates/c/source.c.jinja for rodtip (model sha256 " in c
    assert (work / "gen" / "numpy" / "rodtip_integrate.py").is_file()
    check = _derive(env_dir, work, cache, "generate", "mine.toml", "--out", "gen", "--check")
    assert check.returncode == 0 and "up to date" in check.stdout
    # installed, there are no golden files: one line, exit 2
    golden = _derive(env_dir, work, cache, "generate")
    assert golden.returncode == 2 and golden.stderr.count("\n") == 1 and "--out DIR" in golden.stderr


SWEEP = """
title = "rod-tip flips"
record = ["flip_time", "final_state"]
[pendulum]
model = "models/rodtip.toml"
parameters = { m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, L1 = 0.08, g = 9.81 }
[initial]
state = { theta1 = 0.0, theta2 = 0.0 }
rest = true
[time]
stop = 3.0
outputs = 76
[axes]
theta1 = { linspace = ["-pi", "pi"], num = 6 }
theta2 = { linspace = [-3.0, 3.0], num = 6 }
[events.flip]
coordinate = "theta2"
level = "pi"
[sweep]
chunk = 12
"""


def test_the_wheel_sweeps_a_model_file_on_two_workers_without_a_checkout(venv, tmp_path):
    """`derive sweep` from the wheel, outside the checkout, on a local cluster of 2 worker
    processes: the model file (relative to the sweep file) travels to the workers as its
    description, each builds or loads the integrator from the cache; nothing else is written."""
    env_dir, site = venv
    work, cache = tmp_path / "empty", tmp_path / "cache"
    (work / "models").mkdir(parents=True)
    (work / "models" / "rodtip.toml").write_text(MODEL)
    (work / "flips.toml").write_text(SWEEP)
    before_site, before_checkout = _tree_digest(site / "derive"), _checkout_state()
    run = _derive(env_dir, work, cache, "sweep", "flips.toml", "--workers", "2", "--out", "out")
    assert run.returncode == 0, run.stderr
    assert "3 computed on a local cluster of 2 worker processes" in run.stdout
    check = subprocess.run([str(env_dir / "bin" / "python"), "-c",
                            "import xarray as xr; ds = xr.open_zarr('out/flips.zarr', consolidated=False); "
                            "print(list(ds.flip_time.dims), int(ds.flip_time.notnull().sum()), "
                            "int((ds.status == 0).sum()))"],
                           cwd=work, capture_output=True, text=True)
    assert check.returncode == 0, check.stderr
    dims, flips, ok = check.stdout.rsplit(" ", 2)
    assert dims == "['theta1', 'theta2']" and int(flips) > 0 and int(ok) == 36
    assert (work / "out" / "flips_flip_time.png").is_file()
    assert any((cache / "sweep-models").glob("*.toml"))          # the workers' copy of the model
    assert _tree_digest(site / "derive") == before_site, "the sweep changed site-packages"
    assert _checkout_state() == before_checkout, "the sweep changed the checkout"
    assert sorted(p.name for p in work.iterdir()) == ["flips.toml", "models", "out"]
