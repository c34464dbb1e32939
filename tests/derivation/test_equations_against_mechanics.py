"""The toolkit's generated kernels against independent references.

References (nothing from derive/ is used to build them):
* tests/oracles/mechanics_reference.py: sympy.physics.mechanics (LagrangesMethod with
  particles, rigid bodies, gravity as applied forces, joint torques and dampers as
  torques on link frames with their reactions);
* tests/oracles/cartesian_reference.py: point masses in Cartesian space held by constraint
  forces (tensions), integrated with SciPy's DOP853.

The toolkit's side is a model file written here (tmp_path), read by
derive.model.load_model, compiled by derive.runtime.loader.load and integrated by
derive.simulate.

Norm of the rhs comparisons: over 500 random states (angles uniform in [-pi, pi], rates
uniform in [-3, 3]) and random positive parameters of order 1 (uniform in [0.5, 2];
g in [5, 15]),
    max over states and components of |toolkit - reference| / max(1, |reference|),
with the reference evaluated in 40-digit mpmath and rounded to float64 (so the
difference is the toolkit's own float64 rounding).  Tolerance 1e-12.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.oracles.cartesian_reference import (chain_accelerations, chain_constraints, chain_energy,  # noqa: E402
                                 chain_simulate, simulate as double_reference)
from tests.oracles.mechanics_reference import LinkSpec, planar_chain, spherical_chain  # noqa: E402

from derive.runtime.loader import load  # noqa: E402
from derive.model import load_model  # noqa: E402

N_STATES = 500
TOL = 1e-12


# -- helpers -----------------------------------------------------------------------------

def random_states(n_coordinates: int, rng, k: int = N_STATES) -> np.ndarray:
    return np.concatenate([rng.uniform(-np.pi, np.pi, (k, n_coordinates)),
                           rng.uniform(-3.0, 3.0, (k, n_coordinates))], axis=-1)


def random_params(names, rng) -> np.ndarray:
    return np.array([rng.uniform(5.0, 15.0) if n == "g" else rng.uniform(0.5, 2.0) for n in names])


def relative_error(value, reference) -> float:
    """max |value - reference| / max(1, |reference|) over every state and component."""
    value, reference = np.asarray(value, float), np.asarray(reference, float)
    return float(np.max(np.abs(value - reference) / np.maximum(1.0, np.abs(reference))))


def toolkit(tmp_path: Path, text: str):
    """Write a model file, register it, compile its generated C; -> (model, kernels)."""
    path = tmp_path / "model.toml"
    path.write_text(text)
    model = load_model(path)
    return model, load(model.name)


def compare_rhs(ref, kernels, names, rng, inputs=()):
    """The toolkit's float64 rhs against the exact reference at N_STATES random states."""
    assert list(kernels.names["state_names"]) == ref.coordinates + [f"{c}_dot" for c in ref.coordinates]
    assert list(kernels.names["param_names"]) == list(names)
    y = random_states(ref.n, rng)
    p = random_params(names, rng)
    args = (y, p)
    if inputs:
        u = rng.uniform(-2.0, 2.0, (N_STATES, len(inputs)))
        args = (y, p, u)
    exact = ref.rhs_exact(*args)
    err = relative_error(kernels.rhs(*args), exact)
    err_l = relative_error(kernels.rhs_l(*args).astype(float), exact)
    print(f"rhs relative error: float64 {err:.3g}, long double {err_l:.3g}")   # pytest -s
    return err, err_l


def points(n):
    return [LinkSpec(f"l{i}", f"m{i}") for i in range(1, n + 1)]


def point_parameters(n):
    return [f"m{i}" for i in range(1, n + 1)] + [f"l{i}" for i in range(1, n + 1)] + ["g"]


def links_toml(chart: str, links: list[LinkSpec]) -> str:
    out = []
    for link in links:
        if link.kind == "point":
            body = f'{{ kind = "point", mass = "{link.mass}" }}'
        else:
            body = (f'{{ kind = "rod", mass = "{link.mass}", com = "{link.com}", '
                    f'inertia = "{link.inertia}" }}')
        out.append(f'[[links]]\nchart = "{chart}"\nlength = "{link.length}"\nbody = {body}\n')
    return "\n".join(out)


