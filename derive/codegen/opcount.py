"""Operation counts of the generated code: sympy.count_ops's number, taken faster.

The kernels' docstrings and headers print "Total ops" per kernel, and the generator
weighs a model's size by it (sources.PARALLEL_OPS).  sympy.count_ops builds a symbolic
tally (NEG + 2*MUL + ...) and splits every product into numerator and denominator with
`fraction`, which rebuilds both as new products: a tenth of the CSE stage of a large
model.  `count_ops` here walks the same rules (SymPy 1.14's count_ops, visual=False) and
only counts: the same integer for every expression (tests/codegen/test_printers.py
compares the two on every kernel of the catalogue and the examples); a product whose
exponents are not all numbers, and every node kind it does not know, is counted by SymPy
itself.
"""
from __future__ import annotations

import sympy as sp
from sympy import S
from sympy.core.operations import LatticeOp


def count_ops(expr, memo: dict | None = None) -> int:
    """The number sympy.count_ops(expr) gives (each +, -, *, /, power and function call).

    Parameters
    ----------
    expr : sympy.Expr
        An expression of the kernels (numbers, symbols, sums, products, powers, functions).
    memo : dict, optional
        Counts of subexpressions met before (kept across calls by the caller).

    Returns
    -------
    int

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> count_ops(-x - y), sp.count_ops(-x - y)
    (2, 2)
    >>> count_ops(2 * sp.sin(x) / y ** 2 + 1) == sp.count_ops(2 * sp.sin(x) / y ** 2 + 1)
    True
    """
    memo = {} if memo is None else memo
    expr = sp.sympify(expr)
    if not isinstance(expr, sp.Expr) or expr.is_Relational:
        return int(sp.count_ops(expr))             # a relation, a tuple: SymPy's own rules
    return _count(expr, memo)


def _negative(a) -> bool:
    """SymPy's _coeff_isneg: the leading number is negative."""
    if a.is_Mul:
        a = a.args[0]
    return a.is_Number and bool(a.is_extended_negative)


def _count(a, memo: dict) -> int:
    known = memo.get(a)
    if known is None:
        known = memo[a] = _node(a, memo)
    return known


def _fraction(a):
    """sympy.fraction(a) for a product whose exponents are numbers; None otherwise."""
    terms = sp.Mul.make_args(a)
    if not any(t.is_Pow or (t.is_Rational and not t.is_Integer) or isinstance(t, sp.exp) for t in terms):
        return a, S.One                 # no denominator and nothing to check: `a` as it is
    numer, denom = [], []
    for term in terms:
        if term.is_Pow:
            b, ex = term.base, term.exp
            if not ex.is_Number or b is S.Exp1:
                return None
            if ex.is_extended_negative:
                denom.append(b if ex is S.NegativeOne else sp.Pow(b, -ex))
            else:
                numer.append(term)
        elif isinstance(term, sp.exp):
            return None
        elif term.is_Rational and not term.is_Integer:
            if term.p != 1:
                numer.append(sp.Integer(term.p))
            denom.append(sp.Integer(term.q))
        else:
            numer.append(term)
    return sp.Mul(*numer), sp.Mul(*denom)


def _node(a, memo: dict) -> int:
    """One node as count_ops's loop takes it off its stack (and what it pushes)."""
    if a.is_Symbol:
        return 0
    if a.is_Rational:
        if a is S.One:
            return 0
        return int(a.p < 0) + int(a.q != 1)
    if a.is_Add:
        negs = 0
        n = len(a.args) - 1                     # an ADD or a SUB between terms
        for t in a.args:
            if _negative(t):
                negs += 1
                n += _count(-t, memo)
            else:
                n += _count(t, memo)
        return n + int(negs == len(a.args))     # -x - y: a NEG too
    n = 0
    if a.is_Mul:
        whole = a
        if _negative(a):
            n += 1
            a = a.as_two_terms()[1] if a.args[0] is S.NegativeOne else -a
        parts = _fraction(a)
        if parts is None:
            return sp.count_ops(whole)
        num, den = parts
        if num.is_Integer:
            return n + 1 + int(num < 0) + _count(den, memo)
        if den is not S.One:
            return n + 1 + (0 if den.is_Integer else _count(den, memo)) + _count(num, memo)
        # no denominator: `a` (perhaps no product any more) goes on as any other node
    return n + _rest(a, memo)


def _rest(a, memo: dict) -> int:
    """count_ops's loop after its number, product and sum branches (which `a` left)."""
    if a.is_Pow and a.exp is S.NegativeOne:
        return 1 + _count(a.base, memo)
    if a == S.Exp1:
        return 1
    if a.is_Pow and a.base == S.Exp1:
        return 1 + _count(a.exp, memo)
    n = 0
    if a.is_Mul or isinstance(a, LatticeOp):
        n += len(a.args) - 1
    elif a.args and (a.is_Pow or a.is_Function or isinstance(a, (sp.Derivative, sp.Integral, sp.Sum))):
        n += 1
    if not a.is_Symbol:
        n += sum(_count(x, memo) for x in a.args)
    return n
