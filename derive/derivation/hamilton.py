"""The Hamiltonian form (seed 001 (1)-(3)): p = M q', H = 1/2 p^T M^-1 p + V."""
from __future__ import annotations

import sympy as sp

from .lagrange import ChainForm
from .symbols import ModelSymbols


def inverse_mass_matrix(M: sp.Matrix) -> sp.Matrix:
    """Closed-form inverse; seed 001 gives the 2x2 adjugate formula."""
    return (M.adjugate() / M.det()).applyfunc(sp.factor_terms)


def hamiltonian(M_inv: sp.Matrix, V: sp.Expr, s: ModelSymbols) -> sp.Expr:
    p = sp.Matrix(s.p)
    return (p.T * M_inv * p)[0, 0] / 2 + V


def hamilton_equations(H: sp.Expr, s: ModelSymbols) -> tuple[sp.Matrix, sp.Matrix]:
    """q' = dH/dp, p' = -dH/dq (seed 001, Hamilton's canonical equations)."""
    qdot = sp.Matrix([sp.factor_terms(H.diff(pk)) for pk in s.p])
    pdot = sp.Matrix([-H.diff(qk) for qk in s.q])
    return qdot, pdot


def lagrangian_gradient(form: ChainForm, s: ModelSymbols) -> sp.Matrix:
    """dL/dq = 1/2 q'^T (dM/dq_j) q' - dV/dq_j, in the rates q' (seed 001 (2)).

    Evaluated at q' = M^-1 p it equals -dH/dq; generated code uses this form
    because it reuses q' instead of differentiating M^-1.
    """
    qd = sp.Matrix(s.qd)
    return sp.Matrix([form.filled(sp.expand((qd.T * form.M.diff(qj) * qd)[0, 0] / 2 - form.V.diff(qj)))
                      for qj in s.q])
