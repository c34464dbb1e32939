"""Taylor's method on models with explicit time (issue 23 item 3): t is a variable of the
jet (over a step from t0, t = t0 + tau has the coefficients t0, 1, 0, ...), so a torque
F0 cos(w t) or a pivot at (a cos(w t), 0) is a node of the decomposition like any other.

Every reference here is the model's equation of motion written by hand in this file (not
derive's derivation): SciPy's DOP853 at rtol 1e-13 for double, mpmath's odefun (a Taylor
method of its own at 36 digits) for long double, double-double and quad, and SymPy's
repeated total derivatives d/dt = f . d/dy + d/dt at exact rationals for the jet's
coefficients.  Then the dense output, the events (refused, as for an autonomous Taylor
run), the ensemble and the SIMD lanes (each lane at its own time), and the generated C
under the compilers."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import mpmath
import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import derive
from derive.model import load_model
from derive.runtime import extended
from derive.runtime.extended import extended_taylor
from derive.runtime.power import energy_balance
from derive.runtime.result import summary_rows
from derive.runtime.runner import runner_for
from derive.runtime.taylor_lanes_library import taylor_lanes_library
from derive.runtime.taylor_library import taylor_library
from tests.codegen.test_generate_and_compile import COMPILERS, quad_flags

ROOT = Path(__file__).resolve().parents[2]
FORCED = str(ROOT / "examples" / "models" / "forced_pendulum.toml")
PIVOT = str(ROOT / "examples" / "models" / "driven_pivot.toml")
# exact decimals: the mpmath references read them as the same numbers the runs do
PARAMS = {FORCED: {"m": "1.2", "l": "0.9", "g": "9.81", "c": "0.15", "F0": "1.1", "w": "2.3"},
          PIVOT: {"m": "1.0", "l": "0.8", "g": "9.81", "a": "0.1", "w": "4.5"}}
Y0 = {FORCED: ["0.4", "-0.3"], PIVOT: ["0.3", "0.2"]}
MODELS = [pytest.param(FORCED, id="forced_pendulum"), pytest.param(PIVOT, id="driven_pivot")]


def hand_rhs(model: str, p: dict, lib):
    """The equation of motion by hand, y = (theta, theta'), in the functions of `lib`
    (numpy, mpmath or sympy).  The forced pendulum: m l^2 theta'' = F0 cos(w t) - m g l
    sin(theta) - c theta'.  The pivot at (a cos(w t), 0), the bob at pivot + l (sin theta,
    -cos theta): theta'' = -(g/l) sin(theta) + (a w^2 / l) cos(w t) cos(theta)."""
    if model == FORCED:
        m, l, g, c, F0, w = (p[k] for k in ("m", "l", "g", "c", "F0", "w"))
        return lambda t, y: [y[1], (F0 * lib.cos(w * t) - m * g * l * lib.sin(y[0]) - c * y[1]) / (m * l * l)]
    l, g, a, w = (p[k] for k in ("l", "g", "a", "w"))
    return lambda t, y: [y[1], -g / l * lib.sin(y[0]) + a * w * w / l * lib.cos(w * t) * lib.cos(y[0])]


def floats(values: dict) -> dict:
    return {k: float(v) for k, v in values.items()}


def scipy_reference(model: str, t0: float, times: np.ndarray, y0) -> np.ndarray:
    f = hand_rhs(model, floats(PARAMS[model]), np)
    sol = solve_ivp(f, (t0, times[-1]), [float(v) for v in y0], method="DOP853", rtol=1e-13, atol=1e-15,
                    t_eval=times)
    assert sol.success
    return sol.y.T


# -- double against SciPy ------------------------------------------------------------------

@pytest.mark.parametrize("model", MODELS)
def test_double_agrees_with_solve_ivp_on_the_hand_ode_to_t_20(model):
    times = np.linspace(0.0, 20.0, 81)
    r = derive.simulate(model, [float(v) for v in Y0[model]], times, floats(PARAMS[model]), method="taylor",
                        rtol=1e-13)
    assert r.ok and r.method == "taylor" and r.nsteps > 0
    assert np.max(np.abs(r.y - scipy_reference(model, 0.0, times, Y0[model]))) < 1e-11


@pytest.mark.parametrize("model", MODELS)
def test_a_run_that_starts_late_steps_from_its_own_start_time(model):
    """From t0 = 7.3: the jet's time is the run's, not the time since its start (an
    autonomous shift to 0 would differ at the level of the forcing)."""
    times = np.linspace(7.3, 15.0, 12)
    y0 = [float(v) for v in Y0[model]]
    r = derive.simulate(model, y0, times, floats(PARAMS[model]), method="taylor", rtol=1e-13)
    ref = scipy_reference(model, 7.3, times, Y0[model])
    assert r.ok and np.max(np.abs(r.y - ref)) < 1e-11
    shifted = scipy_reference(model, 0.0, times - 7.3, Y0[model])     # what a time shift would give
    assert np.max(np.abs(shifted - ref)) > 1e-3


@pytest.mark.parametrize("dtype", ["float64", "longdouble", "double-double"])
def test_energy_positions_and_velocities_are_at_the_rows_times(dtype):
    """The moving pivot's kernels take t: a Taylor run's r.energy, r.positions and
    r.velocities are at each row's own time (by hand: the bob at (a cos(w t) + l sin(theta),
    -l cos(theta)), E = T + V)."""
    p = floats(PARAMS[PIVOT])
    times = np.linspace(0.5, 5.0, 7)
    r = derive.simulate(PIVOT, [0.3, 0.2], times, p, method="taylor", rtol=1e-13, dtype=dtype)
    th, om = np.asarray(r.y, float).T
    m, l, g, a, w = (p[k] for k in ("m", "l", "g", "a", "w"))
    pos = np.stack([a * np.cos(w * times) + l * np.sin(th), -l * np.cos(th)], -1)
    vel = np.stack([-a * w * np.sin(w * times) + l * om * np.cos(th), l * om * np.sin(th)], -1)
    energy = 0.5 * m * (vel ** 2).sum(-1) + m * g * pos[:, 1]
    assert np.max(np.abs(np.asarray(r.positions, float)[:, 0] - pos)) < 1e-14
    assert np.max(np.abs(np.asarray(r.velocities, float)[:, 0] - vel)) < 1e-14
    assert np.max(np.abs(np.asarray(r.energy, float) - energy)) < 1e-13


# -- long double, double-double, quad against mpmath ------------------------------------------

SPAN = ("0", "0.5", "1")          # a short span: mpmath's odefun at 36 digits takes seconds


@pytest.fixture(scope="module")
def mp_reference():
    """The hand ODE by mpmath's odefun at 36 digits, per model: the states at SPAN."""
    out = {}
    with mpmath.workdps(36):
        for model in (FORCED, PIVOT):
            p = {k: mpmath.mpf(v) for k, v in PARAMS[model].items()}
            sol = mpmath.odefun(hand_rhs(model, p, mpmath), 0, [mpmath.mpf(v) for v in Y0[model]])
            out[model] = [[+v for v in sol(mpmath.mpf(t))] for t in SPAN]
    return out


