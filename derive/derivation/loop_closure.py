"""Closed loops: holonomic constraints Phi(q; p) = 0 through Lagrange multipliers.

A model's `constraints` (a loop closure, e.g. the four-bar's rocker tip pinned to the
ground) are m expressions Phi(q; p) that vanish on the motion.  Lagrange's equations
with multipliers lambda,

    M(q) q'' + J(q)^T lambda = F(q, q', p, u),    Phi(q; p) = 0,    J = dPhi/dq,

are an index-3 differential-algebraic system.  Differentiating the constraint twice
along the motion (index reduction to 1), J q' = 0 and

    J q'' = gamma,    gamma = -(d(J q')/dq) q',

closes the system: the accelerations and the multipliers solve the augmented linear system

    [M  J^T] [q''   ]   [F    ]
    [J   0 ] [lambda] = [gamma],

which the generated code solves at every stage (derive/codegen/solve.py).  The
constraints are scleronomic (no t), so Phi_t = Phi_tt = 0 and the constraint forces do no
work: a conservative loop conserves T + V.  What keeps a numerical solution on Phi = 0,
J q' = 0 (the index-1 system only keeps Phi'' = 0) is the run time's business: it
measures and reports the drift (derive/runtime/constraints.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .. import cachefile
from ..model import Model
from ..model.expressions import parse_expression
from .symbols import ModelSymbols


@cachefile.register
@dataclass
class ConstraintForm:
    """A closed loop's constraint data, each a function of (q, q'; p)."""
    Phi: sp.Matrix       # (m, 1): the constraints, zero on the motion
    J: sp.Matrix         # (m, n): dPhi/dq
    velocity: sp.Matrix  # (m, 1): J q', zero on the motion (the velocity-level constraint)
    gamma: sp.Matrix     # (m, 1): J q'' = gamma, the acceleration-level constraint


def constraint_form(model: Model, s: ModelSymbols) -> ConstraintForm | None:
    """Phi, J and gamma of a model with `constraints`, None for an open chain.

    Parameters
    ----------
    model : Model
        The model description.
    s : ModelSymbols
        Its symbols.

    Returns
    -------
    ConstraintForm or None
    """
    if not model.is_constrained:
        return None
    where = model.origin or model.name
    allowed = {x.name: x for x in (*s.params, *s.q)}
    Phi = sp.Matrix([parse_expression(text, allowed, f"{where}: constraints[{i}]")
                     for i, text in enumerate(model.constraints, 1)])
    J = Phi.jacobian(sp.Matrix(s.q))
    qd = sp.Matrix(s.qd)
    Jqd = J * qd
    gamma = -(Jqd.jacobian(sp.Matrix(s.q)) * qd)
    return ConstraintForm(Phi, J, Jqd, gamma.applyfunc(lambda e: sp.factor_terms(sp.expand(e))))


def augmented_system(M: sp.Matrix, F: sp.Matrix, c: ConstraintForm) -> tuple[sp.Matrix, sp.Matrix]:
    """([M J^T; J 0], [F; gamma]): the matrix and right-hand side whose solution is
    (q'', lambda).

    Parameters
    ----------
    M, F : sympy.Matrix
        The open chain's mass matrix and forcing.
    c : ConstraintForm
        The loop's constraints.

    Returns
    -------
    tuple of sympy.Matrix
        The (n + m) x (n + m) symmetric matrix and the (n + m) right-hand side.
    """
    m = c.J.rows
    A = sp.Matrix(sp.BlockMatrix([[M, c.J.T], [c.J, sp.zeros(m, m)]]))
    return A, F.col_join(c.gamma)
