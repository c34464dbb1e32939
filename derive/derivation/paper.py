"""The seed's own forms for the double spherical pendulum, computed from a chart.

Seed 000 (2.20)-(2.24) writes the equations as
    A u'' + B w + G = 0,   w = (u1'^2, 2 u1' v1', v1'^2, u2'^2, 2 u2' v2', v2'^2),
with A, B built from inner products of the chart's derivatives, everything
divided by m2 so that mu = 1 + m1/m2 appears.  (3.27)-(3.33) and (4.8) divide
the 2nd and 4th rows (and the 2nd and 4th columns of A) by the polar sines;
(3.35)-(3.39) give the block inverse of the reduced matrix.

These are computed here from their definitions, independently of the
Lagrangian route in lagrange.py; verification checks that both agree.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .. import cachefile
from ..model import Model
from .lagrange import link_vectors
from .symbols import ModelSymbols, per_shape


@cachefile.register
@dataclass
class PaperForms:
    mu: sp.Expr                 # 1 + m1/m2
    w: sp.Matrix                # quadratic rate vector of (2.20)
    A: sp.Matrix                # (2.21), (2.23)
    B: sp.Matrix                # (2.22), (2.24)
    G: sp.Matrix                # gravity vector of (2.20)
    S: sp.Matrix                # diag(1, sin u1, 1, sin u2): the reduction (3.27)
    A_red: sp.Matrix            # A-tilde (3.28)
    B_red: sp.Matrix            # B-tilde (3.30)
    G_red: sp.Matrix            # gravity vector of (3.27) / (4.8)
    Q: sp.Matrix                # (3.29)
    A_hat: sp.Matrix            # (3.36)
    D1: sp.Matrix               # (3.38)
    D2: sp.Matrix               # (3.38)

    def block_inverse(self) -> sp.Matrix:
        """D-hat A-hat of (3.39), with the 2x2 inverses in closed form."""
        D_hat = sp.diag(self.D1.adjugate() / self.D1.det(), self.D2.adjugate() / self.D2.det())
        return D_hat * self.A_hat


def _tidied(expr: sp.Expr) -> sp.Expr:
    # Cancel the polar sines exactly: expand double angles so sin(2u) shows its
    # sin(u) factor, cancel, then let trigsimp fold cos(a)cos(b)+sin(a)sin(b).
    return sp.trigsimp(sp.factor_terms(sp.cancel(sp.expand_trig(expr))))


def _tidy(expr: sp.Expr) -> sp.Expr:
    return per_shape(_tidied, expr)     # the two links' entries are often one shape


def paper_forms(model: Model, s: ModelSymbols) -> PaperForms:
    if len(model.links) != 2 or model.dimension != 3:
        raise ValueError(f"model '{model.name}': the paper's forms need two spherical links")
    m1, m2, g = s.param("m1"), s.param("m2"), s.param("g")
    mu = 1 + m1 / m2
    u1, v1, u2, v2 = s.q
    du1, dv1, du2, dv2 = s.qd
    qvec = link_vectors(model, s)
    coords = [(u1, v1), (u2, v2)]
    first = [[qvec[i].diff(c) for c in coords[i]] for i in range(2)]
    second = [[qvec[i].diff(a, b) for a, b in ((c[0], c[0]), (c[0], c[1]), (c[1], c[1]))]
              for i, c in enumerate(coords)]
    weight = [[mu, 1], [1, 1]]          # (2.21): mu on the (1,1) block only

    def block(i, j, cols):
        return sp.Matrix(2, len(cols), lambda r, c: per_shape(sp.trigsimp, sp.expand(
            weight[i][j] * cols[c].dot(first[i][r]))))

    A = sp.Matrix(sp.BlockMatrix([[block(i, j, first[j]) for j in range(2)] for i in range(2)]))
    B = sp.Matrix(sp.BlockMatrix([[block(i, j, second[j]) for j in range(2)] for i in range(2)]))
    weights_g = [mu * g, g]
    G = sp.Matrix([per_shape(sp.trigsimp, weights_g[i] * qvec[i][2].diff(c))
                   for i in range(2) for c in coords[i]])
    w = sp.Matrix([du1**2, 2 * du1 * dv1, dv1**2, du2**2, 2 * du2 * dv2, dv2**2])

    sines = [link.chart.polar_sine_of(list(c)) for link, c in zip(model.links, coords)]
    S = sp.diag(1, sines[0], 1, sines[1])
    S_inv = sp.diag(1, 1 / sines[0], 1, 1 / sines[1])
    A_red = (S_inv * A * S_inv).applyfunc(_tidy)
    B_red = (S_inv * B).applyfunc(_tidy)
    G_red = (S_inv * G).applyfunc(_tidy)
    Q = A_red[0:2, 2:4]
    a, b = A_red[0, 0], A_red[2, 2]          # mu l1^2 and l2^2 when (3.28) holds
    A_hat = sp.Matrix(sp.BlockMatrix([[b * sp.eye(2), -Q], [-Q.T, a * sp.eye(2)]]))
    D1 = (a * b * sp.eye(2) - Q * Q.T).applyfunc(sp.expand)
    D2 = (a * b * sp.eye(2) - Q.T * Q).applyfunc(sp.expand)
    return PaperForms(mu, w, A, B, G, S, A_red, B_red, G_red, Q, A_hat, D1, D2)
