"""The four-bar linkage's accelerations against an independent derivation (issue 23 item 5).

The reference is sympy.physics.mechanics' LagrangesMethod with the loop closure as its
holonomic constraint equations (`hol_coneqs`): the three links are RigidBodies in frames
rotated by their absolute angles, the joints Points located from them, gravity applied
as a force at each mass centre, and the closure written from the rocker's tip Point, not
from the model file's expressions.  LagrangesMethod forms [M J^T; J 0]-type equations of
its own (with its own multipliers), solved here numerically for q''.  The generated
NumPy and C rhs must agree with it at 20 random states on the constraints, and the
multipliers kernel must close M q'' + J^T lambda = F.
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import LagrangesMethod, Point, ReferenceFrame, RigidBody, dynamicsymbols, inertia

from derive.model import load_model
from derive.runtime.loader import numpy_module

ROOT = Path(__file__).resolve().parents[2]
FOUR_BAR = str(ROOT / "examples" / "models" / "four_bar.toml")
NAMES = ["m1", "m2", "m3", "l1", "l2", "l3", "d", "g"]


@lru_cache(maxsize=None)
def reference():
    """(M_full, f_full) of LagrangesMethod, lambdified in (q, q', params): the state's
    derivative and the multipliers solve M_full x = f_full."""
    q = dynamicsymbols("q1:4")
    qd = dynamicsymbols("q1:4", 1)
    m1, m2, m3, l1, l2, l3, d, g = params = sp.symbols(NAMES, positive=True)
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    bodies, forces, joint = [], [], O
    for i, (qi, m, l) in enumerate(zip(q, (m1, m2, m3), (l1, l2, l3)), 1):
        A = N.orientnew(f"A{i}", "Axis", [qi, N.z])   # -A.y points along the link: (sin q, -cos q)
        A.set_ang_vel(N, qi.diff() * N.z)
        centre = joint.locatenew(f"C{i}", -l / 2 * A.y)
        centre.v2pt_theory(joint, N, A)
        tip = joint.locatenew(f"P{i}", -l * A.y)
        tip.v2pt_theory(joint, N, A)
        bodies.append(RigidBody(f"B{i}", centre, A, m, (inertia(A, 0, 0, m * l ** 2 / 12), centre)))
        forces.append((centre, -m * g * N.y))
        joint = tip
    closure = [joint.pos_from(O).dot(N.x) - d, joint.pos_from(O).dot(N.y)]
    T = sum(b.kinetic_energy(N) for b in bodies)
    lm = LagrangesMethod(T, q, forcelist=forces, frame=N, hol_coneqs=closure)
    lm.form_lagranges_equations()
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


def closed_state(theta1, rate1, p, branch) -> np.ndarray:
    """A state on the loop: the coupler-rocker joint where the circles about the crank's
    tip (radius l2) and the ground pivot (radius l3) meet; rates from J q' = 0."""
    m1, m2, m3, l1, l2, l3, d, g = p
    A = np.array([l1 * np.sin(theta1), -l1 * np.cos(theta1)])
    B = np.array([d, 0.0])
    r = B - A
    L = np.hypot(*r)
    a = (l2 ** 2 - l3 ** 2 + L ** 2) / (2 * L)
    C = A + a * r / L + branch * np.sqrt(l2 ** 2 - a ** 2) * np.array([-r[1], r[0]]) / L
    theta2 = np.arctan2(*(C - A) * [1, -1])
    theta3 = np.arctan2(*(B - C) * [1, -1])
    J = np.array([[l1 * np.cos(theta1), l2 * np.cos(theta2), l3 * np.cos(theta3)],
                  [l1 * np.sin(theta1), l2 * np.sin(theta2), l3 * np.sin(theta3)]])
    rates = np.linalg.solve(J[:, 1:], -J[:, 0] * rate1)
    return np.array([theta1, theta2, theta3, rate1, *rates])


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
