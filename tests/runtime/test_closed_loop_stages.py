"""A closed loop through every other stage (issue 23 item 5): each works on the four-bar
linkage or refuses it in one line naming why (exit status 2 on the command line)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.model import load_model
from derive.model.atlas import chain_problem
from derive.model.description import parse_model
from derive.verification import physics
from tests.runtime.test_closed_loop_runs import FOUR_BAR, P, Y0

ROOT = Path(__file__).resolve().parents[2]
LOOP = "has constraints (a closed loop)"
LOOP_PATTERN = re.escape(LOOP)


def cli(*args, timeout=900) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "derive", *args], env=env, capture_output=True,
                          text=True, timeout=timeout)


def one_error_line(run: subprocess.CompletedProcess, why: str) -> None:
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("derive: error: ") and why in lines[0], run.stderr


def test_linearize_of_a_loop_asks_for_its_free_coordinates_in_one_line():
    """(tests/runtime/test_closed_loop_linearize.py linearizes it with them.)"""
    with pytest.raises(derive.SimulationInputError, match=LOOP_PATTERN) as info:
        derive.linearize(FOUR_BAR, state={"theta1": Y0[0], "theta2": Y0[1], "theta3": Y0[2]}, params=P)
    assert "\n" not in str(info.value) and "give independent=" in str(info.value)


def test_equilibria_of_a_loop_without_its_free_coordinates_is_one_line():
    with pytest.raises(derive.SimulationInputError, match=LOOP_PATTERN):
        derive.equilibria(FOUR_BAR, P)


def test_derive_linearize_exits_2_with_one_line():
    params = ",".join(f"{k}={v}" for k, v in P.items())
    one_error_line(cli("linearize", FOUR_BAR, "--at", "theta1=0.3", "--param", params), LOOP)


def test_a_sweep_of_a_loop_exits_2_with_one_line(tmp_path):
    state = ", ".join(f"{n} = {float(v)!r}" for n, v in
                      zip(["theta1", "theta2", "theta3", "theta1_dot", "theta2_dot", "theta3_dot"], Y0))
    params = ", ".join(f"{k} = {v}" for k, v in P.items())
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'record = ["final_state"]\n[pendulum]\nmodel = "{FOUR_BAR}"\nparameters = {{ {params} }}\n'
                     f'[initial]\nstate = {{ {state} }}\n[time]\nstop = 1.0\noutputs = 11\n'
                     f'[axes]\nm1 = {{ list = [1.0, 2.0] }}\n')
    one_error_line(cli("sweep", str(sweep), "--out", str(tmp_path / "out")), LOOP)
    assert not (tmp_path / "out").exists()


def test_the_atlas_refuses_a_loop_in_one_line():
    with pytest.raises(derive.SimulationInputError, match="atlas") as info:
        derive.simulate(FOUR_BAR, Y0, [0.0, 1.0], P, atlas=True)
    assert "\n" not in str(info.value)


def test_a_spherical_loop_has_no_atlas():
    model = parse_model("""name = "spherical_loop"
