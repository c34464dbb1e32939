"""The plain SymPy symbols of a model: coordinates, rates, momenta, parameters.

Everything is derived with plain Symbols (never ``q(t)``), so nothing has to be
substituted before printing or lambdifying.  The time derivative is applied by
the chain rule with the rates as explicit symbols (see lagrange.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import sympy as sp

from .. import cachefile
from ..model import Model
from ..model.description import TIME
from ..model.expressions import parse_expression

# The time: a plain symbol like the others, so a time-dependent model's equations
# M q'' = F(q, q', p, u, t) print and lambdify as a time-independent model's do.
t = sp.Symbol(TIME, real=True)


@cachefile.register
@dataclass(frozen=True)
class ModelSymbols:
    q: tuple[sp.Symbol, ...]        # generalized coordinates
    qd: tuple[sp.Symbol, ...]       # their rates
    p: tuple[sp.Symbol, ...]        # canonical momenta (Hamiltonian form)
    params: tuple[sp.Symbol, ...]   # in the model's parameter order
    u: tuple[sp.Symbol, ...] = ()   # run-time inputs, in the model's input order

    def param(self, name: str) -> sp.Symbol:
        return next(s for s in self.params if s.name == name)

    @property
    def state(self) -> tuple[sp.Symbol, ...]:
        return self.q + self.qd

    @property
    def hamiltonian_state(self) -> tuple[sp.Symbol, ...]:
        return self.q + self.p


def model_symbols(model: Model) -> ModelSymbols:
    q = tuple(sp.Symbol(n, real=True) for n in model.coordinate_names)
    qd = tuple(sp.Symbol(n, real=True) for n in model.rate_names)
    p = tuple(sp.Symbol(f"p_{n}", real=True) for n in model.coordinate_names)
    # g may be zero or negative (gravity along +z, or none); every other parameter is
    # declared positive, which lets the derivation simplify sqrt(l**2) and the like
    params = tuple(sp.Symbol(n, real=True) if n == "g" else sp.Symbol(n, positive=True)
                   for n in model.parameters)
    u = tuple(sp.Symbol(n, real=True) for n in model.inputs)
    return ModelSymbols(q, qd, p, params, u)


def names(symbols: ModelSymbols) -> dict[str, sp.Symbol]:
    """Every name a model's expressions may use: parameters, inputs, coordinates, rates, the time."""
    return {s.name: s for s in (*symbols.params, *symbols.u, *symbols.q, *symbols.qd, t)}


def motion_names(symbols: ModelSymbols) -> dict[str, sp.Symbol]:
    """The names a prescribed motion (the pivot's) may use: parameters and the time."""
    return {s.name: s for s in (*symbols.params, t)}


def parse_quantity(text: str, symbols: ModelSymbols) -> sp.Expr:
    """A length, mass, inertia or fraction from a description: a parameter or a number."""
    return parse_expression(text, {s.name: s for s in symbols.params}, "model quantity")


_PER_SHAPE: dict = {}       # (simplification, an expression's shape) -> the simplified shape


def per_shape(simplify: Callable[[sp.Expr], sp.Expr], x: sp.Expr) -> sp.Expr:
    """``simplify(x)``, computed once per shape of `x` in this process.

    A shape is `x` with its symbols renamed in the order of their names (names that sort
    as theirs, the same assumptions), so it prints, sorts and simplifies as `x` does, and
    the result renamed back is what ``simplify(x)`` gives.  The derivation's trigsimp
    calls (its largest cost) meet the same few shapes again and again: a chain's Gram
    entries in other angles, the seed's two links' blocks, a chart change's two links.

    Parameters
    ----------
    simplify : callable
        A deterministic SymPy simplification (sympy.trigsimp, say).
    x : sympy.Expr

    Returns
    -------
    sympy.Expr
    """
    x = sp.sympify(x)
    symbols = sorted(x.free_symbols, key=lambda s: s.name)
    shape = [sp.Symbol(f"_gram{k:04d}", **s.assumptions0) for k, s in enumerate(symbols)]
    key = (simplify, x.xreplace(dict(zip(symbols, shape))))
    if key not in _PER_SHAPE:
        _PER_SHAPE[key] = simplify(key[1])
    return _PER_SHAPE[key].xreplace(dict(zip(shape, symbols)))
