"""The four-bar linkage's accelerations against an independent derivation (issue 23 item 5).

The reference is sympy.physics.mechanics' LagrangesMethod with the loop closure as its
holonomic constraint equations (tests/oracles/four_bar.py).  LagrangesMethod forms
[M J^T; J 0]-type equations of its own (with its own multipliers), solved here
numerically for q''.  The generated
NumPy and C rhs must agree with it at 20 random states on the constraints, and the
multipliers kernel must close M q'' + J^T lambda = F.
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from derive.model import load_model
from derive.runtime.loader import numpy_module
from tests.oracles.four_bar import NAMES, closed_state, lagranges_method

ROOT = Path(__file__).resolve().parents[2]
FOUR_BAR = str(ROOT / "examples" / "models" / "four_bar.toml")


@lru_cache(maxsize=None)
def reference():
    """(M_full, f_full) of LagrangesMethod (tests/oracles/four_bar.py), lambdified in
    (q, q', params): the state's derivative and the multipliers solve M_full x = f_full."""
    lm, q, qd, params = lagranges_method()
    Qs, Us = sp.symbols("Q1:4"), sp.symbols("U1:4")
    plain = dict(zip(qd, Us)) | dict(zip(q, Qs))
    Mf = lm.mass_matrix_full.subs(plain)
    ff = lm.forcing_full.subs(plain)
    args = (*Qs, *Us, *params)
    return sp.lambdify(args, Mf, "numpy"), sp.lambdify(args, ff, "numpy")


def reference_qdd(y, p) -> np.ndarray:
    M, f = reference()
    x = np.linalg.solve(np.array(M(*y, *p), dtype=float), np.array(f(*y, *p), dtype=float).ravel())
    return x[3:6]                     # x = (q', q'', lambda)


def random_cases(count: int, seed: int = 23):
    """States on the loop of Grashof crank-rockers (the crank turns fully), random masses."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        l1, l3, l2, d = rng.uniform(0.3, 0.6), rng.uniform(1.2, 1.8), rng.uniform(1.8, 2.4), rng.uniform(1.8, 2.2)
        p = np.array([*rng.uniform(0.5, 3.0, 3), l1, l2, l3, d, rng.uniform(1.0, 20.0)])
        yield closed_state(rng.uniform(-np.pi, np.pi), rng.uniform(-3, 3), p, rng.choice([-1, 1])), p


def test_the_cases_are_on_the_loop():
    load_model(FOUR_BAR)
    for y, p in random_cases(20):
        phi, phi_dot = numpy_module("four_bar").constraints(y, p)
        assert np.abs(phi).max() < 1e-13 and np.abs(phi_dot).max() < 1e-12


def test_numpy_rhs_agrees_with_lagranges_method_at_20_states():
    load_model(FOUR_BAR)
    kernels = numpy_module("four_bar")
    worst = 0.0
    for y, p in random_cases(20):
        ours = np.asarray(kernels.rhs(y, p))[3:]
        theirs = reference_qdd(y, p)
        worst = max(worst, np.abs(ours - theirs).max() / max(1.0, np.abs(theirs).max()))
    assert worst < 1e-10, worst


def test_the_multipliers_close_the_augmented_system():
    """M q'' + J^T lambda = F, with lambda from its own kernel and M, F, J from theirs:
    the multipliers are the ones the solve of rhs found."""
    load_model(FOUR_BAR)
    k = numpy_module("four_bar")
    for y, p in random_cases(20):
        qdd = np.asarray(k.rhs(y, p))[3:]
        residual = (np.asarray(k.mass_matrix(y, p)) @ qdd + np.asarray(k.constraint_jacobian(y, p)).T
                    @ np.asarray(k.multipliers(y, p)) - np.asarray(k.forcing(y, p)))
        assert np.abs(residual).max() < 1e-10 * max(1.0, np.abs(k.forcing(y, p)).max())


def test_a_wrong_answer_would_fail():
    """The open chain's q'' (the loop cut, M q'' = F) is far from the reference: the
    comparison above can fail."""
    load_model(FOUR_BAR)
    k = numpy_module("four_bar")
    y, p = next(random_cases(1))
    open_chain = np.linalg.solve(np.asarray(k.mass_matrix(y, p)), np.asarray(k.forcing(y, p)))
    assert np.abs(open_chain - reference_qdd(y, p)).max() > 1e-3


@pytest.mark.slow
def test_c_rhs_agrees_with_lagranges_method_at_20_states():
    from derive.runtime.loader import load
    load_model(FOUR_BAR)
    library = load("four_bar")
    worst = 0.0
    for y, p in random_cases(20):
        ours = np.asarray(library.rhs(y, p))[3:]
        theirs = reference_qdd(y, p)
        worst = max(worst, np.abs(ours - theirs).max() / max(1.0, np.abs(theirs).max()))
    assert worst < 1e-10, worst
