"""Every printed formula of the seeds, transcribed once, tagged with its equation.

Each :class:`~.claims.Claim` pairs
  * ``printed(c)``: the formula as printed, written as close to the page as
    possible (mu where the page writes mu; J, q_i, dot products as printed),
  * ``derived(c)``: the same quantity from the derivation -- differentiated,
    multiplied out or read off ``c.d`` (M, F, T, V, L, the paper forms, the
    chart's link vectors), never re-typed.
``c`` is the :class:`~.claims.Context` of the claim's model.

Where the page gives several forms joined by "=", each form is its own claim
(distinct descriptions).  Where its label and its value disagree, one claim
checks the value against the quantity named by the label and another against
the quantity the value is (the recorded erratum says which is which).
Seed 000 is H. Inou, "Double pendulum"; seed 001 the compound pendulum note.

Readings decided here (the errata module records what is wrong):
  * (1.27), (1.33), (2.14), (2.15): the label and the value disagree; the
    value is checked against the labelled quantity (an erratum) and against
    the quantity it is (a match).
  * (2.16), (2.17) write theta_i', phi_i' in the general chart (u_i, v_i);
    read as u_i', v_i' (a notation slip, not an erratum) and checked in both
    charts.
  * (3.17): the printed rate vector lacks both th2'^2 and ph2'^2.
  * (3.40) cannot be evaluated as printed (a 4x4 matrix times a 6-vector);
    its gravity term is checked separately at rest, where the rate term
    vanishes.
  * (4.6) "respect orientations": a standard chart v' respects them when it
    orients the sphere like the (4.1) chart, (dv'/dth x dv'/dph) . v' = +sin th
    (equivalently, the map to (4.1) is a rotation, det = +1).
  * 5.1's garbled "(theta', phi' = pi/2 - theta, phi)" is read literally as
    (theta', phi') = (pi/2 - theta, phi) and checked against q' = (q, p, r);
    the swap actually gives (theta, pi/2 - phi).
  * 5.1's rule: "small" means below 0.5, the example threshold of step 1.
  * (5.2)-(5.5) drop the link length in the angle-only forms ("we may assume
    l = 1"); atan2 is invariant under a positive factor, so all forms are
    checked against the link vector of length l1.
"""
from __future__ import annotations

import math

import sympy as sp
from sympy import Matrix, cos, sin, sqrt, atan2, pi

from .claims import (SEED0, SEED1, AtanForm, ChartRule, Claim, IllFormed, Solve,
                     context)

CLAIMS: list[Claim] = []

PLANAR, COMPOUND = "planar", "compound"
STD, ALT, ROT = "spherical_std", "spherical_alt", "spherical_rot"
CHART_NAME = {STD: "standard chart", ALT: "second chart"}
J = Matrix([[0, -1], [1, 0]])        # below (1.12)
I2 = sp.eye(2)


def claim(equation, what, model, derived, *, seed=SEED0, kind="identity", point_map=None):
    """Register the decorated function as the printed side of a claim."""
    def register(printed):
        CLAIMS.append(Claim(seed, equation, what, model, printed, derived, kind, point_map))
        return printed
    return register


def dot(a, b):
    return (Matrix(a).T * Matrix(b))[0, 0]


def stack(*parts):
    return Matrix.vstack(*[Matrix(p) for p in parts])


def blocks(rows):
    return Matrix(sp.BlockMatrix(rows))


def matmul(A, x):
    """A x as written on the page; an ill-formed product when the shapes do not fit."""
    if A.shape[1] != x.shape[0]:
        return IllFormed((A.shape, x.shape), f"{A.shape[0]}x{A.shape[1]} matrix times "
                         f"{x.shape[0]}-vector")
    return A * x


def inverse(m):
    """The inverse of a small printed matrix, in closed form (adjugate / det)."""
    return m.adjugate() / m.det()


# =============================================================================
# Seed 000, section 1: planar double pendulum (model "planar")
# =============================================================================

def th(c, i):
    return (c.theta1, c.theta2)[i - 1]


def thd(c, i):
    return (c.theta1_dot, c.theta2_dot)[i - 1]


def thdd(c, i):
    return (c.theta1_ddot, c.theta2_ddot)[i - 1]


def l(c, i):
    return (c.l1, c.l2)[i - 1]


def dq_both(c):
    return stack(*[c.qvec(i).diff(th(c, i)) for i in (1, 2)])


@claim("1.3", "q_i = (l_i sin theta_i, -l_i cos theta_i)", PLANAR,
       lambda c: stack(c.qvec(1), c.qvec(2)))
def _(c):
    return stack(*[Matrix([l(c, i) * sin(th(c, i)), -l(c, i) * cos(th(c, i))]) for i in (1, 2)])


@claim("1.3", "x_1 = q_1, x_2 = q_1 + q_2", PLANAR, lambda c: stack(*c.d.tips))
def _(c):
    return stack(c.qvec(1), c.qvec(1) + c.qvec(2))


@claim("1.3", "T = 1/2 m1 |x1'|^2 + 1/2 m2 |x2'|^2", PLANAR, lambda c: c.d.T)
def _(c):
    x1, x2 = c.ddt(c.qvec(1)), c.ddt(c.qvec(1) + c.qvec(2))
    return c.m1 * dot(x1, x1) / 2 + c.m2 * dot(x2, x2) / 2


@claim("1.3", "V = m1 g y1 + m2 g y2", PLANAR, lambda c: c.d.V)
def _(c):
    return c.m1 * c.g * c.qvec(1)[1] + c.m2 * c.g * (c.qvec(1) + c.qvec(2))[1]


@claim("1.7", "dq_i/dtheta_i = (l_i cos theta_i, l_i sin theta_i)", PLANAR, dq_both)
def _(c):
    return stack(*[Matrix([l(c, i) * cos(th(c, i)), l(c, i) * sin(th(c, i))]) for i in (1, 2)])


@claim("1.7", "dq_i/dtheta_i = J q_i", PLANAR, dq_both)
def _(c):
    return stack(*[J * c.qvec(i) for i in (1, 2)])


def qdot_both(c):
    return stack(c.qdot(1), c.qdot(2))


@claim("1.8", "q_i' = (l_i theta_i' cos theta_i, l_i theta_i' sin theta_i)", PLANAR, qdot_both)
def _(c):
    return stack(*[thd(c, i) * l(c, i) * Matrix([cos(th(c, i)), sin(th(c, i))]) for i in (1, 2)])


@claim("1.8", "q_i' = theta_i' J q_i", PLANAR, qdot_both)
def _(c):
    return stack(*[thd(c, i) * J * c.qvec(i) for i in (1, 2)])


def dqdot_dtheta(c):
    return stack(*[c.qdot(i).diff(th(c, i)) for i in (1, 2)])


@claim("1.9", "dq_i'/dtheta_i = theta_i' J dq_i/dtheta_i", PLANAR, dqdot_dtheta)
def _(c):
    return stack(*[thd(c, i) * J * c.qvec(i).diff(th(c, i)) for i in (1, 2)])


@claim("1.9", "dq_i'/dtheta_i = theta_i' J^2 q_i", PLANAR, dqdot_dtheta)
def _(c):
    return stack(*[thd(c, i) * J**2 * c.qvec(i) for i in (1, 2)])


@claim("1.9", "dq_i'/dtheta_i = -theta_i' q_i", PLANAR, dqdot_dtheta)
def _(c):
    return stack(*[-thd(c, i) * c.qvec(i) for i in (1, 2)])


@claim("1.10", "dq_i'/dtheta_i' = J q_i", PLANAR,
       lambda c: stack(*[c.qdot(i).diff(thd(c, i)) for i in (1, 2)]))
def _(c):
    return stack(*[J * c.qvec(i) for i in (1, 2)])


def ddt_dqdot_dthetadot(c):
    return stack(*[c.ddt(c.qdot(i).diff(thd(c, i))) for i in (1, 2)])


@claim("1.11", "d/dt dq_i'/dtheta_i' = J q_i'", PLANAR, ddt_dqdot_dthetadot)
def _(c):
    return stack(*[J * c.qdot(i) for i in (1, 2)])


@claim("1.11", "d/dt dq_i'/dtheta_i' = -theta_i' q_i", PLANAR, ddt_dqdot_dthetadot)
def _(c):
    return stack(*[-thd(c, i) * c.qvec(i) for i in (1, 2)])


def qddot_both(c):
    return stack(c.qddot(1), c.qddot(2))


@claim("1.12", "q_i'' = theta_i'' J q_i + theta_i' J q_i'", PLANAR, qddot_both)
def _(c):
    return stack(*[thdd(c, i) * J * c.qvec(i) + thd(c, i) * J * c.qdot(i) for i in (1, 2)])


@claim("1.12", "q_i'' = theta_i'' J q_i - theta_i'^2 q_i", PLANAR, qddot_both)
def _(c):
    return stack(*[thdd(c, i) * J * c.qvec(i) - thd(c, i)**2 * c.qvec(i) for i in (1, 2)])


def L_113_first(c):
    """First form of (1.13) in the link components."""
    q1, q2, v1, v2 = c.cart(1), c.cart(2), c.cart_dot(1), c.cart_dot(2)
    return (c.m1 * dot(v1, v1) / 2 + c.m2 * dot(v1 + v2, v1 + v2) / 2
            - c.m1 * c.g * q1[1] - c.m2 * c.g * (q1[1] + q2[1]))


def L_113_second(c):
    q1, q2, v1, v2 = c.cart(1), c.cart(2), c.cart_dot(1), c.cart_dot(2)
    return ((c.m1 + c.m2) * dot(v1, v1) / 2 + c.m2 * dot(v2, v2) / 2 + c.m2 * dot(v1, v2)
            - (c.m1 + c.m2) * c.g * q1[1] - c.m2 * c.g * q2[1])


claim("1.13", "L, first form, in link components (vs the model's L built in them)", PLANAR,
      lambda c: c.L_cart)(L_113_first)
claim("1.13", "L, second form, in link components", PLANAR, lambda c: c.L_cart)(L_113_second)
claim("1.13", "L, first form, in theta (vs the derivation's L)", PLANAR,
      lambda c: c.d.L)(lambda c: c.to_chart(L_113_first(c)))
claim("1.13", "L, second form, in theta", PLANAR,
      lambda c: c.d.L)(lambda c: c.to_chart(L_113_second(c)))


