"""derive.linearize, derive.equilibria, the generated <model>_linearize kernels and
`derive linearize`: against closed forms written here, finite differences of the rhs,
and each other."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.cli import main
from derive.model import load_model
from derive.runtime.loader import load, numpy_module

DRIVEN = str(Path(__file__).parents[2] / "examples" / "models" / "driven.toml")
PLANAR = {"m1": 1.3, "m2": 0.7, "l1": 0.9, "l2": 1.4, "g": 9.81}


def small_angle_A(m1, m2, l1, l2, g, upright: bool) -> np.ndarray:
    """A of the planar double pendulum at theta = 0 (hanging) or theta = pi (both links up),
    from its small-angle Lagrangian, written by hand: with phi the angles from the rest
    position, T = 1/2 phi'^T M0 phi', V = +-1/2 phi^T K phi (minus upright: the heights
    are -l cos(theta) = +l cos(phi)), M0 = [[(m1 + m2) l1^2, m2 l1 l2], [m2 l1 l2, m2 l2^2]]
    (cos(theta1 - theta2) = cos(phi1 - phi2) = 1 either way), K = diag((m1 + m2) g l1, m2 g l2);
    so phi'' = -+M0^-1 K phi."""
    M0 = np.array([[(m1 + m2) * l1 ** 2, m2 * l1 * l2], [m2 * l1 * l2, m2 * l2 ** 2]])
    K = np.diag([(m1 + m2) * g * l1, m2 * g * l2])
    A = np.zeros((4, 4))
    A[:2, 2:] = np.eye(2)
    A[2:, :2] = (1 if upright else -1) * np.linalg.solve(M0, K)
    return A


@pytest.mark.parametrize("upright", [False, True])
def test_planar_A_at_rest_is_the_small_angle_closed_form(upright):
    state = {"theta1": "pi", "theta2": "pi"} if upright else {}
    A, B = derive.linearize("planar", state, PLANAR)
    assert B.shape == (4, 0)
    np.testing.assert_allclose(A, small_angle_A(**PLANAR, upright=upright), rtol=1e-12, atol=1e-12)


def test_hanging_planar_eigenvalues_are_its_normal_modes():
    g, l = 9.81, 0.8
    A, _ = derive.linearize("planar", [0, 0, 0, 0], {"m1": 2.0, "m2": 2.0, "l1": l, "l2": l, "g": g})
    omega = np.sqrt(g / l * (2 + np.array([-1, 1]) * np.sqrt(2)))
    eig = np.linalg.eigvals(A)
    np.testing.assert_allclose(eig.real, 0, atol=1e-12)
    np.testing.assert_allclose(np.sort(eig.imag), np.sort(np.concatenate([omega, -omega])), rtol=1e-12)


def driven_params():
    return {"m1": 1.1, "m2": 0.6, "l1": 1.2, "l2": 0.8, "g": 9.81, "c1": 0.3, "c2": 0.15}


def test_driven_B_and_A_are_finite_differences_of_the_rhs():
    P, y, u = driven_params(), np.array([0.4, -1.1, 0.7, -0.3]), np.array([0.5, -0.2])
    A, B = derive.linearize(DRIVEN, y, P, u)
    h = 1e-6

    def f(y, u):
        return derive.scipy_rhs(DRIVEN, P, inputs=u).fun(0.0, y)

    B_fd = np.column_stack([(f(y, u + h * e) - f(y, u - h * e)) / (2 * h) for e in np.eye(2)])
    A_fd = np.column_stack([(f(y + h * e, u) - f(y - h * e, u)) / (2 * h) for e in np.eye(4)])
    np.testing.assert_allclose(B, B_fd, rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(A, A_fd, rtol=1e-7, atol=1e-7)
    assert np.abs(B[2:]).min() > 0.01         # each torque reaches both accelerations


@pytest.mark.parametrize("model", ["planar", DRIVEN])
def test_generated_linearize_kernels_agree_with_each_other_and_linearize(model):
    name = load_model(model).name
    rng = np.random.default_rng(23)
    P = driven_params() if name == "driven" else PLANAR
    p = np.array(list(P.values()))
    c, py = load(name, file=f"{name}_linearize"), numpy_module(f"{name}_linearize")
    for _ in range(5):
        y = rng.uniform(-3, 3, 4)
        u = rng.uniform(-1, 1, 2)
        A, B = derive.linearize(model, y, P, u if name == "driven" else None)
        if name == "driven":
            (Ac, Bc), (An, Bn) = c.linearize(y, p, u), py.linearize(y, p, u)
            np.testing.assert_allclose(Bc, B, rtol=1e-11, atol=1e-12)
            np.testing.assert_allclose(Bn, Bc, rtol=1e-12, atol=1e-13)
        else:
            Ac, An = c.linearize(y, p), py.linearize(y, p)
        np.testing.assert_allclose(Ac, A, rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(An, Ac, rtol=1e-12, atol=1e-12)


def test_planar_equilibria_are_the_four_rests_with_one_stable():
    found = derive.equilibria("planar", PLANAR)
    rests = {(e["state"]["theta1"], e["state"]["theta2"]): e["stability"] for e in found}
    assert rests == {(0.0, 0.0): "marginal", (0.0, np.pi): "unstable",
                     (np.pi, 0.0): "unstable", (np.pi, np.pi): "unstable"}
    for e in found:
        assert all(e["state"][n] == 0 for n in ("theta1_dot", "theta2_dot"))


def test_damping_makes_the_hanging_rest_stable():
    found = derive.equilibria(DRIVEN, driven_params())
    hanging = next(e for e in found if e["state"]["theta1"] == 0 and e["state"]["theta2"] == 0)
    assert hanging["stability"] == "stable" and hanging["eigenvalues"].real.max() < 0
    assert sorted(e["stability"] for e in found) == ["stable", "unstable", "unstable", "unstable"]


@pytest.mark.slow          # two spherical derivations, from a cold cache
def test_spherical_rests_in_a_regular_chart_and_at_a_pole():
    P = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
    rot = [e["stability"] for e in derive.equilibria("spherical_rot", P)]
    assert sorted(rot) == ["marginal", "unstable", "unstable", "unstable"]
    std = derive.equilibria("spherical_std", P)       # every rest is at a pole of the chart
    assert len(std) == 4 and {e["stability"] for e in std} == {"chart singular"}
    with pytest.raises(derive.SimulationInputError, match="chart is singular"):
        derive.linearize("spherical_std", {}, P)


def test_cli_prints_A_and_B_as_json(capsys):
    args = ["linearize", DRIVEN, "--at", "theta1=pi/2", "--input", "tau2=0.5",
            "--param", "m1=1.1,m2=0.6,l1=1.2,l2=0.8", "--param", "g=9.81", "--param", "c1=0.3,c2=0.15",
            "--json"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    A, B = derive.linearize(DRIVEN, {"theta1": np.pi / 2}, driven_params(), {"tau2": 0.5})
    np.testing.assert_array_equal(np.array(out["A"]), A)
    np.testing.assert_array_equal(np.array(out["B"]), B)
    assert out["input_names"] == ["tau1", "tau2"] and out["state"]["theta1"] == np.pi / 2


def test_cli_prints_no_negative_zero(capsys):
    assert main(["linearize", "planar", "--param", "m1=1,m2=1,l1=1,l2=1,g=9.81"]) == 0
    out = capsys.readouterr().out
    assert not re.search(r"(?<![\w.])-0(?![\w.])", out) and re.search(r" 0(\s|$)", out), out


def test_cli_lists_the_equilibria(capsys):
    assert main(["linearize", DRIVEN, "--param", "m1=1.1,m2=0.6,l1=1.2,l2=0.8,g=9.81,c1=0.3,c2=0.15",
                 "--equilibria", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["equilibria"]
    expected = derive.equilibria(DRIVEN, driven_params())
    assert [e["stability"] for e in out] == [e["stability"] for e in expected]
    assert [e["state"] for e in out] == [e["state"] for e in expected]


@pytest.mark.parametrize("args, words", [
    (["--at", "theta1=up"], "no number"),
    (["--at", "phi=1"], "unknown state name 'phi'"),
    (["--at", "theta1"], "expected NAME=VALUE"),
    (["--at", "theta1=1,theta1=2"], "'theta1' is given twice (1 and 2)"),
    (["--param", "g=1"], "'g' is given twice (9.81 and 1)"),
])
def test_cli_bad_input_is_one_line_and_exit_2(capsys, args, words):
    assert main(["linearize", "planar", "--param", "m1=1,m2=1,l1=1,l2=1,g=9.81", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("derive: error:") and words in err


@pytest.mark.slow          # a spherical derivation and its kernels' compile, from a cold cache
@pytest.mark.parametrize("model", ["spherical_std", "spherical_rot"])
def test_spherical_linearize_kernels_agree_with_linearize(model):
    """spherical_std's kernels solve the seed's reduced system (its block inverse), not
    M q'' = F: their A is checked against the implicit form of derive.linearize."""
    P = {"m1": 1.2, "m2": 0.8, "l1": 1.0, "l2": 1.3, "g": 9.81}
    p = np.array(list(P.values()))
    rng = np.random.default_rng(6)
    c, py = load(model, file=f"{model}_linearize"), numpy_module(f"{model}_linearize")
    for _ in range(5):
        y = np.concatenate([rng.uniform(0.4, 2.7, 1), rng.uniform(-3, 3, 1), rng.uniform(0.4, 2.7, 1),
                            rng.uniform(-3, 3, 5)])
        A, _ = derive.linearize(model, y, P)
        np.testing.assert_allclose(c.linearize(y, p), A, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(py.linearize(y, p), A, rtol=1e-10, atol=1e-10)


def test_equilibria_of_a_model_whose_rests_are_no_chains_are_refused_in_one_line():
    """A user's trial: equilibria of the cart-pole crashed (TypeError in the chain's link
    blocks); a slider, springs or a potential have rests the hanging/upright list misses."""
    cart_pole = Path(__file__).resolve().parents[2] / "examples" / "models" / "cart_pole.toml"
    with pytest.raises(derive.SimulationInputError, match="this model has a slider, a branch"):
        derive.equilibria(cart_pole, {"M": 1.0, "m": 0.5, "l": 1.0, "g": 9.81})
