"""Stability at the extremes, each with a stated bound.

Poles exactly, high spin next to a pole, extreme mass and length ratios, float vs
double vs long double, forward-then-backward (the 10^6-step energy runs are in
tests/runtime/test_integrators.py)."""
from __future__ import annotations


import numpy as np
import pytest

from tests.oracles.cartesian_reference import energy as ref_energy  # noqa: E402
from tests.oracles.cartesian_reference import simulate as reference  # noqa: E402

from derive.derivation import cartesian
from derive.runtime import simulate  # noqa: E402

TIGHT = dict(method="dop853", rtol=1e-12, atol=1e-14)


def cart(u1, v1, u2, w, l1, l2):
    u1, u2 = np.asarray(u1, float), np.asarray(u2, float)
    u1, u2 = u1 / np.linalg.norm(u1), u2 / np.linalg.norm(u2)
    v1, w = np.asarray(v1, float), np.asarray(w, float)
    v1, w = v1 - (v1 @ u1) * u1, w - (w @ u2) * u2
    x1, vv1 = l1 * u1, l1 * v1
    return np.concatenate([x1, x1 + l2 * u2, vv1, vv1 + l2 * w])


def _against_reference(c12, p, T, n=201, **kw):
    t = np.linspace(0, T, n)
    ref = reference(c12, t, *p)
    r = simulate("spherical", {"cartesian": c12}, t, p, **(kw or TIGHT))
    assert r.ok, r.message
    return r, float(np.max(np.abs(r.positions.reshape(-1, 6) - ref[:, :6]))), ref


@pytest.mark.parametrize("case", ["hanging_down", "standing_up", "both_down_spinning"])
def test_link_exactly_at_a_pole(case):
    """Start exactly at a pole: the atlas starts in a regular chart; positions within 1e-8 of
    the Cartesian reference (t = 5; standing up, unstable, t = 2)."""
    p = [1.0, 1.0, 1.0, 1.0, 9.81]
    if case == "hanging_down":
        c = cart([0, 0, -1], [0.7, 0.2, 0], [0.6, 0.0, -0.8], [0.0, 1.0, 0.0], 1.0, 1.0)
        T = 5.0
    elif case == "standing_up":
        c = cart([0, 0, 1], [0.05, 0.02, 0], [0, 0, 1], [0.0, -0.03, 0.0], 1.0, 1.0)
        T = 2.0
    else:
        c = cart([0, 0, -1], [0.0, 0.0, 0], [0, 0, -1], [0.0, 0.0, 0.0], 1.0, 1.0)
        c[6:9] = [0.3, 0.0, 0.0]
        c[9:12] = [0.3, 0.4, 0.0]
        T = 5.0
    r, err, _ = _against_reference(c, p, T)
    assert err < 1e-8, (case, err)
    # a standard-chart state exactly at the pole (theta1 = 0 or pi) is accepted by the atlas
    y_std = np.array([0.0 if case != "standing_up" else np.pi, 0.3, 1.0, 0.2, 0.7, 0.0, 0.1, 0.5])
    c2 = cartesian.state_to_cartesian("spherical_std", y_std, (1.0, 1.0))
    r2 = simulate("spherical", y_std, r.t, p, **TIGHT)
    r3 = simulate("spherical", {"cartesian": c2}, r.t, p, **TIGHT)
    assert r2.ok and np.max(np.abs(r2.positions - r3.positions)) < 1e-10


def test_standard_chart_alone_refuses_an_exact_pole():
    y = [0.0, 0.0, 0.5, 0.0, 0.7, 0.0, 0.0, 0.0]
    r = simulate("spherical_std", y, [0.0, 1.0], [1, 1, 1, 1, 9.81])
    assert r.status == 5 and r.t_stop == 0.0 and "chart singular" in r.message


