"""SymEngine, SymPy's C++ core, for the heavy algebra of the derivation and code generation.

The expressions stay SymPy's everywhere (the printers, the cache, the checks are SymPy's);
only the operations that dominate the cost of a large model are done in SymEngine and the
result brought back:

* partial derivatives (`Derivatives`): the Christoffel form's dM/dq, the Jacobian
  kernel's dF/dy and dM/dy.  SymEngine differentiates a 12-link chain's forcing about a
  hundred times faster than SymPy.
* expanded products (`by_engine`): T = 1/2 q'^T M q' and the Christoffel form of F,
  summed, differentiated and expanded in SymEngine (derivation/lagrange.py);
* common subexpressions (`engine_cse`): the one CSE pass over a generated file's kernels
  (codegen/emit.py).  On a 12-link chain's 1560 roots SymEngine's cse takes 0.07 s where
  ``sympy.cse`` takes 0.75 s, and leaves fewer operations (10823 against 11919); the
  round trip, by the converters below, costs less than a tenth of a second more.

The result is SymPy's own: each symbol is renamed to a plain one on the way in (SymEngine
keeps no assumptions, and a Dummy would come back as another Dummy) and renamed back on
the way out, which rebuilds the expression with SymPy's automatic evaluation, so it is
the expression SymPy's diff gives (tests/codegen/test_generation_speedups.py compares them on the
catalogue and chains).  What SymEngine cannot take or give back exactly (an unevaluated
derivative: of abs or sign, say) is done by SymPy instead.

The converters of `EngineNames` go node by node with a memo (the roots of a file share most
of their nodes), to and from the node types listed in `_FUNCTIONS`; an expression with any
other node (abs, sign, Piecewise, a Float of other than double precision, a user's
function) leaves that work to SymPy: the CSE pass to ``sympy.cse``, a `by_engine` formula
and the Jacobian's sums to SymPy's arithmetic.
"""
from __future__ import annotations

import sympy as sp
from sympy.core.basic import _args_sortkey

import symengine as se
from symengine.lib import symengine_wrapper as _wrapper


class EngineNames:
    """One namespace between SymPy and SymEngine, with the converters' memos.

    Each SymPy symbol goes in as a plain SymEngine one, `_se000000`, `_se000001`, ... (SymEngine keeps
    no assumptions, and two symbols of one name, a real theta and a plain one or a Dummy,
    would become one), and comes back as itself.  The converters take the node types of
    `_FUNCTIONS` and raise `EngineUnsupported` at any other.

    Examples
    --------
    >>> import sympy as sp
    >>> x = sp.Symbol("x", real=True)
    >>> names = EngineNames()
    >>> (e,) = names.engine([sp.sin(x)**2])
    >>> e, names.sympy([e.diff(names.forward[x])])
    (sin(_se000000)**2, [2*sin(x)*cos(x)])
    """

    def __init__(self):
        self.back: dict = {}
        self.forward = _PlainNames(self.back)
        self._to: dict = {}
        self._from: dict = {}

    def engine(self, exprs) -> list:
        """The SymPy expressions `exprs` as SymEngine's."""
        return _to_engine(exprs, self.forward, self._to)

    def sympy(self, exprs) -> list:
        """SymEngine expressions of this namespace as SymPy's (SymPy's automatic evaluation)."""
        return _from_engine(exprs, self.back, self._from)

    @property
    def nodes(self) -> dict:
        """Every SymPy node converted so far -> its SymEngine node, in post-order (a node
        after its arguments, the arguments in SymPy's order)."""
        return self._to

    def declare(self, symbols) -> None:
        """Name `symbols` in this order (those not named yet)."""
        for symbol in symbols:
            self.forward[symbol]        # noqa: B018 (a new name on first use: _PlainNames)

    def plain(self, symbol: sp.Symbol) -> sp.Symbol:
        """The plain SymPy symbol of the name `symbol` goes by in SymEngine."""
        return sp.Symbol(self.forward[symbol].name)


class _PlainNames(dict):
    """SymPy symbol -> SymEngine symbol, a new plain name on first use (and its way back)."""

    def __init__(self, back: dict):
        super().__init__()
        self._back = back

    def __missing__(self, symbol):
        plain = self[symbol] = se.Symbol(f"_se{len(self):06d}")     # SymEngine orders by name
        self._back[plain] = symbol
        return plain


class EngineUnsupported(Exception):
    """A node the converters do not take: the caller falls back to SymPy."""


