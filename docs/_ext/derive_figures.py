"""Figures the build makes and files it publishes, never pasted by hand.

- The tutorial's plots: the build runs the tutorial's scene (docs/tutorial/scene.toml) with
  ``python -m derive run`` into ``<outdir>/_figures/`` and the tutorial page shows them.
- The control page's plot: the build runs examples/cart_pole_lqr.py (the cart-pole balanced by
  LQR) with ``--plot <outdir>/_figures/cart_pole_lqr.png``.
- The benchmark's plots: every PNG that ``derive bench`` and bench/*.py wrote into
  bench/results/ is copied to ``<outdir>/_figures/bench/`` as it is.

Set ``DERIVE_DOCS_NO_RUN=1`` to skip the scene run (a build for proofreading); the tutorial's
images are then missing, and the tests never set it.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "docs" / "tutorial"
BENCH_RESULTS = ROOT / "bench" / "results"


def run_tutorial_scene(figures: Path) -> None:
    """The tutorial's scene run by derive itself, its plots written into figures."""
    figures.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-m", "derive", "run", str(TUTORIAL / "scene.toml"),
                           "--quiet", "--output-dir", str(figures)], env=env,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"the tutorial's scene failed (exit {done.returncode}): {done.stderr.strip()}")


def run_lqr_example(figures: Path) -> None:
    """The control page's example run as the page shows it, its plot written into figures."""
    figures.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "cart_pole_lqr.py"), "--plot",
                           str(figures / "cart_pole_lqr.png")], env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"examples/cart_pole_lqr.py failed (exit {done.returncode}): {done.stderr.strip()}")


def copy_bench_plots(figures: Path) -> None:
    target = figures / "bench"
    target.mkdir(parents=True, exist_ok=True)
    for png in sorted(BENCH_RESULTS.glob("*.png")):
        shutil.copyfile(png, target / png.name)


def _build_figures(app) -> None:
    if app.builder.format != "html":
        return
    figures = Path(app.outdir) / "_figures"
    copy_bench_plots(figures)
    if not os.environ.get("DERIVE_DOCS_NO_RUN"):
        run_tutorial_scene(figures)
        run_lqr_example(figures)


def setup(app):
    app.connect("builder-inited", _build_figures)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
