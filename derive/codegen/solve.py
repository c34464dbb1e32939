"""The linear solve of M q'' = F, done inside the generated code.

Nothing here inverts a matrix symbolically.  The entries of M and F become
named stages (computed once in the generated code), and the solution is
written in terms of those names:

* two coordinates: the closed-form 2x2 inverse (Cramer), seed 001 below (3);
* one coordinate: q'' = F / M;
* three or more: M = L D L^T (M is symmetric positive definite), the factors as
  stages L<i><j>, D<i> and 1/D<i> computed once, then forward and back
  substitution for each right-hand side (the solution, each Jacobian column);
* the double spherical pendulum: the seed's reduced system (3.27)
  A~ x + B~ w + G~ = 0 with x = S q'', S = diag(1, sin u1, 1, sin u2),
  solved by the block inverse (3.35)-(3.39): x = D^ A^ f~, f~ = -(B~ w + G~),
  then q''_j = x_j / S_jj.

The Jacobian of the rhs differentiates the implicit system instead of the
solution: from M q'' = F, d q''/d y_k = M^-1 (dF/dy_k - (dM/dy_k) q''),
reusing the in-code solve and the q'' already computed; for the reduced
system, dx = A~^-1 (df~/dy_k - (dA~/dy_k) x) and
d q''_j = (dx_j - (dS_jj/dy_k) q''_j) / S_jj.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import sympy as sp

from ..derivation.loop_closure import augmented_system
from ..derivation.symbolic import Derivatives, EngineNames, EngineUnsupported, MatrixDerivatives
from .names import internal as _sym


@dataclass
class Solution:
    symbols: list[sp.Expr]                    # the solution, as stage symbols
    stages: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)


class MassMatrixStages:
    """The entries of a symmetric M as stages M<i><j> (upper triangle, non-zero only)."""

    def __init__(self, M: sp.Matrix):
        if not M.is_square or M != M.T:
            raise ValueError("the mass matrix must be square and symmetric")
        self.n = n = M.rows
        sep = "" if n <= 10 else "_"          # M01 for small matrices, M1_10 beyond
        self.stages: list[tuple[sp.Symbol, sp.Expr]] = []
        entry = {}
        for i in range(n):
            for j in range(i, n):
                if M[i, j] == 0:
                    entry[i, j] = entry[j, i] = sp.S.Zero
                elif M[i, j].is_number:
                    entry[i, j] = entry[j, i] = M[i, j]
                else:
                    sym = _sym(f"M{i}{sep}{j}")
                    self.stages.append((sym, M[i, j]))
                    entry[i, j] = entry[j, i] = sym
        self.entry = sp.Matrix(n, n, lambda i, j: entry[i, j])
        self.symbols_flat = list(self.entry)
        self.inverse_stages: list[tuple[sp.Symbol, sp.Expr]] = []
        if n == 2:
            m = self.entry
            det, rdet = _sym("det"), _sym("rdet")
            self.inverse_stages = [(det, m[0, 0] * m[1, 1] - m[0, 1] ** 2), (rdet, 1 / det)]
            self.rdet = rdet
        else:
            self._factor(sep)
        self.method = {1: "q'' = F / M", 2: "closed-form 2x2 inverse"}.get(
            n, f"L D L^T factorisation of the {n}x{n} mass matrix, forward and back substitution")

    def _factor(self, sep: str) -> None:
        """M = L D L^T as stages (L unit lower triangular; structural zeros stay zero)."""
        n, m = self.n, self.entry
        L = sp.eye(n)
        self.rD: list[sp.Expr] = []
        D: list[sp.Expr] = []
        for j in range(n):
            dj = m[j, j] - sum((L[j, k] ** 2 * D[k] for k in range(j)), sp.S.Zero)
            if n == 1:
                sym_d = dj
            else:
                sym_d = _sym(f"D{j}")
                self.inverse_stages.append((sym_d, dj))
            D.append(sym_d)
            r = _sym(f"rD{j}")
            self.inverse_stages.append((r, 1 / sym_d))
            self.rD.append(r)
            for i in range(j + 1, n):
                lij = (m[i, j] - sum((L[i, k] * L[j, k] * D[k] for k in range(j)), sp.S.Zero)) * r
                if lij == 0:
                    continue
                sym = _sym(f"L{i}{sep}{j}")
                self.inverse_stages.append((sym, lij))
                L[i, j] = sym
        self.L = L

    def apply(self, b: list[sp.Expr]) -> list[sp.Expr]:
        """M^-1 b: adj(M) b / det for 2x2; forward and back substitution through L D L^T
        otherwise, as nested expressions (solve() names the intermediate values)."""
        if self.n == 2:
            m = self.entry
            return [(m[1, 1] * b[0] - m[0, 1] * b[1]) * self.rdet,
                    (m[0, 0] * b[1] - m[0, 1] * b[0]) * self.rdet]
        return self._substitute(b, None)[0]

    def _substitute(self, b: list[sp.Expr], prefix: str | None, out: list[sp.Symbol] | None = None,
                    names: EngineNames | None = None):
        """(x = M^-1 b, stages) through z = L^-1 b, x = L^-T (z / D).  With a prefix, each
        z_i is a stage <prefix>z<i> and each x_i the stage out[i] (default <prefix><i>), so
        every value is computed once and the back substitution reuses them.  With `names`,
        b is SymEngine's and so are the sums, brought back to SymPy at the end."""
        n, stages = self.n, []
        native = (lambda e: e) if names is None else (lambda e: names.engine([e])[0])
        L = [[native(self.L[i, k]) for k in range(i + 1)] for i in range(n)]
        rD, zero = [native(r) for r in self.rD], native(sp.S.Zero)
        z = []
        for i in range(n):
            value = b[i] - sum((L[i][k] * z[k] for k in range(i)), zero)
            if prefix is not None and i and not (value.is_number or value.is_Symbol):
                sym = _sym(f"{prefix}z{i}")
                stages.append((sym, value))
                value = native(sym)
            z.append(value)
        x: list = [None] * n
        for i in reversed(range(n)):
            value = z[i] * rD[i] - sum((L[k][i] * x[k] for k in range(i + 1, n)), zero)
            if prefix is not None:
                sym = out[i] if out is not None else _sym(f"{prefix}{i}")
                stages.append((sym, value))
                value = native(sym)
            x[i] = value
        if names is not None:
            back = names.sympy(x + [v for _, v in stages])
            x, stages = back[:n], [(sym, v) for (sym, _), v in zip(stages, back[n:])]
        return x, stages

    def solve(self, b: list[sp.Expr], prefix: str) -> Solution:
        """Stages for M^-1 b named <prefix>0, <prefix>1, ... (after the factorisation)."""
        syms = [_sym(f"{prefix}{i}") for i in range(self.n)]
        if self.n == 2:
            return Solution(syms, list(self.inverse_stages) + list(zip(syms, self.apply(b))))
        _, stages = self._substitute(b, f"{prefix}_", syms)
        return Solution(syms, list(self.inverse_stages) + stages)


