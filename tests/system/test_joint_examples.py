"""The tree examples of examples/models/ (issue 23 items 1 and 7) through every stage: derive
and verify on the command line, `derive generate --out DIR` (C and NumPy; the NumPy rhs
against M^-1 F of the derivation), `derive.simulate` with dop853 on the compiled C and on
NumPy (the two agree, and a conservative model keeps its energy).  (M and F against
sympy.physics.mechanics: tests/derivation/test_joints_against_mechanics.py.)"""
from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import derive
from derive.derivation.derivation import derive as derivation
from derive.derivation.symbols import t as time

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "models"

# name -> (initial state, parameters, inputs)
CASES = {
    "cart_pole": ([0.1, 2.5, 0.3, 0.0], {"M": 1.0, "m": 0.3, "l": 0.8, "g": 9.81}, {"F": 0.5}),
    "double_pendulum_cart": ([0.1, 0.5, -0.3, 0.0, 0.2, 0.0],
                             {"M": 1.0, "m1": 0.3, "m2": 0.2, "l1": 0.8, "l2": 0.5, "g": 9.81}, {"F": 0.0}),
    "elastic_pendulum": ([1.2, 0.5, 0.0, 0.3], {"m": 1.0, "k": 20.0, "r0": 1.0, "g": 9.81}, None),
    "pendulum_tree": ([0.3, 0.5, -0.4, 0.0, 0.0, 0.0],
                      {"m1": 1.0, "m2": 0.5, "m3": 0.7, "l1": 1.0, "l2": 0.7, "l3": 0.6, "d": 0.5,
                       "g": 9.81}, None),
    "spinning_body": ([0.3, 0.4, 0.0, 0.5, -0.2, 8.0],
                      {"m": 1.0, "l": 0.5, "A": 0.3, "B": 0.2, "C": 0.1, "g": 9.81}, None),
    "hinge_ball": ([0.4, 1.6, 0.3, 0.0, 0.3, 0.2], {"m1": 1.0, "m2": 0.5, "l1": 1.0, "l2": 0.7, "g": 9.81},
                   None),
}


def cli(*args):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "derive", *args], env=env, capture_output=True,
                          text=True, timeout=1800)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_a_tree_example_goes_through_every_stage(name, tmp_path):
    path = EXAMPLES / f"{name}.toml"
    y0, params, inputs = CASES[name]
    for stage in (("derive", str(path)), ("verify", str(path))):
        run = cli(*stage)
        assert run.returncode == 0, run.stderr
    assert "physics checks pass" in run.stdout

    out = tmp_path / "gen"
    run = cli("generate", str(path), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert (out / "c" / f"{name}.c").is_file() and (out / "c" / f"{name}.h").is_file()
    spec = importlib.util.spec_from_file_location(f"gen_{name}", out / "numpy" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(out / "numpy"))
    try:
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(out / "numpy"))
    d = derivation(str(path))
    s = d.symbols
    qdd = sp.lambdify([time, *s.state, *s.params, *s.u], d.M.LUsolve(d.F), "numpy")
    p = [params[x.name] for x in s.params]
    u = [inputs[x.name] for x in s.u] if inputs else []
    args = (np.array(y0), np.array(p), *([np.array(u)] if u else []))
    generated = np.asarray(module.rhs(*args), float)
    expected = np.concatenate([y0[len(s.q):], np.asarray(qdd(0.0, *y0, *p, *u), float).ravel()])
    assert np.allclose(generated, expected, rtol=1e-12, atol=1e-12)

    t = np.linspace(0.0, 2.0, 5)
    runs = {}
    for backend in ("c", "numpy"):
        options = dict(method="dop853", backend=backend, rtol=1e-11, atol=1e-12)
        if inputs:
            options["inputs"] = inputs
        r = derive.simulate(str(path), y0, t, params, **options)
        assert r.ok, r
        runs[backend] = r.y
    assert np.max(np.abs(runs["c"] - runs["numpy"])) < 1e-8
    if d.model.is_conservative:
        energy = sp.lambdify([*s.state, *s.params], d.energy, "numpy")
        E = np.array([energy(*y, *p) for y in runs["c"]])
        assert np.max(np.abs(E - E[0])) < 1e-8 * max(1.0, abs(E[0]))
