"""Kinematic trees (issue 23 items 1 and 7): the cart-pole, the double pendulum on a cart,
the elastic pendulum and a branched tree, derived by derive's general path, against
independent derivations written here with sympy.physics.mechanics (nothing from derive/
builds a reference):

* the cart-pole by sympy's joints and System API (a PrismaticJoint for the cart on the
  ground, a PinJoint for the pole on the cart) and KanesMethod;
* the double pendulum on a cart, the elastic pendulum and the tree by LagrangesMethod on
  points written by hand: gravity an applied force, the cart's drive a force along x,
  the spring a force -k (r - r0) along the bob's direction (no potential energy), the
  tree's rod a RigidBody turning with its frame.

Compared at 20 random (t, state, parameters, inputs) points: M and F entry by entry, and
q'' = M^-1 F, each to 1e-10 relative to max(1, |reference|), in 30-digit mpmath."""
from __future__ import annotations

from pathlib import Path

import mpmath
import numpy as np
import sympy as sp
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics import (KanesMethod, LagrangesMethod, Particle, PinJoint, Point,
                                     PrismaticJoint, ReferenceFrame, RigidBody, System,
                                     dynamicsymbols, inertia)

from derive.derivation.derivation import derive
from derive.derivation.symbols import t as derive_time

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
POINTS = 20
TOL = 1e-10
time = dynamicsymbols._t


class Reference:
    """M, F of a reference, with its time functions replaced by plain symbols named as the
    model's states (x, theta, x_dot, theta_dot, ...), and its parameters and inputs."""

    def __init__(self, M, F, q, names, symbols):
        qd = [qi.diff(time) for qi in q]
        plain = sp.symbols(names)
        rates = sp.symbols([f"{n}_dot" for n in names])
        rule = {**dict(zip(qd, rates)), **dict(zip(q, plain))}
        self.M, self.F = M.xreplace(rule), F.xreplace(rule)
        for expr in (self.M, self.F):
            assert not expr.atoms(AppliedUndef, sp.Derivative)
        self.state = [*plain, *rates]
        self.symbols = symbols          # parameter and input name -> symbol


def lagranges(bodies, forces, q, names, symbols, frame) -> Reference:
    T = sum(b.kinetic_energy(frame) for b in bodies)        # gravity is in the forces
    lm = LagrangesMethod(T, q, forcelist=forces, frame=frame)
    lm.form_lagranges_equations()
    return Reference(lm.mass_matrix, lm.forcing, q, names, symbols)


def cart_pole_reference() -> Reference:
    """sympy's joints: the cart slides on the ground along x, the pole pinned to it."""
    M, m, l, g, F = sp.symbols("M m l g F")
    x, theta = dynamicsymbols("x theta")
    ux, utheta = dynamicsymbols("u_x u_theta")
    ground = RigidBody("ground")
    cart, bob = RigidBody("cart", mass=M), RigidBody("bob", mass=m)
    for body in (cart, bob):             # a cart and a point bob: no rotational inertia
        body.inertia = (inertia(body.frame, 0, 0, 0), body.masscenter)
    slider = PrismaticJoint("slider", ground, cart, coordinates=x, speeds=ux,
                            joint_axis=ground.frame.x)
    pin = PinJoint("pin", cart, bob, coordinates=theta, speeds=utheta, joint_axis=cart.frame.z,
                   child_point=l * bob.frame.y)   # the bob's centre is l below the pin
    system = System.from_newtonian(ground)
    system.add_joints(slider, pin)
    system.apply_uniform_gravity(-g * ground.frame.y)
    system.add_loads((cart.masscenter, F * ground.frame.x))
    system.form_eoms(eom_method=KanesMethod)
    rates = {ux: x.diff(time), utheta: theta.diff(time)}
    Mk = system.mass_matrix.xreplace(rates)
    Fk = system.forcing.xreplace(rates).xreplace({ux.diff(time): 0, utheta.diff(time): 0})
    return Reference(Mk, Fk, [x, theta], ["x", "theta"], dict(M=M, m=m, l=l, g=g, F=F))


def double_pendulum_cart_reference() -> Reference:
    M, m1, m2, l1, l2, g, F = sp.symbols("M m1 m2 l1 l2 g F")
    x, th1, th2 = dynamicsymbols("x theta1 theta2")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    cart = O.locatenew("C", x * N.x)
    bob1 = cart.locatenew("B1", l1 * (sp.sin(th1) * N.x - sp.cos(th1) * N.y))
    bob2 = bob1.locatenew("B2", l2 * (sp.sin(th2) * N.x - sp.cos(th2) * N.y))
    for P in (cart, bob1, bob2):
        P.set_vel(N, P.pos_from(O).dt(N))
    bodies = [Particle("cart", cart, M), Particle("b1", bob1, m1), Particle("b2", bob2, m2)]
    forces = [(cart, F * N.x - M * g * N.y), (bob1, -m1 * g * N.y), (bob2, -m2 * g * N.y)]
    return lagranges(bodies, forces, [x, th1, th2], ["x", "theta1", "theta2"],
                     dict(M=M, m1=m1, m2=m2, l1=l1, l2=l2, g=g, F=F), N)


