"""Stage 2, the derivation: positions -> T, V, L -> M(q) q'' = F(q, q').

With generalized coordinates q and rates q', the kinetic energy is the
quadratic form T = 1/2 q'^T M(q) q', so Lagrange's equation (seed 000 (1.1))
    d/dt dL/dq' - dL/dq = 0
becomes M q'' = F with
    F_j = 1/2 q'^T (dM/dq_j) q' - sum_k q'_k (dM/dq_k q')_j - dV/dq_j,
the Christoffel form.  It is exact and needs no time-dependent symbols.
"""
from __future__ import annotations

import sympy as sp

from ..model import Model
from ..model.expressions import parse_expression
from .symbols import ModelSymbols, names, parse_quantity


def link_directions(model: Model, s: ModelSymbols) -> list[sp.Matrix]:
    """Unit vector of each link in its chart (seed 000 (2.1), (4.1); §1 for planar)."""
    dirs, k = [], 0
    for link in model.links:
        n = len(link.chart.coordinates)
        dirs.append(link.chart.unit_vector(list(s.q[k:k + n])))
        k += n
    return dirs


def link_vectors(model: Model, s: ModelSymbols) -> list[sp.Matrix]:
    """q_i = l_i e_i: the vector along each link, pivot to tip."""
    return [parse_quantity(link.length, s) * e
            for link, e in zip(model.links, link_directions(model, s))]


def tip_positions(model: Model, s: ModelSymbols) -> list[sp.Matrix]:
    """x_1 = q_1, x_2 = q_1 + q_2 (seed 000 below (1.3)): each link's tip."""
    tips, x = [], sp.zeros(model.dimension, 1)
    for qi in link_vectors(model, s):
        x = x + qi
        tips.append(x)
    return tips


def mass_centres(model: Model, s: ModelSymbols) -> list[sp.Matrix]:
    """Where each body's mass sits: the tip for a point, com*l along the link for a rod."""
    centres, base = [], sp.zeros(model.dimension, 1)
    for link, qi in zip(model.links, link_vectors(model, s)):
        centres.append(base + parse_quantity(link.body.com, s) * qi)
        base = base + qi
    return centres


def _clean(expr: sp.Expr) -> sp.Expr:
    # A targeted pass: expand the trigonometric polynomial, then let trigsimp
    # collect sin^2 + cos^2 and the angle-difference forms.
    return sp.trigsimp(sp.expand(expr))


def mass_matrix(model: Model, s: ModelSymbols) -> sp.Matrix:
    """M = sum_k m_k J_k^T J_k + I_k E_k^T E_k, J_k = d(centre_k)/dq, E_k = d(e_k)/dq.

    The rod term is the rotational energy 1/2 I |de/dt|^2 of a thin rod about
    its centre of mass (for a planar link |de/dt| = theta'), seed 001's T.
    """
    q = sp.Matrix(s.q)
    n = len(s.q)
    M = sp.zeros(n, n)
    for link, c, e in zip(model.links, mass_centres(model, s), link_directions(model, s)):
        J = c.jacobian(q)
        M += parse_quantity(link.body.mass, s) * (J.T * J)
        inertia = parse_quantity(link.body.inertia, s)
        if inertia != 0:
            E = e.jacobian(q)
            M += inertia * (E.T * E)
    return M.applyfunc(_clean)


def potential_energy(model: Model, s: ModelSymbols) -> sp.Expr:
    """V = sum_k m_k g (height of centre k); gravity along the last axis, downwards."""
    g = s.param("g")
    return _clean(sum(parse_quantity(link.body.mass, s) * g * c[-1]
                      for link, c in zip(model.links, mass_centres(model, s))))


def kinetic_energy(M: sp.Matrix, s: ModelSymbols) -> sp.Expr:
    qd = sp.Matrix(s.qd)
    return sp.expand((qd.T * M * qd)[0, 0] / 2)


def dissipation_function(model: Model, s: ModelSymbols) -> sp.Expr | None:
    """Rayleigh's dissipation function R(q', q; p) of the model, or None."""
    if model.dissipation is None:
        return None
    return parse_expression(model.dissipation, names(s), f"{model.origin or model.name}: dissipation")


def generalized_forces(model: Model, s: ModelSymbols) -> sp.Matrix | None:
    """The applied generalized forces Q (one per coordinate; zero where the model gives
    none), or None for a model without [forces]."""
    if not model.forces:
        return None
    given = dict(model.forces)
    where = model.origin or model.name
    return sp.Matrix([parse_expression(given[q.name], names(s), f"{where}: forces.{q.name}")
                      if q.name in given else sp.S.Zero for q in s.q])


def non_conservative(R: sp.Expr | None, Q: sp.Matrix | None, s: ModelSymbols) -> sp.Matrix:
    """Q - dR/dq': the right-hand side terms Lagrange's equation gains from applied
    forces and Rayleigh dissipation, d/dt dL/dq' - dL/dq = Q - dR/dq'."""
    out = sp.zeros(len(s.q), 1)
    if Q is not None:
        out += Q
    if R is not None:
        out -= sp.Matrix([R.diff(v) for v in s.qd])
    return out.applyfunc(sp.expand)


def forcing(M: sp.Matrix, V: sp.Expr, s: ModelSymbols) -> sp.Matrix:
    """F of M q'' = F in the Christoffel form given in the module docstring."""
    qd = sp.Matrix(s.qd)
    dM = [M.diff(qk) for qk in s.q]
    Mqd_dot = sum((dM[k] * qd * s.qd[k] for k in range(len(s.q))), sp.zeros(len(s.q), 1))
    F = sp.Matrix([(qd.T * dM[j] * qd)[0, 0] / 2 - Mqd_dot[j] - V.diff(s.q[j])
                   for j in range(len(s.q))])
    return F.applyfunc(_clean)
