"""SymEngine, SymPy's C++ core, for the heavy algebra of the derivation and code generation.

The expressions stay SymPy's everywhere (the printers, the cache, the checks are SymPy's);
only the operations that dominate the cost of a large model are done in SymEngine and the
result brought back:

* partial derivatives (`Derivatives`): the Christoffel form's dM/dq, the Jacobian
  kernel's dF/dy and dM/dy.  SymEngine differentiates a 12-link chain's forcing about a
  hundred times faster than SymPy.

The result is SymPy's own: each symbol is renamed to a plain one on the way in (SymEngine
keeps no assumptions, and a Dummy would come back as another Dummy) and renamed back on
the way out, which rebuilds the expression with SymPy's automatic evaluation, so it is
the expression SymPy's diff gives (tests/codegen/test_generation_speedups.py compares them on the
catalogue and chains).  What SymEngine cannot take or give back exactly (an unevaluated
derivative: of abs or sign, say) is done by SymPy instead.
"""
from __future__ import annotations

import sympy as sp

import symengine as se


class Derivatives:
    """Partial derivatives of a fixed list of SymPy expressions, by SymEngine.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        The expressions, converted once.

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y", real=True)
    >>> d = Derivatives([x**2 * sp.sin(y)])
    >>> d.diff(0, y)
    x**2*cos(y)
    """

    def __init__(self, exprs):
        self.exprs = [sp.sympify(e) for e in exprs]
        symbols = sorted(set().union(*(e.free_symbols for e in self.exprs)), key=sp.default_sort_key)
        self._plain = {s: sp.Symbol(f"_se{k}") for k, s in enumerate(symbols)}
        self._back = {v: k for k, v in self._plain.items()}
        self._converted: dict[int, object] = {}

    def _engine(self, i: int):
        """Expression i in SymEngine, or None where SymEngine cannot take it."""
        if i not in self._converted:
            try:
                self._converted[i] = se.sympify(self.exprs[i].xreplace(self._plain))
            except (TypeError, ValueError, NotImplementedError, RuntimeError, AttributeError):
                self._converted[i] = None
        return self._converted[i]

    def diff(self, i: int, var: sp.Symbol) -> sp.Expr:
        """d exprs[i] / d var, as SymPy's ``exprs[i].diff(var)`` gives it."""
        e = self.exprs[i]
        if var not in e.free_symbols:
            return sp.S.Zero
        engine = self._engine(i)
        if engine is None or var not in self._plain:
            return e.diff(var)
        try:
            result = sp.sympify(engine.diff(se.Symbol(self._plain[var].name))).xreplace(self._back)
        except (TypeError, ValueError, NotImplementedError, RuntimeError, AttributeError, sp.SympifyError):
            return e.diff(var)
        if result.has(sp.Derivative, sp.Subs):     # left unevaluated (abs, sign): SymPy's own
            return e.diff(var)
        return result


class MatrixDerivatives:
    """dM/dz of a SymPy matrix, entry by entry by SymEngine (Derivatives), zero entries free.

    Parameters
    ----------
    M : sympy.Matrix
    """

    def __init__(self, M: sp.Matrix):
        self.shape = M.shape
        self._d = Derivatives(list(M))

    def diff(self, var: sp.Symbol) -> sp.Matrix:
        """dM/d var."""
        rows, cols = self.shape
        return sp.Matrix(rows, cols, [self._d.diff(i, var) for i in range(rows * cols)])

    def entry(self, i: int, j: int, var: sp.Symbol) -> sp.Expr:
        """d M[i, j] / d var."""
        return self._d.diff(i * self.shape[1] + j, var)
