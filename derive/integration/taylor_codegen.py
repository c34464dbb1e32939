"""The generated Taylor integrator: the rhs decomposed into elementary operations, and the
Taylor-coefficient recurrence of each, emitted per model as standalone C99.

Taylor's method (as heyoka does it, Jorba & Zou 2005) advances y' = f(y) by the
truncated series y(t + h) = sum_k y^[k] h^k, where y^[k] = y^(k)(t)/k!.  The
coefficients come from automatic differentiation of f along the solution: f is a
sequence of elementary operations u = a op b (the kernel's CSE graph, each temporary a
node), and each has a recurrence giving its k-th coefficient from the lower ones of its
arguments (normalised derivatives; a_j, b_j the arguments' coefficients):

    u = a +- b      u_k = a_k +- b_k
    u = c a         u_k = c a_k                       (c: a parameter expression)
    u = a b         u_k = sum_{j=0..k} a_j b_{k-j}
    u = a / b       u_k = (a_k - sum_{j=1..k} b_j u_{k-j}) / b_0
    u = sqrt(a)     u_k = (a_k - sum_{j=1..k-1} u_j u_{k-j}) / (2 u_0)
    s = sin a, c = cos a (one pair)
                    s_k =  (1/k) sum_{j=1..k} j a_j c_{k-j}
                    c_k = -(1/k) sum_{j=1..k} j a_j s_{k-j}
    u = exp(a)      u_k = (1/k) sum_{j=1..k} j a_j u_{k-j}

and y^[k+1] = f^[k] / (k + 1).  Subexpressions free of the state (parameters, inputs,
numbers) are constants of the step, computed once (printed by the C printer); only
the others carry coefficient arrays.  Integer powers are products (squares, then
repeated multiplication), negative powers divisions, half-integer powers square roots.

Order and step from the tolerance (Jorba & Zou 2005, section 3.2, as heyoka):
order p = ceil(-ln(tol)/2 + 1); with m = max(1, |y|_inf) (absolute below 1, relative
above), rho_j = (m / |y^[j]|_inf)^(1/j) for j = p-1, p, and h = min(rho_{p-1}, rho_p)
/ e^2 * exp(-0.7/(p-1)).  The series is the dense output: every output time inside a
step is the polynomial evaluated there (Horner), to the tolerance of the step.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from functools import lru_cache

import sympy as sp

from ..codegen.printers import CPrinter
from ..errors import SpecError
from ..model.description import forget_on_model_change

ORDER_MAX = 60       # largest order compiled in (tol 1e-34 for quad needs 41; double <= 20)


@dataclass
class Op:
    kind: str                 # var, add, sub, scale, shift, mul, div, inv, sqrt, sin, cos, exp, square
    args: tuple = ()          # node indices (jets) or, for scale/shift, (node, constant index)
    index: int = -1           # var: the state slot


@dataclass
class Decomposition:
    n: int                              # states
    ops: list[Op] = field(default_factory=list)
    constants: list[sp.Expr] = field(default_factory=list)     # state-free values, once per step
    outputs: list[tuple[str, int]] = field(default_factory=list)   # per state: ("node", i) | ("const", c)
    guards: list[int] = field(default_factory=list)            # nodes whose |value| must stay >= sine_min


class _Builder:
    def __init__(self, state: tuple[sp.Symbol, ...], defs: dict):
        self.state = {s: i for i, s in enumerate(state)}
        self.defs = defs                  # temporary symbol -> expression
        self.d = Decomposition(n=len(state))
        self.memo: dict = {}              # expression -> ("node", i) | ("const", c)
        self.const_memo: dict = {}
        self.trig: dict = {}              # argument node -> (sin node, cos node)
        for s, i in self.state.items():
            self.memo[s] = ("node", self._op(Op("var", (), i)))

    def _op(self, op: Op) -> int:
        self.d.ops.append(op)
        return len(self.d.ops) - 1

    def _const(self, expr: sp.Expr) -> tuple[str, int]:
        if expr not in self.const_memo:
            self.d.constants.append(expr)
            self.const_memo[expr] = len(self.d.constants) - 1
        return ("const", self.const_memo[expr])

    def _depends(self, expr) -> bool:
        return any(s in self.state or (s in self.defs and self._depends(self.defs[s]))
                   for s in expr.free_symbols)

    def _const_value(self, expr):
        """A state-free expression with temporaries substituted (printed once per step)."""
        subs = {s: self._const_value(self.defs[s]) for s in expr.free_symbols if s in self.defs}
        return expr.xreplace(subs) if subs else expr

    def node(self, expr) -> tuple[str, int]:
        expr = sp.sympify(expr)
        if expr in self.memo:
            return self.memo[expr]
        if not self._depends(expr):
            out = self._const(self._const_value(expr))
        elif expr.is_Symbol:
            out = self.node(self.defs[expr])
        elif expr.is_Add:
            out = self._add(expr.args)
        elif expr.is_Mul:
            out = self._mul(expr.args)
        elif expr.is_Pow:
            out = self._pow(expr.base, expr.exp)
        elif isinstance(expr, (sp.sin, sp.cos)):
            s, c = self._sincos(expr.args[0])
            out = ("node", s if isinstance(expr, sp.sin) else c)
        elif isinstance(expr, sp.exp):
            out = ("node", self._op(Op("exp", (self._jet(expr.args[0]),))))
        else:
            raise SpecError(f"the Taylor integrator has no recurrence for {type(expr).__name__} (in {expr})")
        self.memo[expr] = out
        return out

    def _jet(self, expr) -> int:
        kind, i = self.node(expr)
        if kind == "const":            # a jet whose only coefficient is the constant
            return self._op(Op("shift", (None, i)))
        return i

    def _add(self, args) -> tuple[str, int]:
        consts = [a for a in args if not self._depends(a)]
        jets = [a for a in args if self._depends(a)]
        # negative terms as subtractions: a - b rather than a + (-1) b
        pos = [a for a in jets if not _negated(a)]
        neg = [-a for a in jets if _negated(a)]
        if pos:
            acc = self.node(pos[0])[1]
            for a in pos[1:]:
                acc = self._op(Op("add", (acc, self.node(a)[1])))
            for a in neg:
                acc = self._op(Op("sub", (acc, self.node(a)[1])))
        else:
            acc = self._op(Op("scale", (self.node(neg[0])[1], self._const(sp.Integer(-1))[1])))
            for a in neg[1:]:
                acc = self._op(Op("sub", (acc, self.node(a)[1])))
        if consts:
            acc = self._op(Op("shift", (acc, self._const(self._const_value(sp.Add(*consts)))[1])))
        return ("node", acc)

    def _mul(self, args) -> tuple[str, int]:
        consts = [a for a in args if not self._depends(a)]
        jets = [a for a in args if self._depends(a)]
        num = [a for a in jets if not (a.is_Pow and a.exp.is_negative)]
        den = [1 / a for a in jets if a.is_Pow and a.exp.is_negative]
        acc = None
        for a in num:
            i = self.node(a)[1]
            acc = i if acc is None else self._op(Op("mul", (acc, i)))
        if den:
            d = None
            for a in den:
                i = self.node(a)[1]
                d = i if d is None else self._op(Op("mul", (d, i)))
            acc = self._op(Op("inv", (d,))) if acc is None else self._op(Op("div", (acc, d)))
        if consts:
            acc = self._op(Op("scale", (acc, self._const(self._const_value(sp.Mul(*consts)))[1])))
        return ("node", acc)

    def _pow(self, base, e) -> tuple[str, int]:
        b = self._jet(base)
        if e.is_Integer:
            k = int(e)
            if k == 0:
                return self._const(sp.Integer(1))
            acc = self._power(b, abs(k))
            return ("node", acc if k > 0 else self._op(Op("inv", (acc,))))
        if e.is_Rational and e.q == 2:
            r = self._op(Op("sqrt", (b,)))
            k = int(e.p)
            acc = self._power(r, abs(k))
            return ("node", acc if k > 0 else self._op(Op("inv", (acc,))))
        raise SpecError(f"the Taylor integrator has no recurrence for the power {base}**{e}")

    def _power(self, b: int, k: int) -> int:
        """b**k by squaring (k >= 1)."""
        result, square = None, b
        while k:
            if k & 1:
                result = square if result is None else self._op(Op("mul", (result, square)))
            k >>= 1
            if k:
                square = self._op(Op("square", (square,)))
        return result

    def _sincos(self, arg) -> tuple[int, int]:
        a = self._jet(arg)
        if a not in self.trig:
            s = self._op(Op("sin", (a,)))
            c = self._op(Op("cos", (a,)))
            self.d.ops[s].args = (a, c)       # each needs the other's coefficients
            self.d.ops[c].args = (a, s)
            self.trig[a] = (s, c)
        return self.trig[a]


def _negated(expr) -> bool:
    return expr.is_Mul and expr.args[0].is_Number and expr.args[0] < 0


def decompose(rhs_body, state: tuple[sp.Symbol, ...]) -> Decomposition:
    """The elementary operations of a model's CSE'd rhs kernel (derive/codegen/emit.Body)."""
    defs = dict(rhs_body.assignments)
    b = _Builder(state, defs)
    for expr in rhs_body.outputs[0]:
        b.d.outputs.append(b.node(expr))
    for g in rhs_body.guards:
        b.d.guards.append(b._jet(g))
    return b.d


# -- C: the statements of the jet ------------------------------------------------------

def c_statements(d: Decomposition, ctype: str, slots: dict) -> dict:
    """The C the template lays out: the constants (once per step) and one statement per
    operation computing its coefficient k (J[i][k]; C[c] the constants)."""
    pr = CPrinter(slots, ctype)
    consts = [pr.doprint_checked(c) for c in d.constants]
    def ref(i):                  # a state's coefficients are X[i] itself (no copy)
        op = d.ops[i]
        return f"X[{op.index}]" if op.kind == "var" else f"J[{i}]"

    lines = []
    for i, op in enumerate(d.ops):
        nodes = op.args[:1] if op.kind in ("scale", "shift") else op.args    # then a constant index
        a = [None if x is None else ref(x) for x in nodes] + list(op.args[len(nodes):])
        u = ref(i)
        if op.kind == "var":
            continue
        elif op.kind == "add":
            lines.append(f"{u}[k] = {a[0]}[k] + {a[1]}[k];")
        elif op.kind == "sub":
            lines.append(f"{u}[k] = {a[0]}[k] - {a[1]}[k];")
        elif op.kind == "scale":
            lines.append(f"{u}[k] = C[{a[1]}] * {a[0]}[k];")
        elif op.kind == "shift":
            base = "0" if a[0] is None else f"{a[0]}[k]"
            lines.append(f"{u}[k] = {base} + (k == 0 ? C[{a[1]}] : (R)0);")
        elif op.kind == "mul":
            lines.append(f"{u}[k] = TAYLOR_MUL({a[0]}, {a[1]}, k);")
        elif op.kind == "square":
            lines.append(f"{u}[k] = TAYLOR_MUL({a[0]}, {a[0]}, k);")
        elif op.kind == "div":
            lines.append(f"{u}[k] = TAYLOR_DIV({a[0]}[k], {a[1]}, {u}, k);")
        elif op.kind == "inv":
            lines.append(f"{u}[k] = TAYLOR_DIV((R)(k == 0), {a[0]}, {u}, k);")
        elif op.kind == "sqrt":
            lines.append(f"{u}[k] = TAYLOR_SQRT({a[0]}, {u}, k);")
        elif op.kind == "sin":
            lines.append(f"{u}[k] = k == 0 ? SIN({a[0]}[0]) : TAYLOR_SIN({a[0]}, {a[1]}, k);")
        elif op.kind == "cos":
            lines.append(f"{u}[k] = k == 0 ? COS({a[0]}[0]) : TAYLOR_COS({a[0]}, {a[1]}, k);")
        elif op.kind == "exp":
            lines.append(f"{u}[k] = k == 0 ? EXP({a[0]}[0]) : TAYLOR_EXP({a[0]}, {u}, k);")
        else:                                   # pragma: no cover (every kind above)
            raise SpecError(f"unknown Taylor operation {op.kind}")
    outputs = []
    for i, (kind, j) in enumerate(d.outputs):
        src = f"{ref(j)}[k]" if kind == "node" else f"(k == 0 ? C[{j}] : (R)0)"
        outputs.append(f"X[{i}][k + 1] = {src} / (R)(k + 1);")
    return {"constants": consts, "ops": lines, "outputs": outputs,
            "guards": [f"{ref(g)}[0]" for g in d.guards]}


def counts(d: Decomposition) -> dict:
    return dict(Counter(op.kind for op in d.ops))


# -- rendering -------------------------------------------------------------------------

@forget_on_model_change
@lru_cache(maxsize=None)
def rhs_decomposition(name: str) -> Decomposition:
    """The decomposition of model `name`'s rhs (from the one CSE pass of its kernels), made
    once: the C backend asks whether there is one, then renders it."""
    from ..codegen.sources import kernels
    spec, bodies = kernels(name)
    body = next(b for b in bodies if b.kernel.name == "rhs")
    state = next(i.vector.symbols for i in body.kernel.inputs if i.vector.key == "state")
    return decompose(body, tuple(state))


def _slots(name: str) -> dict:
    """Parameters p[i], then inputs p[n_params + i] (the integrators' p = (params, inputs))."""
    from ..codegen.sources import kernels
    _, bodies = kernels(name)
    body = next(b for b in bodies if b.kernel.name == "rhs")
    slots, offset = {}, 0
    for inp in body.kernel.inputs:
        if inp.vector.key == "state":
            continue
        for i, s in enumerate(inp.vector.symbols):
            slots[s] = f"p[{offset + i}]"
        offset += len(inp.vector.symbols)
    return slots


def render_taylor(name: str) -> dict[str, str]:
    """<name>_taylor.h and .c: the Taylor integrator of one model (C backend artifact)."""
    from ..codegen.emit import render
    from .codegen import c_variants, model_info
    from .contract import INFO
    info = model_info(name)
    d = rhs_decomposition(name)
    slots = _slots(name)
    variants = [dict(v, taylor=c_statements(d, v["ctype"], slots)) for v in c_variants()]
    kinds = counts(d)
    M = name.upper()
    uses = {"mul": bool(kinds.keys() & {"mul", "square"}), "div": bool(kinds.keys() & {"div", "inv"}),
            "sqrt": "sqrt" in kinds, "chain": bool(kinds.keys() & {"sin", "cos", "exp"})}
    ctx = {"P": name, "M": M, "title": info.title, "variants": variants, "nops": len(d.ops), "uses": uses,
           "nconst": len(d.constants), "order_max": ORDER_MAX,
           "info_scalars": [f.name for f in INFO if not f.length],
           "op_summary": ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())),
           "nparams": f"{M}_N_PARAMS + {M}_N_INPUTS" if info.n_inputs else f"{M}_N_PARAMS"}
    return {f"c/{name}_taylor.h": render("c/taylor.h.jinja", dict(ctx, template="templates/c/taylor.h.jinja")),
            f"c/{name}_taylor.c": render("c/taylor.c.jinja", dict(ctx, template="templates/c/taylor.c.jinja"))}


def taylor_problem(name: str) -> str | None:
    """Why model `name` has no Taylor integrator (an operation without a recurrence), or None."""
    try:
        rhs_decomposition(name)
    except SpecError as exc:
        return str(exc)
    return None