def test_high_spin_next_to_a_pole():
    """Link 1 at 1e-3 rad from the bottom pole with phi' = 1e3 rad/s (1 m/s around the pole):
    positions within 1e-8 of the reference over t = 1, energy within 1e-9 (relative)."""
    p = [1.0, 1.0, 1.0, 1.0, 9.81]
    y_std = np.array([1e-3, 0.0, 0.4, 1.0, 0.0, 1e3, 0.0, 2.0])
    c = cartesian.state_to_cartesian("spherical_std", y_std, (1.0, 1.0))
    r, err, _ = _against_reference(c, p, 1.0, n=101)
    assert err < 1e-8, err
    assert np.max(np.abs(r.energy - r.energy[0])) < 1e-9 * max(1.0, abs(r.energy[0]))
    # the standard chart alone must refuse (1e-3 < the hard threshold 0.1)
    assert simulate("spherical_std", y_std, r.t, p).status == 5


RATIOS = [(1e-3, 1.0), (1e3, 1.0), (1.0, 1e-2), (1.0, 1e2), (1e-3, 1e2), (1e3, 1e-2)]

# Gauss2 on the same runs: the step resolves the fastest time scale 1/rho_max (rho_max: the
# largest |eigenvalue| of the Hamiltonian Jacobian along the run, from a dense DOP853 run),
# h rho_max ~ 0.1.  m1/m2 = 1e-3: when the links pass through alignment the light middle bob
# whips round (theta1' ~ 100 rad/s, rho_max = 6.7e3 at l1 = l2, 4.3e3 at l1/l2 = 1e2).
# (h, energy bound / scale, position bound / (l1 + l2)); measured: energy 4.5e-10, 7.7e-9,
# 5.1e-10, 6.8e-11, 1.3e-13, 2.7e-10; positions against DOP853 at rtol 1e-13 2.5e-8,
# 4.4e-6, 1.1e-8, 3.2e-10, 8.6e-11, 6.6e-8 (each bound ~4x the measured figure).
GAUSS2 = {(1e-3, 1.0): (2e-5, 2e-9, 1e-7),        # rho_max 6.7e3
          (1e3, 1.0): (0.03, 3e-8, 2e-5),         # rho_max 3.3
          (1.0, 1e-2): (1e-3, 2e-9, 5e-8),        # rho_max 99
          (1.0, 1e2): (5e-3, 3e-10, 2e-9),        # rho_max 18
          (1e-3, 1e2): (2e-5, 1e-12, 1e-9),       # rho_max 4.3e3
          (1e3, 1e-2): (3e-3, 1e-9, 3e-7)}        # rho_max 31


@pytest.mark.parametrize("mratio, lratio", RATIOS)
def test_mass_and_length_ratios_planar(mratio, lratio):
    """m1/m2 in {1e-3, 1e3}, l1/l2 in {1e-2, 1e2}: DOP853 at rtol 1e-11 keeps the energy
    within 1e-8 of its scale (m1 + m2) g (l1 + l2) over t = 5, and agrees with the run at
    rtol 1e-13 to 1e-6 (relative to the lengths).  Gauss2 with a step for the fastest time
    scale (GAUSS2 above) keeps the energy within its stated bound of the scale and the
    positions within theirs of the rtol 1e-13 run, its Newton iteration converging in at most
    5 iterations a step on average."""
    m2, l2 = 1.0, 1.0
    m1, l1 = mratio * m2, lratio * l2
    p = [m1, m2, l1, l2, 9.81]
    scale = (m1 + m2) * 9.81 * (l1 + l2)
    t = np.linspace(0, 5, 51)
    r = simulate("planar", [1.0, -0.5, 0.3, 0.8], t, p, method="dop853", rtol=1e-11, atol=1e-13)
    assert r.ok, r.message
    assert np.max(np.abs(r.energy - r.energy[0])) < 1e-8 * scale
    g = simulate("planar", [1.0, -0.5, 0.3, 0.8], t, p, method="dop853", rtol=1e-13, atol=1e-15)
    assert g.ok, g.message
    assert np.max(np.abs(g.positions - r.positions)) < 1e-6 * (l1 + l2)
    h, e_bound, x_bound = GAUSS2[(mratio, lratio)]
    s = simulate("planar", [1.0, -0.5, 0.3, 0.8], t, p, method="gauss2", step=h)
    assert s.ok, s.message
    de = float(np.max(np.abs(s.energy - s.energy[0]))) / scale
    dx = float(np.max(np.abs(s.positions - g.positions))) / (l1 + l2)
    assert de < e_bound and dx < x_bound, (de, dx)
    assert s.njev >= s.nsteps and s.nnewton <= 5 * s.nsteps, (s.njev, s.nnewton, s.nsteps)