class ImplicitDerivative:
    """d x / d y_k of a system M x = F (x its solution, as stage symbols), from
    M dx/dy_k = dF/dy_k - (dM/dy_k) x: the right-hand side's derivatives and sums by
    SymEngine (derive/derivation/symbolic.py) and solved by the system's own L D L^T
    substitution, in SymEngine too where it takes every entry of M and F (a 12-link
    chain's Jacobian: 0.4 s in SymPy's arithmetic), and brought back to SymPy once.

    Parameters
    ----------
    M : sympy.Matrix
    F : sequence of sympy.Expr
    mass : MassMatrixStages
        M's stages and factorisation.
    engine : bool, optional
        Sum and solve in SymEngine where it takes the system (False: in SymPy; the
        tests compare the two).
    """

    def __init__(self, M: sp.Matrix, F, mass: MassMatrixStages, engine: bool = True):
        self.mass = mass
        names = EngineNames() if engine else None
        try:
            if names is not None:
                names.engine(list(F) + list(M))
        except (EngineUnsupported, RecursionError):
            names = None
        # the sums in SymEngine only through L D L^T (a 2x2 M is solved in closed form)
        self.names = names if mass.n > 2 else None
        self.dF, self.dM = Derivatives(list(F), names), MatrixDerivatives(M, names)

    def residual(self, yk: sp.Symbol, x: list) -> list:
        """dF/dy_k - (dM/dy_k) x, SymEngine's where `names`, else SymPy's."""
        n = len(x)
        if self.names is None:
            return [self.dF.diff(i, yk) - sum(self.dM.entry(i, j, yk) * x[j] for j in range(n))
                    for i in range(n)]
        xs = self.names.engine(x)
        zero = xs[0] * 0
        return [self.dF.engine_diff(i, yk) - sum((self.dM.engine_entry(i, j, yk) * xs[j] for j in range(n)), zero)
                for i in range(n)]

    def solve(self, yk: sp.Symbol, x: list) -> tuple[list[sp.Expr], list]:
        """(dx/dy_k, its stages named d<y_k>_...): zeros where the residual is zero."""
        r = self.residual(yk, x)
        if all(e == 0 for e in r):
            return [sp.S.Zero] * len(r), []
        if self.mass.n <= 2:
            return self.mass.apply(r), []
        return self.mass._substitute(r, f"d{yk.name}_", names=self.names)