@claim("1.14", "dL/dq_1 = (0, (m1 + m2) g)", PLANAR, lambda c: c.dL_dcart(1))
def _(c):
    return Matrix([0, (c.m1 + c.m2) * c.g])


@claim("1.15", "dL/dq_2 = (0, m2 g)", PLANAR, lambda c: c.dL_dcart(2))
def _(c):
    return Matrix([0, c.m2 * c.g])


@claim("1.16", "dL/dq_1' = (m1 + m2) q_1' + m2 q_2'", PLANAR, lambda c: c.dL_dcart_dot(1))
def _(c):
    return (c.m1 + c.m2) * c.cart_dot(1) + c.m2 * c.cart_dot(2)


@claim("1.16", "dL/dq_1' = (m1 + m2) theta1' J q_1 + m2 theta2' J q_2", PLANAR,
       lambda c: c.to_chart(c.dL_dcart_dot(1)))
def _(c):
    return (c.m1 + c.m2) * c.theta1_dot * J * c.qvec(1) + c.m2 * c.theta2_dot * J * c.qvec(2)


@claim("1.17", "dL/dq_2' = m2 q_1' + m2 q_2'", PLANAR, lambda c: c.dL_dcart_dot(2))
def _(c):
    return c.m2 * c.cart_dot(1) + c.m2 * c.cart_dot(2)


@claim("1.17", "dL/dq_2' = m2 theta1' J q_1 + m2 theta2' J q_2", PLANAR,
       lambda c: c.to_chart(c.dL_dcart_dot(2)))
def _(c):
    return c.m2 * c.theta1_dot * J * c.qvec(1) + c.m2 * c.theta2_dot * J * c.qvec(2)


@claim("1.18", "d/dt dL/dq_1' = (m1 + m2) q_1'' + m2 q_2''", PLANAR,
       lambda c: c.ddt(c.dL_dcart_dot(1)))
def _(c):
    return (c.m1 + c.m2) * c.cart_ddot(1) + c.m2 * c.cart_ddot(2)


@claim("1.18", "d/dt dL/dq_1' in theta", PLANAR, lambda c: c.ddt(c.to_chart(c.dL_dcart_dot(1))))
def _(c):
    q1, q2 = c.qvec(1), c.qvec(2)
    return ((c.m1 + c.m2) * c.theta1_ddot * J * q1 + c.m2 * c.theta2_ddot * J * q2
            - (c.m1 + c.m2) * c.theta1_dot**2 * q1 - c.m2 * c.theta2_dot**2 * q2)


@claim("1.19", "d/dt dL/dq_2' = m2 q_1'' + m2 q_2''", PLANAR, lambda c: c.ddt(c.dL_dcart_dot(2)))
def _(c):
    return c.m2 * c.cart_ddot(1) + c.m2 * c.cart_ddot(2)


@claim("1.19", "d/dt dL/dq_2' in theta", PLANAR, lambda c: c.ddt(c.to_chart(c.dL_dcart_dot(2))))
def _(c):
    q1, q2 = c.qvec(1), c.qvec(2)
    return (c.m2 * c.theta1_ddot * J * q1 + c.m2 * c.theta2_ddot * J * q2
            - c.m2 * c.theta1_dot**2 * q1 - c.m2 * c.theta2_dot**2 * q2)


# The four inner products of the chain rule (1.4), (1.6) for link i, derived by
# differentiating the model's L in the link components and the chart's q_i.
def term_gravity(c, i):
    """dL/dq_i . dq_i/dtheta_i"""
    return dot(c.to_chart(c.dL_dcart(i)), c.qvec(i).diff(th(c, i)))


def term_velocity(c, i):
    """dL/dq_i' . dq_i'/dtheta_i"""
    return dot(c.to_chart(c.dL_dcart_dot(i)), c.qdot(i).diff(th(c, i)))


def term_acceleration(c, i):
    """(d/dt dL/dq_i') . dq_i'/dtheta_i'"""
    return dot(c.ddt(c.to_chart(c.dL_dcart_dot(i))), c.qdot(i).diff(thd(c, i)))


def term_moving_frame(c, i):
    """dL/dq_i' . d/dt (dq_i'/dtheta_i')"""
    return dot(c.to_chart(c.dL_dcart_dot(i)), c.ddt(c.qdot(i).diff(thd(c, i))))


def q1_J_q2(c):
    return dot(c.qvec(1), J * c.qvec(2))


def q1_q2(c):
    return dot(c.qvec(1), c.qvec(2))


@claim("1.20", "dL/dq_1 . dq_1/dtheta_1 = (m1 + m2) g l1 sin theta1", PLANAR,
       lambda c: term_gravity(c, 1))
def _(c):
    return (c.m1 + c.m2) * c.g * c.l1 * sin(c.theta1)


@claim("1.21", "dL/dq_1' . dq_1'/dtheta_1, first form", PLANAR, lambda c: term_velocity(c, 1))
def _(c):
    q1, q2 = c.qvec(1), c.qvec(2)
    return dot((c.m1 + c.m2) * c.theta1_dot * J * q1 + c.m2 * c.theta2_dot * J * q2,
               -c.theta1_dot * q1)


@claim("1.21", "dL/dq_1' . dq_1'/dtheta_1 = -m2 theta1' theta2' q_1 . J q_2", PLANAR,
       lambda c: term_velocity(c, 1))
def _(c):
    return -c.m2 * c.theta1_dot * c.theta2_dot * q1_J_q2(c)


@claim("1.22", "(d/dt dL/dq_1') . dq_1'/dtheta_1'", PLANAR, lambda c: term_acceleration(c, 1))
def _(c):
    return ((c.m1 + c.m2) * c.theta1_ddot * c.l1**2 + c.m2 * c.theta2_ddot * q1_q2(c)
            + c.m2 * c.theta2_dot**2 * q1_J_q2(c))


@claim("1.23", "dL/dq_1' . d/dt dq_1'/dtheta_1'", PLANAR, lambda c: term_moving_frame(c, 1))
def _(c):
    return -c.m2 * c.theta1_dot * c.theta2_dot * q1_J_q2(c)


@claim("1.24", "dL/dq_2 . dq_2/dtheta_2 = m2 g l2 sin theta2", PLANAR,
       lambda c: term_gravity(c, 2))
def _(c):
    return c.m2 * c.g * c.l2 * sin(c.theta2)


@claim("1.25", "dL/dq_2' . dq_2'/dtheta_2", PLANAR, lambda c: term_velocity(c, 2))
def _(c):
    return c.m2 * c.theta1_dot * c.theta2_dot * q1_J_q2(c)


@claim("1.26", "(d/dt dL/dq_2') . dq_2'/dtheta_2'", PLANAR, lambda c: term_acceleration(c, 2))
def _(c):
    return (c.m2 * c.theta1_ddot * q1_q2(c) + c.m2 * c.theta2_ddot * c.l2**2
            - c.m2 * c.theta1_dot**2 * q1_J_q2(c))


def p127_first(c):
    return -c.m2 * c.theta1_dot * c.theta2_dot * dot(c.qvec(2), J * c.qvec(1))


def p127_second(c):
    return c.m2 * c.theta1_dot * c.theta2_dot * q1_J_q2(c)


# (1.27) is labelled dL/dq_2' . d/dt (dq_2'/dtheta_2) -- theta_2 without a dot.
claim("1.27", "first form vs the quantity as labelled, d/dt dq_2'/dtheta_2", PLANAR,
      lambda c: dot(c.to_chart(c.dL_dcart_dot(2)), c.ddt(c.qdot(2).diff(c.theta2))))(p127_first)
claim("1.27", "first form vs d/dt dq_2'/dtheta_2' (the term used in 1.33)", PLANAR,
      lambda c: term_moving_frame(c, 2))(p127_first)
claim("1.27", "second form vs d/dt dq_2'/dtheta_2' (the term used in 1.33)", PLANAR,
      lambda c: term_moving_frame(c, 2))(p127_second)

# (1.28)-(1.29): identities for any plane vectors q, q'.
VEC_Q = Matrix(sp.symbols("qa_x qa_y", real=True))
VEC_QP = Matrix(sp.symbols("qb_x qb_y", real=True))


@claim("1.28", "q_i . q_i = l_i^2", PLANAR,
       lambda c: Matrix([dot(c.qvec(i), c.qvec(i)) for i in (1, 2)]))
def _(c):
    return Matrix([c.l1**2, c.l2**2])


@claim("1.28", "q . J q = 0", PLANAR, lambda c: dot(VEC_Q, J * VEC_Q))
def _(c):
    return sp.S.Zero


@claim("1.29", "(J q) . J q' = q . q'", PLANAR, lambda c: dot(J * VEC_Q, J * VEC_QP))
def _(c):
    return dot(VEC_Q, VEC_QP)


@claim("1.29", "q . J q' = (J q) . J^2 q (middle form)", PLANAR, lambda c: dot(VEC_Q, J * VEC_QP))
def _(c):
    return dot(J * VEC_Q, J**2 * VEC_Q)


@claim("1.29", "q . J q' = -q' . J q", PLANAR, lambda c: dot(VEC_Q, J * VEC_QP))
def _(c):
    return -dot(VEC_QP, J * VEC_Q)


@claim("1.30", "q_1 . q_2 = l1 l2 (sin theta1 sin theta1 + cos theta1 cos theta2)", PLANAR, q1_q2)
def _(c):
    return c.l1 * c.l2 * (sin(c.theta1) * sin(c.theta1) + cos(c.theta1) * cos(c.theta2))


@claim("1.30", "q_1 . q_2 = l1 l2 cos(dtheta)", PLANAR, q1_q2)
def _(c):
    return c.l1 * c.l2 * cos(c.theta1 - c.theta2)


@claim("1.31", "q_1 . J q_2 = l1 l2 (sin theta1 cos theta2 - cos theta1 sin theta2)", PLANAR, q1_J_q2)
def _(c):
    return c.l1 * c.l2 * (sin(c.theta1) * cos(c.theta2) - cos(c.theta1) * sin(c.theta2))


@claim("1.31", "q_1 . J q_2 = l1 l2 sin(dtheta)", PLANAR, q1_J_q2)
def _(c):
    return c.l1 * c.l2 * sin(c.theta1 - c.theta2)


def chain_rule_expansion(c, i):
    """The expansion printed in (1.32)/(1.33): the four terms of (1.6), (1.4)."""
    return (term_acceleration(c, i) + term_moving_frame(c, i)
            - term_gravity(c, i) - term_velocity(c, i))


