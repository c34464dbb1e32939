"""The catalogue's reductions derived: when a cheaper model represents a scene exactly.

A reduction of kind "parameters" (derive/model/catalog/reductions.toml) matches the source's
Lagrangian against the target's with the target's parameters as unknowns (its coordinates
renamed to the source's, in order), coefficient by coefficient in the rates and the sines
and cosines of the coordinates, and solves for those unknowns and the source parameters
the reduction may fix.  One solution is the reduction: the target's parameters as
functions of the source's, and the condition (the fixed source parameters' values).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import sympy as sp

from ..errors import ModelError
from ..model.reductions import Reduction
from .derivation import derive


@dataclass(frozen=True)
class ParameterMatch:
    solutions: tuple            # every solution of the coefficient match (dicts Symbol -> expr)
    source_lagrangian: sp.Expr
    target_lagrangian: sp.Expr  # in the source's coordinates, the target's parameters as stand-ins
    stand_ins: dict             # target parameter name -> its stand-in symbol


@cache
def parameter_match(r: Reduction) -> ParameterMatch:
    """The coefficient match of a "parameters" reduction (module docstring)."""
    s, t = derive(r.source), derive(r.target)
    source_params = {x.name: x for x in s.symbols.params}
    stand_ins = {name: sp.Symbol(symbol, positive=True) for name, symbol in r.unknowns}
    loose = [x.name for x in t.symbols.params if x.name not in stand_ins and x.name not in r.same]
    if loose or not set(r.same) <= set(source_params):
        raise ModelError(f"reduction {r.source} -> {r.target}: every target parameter is an unknown or "
                         f"the same as the source's (not {', '.join(loose) or ', '.join(r.same)})")
    replace = {x: stand_ins[x.name] if x.name in stand_ins else source_params[x.name]
               for x in t.symbols.params}
    rename = dict(zip(t.symbols.state, s.symbols.state))
    target_l = sp.expand(t.L.xreplace(replace).xreplace(rename))
    diff = sp.expand(sp.expand_trig(sp.expand(s.L) - target_l))
    trig = [f(q) for q in s.symbols.q for f in (sp.sin, sp.cos)]
    terms = sp.Poly(diff, *s.symbols.qd, *trig).coeffs()
    unknowns = [*stand_ins.values()] + [source_params[n] for n in r.solve_for]
    solutions = sp.solve(terms, unknowns, dict=True)
    return ParameterMatch(tuple(solutions), s.L, target_l, stand_ins)


@dataclass(frozen=True)
class ParameterMap:
    """A solved "parameters" reduction: target parameters and the condition, as expressions
    in the source's parameters."""
    reduction: Reduction
    target: dict                # target parameter name -> expression
    condition: dict             # source parameter name -> the value it must have
    changed: tuple              # the target parameters not simply the source's of that name


@cache
def parameter_map(r: Reduction) -> ParameterMap | None:
    """The reduction's map, or None when the match has no single solution."""
    match = parameter_match(r)
    if len(match.solutions) != 1:
        return None
    sol = match.solutions[0]
    s = derive(r.source)
    source_params = {x.name: x for x in s.symbols.params}
    target = {}
    for x in derive(r.target).symbols.params:
        target[x.name] = sol[match.stand_ins[x.name]] if x.name in match.stand_ins else source_params[x.name]
    changed = tuple(n for n, e in target.items() if not (n in source_params and e == source_params[n]))
    condition = {n: sol[source_params[n]] for n in r.solve_for}
    return ParameterMap(r, target, condition, changed)
