"""The toolkit's generated kernels against independent references.

References (nothing from derive/ is used to build them):
* tests/mechanics_reference.py: sympy.physics.mechanics (LagrangesMethod with
  particles, rigid bodies, gravity as applied forces, joint torques and dampers as
  torques on link frames with their reactions);
* tests/cartesian_reference.py: point masses in Cartesian space held by constraint
  forces (tensions), integrated with SciPy's DOP853.

The toolkit's side is a model file written here (tmp_path), read by
derive.model.load_model, compiled by derive.codegen.loader.load and integrated by
derive.simulate.

Norm of the rhs comparisons: over 500 random states (angles uniform in [-pi, pi], rates
uniform in [-3, 3]) and random positive parameters of order 1 (uniform in [0.5, 2];
g in [5, 15]),
    max over states and components of |toolkit - reference| / max(1, |reference|),
with the reference evaluated in 40-digit mpmath and rounded to float64 (so the
difference is the toolkit's own float64 rounding).  Tolerance 1e-12.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from cartesian_reference import (chain_accelerations, chain_constraints, chain_energy,  # noqa: E402
                                 chain_simulate, simulate as double_reference)
from mechanics_reference import LinkSpec, planar_chain, spherical_chain  # noqa: E402

from derive.codegen.loader import load  # noqa: E402
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
        assert relative_error(a_cart, a) < 1e-11, (n, dim, relative_error(a_cart, a))


def test_cartesian_chain_reduces_to_the_double_spherical_reference():
    """chain_simulate with N = 2 follows tests/cartesian_reference.simulate (the original,
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