def model_toml(name, dimension, parameters, chart, links, extra="") -> str:
    params = ", ".join(f'"{p}"' for p in parameters)
    return (f'name = "{name}"\ntitle = "reference test model {name}"\ndimension = {dimension}\n'
            f'parameters = [{params}]\n{extra}\n' + links_toml(chart, links))


# -- the references themselves -----------------------------------------------------------

@pytest.mark.slow     # integrates both references of several chains: about 20 s
def test_mechanics_references_agree_with_the_cartesian_chain():
    """The two independent references describe the same physics: at random states of a
    4-link planar chain and a 3-link spherical chain (standard and second chart), the tip
    accelerations of the mechanics reference, x'' = J q'' + J' q', equal those of the
    constraint-force formulation at the same positions and velocities (1e-11 relative)."""
    rng = np.random.default_rng(20240601)
    cases = [(planar_chain(points(4), point_parameters(4)), 4, 2),
             (spherical_chain(points(3), point_parameters(3), "standard"), 3, 3),
             (spherical_chain(points(3), point_parameters(3), "second"), 3, 3)]
    for ref, n, dim in cases:
        y = random_states(ref.n, rng, 50)
        p = random_params(ref.parameters, rng)
        qdd = ref.accelerations_exact(y, p)
        x, v, a = ref.cartesian(y, p, qdd)
        masses, lengths, g = p[:n], p[n:2 * n], p[-1]
        a_cart = np.array([chain_accelerations(xk, vk, masses, lengths, g) for xk, vk in zip(x, v)])
        err = relative_error(a_cart, a)
        print(f"{n} links, {dim}-D: tip accelerations agree to {err:.3g}")
        assert err < 1e-11, (n, dim, err)


def test_cartesian_chain_reduces_to_the_double_spherical_reference():
    """chain_simulate with N = 2 follows tests/oracles/cartesian_reference.simulate (the original,
    hand-specialised double spherical pendulum) to 1e-10 over t = 2."""
    m1, m2, l1, l2, g = 1.0, 1.5, 1.0, 0.8, 9.81
    x1 = l1 * np.array([0.6, 0.0, -0.8])
    x2 = x1 + l2 * np.array([0.0, 0.6, -0.8])
    v1 = np.array([0.8, 1.0, 0.6])
    v2 = v1 + np.array([2.0, -0.3, -0.225])
    y0 = np.concatenate([x1, x2, v1, v2])
    t = np.linspace(0.0, 2.0, 101)
    a = double_reference(y0, t, m1, m2, l1, l2, g)
    b = chain_simulate(y0, t, [m1, m2], [l1, l2], g)
    print(f"N = 2 chain vs the double reference: {np.max(np.abs(a - b)):.3g}")
    assert np.max(np.abs(a - b)) < 1e-10, np.max(np.abs(a - b))


# -- 2-link catalogue models (the models that exist today) -------------------------------

def test_planar_double_matches_mechanics(tmp_path):
    """Catalogue `planar` (and the same chain written as a model file) against the
    mechanics reference: two point masses."""
    rng = np.random.default_rng(1)
    names = ["m1", "m2", "l1", "l2", "g"]
    ref = planar_chain(points(2), names)
    err, err_l = compare_rhs(ref, load("planar"), names, rng)
    assert err < TOL and err_l < TOL, (err, err_l)
    _, kernels = toolkit(tmp_path, model_toml("ref_planar2", 2, names, "planar", points(2)))
    err, err_l = compare_rhs(ref, kernels, names, rng)
    assert err < TOL and err_l < TOL, (err, err_l)


def test_compound_double_matches_mechanics():
    """Catalogue `compound`: two rods (rigid bodies, centres of mass at their middles,
    central inertias L1, L2 about z) against the mechanics reference."""
    rng = np.random.default_rng(2)
    names = ["m1", "m2", "l1", "l2", "L1", "L2", "g"]
    ref = planar_chain([LinkSpec("l1", "m1", "rod", "1/2", "L1"),
                        LinkSpec("l2", "m2", "rod", "1/2", "L2")], names)
    err, err_l = compare_rhs(ref, load("compound"), names, rng)
    assert err < TOL and err_l < TOL, (err, err_l)


