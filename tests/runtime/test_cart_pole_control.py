"""The controls engineer's path on the cart-pole (issue 23 items 6-8): the LQR example
(examples/cart_pole_lqr.py) balancing the nonlinear model, checked against the cart-pole's
equations written here and integrated by SciPy with the same feedback.  (The linearisation
at upright against its closed form: tests/derivation/test_joints_against_mechanics.py.)"""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import derive

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "examples" / "models" / "cart_pole.toml"


def _lqr_example():
    spec = importlib.util.spec_from_file_location("cart_pole_lqr", ROOT / "examples" / "cart_pole_lqr.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _cart_pole_rhs(M, m, l, g, force):
    """The cart-pole's Lagrange equations, bob at (x + l sin th, -l cos th):
    (M + m) x'' + m l cos th th'' = F + m l sin th th'^2,   cos th x'' + l th'' = -g sin th."""
    def rhs(t, y):
        x, th, xd, thd = y
        c, s = np.cos(th), np.sin(th)
        lhs = np.array([[M + m, m * l * c], [c, l]])
        xdd, thdd = np.linalg.solve(lhs, [force(t, y) + m * l * s * thd ** 2, -g * s])
        return [xd, thd, xdd, thdd]
    return rhs


def test_lqr_balances_the_cart_pole_as_scipy_on_its_own_equations_does():
    example = _lqr_example()
    A, B, K, closed, run, F = example.balance(t_end=8.0)
    assert closed.real.max() < 0
    assert abs(run.y[-1, 1] - np.pi) < 1e-3 and abs(run.y[-1, 0]) < 1e-2
    feedback = lambda t, y: float(-K[0] @ (np.asarray(y) - example.UPRIGHT))
    reference = solve_ivp(_cart_pole_rhs(**example.PARAMS, force=feedback), (0.0, 8.0), run.y[0],
                          t_eval=run.t, rtol=1e-12, atol=1e-12, method="DOP853")
    assert reference.success
    assert np.max(np.abs(run.y - reference.y.T)) < 1e-7
    # F in the plot is the feedback of the run's own states
    np.testing.assert_allclose(F, [feedback(t, y) for t, y in zip(run.t, run.y)])
