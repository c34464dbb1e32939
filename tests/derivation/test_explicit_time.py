"""Models with explicit time (issue 23 item 3): a pendulum on a driven pivot and a
pendulum under a periodic torque, derived by derive against independent derivations
written here with sympy.physics.mechanics (nothing from derive/ builds the reference):
the pivot is a Point whose position is the prescribed a cos(w t) along x, the bob's
velocity SymPy's time derivative in the inertial frame, gravity an applied force, the
torque and the damping torques on the link's frame.  Compared: q'' = M^-1 F at 20
random (t, state, parameters) points, to 1e-10 relative."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import sympy as sp
from sympy.physics.mechanics import LagrangesMethod, Particle, Point, ReferenceFrame, dynamicsymbols

from derive.derivation.derivation import derive
from derive.derivation.symbols import t as derive_time

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
POINTS = 20
TOL = 1e-10


def mechanics_pendulum(pivot_x, torque):
    """theta'' of a point mass m on a massless rod l whose pivot is at (pivot_x(t), 0),
    under gravity and a torque(t, theta') on the rod: (function of t, theta, theta', p)."""
    m, l, g, a, w, c, F0 = sp.symbols("m l g a w c F0", positive=True)
    time = dynamicsymbols._t
    theta = dynamicsymbols("theta")
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [theta, N.z])           # the rod's frame
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", pivot_x(a, w, time) * N.x)
    B = P.locatenew("B", l * sp.sin(theta) * N.x - l * sp.cos(theta) * N.y)
    B.set_vel(N, B.pos_from(O).dt(N))
    bob = Particle("bob", B, m)
    forces = [(B, -m * g * N.y), (A, torque(F0, w, c, time, theta.diff(time)) * N.z)]
    lm = LagrangesMethod(bob.kinetic_energy(N), [theta], forcelist=forces, frame=N)
    lm.form_lagranges_equations()
    qdd = (lm.mass_matrix.inv() * lm.forcing)[0]
    th, thd, ts = sp.symbols("th thd ts")
    qdd = qdd.subs(theta.diff(time), thd).subs(theta, th).subs(time, ts)
    return sp.lambdify([ts, th, thd, m, l, g, a, w, c, F0], qdd, "mpmath"), dict(m=m, l=l, g=g, a=a, w=w, c=c, F0=F0)


def derive_acceleration(d):
    s = d.symbols
    qdd = (d.M.inv() * d.F)[0]
    return sp.lambdify([derive_time, *s.q, *s.qd, *s.params], qdd, "mpmath")


def compare(model_file, reference, rng):
    import mpmath
    mpmath.mp.dps = 30
    d = derive(str(EXAMPLES / model_file))
    ours = derive_acceleration(d)
    names = list(d.model.parameters)
    worst = 0.0
    for _ in range(POINTS):
        time, theta, rate = rng.uniform(0, 20), rng.uniform(-np.pi, np.pi), rng.uniform(-3, 3)
        p = {n: rng.uniform(5, 15) if n == "g" else rng.uniform(0.5, 2) for n in names}
        full = {n: p.get(n, 0.0) for n in ("m", "l", "g", "a", "w", "c", "F0")}
        ref = float(reference(time, theta, rate, *full.values()))
        got = float(ours(time, theta, rate, *[p[n] for n in names]))
        worst = max(worst, abs(got - ref) / max(1.0, abs(ref)))
    return worst


def test_the_driven_pivot_matches_an_independent_derivation():
    reference, _ = mechanics_pendulum(lambda a, w, time: a * sp.cos(w * time),
                                      lambda F0, w, c, time, rate: 0)
    assert compare("driven_pivot.toml", reference, np.random.default_rng(23)) < TOL


def test_the_forced_pendulum_matches_an_independent_derivation():
    reference, _ = mechanics_pendulum(lambda a, w, time: 0,
                                      lambda F0, w, c, time, rate: F0 * sp.cos(w * time) - c * rate)
    assert compare("forced_pendulum.toml", reference, np.random.default_rng(3)) < TOL


def test_the_pivot_moves_the_bob_and_its_energy():
    d = derive(str(EXAMPLES / "driven_pivot.toml"))
    s = d.symbols
    a, l = s.param("a"), s.param("l")
    theta = s.q[0]
    assert sp.simplify(d.tips[0] - sp.Matrix([a * sp.cos(s.param("w") * derive_time) + l * sp.sin(theta),
                                              -l * sp.cos(theta)])) == sp.zeros(2, 1)
    # T is the bob's 1/2 m |x'|^2 with x' including the partial in t
    x = d.tips[0]
    v = x.jacobian(s.q) * sp.Matrix(s.qd) + x.diff(derive_time)
    assert sp.simplify(d.T - s.param("m") * (v.T * v)[0, 0] / 2) == 0


def test_a_time_independent_model_keeps_its_equations():
    d = derive("planar")
    assert derive_time not in d.F.free_symbols and derive_time not in d.T.free_symbols
