"""Prescribed joint motion (issue 23 item 3: "a prescribed (rheonomic) pivot or joint
motion"): a link with `prescribed = "f(t)"` has no coordinate in the state; derive's
equations of the four example models against derivations written here with
sympy.physics.mechanics, where the driven joint is the same f(t) of SymPy's own time
(frames oriented by W t, a point located at r(t)), so SymPy differentiates it itself:

* crank_pendulum: a point pendulum on the tip of a crank turned at w t (planar);
* pumped_swing: a point bob at r(t) = L (1 + e cos w t) along a hinged arm (a driven slider);
* governor: a rod hinged to a turntable turned about z at W t (3-D, the rod's turning);
* driven_gyroscope: a rigid rotor on a Cardan joint spun at W t about its own axis.

M, F and q'' at 20 random (t, state, parameters) points, to 1e-10 relative, in mpmath
(worst_differences of test_joints_against_mechanics); then the run: derive.simulate of the
crank pendulum against SciPy on the hand-written ODE."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import Particle, Point, ReferenceFrame, RigidBody, dynamicsymbols, inertia

import derive
from derive.errors import ModelError
from derive.model.description import parse_model
from tests.derivation.test_joints_against_mechanics import EXAMPLES, TOL, lagranges, worst_differences

time = dynamicsymbols._t


def crank_reference():
    m, l1, l2, g, w = sp.symbols("m l1 l2 g w")
    theta2 = dynamicsymbols("theta2")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    tip = O.locatenew("tip", l1 * sp.sin(w * time) * N.x - l1 * sp.cos(w * time) * N.y)
    bob = tip.locatenew("bob", l2 * sp.sin(theta2) * N.x - l2 * sp.cos(theta2) * N.y)
    bob.set_vel(N, bob.pos_from(O).dt(N))
    return lagranges([Particle("P", bob, m)], [(bob, -m * g * N.y)], [theta2], ["theta2"],
                     dict(m=m, l1=l1, l2=l2, g=g, w=w), N)


def pumped_swing_reference():
    m, L, e, w, g = sp.symbols("m L e w g")
    theta = dynamicsymbols("theta")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    r = L * (1 + e * sp.cos(w * time))
    bob = O.locatenew("bob", r * sp.sin(theta) * N.x - r * sp.cos(theta) * N.y)
    bob.set_vel(N, bob.pos_from(O).dt(N))
    return lagranges([Particle("P", bob, m)], [(bob, -m * g * N.y)], [theta], ["theta"],
                     dict(m=m, L=L, e=e, w=w, g=g), N)


def governor_reference():
    m, l, I, W, g = sp.symbols("m l I W g")
    theta = dynamicsymbols("theta")
    N = ReferenceFrame("N")
    table = N.orientnew("table", "Axis", [W * time, N.z])
    arm = table.orientnew("arm", "Axis", [theta, table.x])
    O = Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", -l / 2 * arm.z)                 # the rod hangs down its own -z
    G.v2pt_theory(O, N, arm)
    rod = RigidBody("rod", G, arm, m, (inertia(arm, I, I, 0), G))     # no spin about its own axis
    return lagranges([rod], [(G, -m * g * N.z)], [theta], ["theta"], dict(m=m, l=l, I=I, W=W, g=g), N)


def gyroscope_reference():
    m, l, A, B, C, W, g = sp.symbols("m l A B C W g")
    alpha, beta = dynamicsymbols("alpha beta")
    N = ReferenceFrame("N")
    F = N.orientnew("F", "Body", [alpha, beta, W * time], "XYZ")
    O = Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", -l * F.z)
    G.v2pt_theory(O, N, F)
    body = RigidBody("rotor", G, F, m, (inertia(F, A, B, C), G))
    return lagranges([body], [(G, -m * g * N.z)], [alpha, beta], ["alpha", "beta"],
                     dict(m=m, l=l, A=A, B=B, C=C, W=W, g=g), N)


@pytest.mark.parametrize("model_file, reference", [
    ("crank_pendulum.toml", crank_reference),
    ("pumped_swing.toml", pumped_swing_reference),
    ("governor.toml", governor_reference),
    ("driven_gyroscope.toml", gyroscope_reference),
])
def test_a_prescribed_joint_against_mechanics(model_file, reference):
    worst = worst_differences(model_file, reference(), np.random.default_rng(31))
    assert max(worst) < TOL, f"{model_file}: M, F, q'' differ by {worst}"


def test_the_crank_pendulum_runs_as_the_hand_written_ode():
    P = dict(m=1.0, l1=0.3, l2=1.0, g=9.81, w=5.0)
    t = np.linspace(0, 10, 11)
    r = derive.simulate(str(EXAMPLES / "crank_pendulum.toml"), [0.2, 0.0], t, P, rtol=1e-12, atol=1e-12)

    def f(time, y):       # m l2^2 theta'' = -m g l2 sin(theta) + m l1 l2 w^2 sin(w t - theta)
        return [y[1], (-P["g"] * np.sin(y[0]) + P["l1"] * P["w"] ** 2 * np.sin(P["w"] * time - y[0])) / P["l2"]]
    want = solve_ivp(f, (0, 10), [0.2, 0.0], t_eval=t, method="DOP853", rtol=1e-13, atol=1e-13).y.T
    assert r.ok and np.abs(r.y - want).max() < 1e-8


@pytest.mark.parametrize("link, message", [
    ('chart = "standard"\nlength = "l"\nprescribed = "t"\nbody = { kind = "point", mass = "m" }',
     "'prescribed' drives a joint of one coordinate"),
    ('chart = "planar"\nlength = "l"\nprescribed = "theta1"\nbody = { kind = "point", mass = "m" }',
     "prescribed"),
    ('chart = "planar"\nlength = "l"\nprescribed = "w*t"\ncoordinate = "phi"\nbody = { kind = "point", mass = "m" }',
     "a prescribed joint has no coordinate of the state"),
])
def test_a_wrong_prescribed_joint_is_one_line(link, message):
    dim = 3 if "standard" in link else 2
    text = f'name = "bad"\ndimension = {dim}\nparameters = ["m", "l", "g", "w"]\n[[links]]\n{link}\n' \
           f'[[links]]\nchart = "{"standard" if dim == 3 else "planar"}"\nlength = "l"\n' \
           f'body = {{ kind = "point", mass = "m" }}\n'
    with pytest.raises(ModelError, match=message) as info:
        parse_model(text, "bad.toml")
    assert "\n" not in str(info.value)


def test_a_model_whose_every_joint_is_prescribed_is_one_line():
    text = ('name = "bad"\ndimension = 2\nparameters = ["m", "l", "w", "g"]\n[[links]]\nchart = "planar"\n'
            'length = "l"\nprescribed = "w*t"\nbody = { kind = "point", mass = "m" }\n')
    with pytest.raises(ModelError, match="every joint is prescribed: the model has no coordinate"):
        parse_model(text, "bad.toml")