def _error(y, ref) -> float:
    with mpmath.workdps(40):
        return float(max(abs(mpmath.mpf(a) - b) for row, rrow in zip(y, ref) for a, b in zip(row, rrow)))


def _long(v: str) -> np.longdouble:
    """The long double nearest the decimal v."""
    f = Fraction(v)
    return np.longdouble(f.numerator) / np.longdouble(f.denominator)


def _exact_long(x: np.longdouble) -> mpmath.mpf:
    num, den = x.as_integer_ratio()
    with mpmath.workdps(40):
        return mpmath.mpf(num) / den


@pytest.mark.parametrize("model", MODELS)
def test_long_double_agrees_with_mpmath(model, mp_reference):
    y0 = np.array([_long(v) for v in Y0[model]])
    params = {k: _long(v) for k, v in PARAMS[model].items()}
    t = np.array([_long(v) for v in SPAN])
    r = derive.simulate(model, y0, t, params, method="taylor", rtol=2e-18, dtype="longdouble")
    assert r.ok and r.y.dtype == np.longdouble
    if np.finfo(np.longdouble).eps < 1e-18:        # x86's 64-bit significand
        # the inputs rounded to long double (5e-20 relative) and the run's own error; a
        # double run's is 1e-16
        assert _error([[_exact_long(v) for v in row] for row in r.y], mp_reference[model]) < 5e-18