class Derivatives:
    """Partial derivatives of a fixed list of SymPy expressions, by SymEngine.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        The expressions, converted once.
    names : EngineNames, optional
        The namespace to convert them in (shared with other expressions whose derivatives
        are combined in SymEngine: `engine_diff`).

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y", real=True)
    >>> d = Derivatives([x**2 * sp.sin(y)])
    >>> d.diff(0, y)
    x**2*cos(y)
    """

    def __init__(self, exprs, names: EngineNames | None = None):
        self.exprs = [sp.sympify(e) for e in exprs]
        self.names = names if names is not None else EngineNames()
        self._converted: dict[int, object] = {}
        self._general: set[int] = set()       # converted by se.sympify: outside EngineNames' node types

    def _engine(self, i: int):
        """Expression i in SymEngine, or None where SymEngine cannot take it."""
        if i not in self._converted:
            e = self.exprs[i]
            try:
                self._converted[i] = self.names.engine([e])[0]
            except (EngineUnsupported, RecursionError):
                try:            # an abs, a user's function: SymEngine's own conversion, plain names
                    self._converted[i] = se.sympify(e.xreplace({s: self.names.plain(s) for s in e.free_symbols}))
                    self._general.add(i)
                except (TypeError, ValueError, NotImplementedError, RuntimeError, AttributeError):
                    self._converted[i] = None
        return self._converted[i]

    def diff(self, i: int, var: sp.Symbol) -> sp.Expr:
        """d exprs[i] / d var, as SymPy's ``exprs[i].diff(var)`` gives it, where it exists:
        sign's derivative (SymPy's 2*DiracDelta) is zero off its jump (`almost_everywhere`)."""
        return almost_everywhere(self._diff(i, var))

    def _diff(self, i: int, var: sp.Symbol) -> sp.Expr:
        e = self.exprs[i]
        if var not in e.free_symbols:
            return sp.S.Zero
        engine = self._engine(i)
        if engine is None:
            return e.diff(var)
        try:
            d = engine.diff(self.names.forward[var])
            if i not in self._general:
                return self.names.sympy([d])[0]
            back = {self.names.plain(s): s for s in e.free_symbols}
            result = sp.sympify(d).xreplace(back)
        except (EngineUnsupported, RecursionError, TypeError, ValueError, NotImplementedError,
                RuntimeError, AttributeError, sp.SympifyError):
            return e.diff(var)
        if result.has(sp.Derivative, sp.Subs):     # left unevaluated (abs, sign): SymPy's own
            return e.diff(var)
        return result

    def engine_diff(self, i: int, var: sp.Symbol):
        """d exprs[i] / d var in SymEngine, in `names`; every expression must be of the
        node types EngineNames converts (`EngineNames.engine` of them all succeeds)."""
        if var not in self.exprs[i].free_symbols:
            return se.Integer(0)
        return self._engine(i).diff(self.names.forward[var])


def almost_everywhere(expr: sp.Expr) -> sp.Expr:
    """`expr` with every DiracDelta taken as zero: a derivative where it exists.

    A model's force may hold sign (Coulomb friction, -mu*sign(theta1_dot)); its derivative
    is zero everywhere but at the jump, where it has none, and SymPy writes it 2*DiracDelta,
    which no language prints.  The Jacobian and linearisation kernels take it as zero, the
    derivative almost everywhere (a Newton iteration or a linearisation at the jump itself
    sees the friction as constant).

    Examples
    --------
    >>> import sympy as sp
    >>> v = sp.Symbol("v", real=True)
    >>> almost_everywhere(sp.diff(-3*sp.sign(v) - v**2, v))
    -2*v
    """
    if not expr.has(sp.DiracDelta):
        return expr
    return expr.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.S.Zero)


class MatrixDerivatives:
    """dM/dz of a SymPy matrix, entry by entry by SymEngine (Derivatives), zero entries free.

    Parameters
    ----------
    M : sympy.Matrix
    names : EngineNames, optional
        As for Derivatives.
    """

    def __init__(self, M: sp.Matrix, names: EngineNames | None = None):
        self.shape = M.shape
        self._d = Derivatives(list(M), names)

    def diff(self, var: sp.Symbol) -> sp.Matrix:
        """dM/d var."""
        rows, cols = self.shape
        return sp.Matrix(rows, cols, [self._d.diff(i, var) for i in range(rows * cols)])

    def entry(self, i: int, j: int, var: sp.Symbol) -> sp.Expr:
        """d M[i, j] / d var."""
        return self._d.diff(i * self.shape[1] + j, var)

    def engine_entry(self, i: int, j: int, var: sp.Symbol):
        """d M[i, j] / d var in SymEngine (Derivatives.engine_diff)."""
        return self._d.engine_diff(i * self.shape[1] + j, var)