def elastic_pendulum_reference() -> Reference:
    m, k, r0, g = sp.symbols("m k r0 g")
    r, theta = dynamicsymbols("r theta")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    e = sp.sin(theta) * N.x - sp.cos(theta) * N.y
    bob = O.locatenew("B", r * e)
    bob.set_vel(N, bob.pos_from(O).dt(N))
    forces = [(bob, -m * g * N.y - k * (r - r0) * e)]        # gravity and the spring's pull
    return lagranges([Particle("bob", bob, m)], forces, [r, theta], ["r", "theta"],
                     dict(m=m, k=k, r0=r0, g=g), N)


def pendulum_tree_reference() -> Reference:
    """The trunk (point m1 at l1), the left pendulum from its tip (point m2 at l2), the
    right one a rod (m3, length l3, centre at l3/2, central inertia m3 l3^2/12) pinned a
    distance d along the trunk."""
    m1, m2, m3, l1, l2, l3, d, g = sp.symbols("m1 m2 m3 l1 l2 l3 d g")
    th1, th2, th3 = dynamicsymbols("theta1 theta2 theta3")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    A3 = N.orientnew("A3", "Axis", [th3, N.z])
    down = [sp.sin(a) * N.x - sp.cos(a) * N.y for a in (th1, th2, th3)]
    tip1 = O.locatenew("T1", l1 * down[0])
    tip2 = tip1.locatenew("T2", l2 * down[1])
    hinge = O.locatenew("H", d * down[0])
    centre = hinge.locatenew("G3", l3 / 2 * down[2])
    for P in (tip1, tip2, centre):
        P.set_vel(N, P.pos_from(O).dt(N))
    rod = RigidBody("rod", centre, A3, m3, (inertia(A3, 0, 0, m3 * l3**2 / 12), centre))
    bodies = [Particle("b1", tip1, m1), Particle("b2", tip2, m2), rod]
    forces = [(tip1, -m1 * g * N.y), (tip2, -m2 * g * N.y), (centre, -m3 * g * N.y)]
    return lagranges(bodies, forces, [th1, th2, th3], ["theta1", "theta2", "theta3"],
                     dict(m1=m1, m2=m2, m3=m3, l1=l1, l2=l2, l3=l3, d=d, g=g), N)


def hinge_ball_reference() -> Reference:
    """A link on a hinge about N.y (its frame turned by psi, the link along -A.z), then a
    ball joint at its tip, the second link's direction in the second chart
    (cos vartheta, sin vartheta cos varphi, sin vartheta sin varphi); gravity along -z."""
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g")
    psi, vt, vp = dynamicsymbols("psi vartheta2 varphi2")
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [psi, N.y])
    O = Point("O")
    O.set_vel(N, 0)
    b1 = O.locatenew("B1", -l1 * A.z)
    b2 = b1.locatenew("B2", l2 * (sp.cos(vt) * N.x + sp.sin(vt) * sp.cos(vp) * N.y
                                  + sp.sin(vt) * sp.sin(vp) * N.z))
    for P in (b1, b2):
        P.set_vel(N, P.pos_from(O).dt(N))
    forces = [(b1, -m1 * g * N.z), (b2, -m2 * g * N.z)]
    return lagranges([Particle("b1", b1, m1), Particle("b2", b2, m2)], forces, [psi, vt, vp],
                     ["psi", "vartheta2", "varphi2"], dict(m1=m1, m2=m2, l1=l1, l2=l2, g=g), N)


def spinning_body_reference() -> Reference:
    """A RigidBody whose frame is N turned by alpha about x, beta about the new y, gamma
    about the newest z (sympy's 'Body' XYZ orientation: a Cardan joint and a spin), its
    centre l down its own -z from the pivot, central inertia diag(A, B, C) in its frame."""
    m, l, A, B, C, g = sp.symbols("m l A B C g")
    alpha, beta, gamma = dynamicsymbols("alpha beta gamma")
    N = ReferenceFrame("N")
    F = N.orientnew("F", "Body", [alpha, beta, gamma], "XYZ")
    O = Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", -l * F.z)
    G.v2pt_theory(O, N, F)
    body = RigidBody("body", G, F, m, (inertia(F, A, B, C), G))
    return lagranges([body], [(G, -m * g * N.z)], [alpha, beta, gamma], ["alpha", "beta", "gamma"],
                     dict(m=m, l=l, A=A, B=B, C=C, g=g), N)