class MassMatrixDynamics:
    """q'' = M^-1 F: the closed-form 2x2 inverse, or L D L^T for any other size."""

    def __init__(self, d):
        self.s = d.symbols
        self.M, self.F = d.M, d.F
        self.mass = MassMatrixStages(d.M)
        self.method = self.mass.method
        fsyms = [_sym(f"F{i}") for i in range(len(d.F))]
        self.forcing_stages = list(zip(fsyms, d.F))
        sol = self.mass.solve(fsyms, "qdd")
        self.qdd = sol.symbols
        self.stages = self.mass.stages + self.forcing_stages + sol.stages

    def derivative(self, yk: sp.Symbol) -> tuple[list[sp.Expr], list]:
        """d q''/d y_k = M^-1 (dF/dy_k - (dM/dy_k) q'')."""
        return self._implicit.solve(yk, self.qdd)

    @cached_property
    def _implicit(self) -> ImplicitDerivative:
        return ImplicitDerivative(self.M, self.F, self.mass)


class ConstrainedDynamics:
    """A closed loop's q'' and multipliers lambda from the augmented system
    [M J^T; J 0] [q''; lambda] = [F; gamma] (derive/derivation/loop_closure.py), by the
    same L D L^T stages as an open chain's M: the leading block M is symmetric positive
    definite, so the first n pivots are M's and the last m are those of the Schur
    complement -J M^-1 J^T, negative definite where J has full rank; no pivot vanishes
    and no pivoting is needed."""

    def __init__(self, d):
        self.s = d.symbols
        self.M, self.F = augmented_system(d.M, d.F, d.constraints)
        n, m = d.M.rows, d.constraints.J.rows
        self.mass = MassMatrixStages(self.M)
        self.method = (f"L D L^T factorisation of the {n + m}x{n + m} augmented system "
                       f"[M J^T; J 0] [q''; lambda] = [F; gamma] ({m} constraints)")
        bsyms = [_sym(f"F{i}") for i in range(n + m)]
        self.forcing_stages = list(zip(bsyms, self.F))
        self.qdd = [_sym(f"qdd{i}") for i in range(n)]
        self.multipliers = [_sym(f"lam{i}") for i in range(m)]
        self.unknowns = self.qdd + self.multipliers
        _, solve_stages = self.mass._substitute(bsyms, "qdd_", self.unknowns)
        self.stages = self.mass.stages + self.forcing_stages + list(self.mass.inverse_stages) + solve_stages

    def derivative(self, yk: sp.Symbol) -> tuple[list[sp.Expr], list]:
        """d(q'', lambda)/d y_k = A^-1 (db/dy_k - (dA/dy_k) (q'', lambda)); the first n
        entries are d q''/d y_k."""
        return self._implicit.solve(yk, self.unknowns)

    @cached_property
    def _implicit(self) -> ImplicitDerivative:
        return ImplicitDerivative(self.M, self.F, self.mass)