def test_gauss2_step_too_large_for_the_whip_says_newton():
    """m1/m2 = 1e-3 with h = 1e-3 (h rho_max ~ 7 at the whip near t = 0.30): Gauss2 stops there
    with status NEWTON (C and NumPy) rather than return a state it could not converge to."""
    p = [1e-3, 1.0, 1.0, 1.0, 9.81]
    for backend in ("c", "numpy"):
        r = simulate("planar", [1.0, -0.5, 0.3, 0.8], np.linspace(0, 1, 11), p, method="gauss2",
                     step=1e-3, backend=backend)
        assert r.status == 3 and 0.25 < r.t_stop < 0.35, r.message
        assert np.isnan(r.y[4:]).all() and np.isfinite(r.y_stop).all()


@pytest.mark.parametrize("mratio, lratio", RATIOS)
def test_mass_and_length_ratios_spherical_atlas(mratio, lratio):
    """The same ratios on the atlas: positions within 1e-7 (l1 + l2) of the Cartesian reference
    over t = 2, energy within 1e-8 of (m1 + m2) g (l1 + l2)."""
    m2, l2 = 1.0, 1.0
    m1, l1 = mratio * m2, lratio * l2
    p = [m1, m2, l1, l2, 9.81]
    c = cart([0.3, 0.1, -1.0], [0.5, -0.2, 0.1], [0.2, -0.4, -1.0], [0.3, 0.6, 0.0], l1, l2)
    r, err, ref = _against_reference(c, p, 2.0, n=101)
    scale = (m1 + m2) * 9.81 * (l1 + l2)
    assert err < 1e-7 * (l1 + l2), err
    assert np.max(np.abs(r.energy - ref_energy(ref, m1, m2, 9.81))) < 1e-8 * scale


def test_float_double_long_double_on_the_atlas():
    """The same atlas run (RK4, h = 1e-3, t = 2) in three precisions: the double run within
    1e-12 of long double, float within 2e-3 (positions); the charts agree."""
    p = [1.0, 1.5, 1.0, 0.8, 9.81]
    c = cart([0.3, 0.2, -1], [-3.0, 1.0, 0], [0.5, -0.4, -0.7], [2.0, 3.0, 1.0], 1.0, 0.8)
    t = np.linspace(0, 2, 21)
    out = {dt: simulate("spherical", {"cartesian": c}, t, p, method="rk4", step=1e-3, dtype=dt)
           for dt in ("float32", "float64", "longdouble")}
    assert all(r.ok for r in out.values())
    pos = {k: r.positions.astype(np.longdouble) for k, r in out.items()}
    ed = float(np.max(np.abs(pos["float64"] - pos["longdouble"])))
    ef = float(np.max(np.abs(pos["float32"] - pos["longdouble"])))
    assert ed < 1e-12 and ef < 2e-3, (ed, ef)
    assert list(out["float64"].chart) == list(out["longdouble"].chart)


def test_forward_then_backward_on_the_atlas():
    """Through switches and back: Gauss2 (h = 1e-3) returns within 2e-6 (symmetric in each chart;
    the switch points differ forwards and backwards: measured 7e-7), DOP853 (rtol 1e-12) within 1e-7."""
    p = [1.0, 1.5, 1.0, 0.8, 9.81]
    c = cart([0.2, 0.1, 1.0], [2.0, -1.0, 0.0], [-0.3, 0.2, 1.0], [-2.0, 2.5, 0.5], 1.0, 0.8)
    T = 2.0
    for method, kw, tol in (("gauss2", dict(step=1e-3), 2e-6), ("dop853", dict(rtol=1e-12, atol=1e-14), 1e-7)):
        f = simulate("spherical", {"cartesian": c}, [0.0, T], p, method=method, **kw)
        assert f.ok and f.switches >= 1
        back = {"chart": f.chart[-1], "state": f.y[-1]}
        b = simulate("spherical", back, [T, 0.0], p, method=method, **kw)
        assert b.ok
        err = float(np.max(np.abs(b.positions[-1].reshape(6) - c[:6])))
        assert err < tol, (method, err)