def worst_differences(model_file: str, ref: Reference, rng) -> tuple[float, float, float]:
    """The largest relative differences of M, F and q'' over POINTS random points."""
    d = derive(str(EXAMPLES / model_file))
    s = d.symbols
    assert [x.name for x in s.state] == [x.name for x in ref.state]
    ours_args = [derive_time, *s.state, *s.params, *s.u]
    names = [*(x.name for x in s.params), *(x.name for x in s.u)]
    ref_args = [derive_time, *ref.state, *(ref.symbols[n] for n in names)]
    ours = [sp.lambdify(ours_args, X, "mpmath") for X in (d.M, d.F)]
    theirs = [sp.lambdify(ref_args, X, "mpmath") for X in (ref.M, ref.F)]
    worst = [0.0, 0.0, 0.0]
    with mpmath.workdps(30):
        for _ in range(POINTS):
            point = [rng.uniform(0, 10), *rng.uniform(-np.pi, np.pi, len(s.q)),
                     *rng.uniform(-3, 3, len(s.qd)),
                     *[rng.uniform(5, 15) if n == "g" else rng.uniform(0.5, 2) for n in names]]
            point = [mpmath.mpf(float(v)) for v in point]
            if "r" in [x.name for x in s.q]:            # a spring's length is positive
                point[1 + [x.name for x in s.q].index("r")] = abs(point[1]) + 0.5
            M, F = (f(*point) for f in ours)
            Mr, Fr = (mpmath.matrix(f(*point)) for f in theirs)
            qdd, qdd_r = mpmath.lu_solve(M, F), mpmath.lu_solve(Mr, Fr)
            for k, (a, b) in enumerate(((M, Mr), (F, Fr), (qdd, qdd_r))):
                a, b = mpmath.matrix(a), mpmath.matrix(b)
                for i in range(b.rows):
                    for j in range(b.cols):
                        worst[k] = max(worst[k], float(abs(a[i, j] - b[i, j]) / max(1, abs(b[i, j]))))
    return tuple(worst)


def _check(model_file, reference):
    worst = worst_differences(model_file, reference(), np.random.default_rng(23))
    assert max(worst) < TOL, f"{model_file}: M, F, q'' differ by {worst}"


def test_cart_pole_against_sympy_joints():
    _check("cart_pole.toml", cart_pole_reference)


def test_double_pendulum_cart_against_mechanics():
    _check("double_pendulum_cart.toml", double_pendulum_cart_reference)


def test_elastic_pendulum_against_mechanics():
    _check("elastic_pendulum.toml", elastic_pendulum_reference)


def test_hinge_ball_against_mechanics():
    _check("hinge_ball.toml", hinge_ball_reference)


def test_spinning_rigid_body_against_mechanics():
    _check("spinning_body.toml", spinning_body_reference)


def test_pendulum_tree_against_mechanics():
    _check("pendulum_tree.toml", pendulum_tree_reference)


# -- springs: the same physics as a spring force or a torque in the reference ---------------

ELASTIC_BY_A_SPRING = '''
name = "elastic_spring"
dimension = 2
parameters = ["m", "k", "r0", "g"]
coordinates = ["r", "theta"]
[[links]]
name = "arm"
chart = "planar"
coordinate = "theta"
[[links]]
name = "bob"
parent = "arm"
joint = "prismatic"
axis = [0, -1]
coordinate = "r"
body = { kind = "point", mass = "m" }
[[springs]]
between = ["pivot", "bob"]
stiffness = "k"
rest_length = "r0"
'''

TWISTED = '''
name = "twisted_double"
dimension = 2
parameters = ["m1", "m2", "l1", "l2", "k1", "k2", "a", "g"]
[[links]]
name = "upper"
chart = "planar"
length = "l1"
body = { kind = "point", mass = "m1" }
[[links]]
name = "lower"
chart = "planar"
length = "l2"
body = { kind = "point", mass = "m2" }
[[springs]]                        # a torsional spring at the elbow, rest angle a
joint = "lower"
stiffness = "k1"
rest_angle = "a"
[[springs]]                        # a zero-length spring from the pivot to the lower bob
between = ["pivot", "lower"]
stiffness = "k2"
'''


