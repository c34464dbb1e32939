"""The derivation itself, evaluated with mpmath at high precision: the reference
the generated kernels are tested against.

Nothing here shares code with the generated kernels' solve: M q'' = F is
solved by mpmath's LU decomposition on the derivation's M and F, and the
Jacobian is a central difference of that at 40+ digits with a tiny step
(truncation ~ h^2 ~ 1e-24, rounding ~ 10^-dps / h), not the implicit
differentiation the generated code uses.
"""
from __future__ import annotations

import mpmath
import numpy as np
import sympy as sp


class Reference:
    def __init__(self, d, dps: int = 30):
        self.d = d
        self.dps = dps
        s = d.symbols
        args = list(s.state) + list(s.params)
        self.nq, self.n = len(s.q), len(s.state)
        self._M = sp.lambdify(args, d.M, modules="mpmath")
        self._F = sp.lambdify(args, d.F, modules="mpmath")
        self._E = sp.lambdify(args, d.energy, modules="mpmath")
        self._TV = sp.lambdify(args, [d.T, d.V], modules="mpmath")
        self._tips = sp.lambdify(args, sp.Matrix.vstack(*[t.T for t in d.tips]), modules="mpmath")
        if d.polar_sines:
            self._sines = sp.lambdify(args, d.polar_sines, modules="mpmath")
        if d.hamiltonian is not None:
            self._pdot = sp.lambdify(args, d.hamiltonian.dL_dq, modules="mpmath")

    def _mp(self, values):
        return [mpmath.mpf(float(v)) for v in values]

    def _qdd(self, args):
        M = mpmath.matrix(self._M(*args).tolist())
        F = mpmath.matrix(self._F(*args).tolist())
        return list(mpmath.lu_solve(M, F))

    def rhs(self, y, p) -> list:
        with mpmath.workdps(self.dps):
            args = self._mp(y) + self._mp(p)
            return list(args[self.nq:self.n]) + self._qdd(args)

    def mass_matrix(self, y, p):
        with mpmath.workdps(self.dps):
            return self._M(*(self._mp(y) + self._mp(p)))

    def forcing(self, y, p):
        with mpmath.workdps(self.dps):
            return self._F(*(self._mp(y) + self._mp(p)))

    def energy(self, y, p):
        with mpmath.workdps(self.dps):
            return self._E(*(self._mp(y) + self._mp(p)))

    def energy_scale(self, y, p):
        """|T| + |V|: the size of the terms whose sum is the energy."""
        with mpmath.workdps(self.dps):
            T, V = self._TV(*(self._mp(y) + self._mp(p)))
            return abs(T) + abs(V)

    def positions(self, y, p):
        with mpmath.workdps(self.dps):
            return self._tips(*(self._mp(y) + self._mp(p)))

    def polar_sines(self, y, p):
        with mpmath.workdps(self.dps):
            return self._sines(*(self._mp(y) + self._mp(p)))

    def jacobian(self, y, p, h_exp: int = 15):
        """Central differences at dps + 2*h_exp digits with step 10^-h_exp."""
        with mpmath.workdps(self.dps + 2 * h_exp):
            h = mpmath.mpf(10) ** (-h_exp)
            base = self._mp(y)
            pp = self._mp(p)
            J = mpmath.matrix(self.n, self.n)
            for k in range(self.n):
                up, down = list(base), list(base)
                up[k] += h
                down[k] -= h
                fu = list(up[self.nq:]) + self._qdd(up + pp)
                fd = list(down[self.nq:]) + self._qdd(down + pp)
                for i in range(self.n):
                    J[i, k] = (fu[i] - fd[i]) / (2 * h)
            return J

    def _hamilton(self, x: list, pp: list) -> list:
        q, mom = x[:self.nq], x[self.nq:]
        zeros = [mpmath.mpf(0)] * self.nq
        M = mpmath.matrix(self._M(*(q + zeros + pp)).tolist())
        qdot = list(mpmath.lu_solve(M, mpmath.matrix(mom)))
        return qdot + list(self._pdot(*(q + qdot + pp)))

    def hamiltonian_rhs(self, x, p):
        """(q', p') at x = (q, p): q' solves M q' = p, p' = dL/dq at that q'."""
        with mpmath.workdps(self.dps):
            return self._hamilton(self._mp(x), self._mp(p))

    def hamiltonian_jacobian(self, x, p, h_exp: int = 15):
        """Central differences of hamiltonian_rhs at dps + 2*h_exp digits."""
        with mpmath.workdps(self.dps + 2 * h_exp):
            h = mpmath.mpf(10) ** (-h_exp)
            base, pp = self._mp(x), self._mp(p)
            J = mpmath.matrix(self.n, self.n)
            for k in range(self.n):
                up, down = list(base), list(base)
                up[k] += h
                down[k] -= h
                fu, fd = self._hamilton(up, pp), self._hamilton(down, pp)
                for i in range(self.n):
                    J[i, k] = (fu[i] - fd[i]) / (2 * h)
            return J


def to_float(values) -> np.ndarray:
    """mpmath numbers (nested) to float64 (for scales; comparisons use mpf)."""
    if isinstance(values, mpmath.matrix):
        values = values.tolist()
    return np.array(values, dtype=object).astype(float)
