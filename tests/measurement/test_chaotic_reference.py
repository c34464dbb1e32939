"""The high-precision reference of the chaotic planar double pendulum, and derive against it.

tests/data/chaotic_planar_reference.json is made by tests/oracles/make_chaotic_reference.py
(independent of derive: its own equations from the Lagrangian, its own Taylor-series
integrator in mpmath).  Here: the file is what it says (the problem is derive's `planar`
at y0 = (2.5, 2, 0, 0), the energy is conserved, the stored run agrees with the script's
more precise check run), the script's equations and Taylor recurrences are right (against
an LU solve of the mass matrix, a closed form from another source and the accelerations
along the series), and derive's float64 and long double runs follow the reference only for
a while (the chaotic amplification is about 1e16 over t in [0, 20]).

The derive runs use the test session's build cache; on a cold cache the first run compiles
the planar kernels and the order-22 Taylor integrator (tests/runtime/test_taylor.py uses the same).
"""
from __future__ import annotations

import json
import random
from pathlib import Path

import mpmath
import numpy as np
import pytest
from mpmath import mpf

import derive

DATA = Path(__file__).parents[1] / "data"
from tests.oracles import make_chaotic_reference as script  # noqa: E402

REFERENCE = json.loads((DATA / "chaotic_planar_reference.json").read_text())
TIMES = REFERENCE["times"]
DIGITS = REFERENCE["digits"]


def stored_states(digits: int = DIGITS) -> list:
    with mpmath.workdps(digits):
        return [[mpf(v) for v in state] for state in REFERENCE["states"]]


def index_of(t: float) -> int:
    return TIMES.index(t)