def twisted_reference() -> Reference:
    """A planar double pendulum with a torsional spring at the elbow (the torque
    -k1 (theta2 - theta1 - a) on link 2, its reaction on link 1) and the force -k2 x2 on
    the lower bob (a zero-length spring from the pivot)."""
    m1, m2, l1, l2, k1, k2, a, g = sp.symbols("m1 m2 l1 l2 k1 k2 a g")
    th1, th2 = dynamicsymbols("theta1 theta2")
    N = ReferenceFrame("N")
    A1, A2 = N.orientnew("A1", "Axis", [th1, N.z]), N.orientnew("A2", "Axis", [th2, N.z])
    O = Point("O")
    O.set_vel(N, 0)
    b1 = O.locatenew("B1", -l1 * A1.y)
    b2 = b1.locatenew("B2", -l2 * A2.y)
    for P in (b1, b2):
        P.set_vel(N, P.pos_from(O).dt(N))
    torque = -k1 * (th2 - th1 - a) * N.z
    forces = [(b1, -m1 * g * N.y), (b2, -m2 * g * N.y - k2 * b2.pos_from(O)),
              (A2, torque), (A1, -torque)]
    return lagranges([Particle("b1", b1, m1), Particle("b2", b2, m2)], forces, [th1, th2],
                     ["theta1", "theta2"], dict(m1=m1, m2=m2, l1=l1, l2=l2, k1=k1, k2=k2, a=a, g=g), N)


def test_springs_against_mechanics(tmp_path):
    for text, reference in ((ELASTIC_BY_A_SPRING, elastic_pendulum_reference), (TWISTED, twisted_reference)):
        path = tmp_path / "model.toml"
        path.write_text(text)
        worst = worst_differences(str(path), reference(), np.random.default_rng(5))
        assert max(worst) < TOL, f"{text.split()[2]}: M, F, q'' differ by {worst}"


def test_cart_pole_linearised_upright_is_its_closed_form():
    """At the upright rest (theta = pi) x'' = (m g / M) theta + F / M and
    theta'' = ((M + m) g / (M l)) theta + F / (M l), theta measured from upright."""
    import derive
    M, m, l, g = 1.3, 0.4, 0.7, 9.81
    A, B = derive.linearize(str(EXAMPLES / "cart_pole.toml"), state={"theta": "pi"},
                            params={"M": M, "m": m, "l": l, "g": g}, inputs={"F": 0.0})
    expected_A = np.zeros((4, 4))
    expected_A[0, 2] = expected_A[1, 3] = 1.0
    expected_A[2, 1], expected_A[3, 1] = m * g / M, (M + m) * g / (M * l)
    assert np.allclose(A, expected_A, rtol=1e-12, atol=1e-12)
    assert np.allclose(np.ravel(B), [0.0, 0.0, 1 / M, 1 / (M * l)], rtol=1e-12, atol=1e-12)


WINDY = """
name = "windy"
dimension = 2
parameters = ["m1", "m2", "l1", "l2", "c", "w", "g"]
inputs = ["P"]
[[links]]
name = "upper"
chart = "planar"
length = "l1"
body = { kind = "rod", mass = "m1", com = "1/2", inertia = "m1*l1**2/12" }
[[links]]
name = "lower"
chart = "planar"
length = "l2"
body = { kind = "point", mass = "m2" }
[[loads]]                       # a gust on the lower bob, in t and in its height
point = "lower"
force = ["c*sin(w*t)", "-c*theta2_dot"]
[[loads]]                       # a push at the upper rod's centre, a run-time input
point = "upper.centre"
force = ["P", "0"]
"""


def windy_reference() -> Reference:
    """The same double pendulum with the two forces applied at their points (sympy's
    Force on a Point: LagrangesMethod maps them through the points' velocities)."""
    m1, m2, l1, l2, c, w, g, P = sp.symbols("m1 m2 l1 l2 c w g P")
    th1, th2 = dynamicsymbols("theta1 theta2")
    N = ReferenceFrame("N")
    A1, A2 = N.orientnew("A1", "Axis", [th1, N.z]), N.orientnew("A2", "Axis", [th2, N.z])
    O = Point("O")
    O.set_vel(N, 0)
    centre = O.locatenew("C1", -l1 / 2 * A1.y)
    elbow = O.locatenew("E", -l1 * A1.y)
    bob = elbow.locatenew("B2", -l2 * A2.y)
    for point in (centre, elbow, bob):
        point.set_vel(N, point.pos_from(O).dt(N))
    rod = RigidBody("rod", centre, A1, m1, (inertia(A1, 0, 0, m1 * l1**2 / 12), centre))
    forces = [(centre, -m1 * g * N.y + P * N.x),
              (bob, -m2 * g * N.y + c * sp.sin(w * time) * N.x - c * th2.diff(time) * N.y)]
    return lagranges([rod, Particle("b2", bob, m2)], forces, [th1, th2], ["theta1", "theta2"],
                     dict(m1=m1, m2=m2, l1=l1, l2=l2, c=c, w=w, g=g, P=P), N)


def test_loads_at_points_against_mechanics(tmp_path):
    """[[loads]]: forces at a link's tip and at a body's centre, in t, a rate and an input."""
    path = tmp_path / "windy.toml"
    path.write_text(WINDY)
    worst = worst_differences(str(path), windy_reference(), np.random.default_rng(11))
    assert max(worst) < TOL, f"windy: M, F, q'' differ by {worst}"