claim("1.32", "d/dt dL/dtheta1' - dL/dtheta1 = chain-rule expansion", PLANAR,
      lambda c: c.lagrange_lhs(c.theta1))(lambda c: chain_rule_expansion(c, 1))


@claim("1.32", "d/dt dL/dtheta1' - dL/dtheta1, result", PLANAR,
       lambda c: c.lagrange_lhs(c.theta1))
def _(c):
    return ((c.m1 + c.m2) * c.theta1_ddot * c.l1**2 + c.m2 * c.theta2_ddot * q1_q2(c)
            + c.m2 * c.theta2_dot**2 * q1_J_q2(c) - (c.m1 + c.m2) * c.g * c.l1 * sin(c.theta1))


# (1.33): the page's left side reads d/dt dL/dtheta1' - dL/dtheta1 (index 1)
# while the expansion is in the q_2 terms.
claim("1.33", "left side as printed (theta1) vs what the right side expands", PLANAR,
      lambda c: c.lagrange_lhs(c.theta2))(lambda c: c.lagrange_lhs(c.theta1))
claim("1.33", "chain-rule expansion in the q_2 terms", PLANAR,
      lambda c: c.lagrange_lhs(c.theta2))(lambda c: chain_rule_expansion(c, 2))


@claim("1.33", "d/dt dL/dtheta2' - dL/dtheta2, result", PLANAR,
       lambda c: c.lagrange_lhs(c.theta2))
def _(c):
    return (c.m2 * c.theta1_ddot * q1_q2(c) + c.m2 * c.theta2_dot**2 * c.l2**2
            - c.m2 * c.theta1_dot**2 * q1_J_q2(c) - c.m2 * c.g * c.l2 * sin(c.theta2))


def planar_matrix(c):
    """The matrix of (1.34)."""
    dth = c.theta1 - c.theta2
    return Matrix([[c.mu * c.l1**2, c.l1 * c.l2 * cos(dth)],
                   [c.l1 * c.l2 * cos(dth), c.l2**2]])


def planar_rhs(c):
    """The right side of (1.34)."""
    dth = c.theta1 - c.theta2
    return Matrix([-c.theta2_dot**2 * c.l1 * c.l2 * sin(dth) - c.mu * c.g * c.l1 * sin(c.theta1),
                   c.theta1_dot**2 * c.l1 * c.l2 * sin(dth) - c.g * c.l2 * sin(c.theta2)])


claim("1.34", "matrix (mu l1^2, l1 l2 cos; l1 l2 cos, l2^2) = M/m2", PLANAR,
      lambda c: c.d.M / c.m2)(planar_matrix)
claim("1.34", "right side = F/m2", PLANAR, lambda c: c.d.F / c.m2)(planar_rhs)
claim("1.35", "theta'' = matrix^-1 right side", PLANAR,
      lambda c: Solve(c.d.M, c.d.F))(lambda c: inverse(planar_matrix(c)) * planar_rhs(c))


# =============================================================================
# Seed 000, section 2: the general chart, checked in both charts
# =============================================================================

def u(c, i):
    return c.coords(i)[0]


def v(c, i):
    return c.coords(i)[1]


def r_(c, i):
    return c.qvec(i)[2]


def A_223(c, i, j):
    """A_ij of (2.23): inner products of first derivatives."""
    Dj = [c.dq(j, u(c, j)), c.dq(j, v(c, j))]
    Di = [c.dq(i, u(c, i)), c.dq(i, v(c, i))]
    return Matrix(2, 2, lambda r, k: dot(Dj[k], Di[r]))


def B_224(c, i, j):
    """B_ij of (2.24): second derivatives of q_j against first derivatives of q_i."""
    uj, vj = c.coords(j)
    Dj = [c.dq(j, uj, uj), c.dq(j, uj, vj), c.dq(j, vj, vj)]
    Di = [c.dq(i, u(c, i)), c.dq(i, v(c, i))]
    return Matrix(2, 3, lambda r, k: dot(Dj[k], Di[r]))


def A_221(c):
    return blocks([[c.mu * A_223(c, 1, 1), A_223(c, 1, 2)], [A_223(c, 2, 1), A_223(c, 2, 2)]])


def B_222(c):
    return blocks([[c.mu * B_224(c, 1, 1), B_224(c, 1, 2)], [B_224(c, 2, 1), B_224(c, 2, 2)]])


def G_220(c):
    return Matrix([c.mu * c.g * r_(c, 1).diff(u(c, 1)), c.mu * c.g * r_(c, 1).diff(v(c, 1)),
                   c.g * r_(c, 2).diff(u(c, 2)), c.g * r_(c, 2).diff(v(c, 2))])


def w_220(c):
    u1d, v1d = c.rates(1)
    u2d, v2d = c.rates(2)
    return Matrix([u1d**2, 2 * u1d * v1d, v1d**2, u2d**2, 2 * u2d * v2d, v2d**2])