@pytest.mark.parametrize("model, chart", [("spherical_std", "standard"), ("spherical_alt", "second")])
def test_spherical_double_matches_mechanics(model, chart):
    """Catalogue double spherical pendulums (point masses) in the standard and second
    charts against the mechanics reference in the same chart."""
    rng = np.random.default_rng(3)
    names = ["m1", "m2", "l1", "l2", "g"]
    ref = spherical_chain(points(2), names, chart)
    err, err_l = compare_rhs(ref, load(model), names, rng)
    assert err < TOL and err_l < TOL, (err, err_l)


# -- N-link chains, damping, applied forces, inputs --------------------------------------

def test_triple_point_rod_point_matches_mechanics(tmp_path):
    """Triple planar pendulum: point mass, rod (RigidBody, mass centre at l2/2, central
    inertia L2 about z), point mass."""
    rng = np.random.default_rng(4)
    names = ["m1", "m2", "m3", "l1", "l2", "l3", "L2", "g"]
    links = [LinkSpec("l1", "m1"), LinkSpec("l2", "m2", "rod", "1/2", "L2"), LinkSpec("l3", "m3")]
    ref = planar_chain(links, names)
    _, kernels = toolkit(tmp_path, model_toml("ref_triple", 2, names, "planar", links))
    err, err_l = compare_rhs(ref, kernels, names, rng)
    assert err < TOL and err_l < TOL, (err, err_l)


def test_four_link_planar_chain_matches_mechanics(tmp_path):
    """Four point masses on a planar chain."""
    rng = np.random.default_rng(5)
    names = point_parameters(4)
    ref = planar_chain(points(4), names)
    _, kernels = toolkit(tmp_path, model_toml("ref_chain4", 2, names, "planar", points(4)))
    err, err_l = compare_rhs(ref, kernels, names, rng)
    assert err < TOL and err_l < TOL, (err, err_l)


# The damped, torque-driven double pendulum.  Physically: a motor at the pivot applies
# tau1 to link 1 (reaction on the ground); a motor at the elbow applies tau2 to link 2
# and -tau2 to link 1; a viscous damper at the pivot resists theta1' with c1, one at the
# elbow resists the relative rate theta2' - theta1' with c2 (again on both links).  The
# mechanics reference is given exactly that (torques on the link frames).
# For the toolkit's model file the same physics is written as generalized forces in the
# absolute angles, from the virtual work of the motor torques,
#     delta W = tau1 delta theta1 + tau2 (delta theta2 - delta theta1),
# so Q_theta1 = tau1 - tau2, Q_theta2 = tau2, and the dampers as the Rayleigh function
#     R = c1 theta1'^2 / 2 + c2 (theta2' - theta1')^2 / 2
# (the toolkit subtracts dR/dq': -c1 theta1' + c2 (theta2' - theta1') on theta1 and
# -c2 (theta2' - theta1') on theta2, the virtual work of the damper torques).
DAMPED = """
inputs = ["tau1", "tau2"]
dissipation = "c1*theta1_dot**2/2 + c2*(theta2_dot - theta1_dot)**2/2"
[forces]
theta1 = "tau1 - tau2"
theta2 = "tau2"
"""


def test_damped_driven_double_matches_mechanics(tmp_path):
    """Double planar pendulum (point masses) with joint dampers c1, c2 and joint motors
    tau1, tau2 (run-time inputs, random in [-2, 2] per state)."""
    rng = np.random.default_rng(6)
    names = ["m1", "m2", "l1", "l2", "c1", "c2", "g"]
    ref = planar_chain(points(2), names, inputs=["tau1", "tau2"],
                       joint_torques=["tau1", "tau2"], joint_dampers=["c1", "c2"])
    _, kernels = toolkit(tmp_path, model_toml("ref_damped2", 2, names, "planar", points(2), DAMPED))
    err, err_l = compare_rhs(ref, kernels, names, rng, inputs=["tau1", "tau2"])
    assert err < TOL and err_l < TOL, (err, err_l)