# SymPy's functions and SymEngine's, for the CSE's converters: the ones a model's kernels hold
_FUNCTIONS = {sp.sin: se.sin, sp.cos: se.cos, sp.tan: se.tan, sp.exp: se.exp, sp.log: se.log,
              sp.sinh: se.sinh, sp.cosh: se.cosh, sp.tanh: se.tanh,
              sp.asin: se.asin, sp.acos: se.acos, sp.atan: se.atan, sp.atan2: se.atan2}
_FROM_ENGINE = {type(engine(*[se.Symbol(f"z{i}") for i in range(2 if mine is sp.atan2 else 1)])): mine
                for mine, engine in _FUNCTIONS.items()}


def _to_engine(roots, symbols: dict, memo: dict) -> list:
    """SymPy expressions as SymEngine's, each distinct node converted once (`memo`, filled
    in post-order: a node after its arguments, the arguments in SymPy's order)."""
    add, mul, power = se.Add, se.Mul, se.Pow

    def convert(e):
        found = memo.get(e)
        if found is not None:
            return found
        if e.is_Symbol:
            found = symbols[e]
        elif e.is_Add:
            found = add(*[convert(a) for a in e.args])
        elif e.is_Mul:
            found = mul(*[convert(a) for a in e.args])
        elif e.is_Pow:
            found = power(convert(e.base), convert(e.exp))
        elif e.is_Integer:
            found = se.Integer(e.p)
        elif e.is_Rational:
            found = se.Rational(e.p, e.q)
        elif e.is_Float and e._prec == 53:          # a double: SymEngine's RealDouble is exact
            found = se.RealDouble(float(e))
        elif type(e) in _FUNCTIONS:
            found = _FUNCTIONS[type(e)](*[convert(a) for a in e.args])
        else:
            raise EngineUnsupported(type(e).__name__)
        memo[e] = found
        return found

    return [convert(r) for r in roots]


def _from_engine(exprs, symbols: dict, memo: dict, evaluate: bool = False) -> list[sp.Expr]:
    """SymEngine expressions as SymPy's, each distinct node converted once (`memo`);
    `symbols` maps SymEngine's symbols to SymPy's.

    Each node is the one SymPy's automatic evaluation makes of it (`evaluate` builds every
    one so, as the tests do to compare).  A sum or product whose terms came back as they
    went (a sum no sum, a product no product, one number at most, no coefficient to
    spread over a sum) is SymEngine's flat canonical form already: its terms sorted as
    SymPy sorts them (``_args_sortkey``) are what evaluation gives, without its cost, the
    largest part of the round trip."""
    w = _wrapper

    def convert(e):
        found = memo.get(e)
        if found is not None:
            return found
        kind = type(e)
        if kind is w.Add:
            args = [convert(a) for a in e.args]
            found = sp.Add._from_args(sorted(args, key=_args_sortkey)) if not evaluate and _flat(args, "is_Add") \
                else sp.Add(*args)
        elif kind is w.Mul:
            args = [convert(a) for a in e.args]
            found = sp.Mul._from_args(sorted(args, key=_args_sortkey)) if not evaluate and _flat(args, "is_Mul") \
                and not (len(args) == 2 and any(a.is_Add for a in args)) else sp.Mul(*args)
        elif kind is w.Pow:
            base, exp = e.args
            found = sp.Pow(convert(base), convert(exp))
        elif kind is w.Symbol:
            found = symbols[e]
        elif kind in _FROM_ENGINE:
            found = _FROM_ENGINE[kind](*[convert(a) for a in e.args])
        elif e.is_Number and kind is not w.RealMPFR:
            found = e._sympy_()
        else:
            raise EngineUnsupported(kind.__name__)
        memo[e] = found
        return found

    return [convert(e) for e in exprs]


def _flat(args: list, nested: str) -> bool:
    """No term that evaluation would merge: none of the node's own kind (`nested`), one
    number at most, no constant (sqrt(2), pi) and no exp (products of them combine)."""
    numbers = 0
    for a in args:
        if getattr(a, nested) or isinstance(a, sp.exp):
            return False
        if a.is_number:
            if not a.is_Number:
                return False
            numbers += 1
    return numbers <= 1