@pytest.mark.parametrize("precision, rtol, level", [("double-double", 1e-30, 1e-30), ("quad", 1e-32, 1e-32)])
@pytest.mark.parametrize("model", MODELS)
def test_double_double_and_quad_agree_with_mpmath(model, precision, rtol, level, mp_reference):
    r = derive.simulate(model, Y0[model], list(SPAN), PARAMS[model], method="taylor", rtol=rtol, dtype=precision)
    assert r.ok and r.dtype == precision
    assert _error(r.y_exact, mp_reference[model]) < level


# -- the jet's coefficients ---------------------------------------------------------------------

K = 5
T0, Y_AT = "0.7", ("0.25", "-0.6")


def total_derivative_coefficients(model: str) -> list[list]:
    """y^[k] = (d/dt)^k y / k! at (T0, Y_AT), k = 0..K, by SymPy's total derivatives
    g_1 = f(t, y), g_(k+1) = (dg_k/dy) f + dg_k/dt at exact rationals, then 40 digits."""
    t, th, om = sp.symbols("t th om")
    p = {k: sp.Rational(v) for k, v in PARAMS[model].items()}
    f = sp.Matrix(hand_rhs(model, p, sp)(t, [th, om]))
    point = {t: sp.Rational(T0), th: sp.Rational(Y_AT[0]), om: sp.Rational(Y_AT[1])}
    rows, g = [[sp.Rational(v) for v in Y_AT]], f
    for k in range(1, K + 1):
        rows.append([sp.N(v.xreplace(point), 40) / sp.factorial(k) for v in g])
        g = g.jacobian(sp.Matrix([th, om])) * f + g.diff(t)
    with mpmath.workdps(40):
        return [[mpmath.mpf(str(sp.N(rows[k][i], 40))) for k in range(K + 1)] for i in range(2)]


@pytest.mark.parametrize("model", MODELS)
def test_coefficients_at_a_time_are_the_total_derivatives(model):
    ref = total_derivative_coefficients(model)
    lib = taylor_library(load_model(model).name, K)
    p = np.array([float(v) for v in PARAMS[model].values()])
    status, ours = lib.coefficients(np.array([float(v) for v in Y_AT]), p, t=float(T0))
    assert status == 0 and ours.shape == (2, K + 1)
    scale = max(abs(float(v)) for row in ref for v in row)
    assert np.max(np.abs(ours - np.array(ref, float))) < 1e-13 * scale
    _, at_zero = lib.coefficients(np.array([float(v) for v in Y_AT]), p, t=0.0)    # t matters
    assert np.max(np.abs(at_zero - ours)) > 1e-3
    exact = extended_taylor(load_model(model).name, "double-double", K)
    status, dd = exact.coefficients([extended.exact(v, "y") for v in Y_AT],
                                    [extended.exact(v, "p") for v in PARAMS[model].values()], t=T0)
    assert status == 0
    with mpmath.workdps(40):
        worst = max(abs(dd[i * (K + 1) + k] - ref[i][k]) for i in range(2) for k in range(K + 1))
    assert worst < 1e-29 * scale


@pytest.mark.parametrize("model", [FORCED, "planar"])
def test_a_taylor_runs_options_are_the_integrators_defaults(model):
    """TaylorOptions fills the struct from the contract as <model>_integrate_defaults does
    in C (a Taylor run, time-dependent or not, builds no RK library to ask)."""
    from derive.runtime.build import integrator_library
    from derive.runtime.taylor_library import taylor_options
    ours, theirs = taylor_options().defaults(), integrator_library(load_model(model).name).defaults()
    for name, _ in type(theirs)._fields_:
        a, b = getattr(ours, name), getattr(theirs, name)
        assert (bool(a) == bool(b)) if name == "cancel" else a == b, name