def test_damped_double_with_constant_torques_matches_mechanics(tmp_path):
    """The same damped, driven double pendulum with the motor torques as parameters
    (constants of the run) instead of run-time inputs: the dissipation and the [forces]
    table without the kernel argument u."""
    rng = np.random.default_rng(8)
    names = ["m1", "m2", "l1", "l2", "c1", "c2", "tau1", "tau2", "g"]
    ref = planar_chain(points(2), names, joint_torques=["tau1", "tau2"], joint_dampers=["c1", "c2"])
    extra = DAMPED.replace('inputs = ["tau1", "tau2"]\n', "")
    _, kernels = toolkit(tmp_path, model_toml("ref_damped2_const", 2, names, "planar", points(2), extra))
    err, err_l = compare_rhs(ref, kernels, names, rng)
    assert err < TOL and err_l < TOL, (err, err_l)


@pytest.mark.slow          # ~20 s with a cold cache (the toolkit's derivation), 7 s warm
@pytest.mark.parametrize("chart", ["standard", "second"])
def test_triple_spherical_matches_mechanics(tmp_path, chart):
    """Triple spherical chain of point masses, every link in the same chart.  Random
    states come as close as 1e-3 to the charts' poles, where the rhs is ill-conditioned
    (terms in 1/sin): measured 9e-14 (standard) and 4e-13 (second, at a state with two
    polar sines ~0.03) in float64 -- a plain float64 evaluation of the mechanics
    reference's own expressions is off by 4e-13 and 7e-13 there -- and 2e-16 in long
    double."""
    rng = np.random.default_rng(7)
    names = point_parameters(3)
    ref = spherical_chain(points(3), names, chart)
    _, kernels = toolkit(tmp_path, model_toml(f"ref_sph3_{chart}_chart", 3, names, chart, points(3)))
    err, err_l = compare_rhs(ref, kernels, names, rng)
    assert err < TOL and err_l < TOL, (err, err_l)


# -- a triple spherical chain integrated through (and near) the standard chart's pole -----

SPH3 = np.array([1.0, 0.8, 0.6, 1.0, 0.9, 0.7, 9.81])      # m1 m2 m3 l1 l2 l3 g
T_END = 2.0
POSITION_TOL = 1e-7


def _tips(Y):
    return Y[:, :9].reshape(-1, 3, 3)


def _check_reference(Y):
    """The Cartesian reference keeps its constraints and its energy (no stabilisation)."""
    pos, vel = chain_constraints(Y, SPH3[3:6])
    E = chain_energy(Y, SPH3[:3], SPH3[6])
    assert np.max(np.abs(pos)) < 1e-10 and np.max(np.abs(vel)) < 1e-9, (pos, vel)
    assert np.max(np.abs(E - E[0])) < 1e-9, np.max(np.abs(E - E[0]))


def _polar_sines(X, axis):
    d = X - np.concatenate([np.zeros((len(X), 1, 3)), X[:, :-1]], 1)
    e = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return np.sqrt(np.maximum(0.0, 1.0 - e[..., axis] ** 2))