class ReducedDynamics:
    """The seed's reduced system and block inverse, (3.27)-(3.40)."""
    method = "the block inverse of seed 000 (3.35)-(3.39) on the reduced system (3.27)"

    def __init__(self, d):
        P = d.paper
        self.s = d.symbols
        A = P.A_red
        if A.shape != (4, 4):
            raise ValueError("the reduced system must be 4x4")
        a, b = A[0, 0], A[2, 2]
        if A[0:2, 0:2] != a * sp.eye(2) or A[2:4, 2:4] != b * sp.eye(2) or A[2:4, 0:2] != A[0:2, 2:4].T:
            raise ValueError(f"model '{d.name}': A~ is not of the form [[a I, Q], [Q^T, b I]] (3.28)")
        self.Q_expr = A[0:2, 2:4]
        self.S = P.S
        self.sines = [P.S[j, j] for j in range(4)]
        Aa, Ab = _sym("Aa"), _sym("Ab")
        Qs = sp.Matrix(2, 2, lambda i, j: _sym(f"Q{i}{j}"))
        stages = [(Aa, a), (Ab, b)] + [(Qs[i, j], self.Q_expr[i, j]) for i in range(2) for j in range(2)]
        ab = _sym("AaAb")
        stages.append((ab, Aa * Ab))
        # D1 = ab I - Q Q^T, D2 = ab I - Q^T Q  (3.38), symmetric 2x2
        D1 = ab * sp.eye(2) - Qs * Qs.T
        D2 = ab * sp.eye(2) - Qs.T * Qs
        self.Dinv = []
        for name, D in (("D1", D1), ("D2", D2)):
            e00, e01, e11 = _sym(f"{name}_00"), _sym(f"{name}_01"), _sym(f"{name}_11")
            r = _sym(f"r{name}")
            stages += [(e00, D[0, 0]), (e01, D[0, 1]), (e11, D[1, 1]), (r, 1 / (e00 * e11 - e01 ** 2))]
            self.Dinv.append(sp.Matrix([[e11, -e01], [-e01, e00]]) * r)
        self.A_hat = sp.Matrix(sp.BlockMatrix([[Ab * sp.eye(2), -Qs], [-Qs.T, Aa * sp.eye(2)]]))
        self.A_sym = sp.Matrix(sp.BlockMatrix([[Aa * sp.eye(2), Qs], [Qs.T, Ab * sp.eye(2)]]))
        self.f_expr = -(P.B_red * P.w + P.G_red)
        fs = [_sym(f"f{i}") for i in range(4)]
        stages += list(zip(fs, self.f_expr))
        # x_j is q''_j itself where S_jj = 1; elsewhere q''_j = x_j / S_jj
        xs = [_sym(f"qdd{j}" if self.sines[j] == 1 else f"xr{j}") for j in range(4)]
        stages += list(zip(xs, self.apply(fs)))
        self.x = xs
        self.rs, self.qdd = [], []             # 1 / S_jj, as stages where S_jj != 1
        for j, sj in enumerate(self.sines):
            if sj == 1:
                self.rs.append(sp.S.One)
                self.qdd.append(xs[j])
            else:
                r, q = _sym(f"rs{j}"), _sym(f"qdd{j}")
                stages += [(r, 1 / sj), (q, xs[j] * r)]
                self.rs.append(r)
                self.qdd.append(q)
        self.stages = stages

    def apply(self, r: list[sp.Expr]) -> list[sp.Expr]:
        """A~^-1 r = D^ A^ r (3.39)."""
        g = self.A_hat * sp.Matrix(r)
        return list(self.Dinv[0] * g[0:2, 0]) + list(self.Dinv[1] * g[2:4, 0])

    def derivative(self, yk: sp.Symbol) -> tuple[list[sp.Expr], list]:
        dA = sp.Matrix(sp.BlockMatrix([[sp.zeros(2), self.Q_expr.diff(yk)],
                                       [self.Q_expr.T.diff(yk), sp.zeros(2)]]))
        r = self.f_expr.diff(yk) - dA * sp.Matrix(self.x)
        dx = self.apply(list(r)) if any(e != 0 for e in r) else [sp.S.Zero] * 4
        out = []
        for j in range(4):
            ds = self.sines[j].diff(yk)
            out.append((dx[j] - ds * self.qdd[j]) * self.rs[j] if ds != 0 else dx[j] * self.rs[j])
        return out, []


@dataclass
class Jacobian:
    exprs: list[sp.Expr]
    stages: list[tuple[sp.Symbol, sp.Expr]]


def jacobian(dyn, s) -> Jacobian:
    """J of y' = (q', q''(y)) with respect to y, row-major."""
    nq, n = len(s.q), len(s.state)
    cols, stages = [], []
    for yk in s.state:
        col, st = dyn.derivative(yk)
        cols.append(col)
        stages += st
    J = sp.zeros(n, n)
    for i in range(nq):
        J[i, nq + i] = 1
    for k in range(n):
        for i in range(nq):
            J[nq + i, k] = cols[k][i]
    return Jacobian(list(J), stages)
