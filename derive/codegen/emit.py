"""CSE, ordering and rendering: from kernel specs to text.

One ``sympy.cse`` pass (``order='canonical'``) runs over every stage, guard
and output of a file.  Each kernel then takes the temporaries it needs, in
dependency order, renumbered t0, t1, ... so that one kernel's code does not
depend on which other kernels share the file.  Integer powers of compound
expressions get their base as a temporary, so printers can write x*x.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import jinja2
import sympy as sp

from .spec import Kernel, ModelSpec

TEMPLATES = Path(__file__).resolve().parents[2] / "templates"


@dataclass
class Body:
    """One kernel after CSE: ordered assignments, then outputs and guards."""
    kernel: Kernel
    assignments: list[tuple[sp.Symbol, sp.Expr]]   # temporaries and stages, in order
    outputs: list[list[sp.Expr]]                    # per output, row-major
    guards: list[sp.Expr]
    ops: int
    unused_inputs: list[str]


def _numbered(prefix: str):
    i = 0
    while True:
        yield sp.Symbol(f"{prefix}{i}", real=True)
        i += 1


def _free_names(exprs) -> set[sp.Symbol]:
    out = set()
    for e in exprs:
        out |= sp.sympify(e).free_symbols
    return out


def _lift_powers(defs: dict, roots: list[sp.Expr], fresh) -> list[sp.Expr]:
    """Give every base of an integer power (|n| >= 2) that is no symbol its own temporary."""
    bases: dict[sp.Expr, sp.Symbol] = {}

    def lift(expr):
        if not isinstance(expr, sp.Basic) or expr.is_Atom:
            return expr
        args = [lift(a) for a in expr.args]
        if args != list(expr.args):
            expr = expr.func(*args)
        if expr.is_Pow and expr.exp.is_Integer and abs(int(expr.exp)) >= 2 and not expr.base.is_Symbol:
            if expr.base not in bases:
                bases[expr.base] = next(fresh)
                defs[bases[expr.base]] = expr.base
            return sp.Pow(bases[expr.base], expr.exp)
        return expr

    for sym in list(defs):
        defs[sym] = lift(defs[sym])
    return [lift(r) for r in roots]


def _alias_stages(defs: dict, reduced: list, stages: set):
    """A stage defined as a bare temporary takes over that temporary (no copies)."""
    alias = {}
    for sym in stages:
        target = defs[sym]
        if isinstance(target, sp.Symbol) and target.name.startswith("_cse") and target not in alias:
            alias[target] = sym
    if not alias:
        return defs, reduced
    out = {}
    for sym, expr in defs.items():
        if sym in stages and sym in alias.values() and defs[sym] in alias and alias[defs[sym]] == sym:
            continue                      # placed where its temporary was
        key = alias.get(sym, sym)
        out[key] = expr.xreplace(alias)
    return out, [sp.sympify(e).xreplace(alias) for e in reduced]


def cse_file(spec: ModelSpec) -> list[Body]:
    """One CSE pass over all outputs of the file, split back into kernels."""
    stage_defs: dict[sp.Symbol, sp.Expr] = {}
    for k in spec.kernels:
        for sym, expr in k.stages:
            stage_defs.setdefault(sym, expr)
    stage_syms = list(stage_defs)
    roots: list[sp.Expr] = [stage_defs[s] for s in stage_syms]
    spans = []
    for k in spec.kernels:
        start = len(roots)
        roots += list(k.guards)
        for out in k.outputs:
            roots += list(out.exprs)
        spans.append((start, len(roots)))

    fresh = _numbered("_cse")
    repl, reduced = sp.cse(roots, symbols=fresh, order="canonical")
    defs: dict[sp.Symbol, sp.Expr] = dict(repl)
    for sym, expr in zip(stage_syms, reduced):
        defs[sym] = expr
    defs, reduced = _alias_stages(defs, reduced, set(stage_syms))
    reduced = _lift_powers(defs, reduced, _numbered("_pow"))
    position = {sym: i for i, sym in enumerate(list(defs))}

    bodies = []
    for k, (start, end) in zip(spec.kernels, spans):
        mine = reduced[start:end]
        order: list[sp.Symbol] = []
        done: set[sp.Symbol] = set()

        def visit(sym):
            if sym in done:
                return
            done.add(sym)
            for dep in sorted(defs[sym].free_symbols & defs.keys(), key=position.__getitem__):
                visit(dep)
            order.append(sym)

        for expr in mine:
            for dep in sorted(sp.sympify(expr).free_symbols & defs.keys(), key=position.__getitem__):
                visit(dep)
        rename, n = {}, 0
        for sym in order:
            if sym.name.startswith("_"):
                rename[sym] = sp.Symbol(f"t{n}", real=True)
                n += 1
        assignments = [(rename.get(s, s), defs[s].xreplace(rename)) for s in order]
        mine = [sp.sympify(e).xreplace(rename) for e in mine]
        guards = mine[:len(k.guards)]
        outputs, i = [], len(k.guards)
        for out in k.outputs:
            outputs.append(mine[i:i + out.size])
            i += out.size
        ops = sum(sp.count_ops(e) for _, e in assignments) + sum(sp.count_ops(e) for e in mine)
        used = _free_names([e for _, e in assignments] + mine)
        unused = [inp.name for inp in k.inputs if not (set(inp.vector.symbols) & used)]
        bodies.append(Body(k, assignments, outputs, guards, int(ops), unused))
    return bodies


def environment() -> jinja2.Environment:
    return jinja2.Environment(loader=jinja2.FileSystemLoader(str(TEMPLATES)),
                              undefined=jinja2.StrictUndefined, trim_blocks=True,
                              lstrip_blocks=True, keep_trailing_newline=True,
                              autoescape=False)


def render(template: str, context: dict) -> str:
    return environment().get_template(template).render(**context)
