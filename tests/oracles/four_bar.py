"""The four-bar linkage built with sympy.physics.mechanics, for the closed-loop tests.

For tests only; nothing here comes from derive/.  The three links are RigidBodies in
frames rotated by their absolute angles, the joints Points located from them, gravity a
force at each mass centre, and the loop closure written from the rocker's tip Point (not
from the model file's expressions); LagrangesMethod takes the closure as its holonomic
constraint equations (`hol_coneqs`).  Its conventions are the model file's
(examples/models/four_bar.toml): angles from the downward vertical, link vectors
l (sin q, -cos q), the rocker's tip pinned at (d, 0).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import sympy as sp
from sympy.physics.mechanics import LagrangesMethod, Point, ReferenceFrame, RigidBody, dynamicsymbols, inertia

NAMES = ["m1", "m2", "m3", "l1", "l2", "l3", "d", "g"]


@lru_cache(maxsize=None)
def lagranges_method():
    """(lm, q, q', params): the four-bar's LagrangesMethod, its equations formed."""
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
    return lm, q, qd, params


def closed_state(theta1, rate1, p, branch) -> np.ndarray:
    """A state on the loop: the coupler-rocker joint where the circles about the crank's
    tip (radius l2) and the ground pivot (radius l3) meet; rates from J q' = 0."""
    m1, m2, m3, l1, l2, l3, d, g = p
    A = np.array([l1 * np.sin(theta1), -l1 * np.cos(theta1)])
    B = np.array([d, 0.0])
    r = B - A
    L = np.hypot(*r)
    a = (l2 ** 2 - l3 ** 2 + L ** 2) / (2 * L)
    with np.errstate(invalid="ignore"):          # NaN where the circles do not meet (out of reach)
        C = A + a * r / L + branch * np.sqrt(l2 ** 2 - a ** 2) * np.array([-r[1], r[0]]) / L
    theta2 = np.arctan2(*(C - A) * [1, -1])
    theta3 = np.arctan2(*(B - C) * [1, -1])
    J = np.array([[l1 * np.cos(theta1), l2 * np.cos(theta2), l3 * np.cos(theta3)],
                  [l1 * np.sin(theta1), l2 * np.sin(theta2), l3 * np.sin(theta3)]])
    rates = np.linalg.solve(J[:, 1:], -J[:, 0] * rate1)
    return np.array([theta1, theta2, theta3, rate1, *rates])