# -- dense output, events, ensembles ------------------------------------------------------------

@pytest.mark.parametrize("model", MODELS)
def test_output_times_inside_steps_are_the_series_and_do_not_change_the_steps(model):
    y0, p = [float(v) for v in Y0[model]], floats(PARAMS[model])
    few = derive.simulate(model, y0, [0.0, 6.0], p, method="taylor", rtol=1e-13)
    times = np.linspace(0.0, 6.0, 1201)
    many = derive.simulate(model, y0, times, p, method="taylor", rtol=1e-13)
    assert few.nsteps == many.nsteps < len(times) // 4          # most outputs fall inside a step
    assert np.array_equal(few.y[-1], many.y[-1])
    assert np.max(np.abs(many.y - scipy_reference(model, 0.0, times, Y0[model]))) < 1e-11


def test_events_are_refused_in_one_line_as_for_an_autonomous_taylor_run():
    """Events need an adaptive RK method's dense output (derive/runtime/events.py), for a
    time-dependent model's Taylor run as for an autonomous one's."""
    messages = []
    for model, y0, p in ((FORCED, [0.4, -0.3], floats(PARAMS[FORCED])),
                         ("planar", [1.0, 0.5, 0.0, 0.0], {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81})):
        with pytest.raises(derive.SimulationInputError) as info:
            derive.simulate(model, y0, [0.0, 1.0], p, method="taylor", events={"down": "theta1"})
        messages.append(str(info.value))
    assert messages[0] == messages[1] and "\n" not in messages[0] and "dop853" in messages[0]


@pytest.mark.parametrize("model", MODELS)
def test_sol_between_rows_is_the_solution_at_its_own_time(model):
    """r.sol(t) integrates each interval from its row at the row's time: y_k at t_k
    exactly, the hand ODE's solution between rows (within 1e-11 of SciPy's), and a
    continuous function (what the energy balance's Gauss sums need: its residual is at
    roundoff, not the trapezoid rule's error on 11 rows)."""
    y0, p = [float(v) for v in Y0[model]], floats(PARAMS[model])
    rows = np.linspace(2.0, 12.0, 11)
    r = derive.simulate(model, y0, rows, p, method="taylor", rtol=1e-13)
    assert np.array_equal(r.sol(rows), r.y) and r.sol(2.0).shape == (2,)
    between = np.linspace(2.0, 12.0, 337)
    assert np.max(np.abs(r.sol(between) - scipy_reference(model, 2.0, between, Y0[model]))) < 1e-11
    e = 1e-7                          # across a row: the slope's change and no jump past the tolerance
    before, after = r.sol(np.array([5.0 - e, 5.0 + e]))
    slope = np.array(hand_rhs(model, p, np)(5.0, r.sol(5.0)))
    assert np.max(np.abs(after - before - 2 * e * slope)) < 1e-11
    assert "Gauss" in energy_balance(r).how
    row = [v for v in summary_rows(r) if v[0] == "energy balance"][0][1]
    assert float(row.split()[0]) < 1e-12
    with pytest.raises(derive.SimulationInputError, match="outside the run's span"):
        r.sol(1.0)


@pytest.mark.parametrize("dtype", ["float32", "float64", "longdouble"])
def test_an_ensemble_is_each_member_simulated(dtype):
    """float and double in SIMD lanes, long double by the scalar batch: bit for bit."""
    rng = np.random.default_rng(3)
    y0 = rng.uniform(-1, 1, (9, 2))
    p = floats(PARAMS[PIVOT])
    params = {**p, "a": np.linspace(0.05, 0.2, 9)}        # one amplitude per trajectory
    times = np.linspace(1.0, 5.0, 9)
    rtol = 1e-5 if dtype == "float32" else 1e-12
    ens = derive.ensemble(PIVOT, y0, times, params, method="taylor", rtol=rtol, dtype=dtype, threads=2)
    assert list(ens.status_names) == ["ok"] * 9 and ens.y.dtype == np.dtype(dtype)
    for i in range(9):
        one = derive.simulate(PIVOT, y0[i].astype(dtype), times.astype(dtype), {**p, "a": params["a"][i]},
                              method="taylor", rtol=rtol, dtype=dtype)
        assert np.array_equal(ens.y[i], one.y)