def by_engine(compute, *groups) -> list[sp.Expr]:
    """compute(expand, *groups) in SymEngine, its results brought back to SymPy.

    `compute` writes a formula once for either algebra: it takes an expand function and
    lists of expressions (symbols too) and returns a list of expressions, using only
    arithmetic, ``.diff`` and `expand`.  Each group (a list of SymPy expressions) is
    converted in one namespace; where the converters do not take an expression, the
    formula runs on the SymPy expressions with ``sympy.expand`` instead.

    Parameters
    ----------
    compute : callable
    *groups : sequences of sympy.Expr

    Returns
    -------
    list of sympy.Expr

    Examples
    --------
    >>> import sympy as sp
    >>> a, b = sp.symbols("a b", real=True)
    >>> by_engine(lambda expand, xs: [expand((xs[0] + xs[1])**2).diff(xs[0])], [a, b])
    [2*a + 2*b]
    """
    names = EngineNames()
    try:
        converted = [names.engine([sp.sympify(e) for e in g]) for g in groups]
        return names.sympy(compute(se.expand, *converted))
    except (EngineUnsupported, RecursionError, RuntimeError):
        return list(compute(sp.expand, *[[sp.sympify(e) for e in g] for g in groups]))


def engine_cse(roots, symbols) -> tuple[list[tuple[sp.Symbol, sp.Expr]], list[sp.Expr]] | None:
    """``sympy.cse(roots, symbols)``'s replacements and reduced expressions, by SymEngine.

    Parameters
    ----------
    roots : sequence of sympy.Expr
    symbols : iterator of sympy.Symbol
        The names of the replacements, taken in order.

    Returns
    -------
    (replacements, reduced) or None
        Each replacement uses only the ones before it; None where a root holds a node
        SymEngine's converters do not take (the caller runs ``sympy.cse``).

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y", real=True)
    >>> t = (sp.Symbol(f"t{i}") for i in range(9))
    >>> engine_cse([sp.sin(x + y)**2, sp.cos(x + y)*sp.sin(x + y)], t)
    ([(t0, x + y), (t1, sin(t0))], [t1**2, t1*cos(t0)])
    """
    roots = [sp.sympify(r) for r in roots]
    names = EngineNames()
    # named in SymPy's order of symbols: SymEngine picks the sign of an odd function's
    # argument by the names (sin(phi1 - phi2), as SymPy writes it, not -sin(phi2 - phi1))
    names.declare(sorted(set().union(*(r.free_symbols for r in roots)), key=sp.default_sort_key))
    try:
        replacements, reduced = se.cse(names.engine(roots))
        replacements = _reading_order(replacements, names.nodes)
        for temporary, _ in replacements:
            names.back[temporary] = next(symbols)
        converted = names.sympy([e for _, e in replacements] + list(reduced))
    except (EngineUnsupported, RecursionError, TypeError, ValueError, NotImplementedError, RuntimeError):
        return None
    cut = len(replacements)
    return [(names.back[t], e) for (t, _), e in zip(replacements, converted[:cut])], converted[cut:]


def _reading_order(replacements: list, memo: dict) -> list:
    """SymEngine's replacements in the order a reader meets them in the roots.

    SymEngine orders them by its hashes (sin(theta2) could come before sin(theta1)); here
    each goes where the subexpression it stands for first appears in the roots walked in
    SymPy's order (`memo`'s post-order), after the replacements it uses."""
    position: dict = {}
    for i, node in enumerate(memo.values()):
        position.setdefault(node, i)
    temporaries = {t: d for t, d in replacements}
    expanded: dict = {}
    key: dict = {}
    for i, (t, d) in enumerate(replacements):          # each uses only those before it
        inner = {s: expanded[s] for s in d.free_symbols if s in expanded}
        expanded[t] = d.xreplace(inner) if inner else d
        key[t] = (position.get(expanded[t], len(position)), i)
    placed: dict = {}

    def place(t):
        if t in placed:
            return
        for dep in sorted((s for s in temporaries[t].free_symbols if s in temporaries), key=key.__getitem__):
            place(dep)
        placed[t] = temporaries[t]

    for t in sorted(temporaries, key=key.__getitem__):
        place(t)
    return list(placed.items())