def test_the_file_states_its_problem():
    assert REFERENCE["model"] == "planar"
    assert REFERENCE["state_names"] == ["theta1", "theta2", "omega1", "omega2"]
    assert REFERENCE["parameter_names"] == ["m1", "m2", "l1", "l2", "g"]
    assert REFERENCE["parameters"] == {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
    assert REFERENCE["parameters_exact"]["g"] == "9.8100000000000004973799150320701301097869873046875"
    assert REFERENCE["y0"] == [2.5, 2.0, 0.0, 0.0]
    assert TIMES == [0.5 * k for k in range(41)]
    assert len(REFERENCE["states"]) == len(TIMES)
    assert all(len(s) == 4 for s in REFERENCE["states"])
    assert [float(v) for v in REFERENCE["states"][0]] == REFERENCE["y0"]
    assert REFERENCE["digits"] >= 40 and REFERENCE["check_run"]["digits"] > REFERENCE["digits"]
    for key in ("method", "order", "step_rule", "mpmath_version", "command", "runtime_seconds"):
        assert key in REFERENCE


def test_derive_integrates_the_same_problem():
    """derive's energy at t = 0 is the reference's: same masses, lengths, g, state order
    and the same zero of the potential."""
    r = derive.simulate("planar", REFERENCE["y0"], [0.0, 0.5], REFERENCE["parameters"],
                        method="dop853", rtol=1e-13)
    assert r.ok
    assert abs(r.energy[0] - float(REFERENCE["energy_t0"])) <= 1e-13 * abs(r.energy[0])


def test_energy_is_conserved_at_every_stored_time():
    """The energy of each stored state (computed here, the formula written afresh) is the
    initial one to 1e-30 relative."""
    with mpmath.workdps(DIGITS):
        m1, m2, l1, l2, g = (mpf(REFERENCE["parameters"][n]) for n in REFERENCE["parameter_names"])

        def energy(th1, th2, w1, w2):
            x1, y1 = l1 * mpmath.sin(th1), -l1 * mpmath.cos(th1)
            vx1, vy1 = l1 * w1 * mpmath.cos(th1), l1 * w1 * mpmath.sin(th1)
            vx2, vy2 = vx1 + l2 * w2 * mpmath.cos(th2), vy1 + l2 * w2 * mpmath.sin(th2)
            y2 = y1 - l2 * mpmath.cos(th2)
            return (m1 * (vx1 ** 2 + vy1 ** 2) + m2 * (vx2 ** 2 + vy2 ** 2)) / 2 + g * (m1 * y1 + m2 * y2)

        states = stored_states()
        e0 = energy(*states[0])
        assert abs(e0 - mpf(REFERENCE["energy_t0"])) < mpf(10) ** -35
        worst = max(abs(energy(*s) - e0) / abs(e0) for s in states)
    print(f"largest relative energy error over the stored states: {mpmath.nstr(worst, 3)}")
    assert worst < 1e-30


def test_stored_run_agrees_with_the_check_run():
    differences = [float(d) for d in REFERENCE["self_difference"]]
    assert len(differences) == len(TIMES) and differences[0] == 0
    assert differences[index_of(20.0)] < 1e-20
    assert max(float(e) for e in REFERENCE["relative_energy_error"]) < 1e-30


def random_states(rng: random.Random, n: int) -> list:
    return [[mpf(rng.uniform(-3.2, 3.2)), mpf(rng.uniform(-3.2, 3.2)),
             mpf(rng.uniform(-4, 4)), mpf(rng.uniform(-4, 4))] for _ in range(n)]


def random_params(rng: random.Random) -> dict:
    return {n: mpf(rng.uniform(5, 15) if n == "g" else rng.uniform(0.5, 2)) for n in script.PARAMETER_NAMES}


def test_the_scripts_accelerations_solve_the_mass_matrix_and_match_a_closed_form():
    """The script's Cramer's-rule accelerations against mpmath.lu_solve of M(q) alpha = r
    and against myphysicslab's closed form (E. Neumann, "Double Pendulum")."""
    rng = random.Random(16)
    with mpmath.workdps(50):
        for _ in range(5):
            p = random_params(rng)
            m1, m2, l1, l2, g = (p[n] for n in script.PARAMETER_NAMES)
            for th1, th2, w1, w2 in random_states(rng, 10):
                alpha = script.accelerations((th1, th2, w1, w2), p)
                d = th1 - th2
                mass = mpmath.matrix([[(m1 + m2) * l1 ** 2, m2 * l1 * l2 * mpmath.cos(d)],
                                      [m2 * l1 * l2 * mpmath.cos(d), m2 * l2 ** 2]])
                r = mpmath.matrix([-m2 * l1 * l2 * w2 ** 2 * mpmath.sin(d) - (m1 + m2) * g * l1 * mpmath.sin(th1),
                                   m2 * l1 * l2 * w1 ** 2 * mpmath.sin(d) - m2 * g * l2 * mpmath.sin(th2)])
                solved = mpmath.lu_solve(mass, r)
                den = 2 * m1 + m2 - m2 * mpmath.cos(2 * d)
                closed = ((-g * (2 * m1 + m2) * mpmath.sin(th1) - m2 * g * mpmath.sin(th1 - 2 * th2)
                           - 2 * mpmath.sin(d) * m2 * (w2 ** 2 * l2 + w1 ** 2 * l1 * mpmath.cos(d))) / (l1 * den),
                          2 * mpmath.sin(d) * (w1 ** 2 * l1 * (m1 + m2) + g * (m1 + m2) * mpmath.cos(th1)
                                               + w2 ** 2 * l2 * m2 * mpmath.cos(d)) / (l2 * den))
                for a, b, c in zip(alpha, solved, closed):
                    assert abs(a - b) < mpf(10) ** -45 * max(1, abs(b))
                    assert abs(a - c) < mpf(10) ** -45 * max(1, abs(c))


def test_the_taylor_polynomial_satisfies_the_equations():
    """Along the series from a random state, at the step the script's rule takes for tol
    1e-60, theta'(h) is omega(h) and omega'(h) the accelerations at y(h) to the truncation
    (measured 1e-59); an error of 1e-3 relative in coefficient 35 alone leaves 4e-56 or
    more: the recurrences give the solution's series to every order."""
    rng = random.Random(20)
    order = 40
    with mpmath.workdps(80):
        p = random_params(rng)
        for state in random_states(rng, 3):
            series = script.taylor_coefficients(state, p, order)
            h = script.step_size(series, 1, mpf(10) ** -60)
            y = [script.horner(s, h) for s in series]
            rates = [sum(k * s[k] * h ** (k - 1) for k in range(1, order + 1)) for s in series]
            alpha = script.accelerations(y, p)
            assert abs(rates[0] - y[2]) + abs(rates[1] - y[3]) < mpf(10) ** -57
            assert max(abs(a - b) for a, b in zip(rates[2:], alpha)) < mpf(10) ** -57


def test_the_script_writes_a_reference(tmp_path):
    """The command line on a short horizon: the same layout as the stored file, the same
    states at the shared times (to the stored digits' rounding at this lower precision)."""
    out = tmp_path / "short.json"
    assert script.main(["--digits", "40", "--t-end", "0.5", "--out", str(out)]) == 0
    short = json.loads(out.read_text())
    assert set(short) == set(REFERENCE)
    assert short["times"] == [0.0, 0.5] and short["digits"] == 40
    assert short["command"] == "python3 tests/oracles/make_chaotic_reference.py --digits 40 --t-end 0.5 --out " + str(out)
    assert float(short["self_difference"][-1]) < 1e-30
    for a, b in zip(short["states"], REFERENCE["states"]):
        assert max(abs(mpf(x) - mpf(y)) for x, y in zip(a, b)) < 1e-33


@pytest.mark.parametrize("argv, message", [
    (["--digits", "30"], "--digits must be at least 40"),
    (["--t-end", "0.7"], "--t-end must be a positive multiple of 0.5"),
    (["--t-end", "-1"], "--t-end must be a positive multiple of 0.5"),
])
def test_the_script_refuses_bad_arguments(argv, message, capsys, tmp_path):
    with pytest.raises(SystemExit) as stop:
        script.main(argv + ["--out", str(tmp_path / "x.json")])
    assert stop.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.json").exists()


def derive_error(result, t: float) -> float:
    """max over the state of |derive - reference| at the stored time t, in the run's dtype."""
    row = result.y[list(result.t).index(t)]
    reference = np.array([np.longdouble(v) for v in REFERENCE["states"][index_of(t)]])
    return float(np.max(np.abs(row.astype(np.longdouble) - reference)))


def test_float64_follows_the_reference_only_for_a_while():
    """dop853 in float64 at rtol 1e-13 (measured: 1.4e-13 at t = 2, 2e-5 at t = 10, O(10)
    at t = 20): the reference is needed to check anything beyond t ~ 6."""
    r = derive.simulate("planar", REFERENCE["y0"], TIMES, REFERENCE["parameters"],
                        method="dop853", rtol=1e-13)
    assert r.ok and r.y.dtype == np.float64
    errors = {t: derive_error(r, t) for t in (2.0, 6.0, 10.0, 20.0)}
    print("float64 dop853 rtol 1e-13:", {t: f"{e:.2e}" for t, e in errors.items()})
    assert errors[2.0] < 1e-8
    assert errors[20.0] > 1e-8


@pytest.mark.slow     # an mpmath reference to t = 10 and a long double Taylor build: about 30 s
def test_long_double_taylor_follows_the_reference_to_t_10():
    """derive's Taylor integrator in long double at rtol 2e-18 (the tightest its order-22
    build allows; measured: 6e-18 at t = 2, 8e-10 at t = 10, 4e-2 at t = 20)."""
    r = derive.simulate("planar", REFERENCE["y0"], TIMES, REFERENCE["parameters"],
                        method="taylor", dtype="longdouble", rtol=2e-18)
    assert r.ok and r.y.dtype == np.longdouble
    errors = {t: derive_error(r, t) for t in (2.0, 10.0, 20.0)}
    print("long double taylor rtol 2e-18:", {t: f"{e:.2e}" for t, e in errors.items()})
    assert errors[2.0] < 1e-15
    assert errors[10.0] < 1e-8
    assert errors[20.0] > 1e-8


@pytest.mark.slow
def test_the_script_reproduces_the_stored_states_to_t_2():
    """The script's integration, re-run in-process at the stored precision, gives the
    stored states (40 significant digits) to 1e-35."""
    times = [t for t in TIMES if 0 < t <= 2.0]
    run = script.integrate(REFERENCE["y0"], REFERENCE["parameters"], times, DIGITS)
    assert run["order"] == REFERENCE["order"]
    stored = stored_states()
    with mpmath.workdps(DIGITS):
        for t, state in zip(times, run["states"]):
            difference = max(abs(a - b) for a, b in zip(state, stored[index_of(t)]))
            assert difference < mpf(10) ** -35, (t, mpmath.nstr(difference, 3))


@pytest.mark.slow
def test_mpmath_odefun_agrees_at_t_half():
    """mpmath's own Taylor integrator (odefun, another implementation of the method) on the
    script's accelerations reaches the stored state at t = 0.5 to its 30 digits."""
    with mpmath.workdps(30):
        p = script.mp_params(REFERENCE["parameters"])

        def rhs(t, y):
            return [y[2], y[3], *script.accelerations(y, p)]

        y = mpmath.odefun(rhs, 0, [mpf(v) for v in REFERENCE["y0"]])(mpf("0.5"))
        stored = stored_states(30)[index_of(0.5)]
        assert max(abs(a - b) for a, b in zip(y, stored)) < mpf(10) ** -28
