"""The JAX backend's checks (jax_backend_checks.py), run by pytest in a process of their own.

Why a process of their own: in a pytest-xdist worker, jaxlib's runtime (after a jit and a
grad) and derive's compiled C loaded later in the same worker made the worker abort
(SIGABRT in the benchmark's first C call, reproduced with `pytest -n 1` on the JAX tests then
tests/measurement/test_bench.py; not reproduced in a plain Python process doing the same).
Each check still reports as its own line: the output of that run is printed on failure.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

CHECKS = Path(__file__).with_name("jax_backend_checks.py")
ROOT = Path(__file__).resolve().parents[2]


def test_the_jax_backend_checks_pass_in_a_process_of_their_own():
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider",
                          str(CHECKS)], cwd=ROOT, capture_output=True, text=True, timeout=900,
                         env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert run.returncode == 0, run.stdout[-6000:] + run.stderr[-2000:]
    assert " passed" in run.stdout and "skipped" not in run.stdout, run.stdout[-2000:]