@pytest.mark.slow
def test_triple_spherical_through_the_pole_in_the_second_chart(tmp_path):
    """Link 1 passes exactly through the standard chart's pole (hanging straight down at
    t = 0) with a 3-D motion of the whole chain; the toolkit integrates it in the second
    chart, regular there, from t = -1 to 1 with DOP853 (rtol 1e-12), and its bob
    positions stay within 1e-7 of the Cartesian constraint-force reference.

    The start is made by the reference itself: the state at t = 0 has x1 = (0, 0, -l1);
    integrating it back to t = -1 gives the start of both runs."""
    names = point_parameters(3)
    m, l, g = SPH3[:3], SPH3[3:6], SPH3[6]
    x1 = np.array([0.0, 0.0, -l[0]])
    e2 = np.array([0.5, 0.3, -0.8]) / np.linalg.norm([0.5, 0.3, -0.8])
    e3 = np.array([-0.4, 0.6, -0.7]) / np.linalg.norm([-0.4, 0.6, -0.7])
    x2, x3 = x1 + l[1] * e2, x1 + l[1] * e2 + l[2] * e3
    v1 = np.array([2.0, 1.2, 0.0])                      # tangent: x1 . v1 = 0
    w2 = np.cross(np.array([0.3, -1.5, 1.0]), e2) * l[1]
    w3 = np.cross(np.array([1.2, 0.8, 0.4]), e3) * l[2]
    now = np.concatenate([x1, x2, x3, v1, v1 + w2, v1 + w2 + w3])
    back = chain_simulate(now, np.array([0.0, -1.0]), m, l, g)[-1]
    t = np.linspace(-1.0, 1.0, 201)
    Y = chain_simulate(back, t, m, l, g)
    _check_reference(Y)
    assert np.max(np.abs(Y[100] - now)) < 1e-10            # it passes through the pole at t = 0
    X = _tips(Y)
    assert _polar_sines(X, 2)[100, 0] < 1e-10              # link 1 vertical: standard chart singular
    assert np.min(_polar_sines(X, 0)) > 0.25               # never near x: second chart regular

    ref = spherical_chain(points(3), names, "second")
    y0 = ref.state_from_cartesian(_tips(back[None])[0], back[9:].reshape(3, 3), SPH3, "second")
    path = tmp_path / "model.toml"
    path.write_text(model_toml("ref_sph3_pole_second_chart", 3, names, "second", points(3)))
    from derive import simulate
    r = simulate(str(path), y0, t, SPH3, method="dop853", rtol=1e-12, atol=1e-14)
    assert r.ok, r.message
    err = float(np.max(np.abs(np.asarray(r.positions, float) - X)))
    print(f"max bob position error {err:.3g} ({r.nfev} rhs evaluations)")
    assert err < POSITION_TOL, f"max bob position error {err:.3g}"


@pytest.mark.slow
def test_triple_spherical_near_the_pole_in_the_standard_chart(tmp_path):
    """In the standard chart: link 1 swings past the downward vertical with a small
    azimuthal rate, its polar sine dipping to ~0.05 (link 3 to ~0.045), below the default
    single-chart threshold 0.1, so sine_min = 0.01 is given.  Bob positions over t = 2
    against the Cartesian reference, DOP853 at rtol 1e-12: within 1e-7."""
    names = point_parameters(3)
    m, l, g = SPH3[:3], SPH3[3:6], SPH3[6]
    ref = spherical_chain(points(3), names, "standard")
    y0 = np.array([0.5, 0.0, 1.1, 2.0, 1.4, 3.0, -2.0, 0.5, 0.0, 2.5, 0.0, -2.0])
    x, v = ref.cartesian(y0, SPH3)
    t = np.linspace(0.0, T_END, 401)
    Y = chain_simulate(np.concatenate([x.ravel(), v.ravel()]), t, m, l, g)
    _check_reference(Y)
    X = _tips(Y)
    s = _polar_sines(X, 2)
    assert 0.01 < np.min(s[:, 0]) < 0.1, np.min(s, 0)      # close to, not through, the pole
    assert np.min(s) > 0.01, np.min(s, 0)

    path = tmp_path / "model.toml"
    path.write_text(model_toml("ref_sph3_pole_standard", 3, names, "standard", points(3)))
    from derive import simulate
    r = simulate(str(path), y0, t, SPH3, method="dop853", rtol=1e-12, atol=1e-14, sine_min=0.01)
    assert r.ok, r.message
    err = float(np.max(np.abs(np.asarray(r.positions, float) - X)))
    print(f"max bob position error {err:.3g} ({r.nfev} rhs evaluations)")
    assert err < POSITION_TOL, f"max bob position error {err:.3g}"


# -- integrations of the planar chains ---------------------------------------------------