def test_each_lane_steps_at_its_own_time():
    """Three lanes over seven trajectories (so lanes refill, and idle at the end), each
    with its own steps, so at every jet the lanes are at different times: every
    trajectory bit for bit the scalar integrator's, and the solution of the hand ODE, from
    a batch starting at 0 and one starting at 3.7."""
    name, order = load_model(FORCED).name, 12
    opt = runner_for(name, "taylor").options({"rtol": 1e-12})
    lanes = taylor_lanes_library(name, order, "float64", lanes=3)
    scalar = taylor_library(name, order, "float64")
    rng = np.random.default_rng(5)
    y0 = rng.uniform(-1, 1, (7, 2))
    p = np.array([floats(PARAMS[FORCED])[k] for k in ("m", "l", "g", "c", "F0", "w")])
    for t0 in (0.0, 3.7):
        times = np.linspace(t0, t0 + 4.0, 6)
        y_lanes, infos = lanes.run(y0, p, times, opt)
        y_scalar, _ = scalar.run(y0, p, times, opt)
        assert all(info.status == 0 for info in infos)
        assert np.array_equal(y_lanes, y_scalar)
        for i in range(7):
            # rtol 1e-12 on states and rates of order 1: 1e-10 (a lane at the first lane's
            # t0, or at 0, would be off by the forcing's change, 1e-2 or more)
            assert np.max(np.abs(y_lanes[i] - scipy_reference(FORCED, t0, times, y0[i]))) < 1e-10


# -- the generated C ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def timed_tree(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("timed")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-m", "derive", "generate", "--out", str(out), "--backend", "c", FORCED, PIVOT],
                   env=env, check=True, capture_output=True, timeout=600)
    return out / "c"


def test_generate_emits_the_taylor_files_of_a_timed_model(timed_tree):
    for name in ("forced_pendulum", "driven_pivot"):
        for stem in ("_taylor.c", "_taylor.h", "_taylor_quad.c", "_taylor_quad.h", "_taylor_lanes.c",
                     "_taylor_lanes.h", "_integrate.h"):
            assert (timed_tree / f"{name}{stem}").is_file(), name + stem
        header = (timed_tree / f"{name}_taylor.h").read_text()
        assert f"int {name}_taylor_coefficients(const double *t, const double *y," in header


@pytest.mark.parametrize("compiler, flags", COMPILERS, ids=[f"{c}-{i}" for i, (c, _) in enumerate(COMPILERS)])
def test_the_timed_taylor_c_compiles_cleanly(timed_tree, compiler, flags, tmp_path):
    if shutil.which(compiler) is None:
        pytest.fail(f"{compiler} is required here (tests/run.sh installs it)")
    for source in sorted(timed_tree.glob("*_taylor*.c")):
        cmd = [compiler, *flags, *quad_flags(compiler, source), "-c", str(source),
               "-o", str(tmp_path / (source.stem + ".o"))]
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path)
        assert proc.returncode == 0 and proc.stderr == "", f"{' '.join(cmd)}\n{proc.stderr}"


def test_the_timed_files_are_the_same_under_another_hash_seed(timed_tree, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONHASHSEED="4242")
    subprocess.run([sys.executable, "-m", "derive", "generate", "--out", str(tmp_path), "--backend", "c",
                    FORCED, PIVOT], env=env, check=True, capture_output=True, timeout=600)
    files = sorted(p.name for p in timed_tree.iterdir())
    assert files == sorted(p.name for p in (tmp_path / "c").iterdir())
    for name in files:
        assert (timed_tree / name).read_bytes() == (tmp_path / "c" / name).read_bytes(), name