dimension = 3
parameters = ["m1", "m2", "l1", "l2", "g"]
constraints = ["l1*sin(theta1)*cos(phi1) + l2*sin(theta2)*cos(phi2) - l1"]
[[links]]
chart = "standard"
length = "l1"
body = { kind = "point", mass = "m1" }
[[links]]
chart = "standard"
length = "l2"
body = { kind = "point", mass = "m2" }
""", "spherical_loop.toml")
    assert "an atlas is for an open chain" in chain_problem(model)


def test_an_ensemble_start_off_the_loop_is_refused_naming_the_trajectory():
    starts = np.stack([Y0, Y0 + np.array([0.0, 0.01, 0, 0, 0, 0])])
    with pytest.raises(derive.SimulationInputError, match=r"^trajectory 1: four_bar: the initial state is off"):
        derive.ensemble(FOUR_BAR, starts, [0.0, 1.0], P)


@pytest.mark.slow
def test_an_ensemble_reports_each_trajectorys_drift():
    other = derive.consistent_state(FOUR_BAR, Y0 + 0.1, P)
    ens = derive.ensemble(FOUR_BAR, np.stack([Y0, other]), np.linspace(0, 10, 11), P, threads=1)
    assert list(ens.status_names) == ["ok", "ok"]
    one = derive.simulate(FOUR_BAR, other, np.linspace(0, 10, 11), P)
    assert ens.constraint_drift[1] == one.constraint_drift
    assert all(not d.exceeded for d in ens.constraint_drift)


@pytest.mark.slow
def test_taylor_runs_a_loop_and_reports_its_drift():
    r = derive.simulate(FOUR_BAR, Y0, np.linspace(0, 10, 11), P, method="taylor")
    assert r.ok and not r.constraint_drift.exceeded and r.energy_error < 1e-8


def test_verify_runs_the_checks_that_apply_and_names_those_that_do_not():
    run = cli("verify", FOUR_BAR)
    assert run.returncode == 0, run.stdout + run.stderr
    out = run.stdout
    assert "ok   four_bar: energy conserved" in out and "with J q' = 0" in out
    assert "ok   four_bar: the loop stays closed" in out
    assert "n/a  four_bar: Cartesian constraint forces" in out and "n/a  four_bar: Hamiltonian form" in out
    assert "3/3 physics checks pass" in out


def test_the_loop_check_could_fail(monkeypatch):
    """The open chain's accelerations (the loop cut) do not keep the loop closed, and the
    check says so."""
    monkeypatch.setattr(physics, "loop_accelerations", physics.accelerations)
    assert not physics.loop_stays_closed(load_model(FOUR_BAR)).passed


def test_latex_writes_the_closed_loop_section(tmp_path):
    run = cli("latex", FOUR_BAR, "--out", str(tmp_path))
    assert run.returncode == 0, run.stderr
    tex = (tmp_path / "four_bar.tex").read_text()
    assert r"\section{Closed loop}" in tex and r"\Phi_{2}" in tex and r"\gamma_{1}" in tex
    assert r"M\,\ddot q + J^{T} \lambda = F" in tex


@pytest.mark.slow
def test_a_scene_of_the_four_bar_reports_its_drift(tmp_path):
    state = ", ".join(f"{n} = {float(v)!r}" for n, v in
                      zip(["theta1", "theta2", "theta3", "theta1_dot", "theta2_dot", "theta3_dot"], Y0))
    params = ", ".join(f"{k} = {v}" for k, v in P.items())
    scene = tmp_path / "four_bar.toml"
    scene.write_text(f'[pendulum]\nmodel = "{FOUR_BAR}"\nparameters = {{ {params} }}\n'
                     f'[initial]\nstate = {{ {state} }}\n[accuracy]\ntarget = 1e-3\n'
                     f'[time]\nstop = 30.0\noutputs = 201\n[output]\ndirectory = "{tmp_path / "out"}"\n'
                     f'plots = ["paths"]\n')
    run = cli("run", str(scene))
    assert run.returncode == 0, run.stderr
    assert "loop    constraint drift max |Phi| = " in run.stdout


@pytest.mark.slow
def test_the_generated_c_of_a_loop_is_clean_under_werror(tmp_path):
    run = cli("generate", FOUR_BAR, "--out", str(tmp_path / "gen"))
    assert run.returncode == 0, run.stderr
    header = (tmp_path / "gen" / "c" / "four_bar.h").read_text()
    assert "four_bar_constraints(" in header and "four_bar_multipliers(" in header
    for name in ("four_bar.c", "four_bar_integrate.c", "four_bar_fixed.c", "four_bar_linearize.c"):
        proc = subprocess.run(["cc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O1", "-c",
                               str(tmp_path / "gen" / "c" / name), "-o", str(tmp_path / "x.o")],
                              capture_output=True, text=True)
        assert proc.returncode == 0, (name, proc.stderr)


def test_the_lyapunov_tangent_vector_is_held_to_the_loop(monkeypatch):
    """Each step's projection is onto the null space of G = d(Phi, J q')/dy, of the
    dimension of the loop's states (2: one degree of freedom), and the exponent uses them."""
    from derive.measurement import trust
    from derive.runtime.loader import numpy_module
    load_model(FOUR_BAR)
    p = np.array(list(P.values()))
    kernels = numpy_module("four_bar")
    states = np.stack([Y0, derive.consistent_state(FOUR_BAR, Y0 + 0.1, P)])
    projections = trust._tangent_projections("four_bar", kernels, (states, p))
    G = np.asarray(kernels.constraint_state_jacobian(states, p))
    for g, proj in zip(G, projections):
        assert np.abs(g @ proj).max() < 1e-12 and np.abs(proj @ proj - proj).max() < 1e-12
        assert np.linalg.matrix_rank(proj) == 2          # 1 degree of freedom: (q, q') on the loop
    seen = []
    real = trust._tangent_projections
    monkeypatch.setattr(trust, "_tangent_projections", lambda *args: seen.append(real(*args)) or seen[-1])
    exponent = trust.largest_lyapunov("four_bar", Y0, P, 10.0, backend="numpy").exponent
    assert seen and len(seen[0]) > 100 and np.isfinite(exponent)     # a projection at every step
    assert trust._tangent_projections("planar", kernels, (states, p)) is None