def test_four_link_chain_integrated_against_the_cartesian_chain(tmp_path):
    """derive.simulate on the 4-link planar chain of point masses (DOP853, rtol 1e-12)
    against the 2-D constraint-force reference over t = 2: bob positions within 1e-7."""
    names = point_parameters(4)
    p = np.array([1.0, 0.7, 0.9, 0.5, 1.0, 0.8, 0.9, 0.6, 9.81])
    ref = planar_chain(points(4), names)
    y0 = np.array([1.0, 0.4, -0.5, 1.5, 0.0, 1.0, -1.0, 0.5])
    x, v = ref.cartesian(y0, p)
    t = np.linspace(0.0, 2.0, 201)
    Y = chain_simulate(np.concatenate([x.ravel(), v.ravel()]), t, p[:4], p[4:8], p[8], dim=2)
    pos, vel = chain_constraints(Y, p[4:8], dim=2)
    assert np.max(np.abs(pos)) < 1e-10 and np.max(np.abs(vel)) < 1e-9
    path = tmp_path / "model.toml"
    path.write_text(model_toml("ref_chain4", 2, names, "planar", points(4)))
    from derive import simulate
    r = simulate(str(path), y0, t, p, method="dop853", rtol=1e-12, atol=1e-14)
    assert r.ok, r.message
    err = float(np.max(np.abs(np.asarray(r.positions, float) - Y[:, :8].reshape(-1, 4, 2))))
    print(f"max bob position error {err:.3g}")
    assert err < POSITION_TOL, f"max bob position error {err:.3g}"


def test_damped_driven_double_integrated_against_mechanics(tmp_path):
    """derive.simulate with constant run-time inputs (tau1, tau2) on the damped, driven
    double pendulum against SciPy's DOP853 (rtol 1e-12) on the mechanics reference's rhs,
    over t = 3: bob positions within 1e-8; and the reference's power balance
    dE/dt = tau1 theta1' + tau2 (theta2' - theta1') - c1 theta1'^2 - c2 (theta2' - theta1')^2
    holds along it to 1e-12 (checks the reference's torques and dampers)."""
    from scipy.integrate import solve_ivp
    names = ["m1", "m2", "l1", "l2", "c1", "c2", "g"]
    p = np.array([1.0, 0.8, 1.0, 0.7, 0.3, 0.2, 9.81])
    u = np.array([0.5, -0.4])
    ref = planar_chain(points(2), names, inputs=["tau1", "tau2"],
                       joint_torques=["tau1", "tau2"], joint_dampers=["c1", "c2"])
    y0 = np.array([1.2, -0.5, 0.0, 1.0])
    t = np.linspace(0.0, 3.0, 3001)
    sol = solve_ivp(lambda _t, y: ref.rhs(y, p, u), (0.0, 3.0), y0, method="DOP853",
                    t_eval=t, rtol=1e-12, atol=1e-14)
    assert sol.success
    Y = sol.y.T
    # dE/dt = sum m_i v_i . (a_i + g e_y), with the tips' accelerations from the chain rule
    x, v, a = ref.cartesian(Y, p, ref.accelerations(Y, p, u))
    a[..., 1] += p[6]
    dE = p[0] * (v[:, 0] * a[:, 0]).sum(-1) + p[1] * (v[:, 1] * a[:, 1]).sum(-1)
    w1, rel = Y[:, 2], Y[:, 3] - Y[:, 2]
    power = u[0] * w1 + u[1] * rel - p[4] * w1 ** 2 - p[5] * rel ** 2
    assert np.max(np.abs(dE - power)) < 1e-12, np.max(np.abs(dE - power))

    path = tmp_path / "model.toml"
    path.write_text(model_toml("ref_damped2", 2, names, "planar", points(2), DAMPED))
    from derive import simulate
    r = simulate(str(path), y0, t, p, method="dop853", rtol=1e-12, atol=1e-14, inputs=u)
    assert r.ok, r.message
    err = float(np.max(np.abs(np.asarray(r.positions, float) - x)))
    print(f"max bob position error {err:.3g}")
    assert err < 1e-8, f"max bob position error {err:.3g}"