def unweighted(M, c):
    """Undo the mu of the (1,1) block: the A_ij / B_ij themselves."""
    M = Matrix(M)
    M[0:2, 0:M.shape[1] // 2] = M[0:2, 0:M.shape[1] // 2] / c.mu_value
    return M


@claim("2.1", "standard chart q_i = l_i (sin th cos ph, sin th sin ph, -cos th)", STD,
       lambda c: stack(c.qvec(1), c.qvec(2)))
def _(c):
    return stack(*[l(c, i) * Matrix([sin(u(c, i)) * cos(v(c, i)), sin(u(c, i)) * sin(v(c, i)),
                                     -cos(u(c, i))]) for i in (1, 2)])


def L_213(c):
    v1, v2 = c.cart_dot(1), c.cart_dot(2)
    return (c.mu * dot(v1, v1) / 2 + dot(v2, v2) / 2 + dot(v1, v2)
            - c.mu * c.g * c.cart(1)[2] - c.g * c.cart(2)[2])


def dL_dqdot_216(c, i):
    """(2.16)/(2.17) second form, theta_i', phi_i' read as u_i', v_i'."""
    weight = c.mu if i == 1 else 1
    u1d, v1d = c.rates(1)
    u2d, v2d = c.rates(2)
    return (weight * (u1d * c.dq(1, u(c, 1)) + v1d * c.dq(1, v(c, 1)))
            + u2d * c.dq(2, u(c, 2)) + v2d * c.dq(2, v(c, 2)))


def ddt_dL_dqdot_218(c, i):
    """(2.18)/(2.19): the time derivative of dL/dq_i'."""
    weight = c.mu if i == 1 else 1
    total = sp.zeros(3, 1)
    for j, wj in ((1, weight), (2, 1)):
        uj, vj = c.coords(j)
        ujd, vjd = c.rates(j)
        ujdd, vjdd = c.accels(j)
        total += wj * (ujdd * c.dq(j, uj) + vjdd * c.dq(j, vj) + ujd**2 * c.dq(j, uj, uj)
                       + 2 * ujd * vjd * c.dq(j, uj, vj) + vjd**2 * c.dq(j, vj, vj))
    return total


# In the link components (p_i, q_i, r_i) the formulas do not depend on the chart.
claim("2.13", "L/m2 in link components", STD, lambda c: c.L_cart / c.m2)(L_213)
claim("2.14", "(0, 0, -mu g) as labelled, dL/dq_1'", STD,
      lambda c: c.dL_dcart_dot(1) / c.m2)(lambda c: Matrix([0, 0, -c.mu * c.g]))
claim("2.14", "(0, 0, -mu g) as dL/dq_1", STD,
      lambda c: c.dL_dcart(1) / c.m2)(lambda c: Matrix([0, 0, -c.mu * c.g]))
claim("2.15", "(0, 0, -g) as labelled, dL/dq_2'", STD,
      lambda c: c.dL_dcart_dot(2) / c.m2)(lambda c: Matrix([0, 0, -c.g]))
claim("2.15", "(0, 0, -g) as dL/dq_2", STD,
      lambda c: c.dL_dcart(2) / c.m2)(lambda c: Matrix([0, 0, -c.g]))
claim("2.16", "dL/dq_1' = mu q_1' + q_2'", STD,
      lambda c: c.dL_dcart_dot(1) / c.m2)(lambda c: c.mu * c.cart_dot(1) + c.cart_dot(2))
claim("2.17", "dL/dq_2' = q_1' + q_2'", STD,
      lambda c: c.dL_dcart_dot(2) / c.m2)(lambda c: c.cart_dot(1) + c.cart_dot(2))

# In chart coordinates: checked in both charts (the general setting of section 2).
for _model in (STD, ALT):
    _chart = CHART_NAME[_model]
    claim("2.13", f"L/m2 in chart coordinates ({_chart})", _model,
          lambda c: c.d.L / c.m2)(lambda c: c.to_chart(L_213(c)))
    claim("2.16", f"dL/dq_1' in chart derivatives ({_chart})", _model,
          lambda c: c.to_chart(c.dL_dcart_dot(1)) / c.m2)(lambda c: dL_dqdot_216(c, 1))
    claim("2.17", f"dL/dq_2' in chart derivatives ({_chart})", _model,
          lambda c: c.to_chart(c.dL_dcart_dot(2)) / c.m2)(lambda c: dL_dqdot_216(c, 2))
    claim("2.18", f"d/dt dL/dq_1' ({_chart})", _model,
          lambda c: c.ddt(c.to_chart(c.dL_dcart_dot(1))) / c.m2)(lambda c: ddt_dL_dqdot_218(c, 1))
    claim("2.19", f"d/dt dL/dq_2' ({_chart})", _model,
          lambda c: c.ddt(c.to_chart(c.dL_dcart_dot(2))) / c.m2)(lambda c: ddt_dL_dqdot_218(c, 2))
    claim("2.20", f"A u'' + B w + G = (M q'' - F)/m2 ({_chart})", _model,
          lambda c: c.lagrange_per_m2)(
              lambda c: A_221(c) * c.qdd_vec + B_222(c) * w_220(c) + G_220(c))
    claim("2.20", f"gravity vector (mu g dr_1/du_1, ...) ({_chart})", _model,
          lambda c: c.G_lagrange)(G_220)
    claim("2.20", f"the derivation's PaperForms A, B, G, w in (2.20) ({_chart})", _model,
          lambda c: c.lagrange_per_m2)(
              lambda c: c.d.paper.A * c.qdd_vec + c.d.paper.B * c.d.paper.w + c.d.paper.G)
    claim("2.21", f"A = (mu A11, A12; A21, A22) = M/m2 ({_chart})", _model,
          lambda c: c.A_lagrange)(A_221)
    claim("2.22", f"B = (mu B11, B12; B21, B22) from F ({_chart})", _model,
          lambda c: c.B_lagrange)(B_222)
    claim("2.23", f"the blocks A_ij ({_chart})", _model,
          lambda c: unweighted(c.A_lagrange, c))(
              lambda c: blocks([[A_223(c, i, j) for j in (1, 2)] for i in (1, 2)]))
    claim("2.24", f"the blocks B_ij ({_chart})", _model,
          lambda c: unweighted(c.B_lagrange, c))(
              lambda c: blocks([[B_224(c, i, j) for j in (1, 2)] for i in (1, 2)]))


# =============================================================================
# Seed 000, section 3: the standard chart (model "spherical_std")
# =============================================================================

class Trig:
    """sin/cos of the angles of one spherical model, named as on the page."""

    def __init__(self, c):
        t1, p1, t2, p2 = c.q
        self.s1, self.c1, self.s2, self.c2 = sin(t1), cos(t1), sin(t2), cos(t2)
        self.sD, self.cD = sin(p1 - p2), cos(p1 - p2)
        self.sp1, self.cp1, self.sp2, self.cp2 = sin(p1), cos(p1), sin(p2), cos(p2)
        self.l1, self.l2, self.mu, self.g = c.l1, c.l2, c.mu, c.g

    def s(self, i):
        return (self.s1, self.s2)[i - 1]

    def c(self, i):
        return (self.c1, self.c2)[i - 1]

    def sp(self, i):
        return (self.sp1, self.sp2)[i - 1]

    def cp(self, i):
        return (self.cp1, self.cp2)[i - 1]

    def l(self, i):
        return (self.l1, self.l2)[i - 1]


def std_first(c):
    """Derived: (dq_i/dtheta_i, dq_i/dphi_i) side by side for both links."""
    return stack(*[Matrix.hstack(c.dq(i, u(c, i)), c.dq(i, v(c, i))) for i in (1, 2)])


@claim("3.1", "dq_i/dtheta_i, dq_i/dphi_i", STD, std_first)
def _(c):
    t = Trig(c)
    return stack(*[Matrix([[t.l(i) * t.c(i) * t.cp(i), -t.l(i) * t.s(i) * t.sp(i)],
                           [t.l(i) * t.c(i) * t.sp(i), t.l(i) * t.s(i) * t.cp(i)],
                           [t.l(i) * t.s(i), 0]]) for i in (1, 2)])


def d2(c, a, b):
    """Derived second derivatives of both links: a, b in {'u', 'v'}."""
    return stack(*[c.dq(i, c.coords(i)["uv".index(a)], c.coords(i)["uv".index(b)]) for i in (1, 2)])


@claim("3.2", "d2q_i/dtheta_i^2 explicit", STD, lambda c: d2(c, "u", "u"))
def _(c):
    t = Trig(c)
    return stack(*[Matrix([-t.l(i) * t.s(i) * t.cp(i), -t.l(i) * t.s(i) * t.sp(i),
                           t.l(i) * t.c(i)]) for i in (1, 2)])


@claim("3.2", "d2q_i/dtheta_i^2 = -q_i", STD, lambda c: d2(c, "u", "u"))
def _(c):
    return stack(-c.qvec(1), -c.qvec(2))


@claim("3.2", "d2q_i/dphi_i^2 explicit", STD, lambda c: d2(c, "v", "v"))
def _(c):
    t = Trig(c)
    return stack(*[-Matrix([t.l(i) * t.s(i) * t.cp(i), t.l(i) * t.s(i) * t.sp(i), 0])
                   for i in (1, 2)])


@claim("3.2", "d2q_i/dphi_i^2 = -(p_i, q_i, 0)", STD, lambda c: d2(c, "v", "v"))
def _(c):
    return stack(*[-Matrix([c.qvec(i)[0], c.qvec(i)[1], 0]) for i in (1, 2)])


@claim("3.3", "d2q_i/dtheta_i dphi_i", STD, lambda c: d2(c, "u", "v"))
def _(c):
    t = Trig(c)
    return stack(*[Matrix([-t.l(i) * t.c(i) * t.sp(i), t.l(i) * t.c(i) * t.cp(i), 0])
                   for i in (1, 2)])


def orthogonal_pairs(c):
    """The five products listed as orthogonal before (3.4), for both links."""
    out = []
    for i in (1, 2):
        th_, ph_ = c.coords(i)
        Dt, Dp = c.dq(i, th_), c.dq(i, ph_)
        out += [dot(Dt, Dp), dot(Dt, c.dq(i, th_, th_)), dot(Dt, c.dq(i, th_, ph_)),
                dot(Dp, c.dq(i, th_, th_)), dot(Dp, c.dq(i, ph_, ph_))]
    return Matrix(out)


claim("3.4", "orthogonal pairs listed before (3.4)", STD, orthogonal_pairs)(
    lambda c: sp.zeros(10, 1))


def same_link(c, f):
    """Derived inner products of one link's derivatives, both links."""
    return Matrix([f(c, i, *c.coords(i)) for i in (1, 2)])


claim("3.4", "dq_i/dtheta_i . dq_i/dtheta_i = l_i^2", STD,
      lambda c: same_link(c, lambda c, i, t, p: dot(c.dq(i, t), c.dq(i, t))))(
    lambda c: Matrix([c.l1**2, c.l2**2]))
claim("3.5", "dq_i/dphi_i . dq_i/dphi_i = l_i^2 sin^2 theta_i", STD,
      lambda c: same_link(c, lambda c, i, t, p: dot(c.dq(i, p), c.dq(i, p))))(
    lambda c: Matrix([Trig(c).l(i)**2 * Trig(c).s(i)**2 for i in (1, 2)]))
claim("3.6", "dq_i/dphi_i . d2q_i/dtheta_i dphi_i = l_i^2 sin cos", STD,
      lambda c: same_link(c, lambda c, i, t, p: dot(c.dq(i, p), c.dq(i, t, p))))(
    lambda c: Matrix([Trig(c).l(i)**2 * Trig(c).s(i) * Trig(c).c(i) for i in (1, 2)]))
claim("3.6", "dq_i/dphi_i . d2q_i/dtheta_i dphi_i = 1/2 l_i^2 sin(2 theta_i)", STD,
      lambda c: same_link(c, lambda c, i, t, p: dot(c.dq(i, p), c.dq(i, t, p))))(
    lambda c: Matrix([l(c, i)**2 * sin(2 * u(c, i)) / 2 for i in (1, 2)]))
claim("3.7", "dq_i/dtheta_i . d2q_i/dphi_i^2 = -l_i^2 sin cos", STD,
      lambda c: same_link(c, lambda c, i, t, p: dot(c.dq(i, t), c.dq(i, p, p))))(
    lambda c: Matrix([-Trig(c).l(i)**2 * Trig(c).s(i) * Trig(c).c(i) for i in (1, 2)]))
claim("3.7", "dq_i/dtheta_i . d2q_i/dphi_i^2 = -1/2 l_i^2 sin(2 theta_i)", STD,
      lambda c: same_link(c, lambda c, i, t, p: dot(c.dq(i, t), c.dq(i, p, p))))(
    lambda c: Matrix([-l(c, i)**2 * sin(2 * u(c, i)) / 2 for i in (1, 2)]))


def cross(a, b):
    """Derived dq_1/d(a) . dq_2/d(b): a, b are tuples of 'u'/'v' for links 1 and 2."""
    def derived(c):
        da = c.dq(1, *[c.coords(1)["uv".index(x)] for x in a])
        db = c.dq(2, *[c.coords(2)["uv".index(x)] for x in b])
        return dot(da, db)
    return derived


@claim("3.8", "dq1/dth1 . dq2/dth2, first form", STD, cross("u", "u"))
def _(c):
    t = Trig(c)
    return t.l1 * t.l2 * (t.c1 * t.c2 * (t.cp1 * t.cp2 + t.sp1 * t.sp2) + t.s1 * t.s2)


@claim("3.8", "dq1/dth1 . dq2/dth2 = l1 l2 (c1 c2 cos dphi + s1 s2)", STD, cross("u", "u"))
def _(c):
    t = Trig(c)
    return t.l1 * t.l2 * (t.c1 * t.c2 * t.cD + t.s1 * t.s2)


_CROSS = [  # (equation, what, derived, printed)
    ("3.9", "dq1/dth1 . dq2/dph2", cross("u", "v"), lambda t: t.c1 * t.s2 * t.sD),
    ("3.10", "dq1/dph1 . dq2/dph2", cross("v", "v"), lambda t: t.s1 * t.s2 * t.cD),
    ("3.11", "dq1/dth1 . d2q2/dth2^2", cross("u", "uu"),
     lambda t: t.s1 * t.c2 - t.c1 * t.s2 * t.cD),
    ("3.12", "dq1/dth1 . d2q2/dth2 dph2", cross("u", "uv"), lambda t: t.c1 * t.c2 * t.sD),
    ("3.13", "dq1/dth1 . d2q2/dph2^2", cross("u", "vv"), lambda t: -t.c1 * t.s2 * t.cD),
    ("3.14", "dq1/dph1 . d2q2/dth2^2", cross("v", "uu"), lambda t: t.s1 * t.s2 * t.sD),
    ("3.15", "dq1/dph1 . d2q2/dth2 dph2", cross("v", "uv"), lambda t: t.s1 * t.c2 * t.cD),
    ("3.16", "dq1/dph1 . d2q2/dph2^2", cross("v", "vv"), lambda t: t.s1 * t.s2 * t.sD),
]
for _eq, _what, _derived, _f in _CROSS:
    claim(_eq, _what, STD, _derived)(lambda c, f=_f: c.l1 * c.l2 * f(Trig(c)))


@claim("3.17", "rate vector (th1'^2, 2 th1' ph1', ph1'^2, 2 th2' ph2')", STD,
       lambda c: c.d.paper.w)
def _(c):
    return Matrix([c.theta1_dot**2, 2 * c.theta1_dot * c.phi1_dot, c.phi1_dot**2,
                   2 * c.theta2_dot * c.phi2_dot])


def G_317(c):
    return Matrix([c.mu * c.g * c.l1 * sin(c.theta1), 0, c.g * c.l2 * sin(c.theta2), 0])


claim("3.17", "gravity vector (mu g l1 sin th1, 0, g l2 sin th2, 0)", STD,
      lambda c: c.G_lagrange)(G_317)


def A_ii_319(t, i):
    return t.l(i)**2 * Matrix([[1, 0], [0, t.s(i)**2]])


def A12_320(t):
    return t.l1 * t.l2 * Matrix([[t.c1 * t.c2 * t.cD + t.s1 * t.s2, t.c1 * t.s2 * t.sD],
                                 [-t.s1 * t.c2 * t.sD, t.s1 * t.s2 * t.cD]])


def A_318(c):
    t = Trig(c)
    return blocks([[t.mu * A_ii_319(t, 1), A12_320(t)], [A12_320(t).T, A_ii_319(t, 2)]])


def B_ii_324(t, i):
    return t.l(i)**2 * Matrix([[0, 0, -t.s(i) * t.c(i)], [0, t.s(i) * t.c(i), 0]])


def B12_325(t):
    return t.l1 * t.l2 * Matrix([
        [t.s1 * t.c2 - t.c1 * t.s2 * t.cD, t.c1 * t.c2 * t.sD, -t.c1 * t.s2 * t.cD],
        [t.s1 * t.s2 * t.sD, t.s1 * t.c2 * t.cD, t.s1 * t.s2 * t.sD]])


def B21_326(t):
    return t.l1 * t.l2 * Matrix([
        [t.c1 * t.s2 - t.s1 * t.c2 * t.cD, -t.c1 * t.c2 * t.sD, -t.s1 * t.c2 * t.cD],
        [-t.s1 * t.s2 * t.sD, t.c1 * t.s2 * t.cD, -t.s1 * t.s2 * t.sD]])


def B_323(c):
    t = Trig(c)
    return blocks([[t.mu * B_ii_324(t, 1), B12_325(t)], [B21_326(t), B_ii_324(t, 2)]])


claim("3.18", "A = (mu A11, A12; A21, A22) with (3.19)-(3.21)", STD,
      lambda c: c.A_lagrange)(A_318)
claim("3.19", "A_ii = l_i^2 diag(1, sin^2 theta_i)", STD,
      lambda c: stack(unweighted(c.A_lagrange, c)[0:2, 0:2], c.A_lagrange[2:4, 2:4]))(
    lambda c: stack(A_ii_319(Trig(c), 1), A_ii_319(Trig(c), 2)))
claim("3.20", "A_12", STD, lambda c: c.A_lagrange[0:2, 2:4])(lambda c: A12_320(Trig(c)))
claim("3.21", "A_21 = transpose of A_12", STD,
      lambda c: c.A_lagrange[2:4, 0:2])(lambda c: A12_320(Trig(c)).T)
claim("3.23", "B = (mu B11, B12; B21, B22) with (3.24)-(3.26)", STD,
      lambda c: c.B_lagrange)(B_323)
claim("3.24", "B_ii", STD,
      lambda c: stack(unweighted(c.B_lagrange, c)[0:2, 0:3], c.B_lagrange[2:4, 3:6]))(
    lambda c: stack(B_ii_324(Trig(c), 1), B_ii_324(Trig(c), 2)))
claim("3.25", "B_12", STD, lambda c: c.B_lagrange[0:2, 3:6])(lambda c: B12_325(Trig(c)))
claim("3.26", "B_21", STD, lambda c: c.B_lagrange[2:4, 0:3])(lambda c: B21_326(Trig(c)))


def Q_329(c):
    t = Trig(c)
    return t.l1 * t.l2 * Matrix([[t.c1 * t.c2 * t.cD + t.s1 * t.s2, t.c1 * t.sD],
                                 [-t.c2 * t.sD, t.cD]])


def A_red_328(c):
    return blocks([[c.mu * c.l1**2 * I2, Q_329(c)], [Q_329(c).T, c.l2**2 * I2]])


def B_red_ii_331(t, i):
    return t.l(i)**2 * Matrix([[0, 0, -t.s(i) * t.c(i)], [0, t.c(i), 0]])


def B_red12_332(t):
    return t.l1 * t.l2 * Matrix([
        [t.s1 * t.c2 - t.c1 * t.s2 * t.cD, t.c1 * t.c2 * t.sD, -t.c1 * t.s2 * t.cD],
        [t.s2 * t.sD, t.c2 * t.cD, t.s2 * t.sD]])


def B_red21_333(t):
    return t.l1 * t.l2 * Matrix([
        [t.c1 * t.s2 - t.s1 * t.c2 * t.cD, -t.c1 * t.c2 * t.sD, -t.s1 * t.c2 * t.cD],
        [-t.s1 * t.sD, t.c1 * t.cD, -t.s1 * t.sD]])


def B_red_330(c):
    t = Trig(c)
    return blocks([[t.mu * B_red_ii_331(t, 1), B_red12_332(t)],
                   [B_red21_333(t), B_red_ii_331(t, 2)]])


def w_std(c):
    """The 6-entry rate vector as printed in (3.27), (3.40)."""
    return Matrix([c.theta1_dot**2, 2 * c.theta1_dot * c.phi1_dot, c.phi1_dot**2,
                   c.theta2_dot**2, 2 * c.theta2_dot * c.phi2_dot, c.phi2_dot**2])


@claim("3.27", "reduced equation A~ x + B~ w + G = 0 (x with phi_i' sin theta_i)", STD,
       lambda c: c.reduced_lagrange)
def _(c):
    x = Matrix([c.theta1_ddot, c.phi1_dot * sin(c.theta1),
                c.theta2_ddot, c.phi2_dot * sin(c.theta2)])
    return A_red_328(c) * x + B_red_330(c) * w_std(c) + G_317(c)


claim("3.28", "A~ = (mu l1^2 I, Q; tQ, l2^2 I)", STD, lambda c: c.A_red_lagrange)(A_red_328)
claim("3.29", "Q", STD, lambda c: c.A_red_lagrange[0:2, 2:4])(Q_329)
claim("3.30", "B~ = (mu B~11, B~12; B~21, B~22)", STD, lambda c: c.B_red_lagrange)(B_red_330)
claim("3.31", "B~_ii", STD,
      lambda c: stack(unweighted(c.B_red_lagrange, c)[0:2, 0:3], c.B_red_lagrange[2:4, 3:6]))(
    lambda c: stack(B_red_ii_331(Trig(c), 1), B_red_ii_331(Trig(c), 2)))
claim("3.32", "B~_12", STD, lambda c: c.B_red_lagrange[0:2, 3:6])(lambda c: B_red12_332(Trig(c)))
claim("3.33", "B~_21", STD, lambda c: c.B_red_lagrange[2:4, 0:3])(lambda c: B_red21_333(Trig(c)))
claim("3.27", "gravity vector of the reduced equation", STD, lambda c: c.G_red_lagrange)(G_317)

# (3.35): for any square Q, R and scalars alpha, beta.
ALPHA, BETA = sp.symbols("alpha beta", real=True)
QQ_ = Matrix(2, 2, sp.symbols("Qm11 Qm12 Qm21 Qm22", real=True))
RR_ = Matrix(2, 2, sp.symbols("Rm11 Rm12 Rm21 Rm22", real=True))
claim("3.35", "(beta I, -Q; -R, alpha I)(alpha I, Q; R, beta I)", STD,
      lambda c: blocks([[BETA * I2, -QQ_], [-RR_, ALPHA * I2]])
      * blocks([[ALPHA * I2, QQ_], [RR_, BETA * I2]]))(
    lambda c: blocks([[ALPHA * BETA * I2 - QQ_ * RR_, sp.zeros(2)],
                      [sp.zeros(2), ALPHA * BETA * I2 - RR_ * QQ_]]))


def A_hat_336(c):
    return blocks([[c.l2**2 * I2, -Q_329(c)], [-Q_329(c).T, c.mu * c.l1**2 * I2]])


def D1_338(c):
    return c.mu * c.l1**2 * c.l2**2 * I2 - Q_329(c) * Q_329(c).T


def D2_338(c):
    return c.mu * c.l1**2 * c.l2**2 * I2 - Q_329(c).T * Q_329(c)


def D_hat_338(c):
    return sp.diag(inverse(D1_338(c)), inverse(D2_338(c)))


claim("3.36", "A^ = (l2^2 I, -Q; -tQ, mu l1^2 I) vs the derivation's A_hat", STD,
      lambda c: c.d.paper.A_hat)(A_hat_336)
claim("3.37", "A^ A~ = diag(mu l1^2 l2^2 I - Q tQ, mu l1^2 l2^2 I - tQ Q)", STD,
      lambda c: c.d.paper.A_hat * c.A_red_lagrange)(
    lambda c: sp.diag(D1_338(c), D2_338(c)))
claim("3.38", "D1, D2 vs the derivation's", STD,
      lambda c: stack(c.d.paper.D1, c.d.paper.D2))(lambda c: stack(D1_338(c), D2_338(c)))
claim("3.39", "A~^-1 = D^ A^", STD,
      lambda c: Solve(c.A_red_lagrange, sp.eye(4)))(lambda c: D_hat_338(c) * A_hat_336(c))
claim("3.39", "the derivation's block_inverse() = A~^-1", STD,
      lambda c: Solve(c.A_red_lagrange, sp.eye(4)))(lambda c: c.d.paper.block_inverse())


def x_reduced(c):
    """The reduced accelerations (th1'', ph1'' sin th1, th2'', ph2'' sin th2), derived:
    A~ x = -(B~ w + G~) is S^-1 (M q'' - F)/m2 = 0 solved for x."""
    return Solve(c.A_red_lagrange, -(c.B_red_lagrange * c.rate_vector + c.G_red_lagrange))


@claim("3.40", "x = -D^ A^ w + (mu g l1 sin th1, 0, g l2 sin th2, 0)", STD, x_reduced)
def _(c):
    rate_term = matmul(-D_hat_338(c) * A_hat_336(c), w_std(c))
    return rate_term if isinstance(rate_term, IllFormed) else rate_term + G_317(c)


claim("3.40", "at rest (w = 0): x = (mu g l1 sin th1, 0, g l2 sin th2, 0)", STD,
      lambda c: Solve(c.A_red_lagrange, -c.G_red_lagrange))(G_317)


def energy_per_m2(c):
    return c.d.energy / c.m2


@claim("3.41", "E/m2 = 1/2 m1/m2 |q1'|^2 + 1/2 |q1' + q2'|^2 + mu g r1 + g r2", STD, energy_per_m2)
def _(c):
    v1, v2 = c.qdot(1), c.qdot(2)
    return (c.m1 / c.m2 * dot(v1, v1) / 2 + dot(v1 + v2, v1 + v2) / 2
            + c.mu * c.g * r_(c, 1) + c.g * r_(c, 2))


@claim("3.42", "E/m2 = 1/2 (mu |q1'|^2 + |q2'|^2) + q1'.q2' + mu g r1 + g r2", STD, energy_per_m2)
def _(c):
    v1, v2 = c.qdot(1), c.qdot(2)
    return (c.mu * dot(v1, v1) + dot(v2, v2)) / 2 + dot(v1, v2) + c.mu * c.g * r_(c, 1) + c.g * r_(c, 2)


def energy_kinetic_diag(c):
    t = Trig(c)
    return (c.mu * c.l1**2 * (c.theta1_dot**2 + c.phi1_dot**2 * t.s1**2)
            + c.l2**2 * (c.theta2_dot**2 + c.phi2_dot**2 * t.s2**2)) / 2


@claim("3.42", "E/m2 with the inner products of chart derivatives", STD, energy_per_m2)
def _(c):
    t1, p1, t2, p2 = c.q
    return (energy_kinetic_diag(c) + c.g * (c.mu * r_(c, 1) + r_(c, 2))
            + c.theta1_dot * c.theta2_dot * dot(c.dq(1, t1), c.dq(2, t2))
            + c.theta1_dot * c.phi2_dot * dot(c.dq(1, t1), c.dq(2, p2))
            + c.phi1_dot * c.theta2_dot * dot(c.dq(1, p1), c.dq(2, t2))
            + c.phi1_dot * c.phi2_dot * dot(c.dq(1, p1), c.dq(2, p2)))


@claim("3.42", "E/m2 explicit", STD, energy_per_m2)
def _(c):
    t = Trig(c)
    return (energy_kinetic_diag(c) - c.g * (c.mu * c.l1 * t.c1 + c.l2 * t.c2)
            + c.l1 * c.l2 * (c.theta1_dot * c.theta2_dot * (t.c1 * t.c2 * t.cD + t.s1 * t.s2)
                             + c.theta1_dot * c.phi2_dot * t.c1 * t.s2 * t.sD
                             - c.phi1_dot * c.theta2_dot * t.s1 * t.c2 * t.sD
                             + c.phi1_dot * c.phi2_dot * t.s1 * t.s2 * t.cD))


# =============================================================================
# Seed 000, section 4: the second chart (model "spherical_alt")
# =============================================================================

def renamed(x, frm, to):
    """The page's "replace (theta, phi) by (vartheta, varphi)": substitute the
    coordinates and rates of context ``frm`` by those of ``to``."""
    pairs = list(zip(frm.q + frm.qd + frm.qdd, to.q + to.qd + to.qdd))
    return x.xreplace(dict(pairs))


def from_std(f):
    """A printed section-3 formula, with (theta, phi) replaced by (vartheta, varphi)."""
    return lambda c: renamed(f(context(STD)), context(STD), c)


@claim("4.1", "q_i = l_i (cos vt, sin vt cos vp, sin vt sin vp)", ALT,
       lambda c: stack(c.qvec(1), c.qvec(2)))
def _(c):
    return stack(*[l(c, i) * Matrix([cos(u(c, i)), sin(u(c, i)) * cos(v(c, i)),
                                     sin(u(c, i)) * sin(v(c, i))]) for i in (1, 2)])


@claim("4.2", "dq_i/dvartheta_i, dq_i/dvarphi_i", ALT, std_first)
def _(c):
    return stack(*[l(c, i) * Matrix([[-sin(u(c, i)), 0],
                                     [cos(u(c, i)) * cos(v(c, i)), -sin(u(c, i)) * sin(v(c, i))],
                                     [cos(u(c, i)) * sin(v(c, i)), sin(u(c, i)) * cos(v(c, i))]])
                   for i in (1, 2)])


@claim("4.3", "d2q_i/dvartheta_i^2 explicit", ALT, lambda c: d2(c, "u", "u"))
def _(c):
    return stack(*[l(c, i) * Matrix([-cos(u(c, i)), -sin(u(c, i)) * cos(v(c, i)),
                                     -sin(u(c, i)) * sin(v(c, i))]) for i in (1, 2)])


@claim("4.3", "d2q_i/dvartheta_i^2 = -q_i", ALT, lambda c: d2(c, "u", "u"))
def _(c):
    return stack(-c.qvec(1), -c.qvec(2))


@claim("4.3", "d2q_i/dvarphi_i^2 explicit", ALT, lambda c: d2(c, "v", "v"))
def _(c):
    return stack(*[l(c, i) * Matrix([0, -sin(u(c, i)) * cos(v(c, i)),
                                     -sin(u(c, i)) * sin(v(c, i))]) for i in (1, 2)])


@claim("4.3", "d2q_i/dvarphi_i^2 = -(0, q_i, r_i)", ALT, lambda c: d2(c, "v", "v"))
def _(c):
    return stack(*[-Matrix([0, c.qvec(i)[1], c.qvec(i)[2]]) for i in (1, 2)])


@claim("4.4", "d2q_i/dvartheta_i dvarphi_i", ALT, lambda c: d2(c, "u", "v"))
def _(c):
    return stack(*[l(c, i) * Matrix([0, -cos(u(c, i)) * sin(v(c, i)),
                                     cos(u(c, i)) * cos(v(c, i))]) for i in (1, 2)])


O_45 = Matrix([[0, 0, -1], [1, 0, 0], [0, 1, 0]])


@claim("4.5", "(cos, sin cos, sin sin) = O (sin cos, sin sin, -cos)", ALT,
       lambda c: stack(c.unit(1), c.unit(2)))
def _(c):
    return stack(*[O_45 * Matrix([sin(u(c, i)) * cos(v(c, i)), sin(u(c, i)) * sin(v(c, i)),
                                  -cos(u(c, i))]) for i in (1, 2)])


claim("4.5", "O is orthogonal", ALT, lambda c: O_45.T * O_45)(lambda c: sp.eye(3))
claim("4.5", "O is orientation-reversing (Remark): det O = -1", ALT,
      lambda c: O_45.det())(lambda c: sp.Integer(-1))
claim("4.5", "A of (2.20) is the same as for (theta, phi), renamed", ALT,
      lambda c: c.A_lagrange)(from_std(lambda s: s.A_lagrange))
claim("4.5", "B of (2.20) is the same as for (theta, phi), renamed", ALT,
      lambda c: c.B_lagrange)(from_std(lambda s: s.B_lagrange))


def orientation(e, u_, v_):
    """(de/du x de/dv) . e: the sign says which way the chart orients the sphere."""
    return sp.expand(e.diff(u_).cross(e.diff(v_)).dot(e))


def second_chart_orientation(c):
    """The orientation of the (4.1) chart, at coordinates named (theta, phi) as in (4.6)."""
    t1, p1 = c.coords(1)
    return orientation(c.unit(1), t1, p1)


_ALTERNATIVES_46 = [
    ("(sin th sin ph, sin th cos ph, cos th)",
     lambda s, cc, sp_, cp: Matrix([s * sp_, s * cp, cc])),
    ("(sin th sin ph, sin th cos ph, -cos th)",
     lambda s, cc, sp_, cp: Matrix([s * sp_, s * cp, -cc])),
    ("(sin th cos ph, -sin th sin ph, -cos th)",
     lambda s, cc, sp_, cp: Matrix([s * cp, -s * sp_, -cc])),
]
for _what, _vec in _ALTERNATIVES_46:
    claim("4.6", f"standard chart {_what} orients the sphere like the (4.1) chart", ALT,
          second_chart_orientation)(
        lambda c, f=_vec: orientation(
            f(sin(u(c, 1)), cos(u(c, 1)), sin(v(c, 1)), cos(v(c, 1))), u(c, 1), v(c, 1)))


def G_47(c):
    t = Trig(c)
    return Matrix([c.mu * c.g * c.l1 * t.c1 * t.sp1, c.mu * c.g * c.l1 * t.s1 * t.cp1,
                   c.g * c.l2 * t.c2 * t.sp2, c.g * c.l2 * t.s2 * t.cp2])


def G_48(c):
    t = Trig(c)
    return Matrix([c.mu * c.g * c.l1 * t.c1 * t.sp1, c.mu * c.g * c.l1 * t.cp1,
                   c.g * c.l2 * t.c2 * t.sp2, c.g * c.l2 * t.cp2])


claim("4.7", "gravity vector", ALT, lambda c: c.G_lagrange)(G_47)
def eq_47(c):
    """(4.7): A, B renamed from section 3, the printed gravity vector."""
    return from_std(A_318)(c) * c.qdd_vec + from_std(B_323)(c) * from_std(w_std)(c) + G_47(c)


def eq_48(c):
    """(4.8): A~, B~ renamed from section 3, the printed reduced gravity vector."""
    x = Matrix([c.vartheta1_ddot, c.varphi1_ddot * sin(c.vartheta1),
                c.vartheta2_ddot, c.varphi2_ddot * sin(c.vartheta2)])
    return from_std(A_red_328)(c) * x + from_std(B_red_330)(c) * from_std(w_std)(c) + G_48(c)


claim("4.7", "A u'' + B w + G = (M q'' - F)/m2, A, B renamed from section 3", ALT,
      lambda c: c.lagrange_per_m2)(eq_47)
claim("4.8", "gravity vector of the reduced equation", ALT, lambda c: c.G_red_lagrange)(G_48)
claim("4.8", "reduced equation, A~ and B~ renamed from section 3", ALT,
      lambda c: c.reduced_lagrange)(eq_48)
claim("§4.2", "A~^-1 = D^ A^ of section 3.3, renamed", ALT,
      lambda c: Solve(c.A_red_lagrange, sp.eye(4)))(
    lambda c: from_std(lambda s: D_hat_338(s) * A_hat_336(s))(c))


# =============================================================================
# Seed 000, section 5: several charts
# =============================================================================

def swap_xy(x):
    """q' = (q, p, r): x and y exchanged (section 5.1)."""
    return Matrix([x[1], x[0], x[2]])


def std_unit_at(c, theta, phi):
    """The standard chart's unit vector (2.1) at given angles."""
    return c.unit(1).xreplace({c.theta1: theta, c.phi1: phi})


claim("5.1", "rotated chart = (vartheta, varphi) chart of q' = (q, p, r)", ROT,
      lambda c: stack(c.unit(1), c.unit(2)))(
    lambda c: stack(*[swap_xy(c.other(ALT).unit(i)) for i in (1, 2)]))
claim("5.1", "(theta', phi') = (pi/2 - theta, phi) for q' = (q, p, r)", STD,
      lambda c: swap_xy(c.unit(1)))(lambda c: std_unit_at(c, pi / 2 - c.theta1, c.phi1))
claim("5.1", "rotated chart: the same M as the second chart", ROT,
      lambda c: c.d.M)(lambda c: c.other(ALT).d.M)
claim("5.1", "rotated chart: the same F as the second chart", ROT,
      lambda c: c.d.F)(lambda c: c.other(ALT).d.F)
claim("5.1", "rotated chart: the same A, B of (2.20) as the second chart", ROT,
      lambda c: Matrix.hstack(c.A_lagrange, c.B_lagrange))(
    lambda c: Matrix.hstack(c.other(ALT).A_lagrange, c.other(ALT).B_lagrange))
claim("5.1", "rotated chart: (4.7) and (4.8) hold exactly as printed", ROT,
      lambda c: stack(c.lagrange_per_m2, c.reduced_lagrange))(
    lambda c: stack(eq_47(c), eq_48(c)))


def rule_51(theta1, phi1, theta2, phi2):
    """The algorithm at the end of 5.1, with 'small' meaning below 0.5.

    Why the chosen chart's polar sines are >= 0.5: step 1 checks them directly.
    In step 2 some |sin th_j| < 0.5.  The second chart's polar sine of a unit
    vector e is sqrt(1 - e_x^2), the rotated chart's sqrt(1 - e_y^2), and
    e_x^2 + e_y^2 = sin^2 th.  A link with |sin th| < 0.5 gets > 0.866 in both.
    (a) the other link has |sin ph| < 0.5, so e_y^2 < 0.25: rotated chart > 0.866;
    (b) otherwise |sin ph| >= 0.5 or |sin th| < 0.5, so e_x^2 <= 0.75: second
    chart >= 0.5.  The claim checks this over random and edge states."""
    small = [abs(math.sin(theta1)) < 0.5, abs(math.sin(theta2)) < 0.5]
    if not any(small):
        return STD                                        # step 1
    for i, phi in enumerate((phi1, phi2)):
        if not small[i] and abs(math.sin(phi)) < 0.5:
            return ROT                                    # step 2(a): (vartheta', varphi')
    return ALT                                            # step 2(b)


def chosen_polar_sines(c):
    """Derived: the polar sines (the derivation's polar_sines) of a chart at a
    standard-chart state, after converting the state into that chart."""
    cache = {}

    def polar(chart_model, state):
        if chart_model not in cache:
            cache[chart_model] = _chart_converter(c, chart_model)
        return cache[chart_model](state)
    return polar


def _chart_converter(c, chart_model):
    t = c.other(chart_model)
    R = sp.Dummy("R", positive=True)
    angles = [t.point_map(c.unit(i), R, i) for i in (1, 2)]
    # the target coordinates of both links as functions of the standard state
    to_coords = [sp.lambdify(c.q, [m.angles[x] for x in t.coords(i)], "math")
                 for i, m in zip((1, 2), angles)]
    sines = sp.lambdify(t.q, t.d.polar_sines, "math")
    e_target = sp.lambdify(t.q, list(t.unit(1)) + list(t.unit(2)), "math")
    e_source = sp.lambdify(c.q, list(c.unit(1)) + list(c.unit(2)), "math")

    def polar(state):
        coords = [x for f in to_coords for x in f(*state)]
        # the conversion must reproduce the point, or the sines mean nothing
        if max(abs(a - b) for a, b in zip(e_target(*coords), e_source(*state))) > 1e-9:
            raise AssertionError(f"chart conversion to {chart_model} failed at {state}")
        return [abs(s) for s in sines(*coords)]
    return polar


claim("5.1", "chart rule: the chosen chart's polar sines are >= 0.5", STD,
      chosen_polar_sines, kind="rule")(lambda c: ChartRule(rule_51, 0.5))


# (5.2)-(5.5): atan2 forms.  p, q, r are the source point's components.
def atan_claim(equation, what, source, target, formulas):
    claim(equation, what, source, lambda c: c.qvec(1), kind="angle")(
        lambda c: AtanForm(target, formulas(c, c.other(target))))


def pqr(c):
    return list(c.qvec(1))


atan_claim("5.2", "varphi = atan2(r, q)", STD, ALT,
           lambda c, t: {t.varphi1: atan2(pqr(c)[2], pqr(c)[1])})
atan_claim("5.2", "varphi = atan2(-cos th, sin th sin ph)", STD, ALT,
           lambda c, t: {t.varphi1: atan2(-cos(c.theta1), sin(c.theta1) * sin(c.phi1))})
atan_claim("5.3", "vartheta = atan2(r, p sin varphi)", STD, ALT,
           lambda c, t: {t.vartheta1: atan2(pqr(c)[2], pqr(c)[0] * sin(t.varphi1))})
atan_claim("5.3", "vartheta = atan2(-cos th, sin th cos ph sin varphi)", STD, ALT,
           lambda c, t: {t.vartheta1: atan2(-cos(c.theta1),
                                            sin(c.theta1) * cos(c.phi1) * sin(t.varphi1))})
atan_claim("5.3", "vartheta = atan2(q, p cos varphi)", STD, ALT,
           lambda c, t: {t.vartheta1: atan2(pqr(c)[1], pqr(c)[0] * cos(t.varphi1))})
atan_claim("5.3", "vartheta = atan2(sin th sin ph, sin th cos ph cos varphi)", STD, ALT,
           lambda c, t: {t.vartheta1: atan2(sin(c.theta1) * sin(c.phi1),
                                            sin(c.theta1) * cos(c.phi1) * cos(t.varphi1))})
atan_claim("5.3", "vartheta = atan2(sqrt(q^2 + r^2), p)", STD, ALT,
           lambda c, t: {t.vartheta1: atan2(sqrt(pqr(c)[1]**2 + pqr(c)[2]**2), pqr(c)[0])})
atan_claim("5.3", "vartheta = atan2(sqrt(sin^2 th sin^2 ph + cos^2 th), sin th cos ph)", STD, ALT,
           lambda c, t: {t.vartheta1: atan2(sqrt(sin(c.theta1)**2 * sin(c.phi1)**2
                                                 + cos(c.theta1)**2),
                                            sin(c.theta1) * cos(c.phi1))})
atan_claim("5.4", "phi = atan2(q, p)", ALT, STD,
           lambda c, t: {t.phi1: atan2(pqr(c)[1], pqr(c)[0])})
atan_claim("5.4", "phi = atan2(sin vt cos vp, cos vt)", ALT, STD,
           lambda c, t: {t.phi1: atan2(sin(c.vartheta1) * cos(c.varphi1), cos(c.vartheta1))})
atan_claim("5.5", "theta = atan2(p, -r cos phi)", ALT, STD,
           lambda c, t: {t.theta1: atan2(pqr(c)[0], -pqr(c)[2] * cos(t.phi1))})
atan_claim("5.5", "theta = atan2(cos vt, -sin vt sin vp cos phi)", ALT, STD,
           lambda c, t: {t.theta1: atan2(cos(c.vartheta1),
                                         -sin(c.vartheta1) * sin(c.varphi1) * cos(t.phi1))})
atan_claim("5.5", "theta = atan2(q, -r sin phi)", ALT, STD,
           lambda c, t: {t.theta1: atan2(pqr(c)[1], -pqr(c)[2] * sin(t.phi1))})
atan_claim("5.5", "theta = atan2(sin vt cos vp, -sin vt sin vp sin phi)", ALT, STD,
           lambda c, t: {t.theta1: atan2(sin(c.vartheta1) * cos(c.varphi1),
                                         -sin(c.vartheta1) * sin(c.varphi1) * sin(t.phi1))})
atan_claim("5.5", "theta = atan2(sqrt(p^2 + q^2), -r)", ALT, STD,
           lambda c, t: {t.theta1: atan2(sqrt(pqr(c)[0]**2 + pqr(c)[1]**2), -pqr(c)[2])})
atan_claim("5.5", "theta = atan2(sqrt(cos^2 vt + sin^2 vt cos^2 vp), -sin vt sin vp)", ALT, STD,
           lambda c, t: {t.theta1: atan2(sqrt(cos(c.vartheta1)**2
                                              + sin(c.vartheta1)**2 * cos(c.varphi1)**2),
                                         -sin(c.vartheta1) * sin(c.varphi1))})


# (5.6)-(5.14): rates.  One link ("we omit the suffix"), link 1, l = l1.
def qdot_link1(c):
    return c.qdot(1)


@claim("5.6", "q' = theta' dq/dtheta + phi' dq/dphi", STD, qdot_link1)
def _(c):
    return c.theta1_dot * c.dq(1, c.theta1) + c.phi1_dot * c.dq(1, c.phi1)


@claim("5.6", "q' = vartheta' dq/dvartheta + varphi' dq/dvarphi", ALT, qdot_link1)
def _(c):
    return c.vartheta1_dot * c.dq(1, c.vartheta1) + c.varphi1_dot * c.dq(1, c.varphi1)


claim("5.7", "q' . dq/dtheta = l^2 theta'", STD,
      lambda c: dot(c.qdot(1), c.dq(1, c.theta1)))(lambda c: c.l1**2 * c.theta1_dot)
claim("5.8", "q' . dq/dphi = l^2 phi' sin^2 theta", STD,
      lambda c: dot(c.qdot(1), c.dq(1, c.phi1)))(
    lambda c: c.l1**2 * c.phi1_dot * sin(c.theta1)**2)
claim("5.9", "q' . dq/dvartheta = l^2 vartheta'", ALT,
      lambda c: dot(c.qdot(1), c.dq(1, c.vartheta1)))(lambda c: c.l1**2 * c.vartheta1_dot)
claim("5.10", "q' . dq/dvarphi = l^2 varphi' sin^2 vartheta", ALT,
      lambda c: dot(c.qdot(1), c.dq(1, c.varphi1)))(
    lambda c: c.l1**2 * c.varphi1_dot * sin(c.vartheta1)**2)

claim("5.11", "theta' = 1/l^2 q' . dq/dtheta", STD, lambda c: c.theta1_dot)(
    lambda c: dot(c.qdot(1), c.dq(1, c.theta1)) / c.l1**2)
claim("5.12", "phi' = 1/l^2 q' . dq/dphi (first equality)", STD, lambda c: c.phi1_dot)(
    lambda c: dot(c.qdot(1), c.dq(1, c.phi1)) / c.l1**2)
claim("5.13", "vartheta' = 1/l^2 q' . dq/dvartheta", ALT, lambda c: c.vartheta1_dot)(
    lambda c: dot(c.qdot(1), c.dq(1, c.vartheta1)) / c.l1**2)
claim("5.14", "varphi' = 1/l^2 q' . dq/dvarphi (first equality)", ALT, lambda c: c.varphi1_dot)(
    lambda c: dot(c.qdot(1), c.dq(1, c.varphi1)) / c.l1**2)

ROOT = sp.Symbol("R_polar", positive=True)     # the target chart's polar sine at the point


def target_map(target):
    """The target chart's link-1 angles at the source chart's point (exact, with root)."""
    return lambda c: c.other(target).point_map(c.unit(1), ROOT)


def jacobian_rates(c, target):
    """Derived: the target rates solving J_t (target rates) = J_s (source rates), with
    J the Jacobians of both charts' link vectors -- the least-squares solution
    (J_t^T J_t)^-1 J_t^T J_s x', exact because both columns spans are the
    tangent plane."""
    t = c.other(target)
    Jt = t.qvec(1).jacobian(Matrix(t.coords(1)))
    Js = c.qvec(1).jacobian(Matrix(c.coords(1)))
    return inverse(Jt.T * Jt) * Jt.T * Js * Matrix(c.rates(1))


def source_velocity(c):
    return sum((x * c.dq(1, y) for x, y in zip(c.rates(1), c.coords(1))), sp.zeros(3, 1))


claim("5.6", "the Jacobian rates reproduce q' (tangent planes agree)", ALT,
      lambda c: c.qdot(1), point_map=target_map(STD))(
    lambda c: c.other(STD).qvec(1).jacobian(Matrix(c.other(STD).coords(1)))
    * jacobian_rates(c, STD))
claim("5.11", "theta' = 1/l^2 (vt' dq/dvt + vp' dq/dvp) . dq/dtheta", ALT,
      lambda c: jacobian_rates(c, STD)[0], point_map=target_map(STD))(
    lambda c: dot(source_velocity(c), c.other(STD).dq(1, c.other(STD).theta1)) / c.l1**2)
claim("5.12", "phi' = 1/(l^2 sin^2 theta) (vt' dq/dvt + vp' dq/dvp) . dq/dphi", ALT,
      lambda c: jacobian_rates(c, STD)[1], point_map=target_map(STD))(
    lambda c: dot(source_velocity(c), c.other(STD).dq(1, c.other(STD).phi1))
    / (c.l1**2 * sin(c.other(STD).theta1)**2))
claim("5.13", "vartheta' = 1/l^2 (th' dq/dth + ph' dq/dph) . dq/dvartheta", STD,
      lambda c: jacobian_rates(c, ALT)[0], point_map=target_map(ALT))(
    lambda c: dot(source_velocity(c), c.other(ALT).dq(1, c.other(ALT).vartheta1)) / c.l1**2)
claim("5.14", "varphi' = 1/(l^2 sin^2 vartheta) (th' dq/dth + ph' dq/dph) . dq/dvarphi", STD,
      lambda c: jacobian_rates(c, ALT)[1], point_map=target_map(ALT))(
    lambda c: dot(source_velocity(c), c.other(ALT).dq(1, c.other(ALT).varphi1))
    / (c.l1**2 * sin(c.other(ALT).vartheta1)**2))


# =============================================================================
# Seed 001: compound double pendulum (model "compound")
# =============================================================================

def com_001(c):
    """(x1, y1, x2, y2) as printed."""
    l1, l2, t1, t2 = c.l1, c.l2, c.theta1, c.theta2
    half = sp.Rational(1, 2)
    return Matrix([half * l1 * sin(t1), -half * l1 * cos(t1),
                   l1 * sin(t1) + half * l2 * sin(t2), -l1 * cos(t1) - half * l2 * cos(t2)])


def vel_001(c):
    l1, l2, t1, t2 = c.l1, c.l2, c.theta1, c.theta2
    d1, d2 = c.theta1_dot, c.theta2_dot
    half = sp.Rational(1, 2)
    return Matrix([half * l1 * cos(t1) * d1, half * l1 * sin(t1) * d1,
                   l1 * cos(t1) * d1 + half * l2 * cos(t2) * d2,
                   l1 * sin(t1) * d1 + half * l2 * sin(t2) * d2])


def A_hat_001(c):
    """The symmetric matrix of T = 1/2 theta'^t A^ theta'."""
    half = sp.Rational(1, 2)
    off = half * c.m2 * c.l1 * c.l2 * cos(c.theta1 - c.theta2)
    return Matrix([[c.m1 * (half * c.l1)**2 + c.L1 + c.m2 * c.l1**2, off],
                   [off, c.m2 * (half * c.l2)**2 + c.L2]])


def U_001(c):
    half = sp.Rational(1, 2)
    return (-c.m1 * c.g * half * c.l1 * cos(c.theta1)
            - c.m2 * c.g * (c.l1 * cos(c.theta1) + half * c.l2 * cos(c.theta2)))


def pdot_001(c):
    """p1', p2' as printed (in theta, theta')."""
    half = sp.Rational(1, 2)
    s12 = sin(c.theta1 - c.theta2)
    return Matrix([
        -half * c.m2 * c.l1 * c.l2 * s12 * c.theta1_dot * c.theta2_dot
        - c.m1 * c.g * half * c.l1 * sin(c.theta1) - c.m2 * c.g * c.l1 * sin(c.theta1),
        half * c.m2 * c.l1 * c.l2 * s12 * c.theta1_dot * c.theta2_dot
        - c.m2 * c.g * half * c.l2 * sin(c.theta2)])


def inverse_001(A):
    """A^-1 = 1/det (b, -c; -c, a) for A = (a, c; c, b), det = ab - c^2."""
    a, cc, b = A[0, 0], A[0, 1], A[1, 1]
    return Matrix([[b, -cc], [-cc, a]]) / (a * b - cc**2)


def thetadot_001(c):
    """theta' = A^-1 p of (3)."""
    return inverse_001(A_hat_001(c)) * Matrix(c.d.symbols.p)


def H_001(c):
    p = Matrix(c.d.symbols.p)
    return (p.T * inverse_001(A_hat_001(c)) * p)[0, 0] / 2 + U_001(c)


def theta_vec(c):
    return Matrix([c.theta1_dot, c.theta2_dot])


claim("x_i, y_i", "centres of mass of the rods", COMPOUND,
      lambda c: stack(*c.d.centres), seed=SEED1)(com_001)
claim("x_i', y_i'", "velocities of the centres of mass", COMPOUND,
      lambda c: c.ddt(stack(*c.d.centres)), seed=SEED1)(vel_001)


@claim("T", "T = 1/2 m1 v1^2 + 1/2 L1 th1'^2 + 1/2 m2 v2^2 + 1/2 L2 th2'^2", COMPOUND,
       lambda c: c.d.T, seed=SEED1)
def _(c):
    v = vel_001(c)
    return (c.m1 * (v[0]**2 + v[1]**2) / 2 + c.L1 * c.theta1_dot**2 / 2
            + c.m2 * (v[2]**2 + v[3]**2) / 2 + c.L2 * c.theta2_dot**2 / 2)


claim("T", "T = 1/2 theta'^t A^ theta'", COMPOUND, lambda c: c.d.T, seed=SEED1)(
    lambda c: (theta_vec(c).T * A_hat_001(c) * theta_vec(c))[0, 0] / 2)
claim("T", "the matrix A^ = M", COMPOUND, lambda c: c.d.M, seed=SEED1)(A_hat_001)
claim("U", "potential energy U", COMPOUND, lambda c: c.d.V, seed=SEED1)(U_001)
claim("(1)", "p = dL/dtheta' = A^ theta'", COMPOUND,
      lambda c: Matrix([c.d.L.diff(x) for x in c.qd]), seed=SEED1)(
    lambda c: A_hat_001(c) * theta_vec(c))
claim("(2)", "p1', p2' = dL/dtheta_i as printed", COMPOUND,
      lambda c: Matrix([c.d.L.diff(x) for x in c.q]), seed=SEED1)(pdot_001)
claim("(2)", "p1', p2' = the derivation's dL/dq", COMPOUND,
      lambda c: c.d.hamiltonian.dL_dq, seed=SEED1)(pdot_001)
claim("(2)", "d/dt (A^ theta') = p' is Lagrange's equation M q'' = F", COMPOUND,
      lambda c: c.d.M * c.qdd_vec - c.d.F, seed=SEED1)(
    lambda c: c.ddt(A_hat_001(c) * theta_vec(c)) - pdot_001(c))
claim("(3)", "theta' = A^-1 p = dH/dp", COMPOUND,
      lambda c: c.d.hamiltonian.qdot, seed=SEED1)(thetadot_001)
claim("(3)", "p' = dL/dtheta at theta' = A^-1 p, = -dH/dtheta", COMPOUND,
      lambda c: c.d.hamiltonian.pdot, seed=SEED1)(
    lambda c: pdot_001(c).xreplace(dict(zip(c.qd, thetadot_001(c)))))
claim("H", "H = 1/2 p^t A^-1 p + U", COMPOUND, lambda c: c.d.hamiltonian.H, seed=SEED1)(H_001)
claim("H", "dH/dp of the printed H = the derivation's q'", COMPOUND,
      lambda c: c.d.hamiltonian.qdot, seed=SEED1)(
    lambda c: Matrix([H_001(c).diff(p) for p in c.d.symbols.p]))
claim("H", "-dH/dtheta of the printed H = the derivation's p'", COMPOUND,
      lambda c: c.d.hamiltonian.pdot, seed=SEED1)(
    lambda c: Matrix([-H_001(c).diff(x) for x in c.q]))

_A, _B, _C = sp.symbols("a_ b_ c_", real=True)
claim("A^-1", "1/det (b, -c; -c, a) inverts (a, c; c, b)", COMPOUND,
      lambda c: Solve(Matrix([[_A, _C], [_C, _B]]), sp.eye(2)), seed=SEED1)(
    lambda c: inverse_001(Matrix([[_A, _C], [_C, _B]])))
