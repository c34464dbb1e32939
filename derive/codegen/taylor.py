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

and y^[k+1] = f^[k] / (k + 1).  Each kind of operation is a row of OPERATIONS: its
recurrence, its statement in the scalar jet and in the lanes' (taylor_lanes.py), the
coefficients it keeps and its cost.  Subexpressions free of the state (parameters, inputs,
numbers) are constants of the step, computed once (printed by the C printer); only
the others carry coefficient arrays.  Integer powers are products (squares, then
repeated multiplication), negative powers divisions, half-integer powers square roots.

Order and step from the tolerance (Jorba & Zou 2005, section 3.2, as heyoka):
order p = ceil(-ln(tol)/2 + 1); with m = max(1, |y|_inf) (absolute below 1, relative
above), rho_j = (m / |y^[j]|_inf)^(1/j) for j = p-1, p, and h = min(rho_{p-1}, rho_p)
/ e^2 * exp(-0.7/(p-1)).  The series is the dense output: every output time inside a
step is the polynomial evaluated there (Horner), to the tolerance of the step.

The jet is written in two forms, the same arithmetic: unrolled (c_statements: one
statement per operation in the loop over the orders, which the compiler unrolls at a fixed
order) and compact (compact_statements, heyoka's compact mode: the operations of one level
whose statements read alike in one segment, a loop over its rows with the operands' rows
in index tables).  The unrolled code grows as the operations times the order squared, the
compact one with the operations alone; UNROLL_COST sets the default between them.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Callable

import sympy as sp

from .printers import CPrinter
from ..errors import SpecError
from ..model.description import forget_on_model_change
from .sources import kernels, model_spec_of
from .emit import cse_file, render
from .integrators import library_files, model_info
from .contract import (INFO, STATUS_TABLE, TAYLOR_ORDER_DIVISOR, TAYLOR_ORDER_MAX, TAYLOR_ORDER_MIN,
                       TAYLOR_ORDER_OFFSET, TAYLOR_ORDER_RULE)

# the order rule's numbers, rendered into the C (the rule itself: codegen/contract.py)
ORDER_RULE = {"order_max": TAYLOR_ORDER_MAX, "order_min": TAYLOR_ORDER_MIN,
              "order_divisor": TAYLOR_ORDER_DIVISOR, "order_offset": TAYLOR_ORDER_OFFSET}


@dataclass
class Op:
    kind: str                 # a row of OPERATIONS: var, time, add, sub, scale, shift, mul, div, inv, sqrt, sin, cos, exp, square
    args: tuple = ()          # node indices (jets) or, for scale/shift, (node, constant index)
    index: int = -1           # var: the state slot


@dataclass
class Decomposition:
    n: int                              # states
    ops: list[Op] = field(default_factory=list)
    constants: list[sp.Expr] = field(default_factory=list)     # state-free values, once per step
    outputs: list[tuple[str, int]] = field(default_factory=list)   # per state: ("node", i) | ("const", c)
    guards: list[int] = field(default_factory=list)            # nodes whose |value| must stay >= sine_min
    timed: bool = False        # a time-dependent model's: the jet takes t0, the time at the step's start

    @property
    def reads_time(self) -> bool:
        """Whether some node is the time t (else a timed jet leaves t0 unused)."""
        return any(op.kind == "time" for op in self.ops)


class _Builder:
    def __init__(self, state: tuple[sp.Symbol, ...], defs: dict, time: sp.Symbol | None = None):
        self.state = {s: i for i, s in enumerate(state)}
        self.time = time                  # the time t of a time-dependent model: a jet, not a constant
        self.defs = defs                  # temporary symbol -> expression
        self.d = Decomposition(n=len(state), timed=time is not None)
        self.memo: dict = {}              # expression -> ("node", i) | ("const", c)
        self.depends_memo: dict = {}      # symbol -> whether it depends on the state or the time
        self.const_memo: dict = {}
        self.op_memo: dict = {}           # (kind, args) -> node: an operation made twice is one node
        self.trig: dict = {}              # argument node -> (sin node, cos node)
        for s, i in self.state.items():
            self.memo[s] = ("node", self._op(Op("var", (), i)))

    def _op(self, op: Op) -> int:
        key = (op.kind, op.args, op.index)
        if op.kind not in ("sin", "cos") and key in self.op_memo:
            return self.op_memo[key]
        self.d.ops.append(op)
        self.op_memo[key] = len(self.d.ops) - 1
        return len(self.d.ops) - 1

    def _const(self, expr: sp.Expr) -> tuple[str, int]:
        if expr not in self.const_memo:
            self.d.constants.append(expr)
            self.const_memo[expr] = len(self.d.constants) - 1
        return ("const", self.const_memo[expr])

    def _depends(self, expr) -> bool:
        return any(self._symbol_depends(s) for s in expr.free_symbols)

    def _symbol_depends(self, s) -> bool:
        """Whether symbol s is the state, the time or a temporary of them (once per symbol:
        the temporaries of a large model nest deep and share much)."""
        if s not in self.depends_memo:
            self.depends_memo[s] = s in self.state or s == self.time or \
                (s in self.defs and self._depends(self.defs[s]))
        return self.depends_memo[s]

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
        elif expr == self.time:           # t(t0 + tau) = t0 + tau: coefficients t0, 1, 0, ...
            out = ("node", self._op(Op("time")))
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
        c = self._const(self._const_value(sp.Add(*consts)))[1] if consts else None
        if pos:
            acc = self.node(pos[0])[1]
            for a in pos[1:]:
                acc = self._op(Op("add", (acc, self.node(a)[1])))
            for a in neg:
                acc = self._op(Op("sub", (acc, self.node(a)[1])))
            if c is not None:
                acc = self._op(Op("shift", (acc, c)))
            return ("node", acc)
        first = self.node(neg[0])[1]
        # c - a (one node, not -1 a then a shift by c), or -a
        acc = self._op(Op("csub", (first, c))) if c is not None else self._scaled(first, sp.Integer(-1))
        for a in neg[1:]:
            acc = self._op(Op("sub", (acc, self.node(a)[1])))
        return ("node", acc)

    def _mul(self, args) -> tuple[str, int]:
        consts = [a for a in args if not self._depends(a)]
        jets = [a for a in args if self._depends(a)]
        num = [self.node(a)[1] for a in jets if not (a.is_Pow and a.exp.is_negative)]
        den = [self.node(1 / a)[1] for a in jets if a.is_Pow and a.exp.is_negative]
        # a factor 1/b (an inverse the CSE named) divides by b: a quotient costs what the
        # product by 1/b costs, and the inverse's own recurrence may then go
        inverses = [i for i in num if self.d.ops[i].kind == "inv"]
        if len(inverses) < len(num):
            num = [i for i in num if i not in inverses]
            den += [self.d.ops[i].args[0] for i in inverses]
        acc = None
        for i in num:
            acc = i if acc is None else self._op(Op("mul", (acc, i)))
        if den:
            d = None
            for i in den:
                d = i if d is None else self._op(Op("mul", (d, i)))
            acc = self._op(Op("inv", (d,))) if acc is None else self._op(Op("div", (acc, d)))
        if consts:
            acc = self._scaled(acc, self._const_value(sp.Mul(*consts)))
        return ("node", acc)

    def _scaled(self, node: int, c: sp.Expr) -> int:
        """c times a node; c (c0 a) as one scaling (c c0) a."""
        op = self.d.ops[node]
        if op.kind == "scale":
            node, c = op.args[0], c * self.d.constants[op.args[1]]
        if c == 1:
            return node
        return self._op(Op("scale", (node, self._const(c)[1])))

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


def _pruned(d: Decomposition) -> Decomposition:
    """d without the nodes nothing reads (a scaling folded into another, an inverse turned
    into quotients) and the constants none reads, renumbered in order; the states stay
    (X[i] is the solution)."""
    live = {i for i, op in enumerate(d.ops) if op.kind == "var"}
    live |= {j for kind, j in d.outputs if kind == "node"} | set(d.guards)
    for i in range(len(d.ops) - 1, -1, -1):
        if i in live:
            live |= set(_node_args(d.ops[i]))
    # sin and cos read each other: a pair stays whole when either is read
    live |= {j for i in list(live) if d.ops[i].kind in ("sin", "cos") for j in d.ops[i].args}
    new = {i: n for n, i in enumerate(sorted(live))}
    used = sorted({c for i in live for c in _const_args(d.ops[i])} | {j for kind, j in d.outputs if kind == "const"})
    const = {c: n for n, c in enumerate(used)}
    out = Decomposition(n=d.n, constants=[d.constants[c] for c in used], timed=d.timed)
    for i in sorted(live):
        op = d.ops[i]
        k = len(op.args) - operation(op).consts
        args = tuple(None if a is None else new[a] for a in op.args[:k]) + tuple(const[c] for c in op.args[k:])
        out.ops.append(Op(op.kind, args, op.index))
    out.outputs = [(kind, new[j] if kind == "node" else const[j]) for kind, j in d.outputs]
    out.guards = [new[g] for g in d.guards]
    return out


def _const_args(op: Op) -> tuple:
    """The constants' indices an operation reads."""
    return op.args[len(op.args) - operation(op).consts:]


def _node_args(op: Op) -> tuple:
    """The nodes an operation reads (its arguments but the constants' indices)."""
    k = len(op.args) - operation(op).consts
    return tuple(a for a in op.args[:k] if a is not None)


def decompose(rhs_body, state: tuple[sp.Symbol, ...], time: sp.Symbol | None = None) -> Decomposition:
    """The elementary operations of a model's CSE'd rhs kernel (derive/codegen/emit.Body);
    `time`: the symbol t of a time-dependent model, a variable of the jet (heyoka's
    `time`), whose Taylor coefficients over a step from t0 are t0, 1, 0, 0, ..."""
    defs = dict(rhs_body.assignments)
    b = _Builder(state, defs, time)
    for expr in rhs_body.outputs[0]:
        b.d.outputs.append(b.node(expr))
    for g in rhs_body.guards:
        b.d.guards.append(b._jet(g))
    return _pruned(b.d)


# -- the operations: one table for every emitter -----------------------------------------

@dataclass(frozen=True)
class Operation:
    """One kind of elementary operation (heyoka's table of them, in small): its recurrence,
    its statement in the scalar jet (derive_taylor.h) and in the lanes' jet
    (derive_taylor_lanes.h), the nodes whose every coefficient it reads, and its cost.

    The statements are functions of (u, a): u the node's coefficients, a its arguments
    (the nodes' coefficients, None for none, then a constant's index for scale and shift).
    For the scalar jet a node is its row (J[i], X[i]: u[k] its coefficient k); for the
    lanes a taylor_lanes._Lanes (u.row every order's lanes, u.cur order k's).  None: no
    statement (a state; cos, which its sin's statement computes: `with_previous`)."""
    meaning: str                          # u_k from the arguments' coefficients
    scalar: Callable | None               # (u, a) -> the scalar jet's C statement
    lane: Callable | None                 # (u, a) -> the lanes' jet's C statement
    history: Callable = lambda i, args: ()   # (node, args) -> the nodes read at every order
    cost: Callable = lambda k: 0          # k -> the additions, multiplications and divisions of u_k (k >= 1)
    calls: str | None = None              # derive_taylor.h's recurrence it calls (DERIVE_TAYLOR_USES_*)
    lane_calls: str | None = None         # derive_taylor_lanes.h's (DERIVE_LANES_USES_*)
    consts: int = 0                       # trailing args that are constants' indices
    with_previous: str | None = None      # computed by the statement of the operation before it, of this kind


def _shift(u, a):
    shift = f"k == 0 ? C[{a[1]}] : T_INT(0)"
    return f"{u}[k] = {shift};" if a[0] is None else f"{u}[k] = T_ADD({a[0]}[k], {shift});"


def _operands(i, args):                   # a product reads its operands' every coefficient
    return args


def _quotient(i, args):                   # a quotient its divisor's and its own
    return (args[-1], i)


def _own(i, args):                        # a square root its own
    return (i,)


def _chain(i, args):                      # sin, cos, exp: the argument's and their own
    return (args[0], i)


def _square_cost(k):                      # 2 sum_{j<k/2} a_j a_{k-j} (+ a_{k/2}^2): half a product's
    return 2 * ((k - 1) // 2) + (2 if k % 2 == 0 else 0) + 3


OPERATIONS = {
    "var": Operation("a state: the solution's own coefficients", None, None),
    # the jet's argument t0 (the time at the start of the step): u_0 = t0, u_1 = 1, u_k = 0 past
    "time": Operation("u = t: u_0 = t0, u_1 = 1, u_k = 0 (k >= 2)",
                      lambda u, a: f"{u}[k] = k == 0 ? t0 : T_INT(k == 1);",
                      lambda u, a: f"LANES_TIME({u.cur}, t0, k);"),
    "add": Operation("u_k = a_k + b_k",
                     lambda u, a: f"{u}[k] = T_ADD({a[0]}[k], {a[1]}[k]);",
                     lambda u, a: f"LANES_ADD({u.cur}, {a[0].cur}, {a[1].cur});",
                     cost=lambda k: 1, lane_calls="ADD"),
    "sub": Operation("u_k = a_k - b_k",
                     lambda u, a: f"{u}[k] = T_SUB({a[0]}[k], {a[1]}[k]);",
                     lambda u, a: f"LANES_SUB({u.cur}, {a[0].cur}, {a[1].cur});",
                     cost=lambda k: 1, lane_calls="SUB"),
    "scale": Operation("u_k = c a_k (c a constant)",
                       lambda u, a: f"{u}[k] = T_MUL(C[{a[1]}], {a[0]}[k]);",
                       lambda u, a: f"LANES_SCALE({u.cur}, C[{a[1]}], {a[0].cur});",
                       cost=lambda k: 1, lane_calls="SCALE", consts=1),
    "shift": Operation("u_0 = a_0 + c, u_k = a_k (a none: the constant c alone)", _shift,
                       lambda u, a: f"LANES_SHIFT({u.cur}, {'0' if a[0] is None else a[0].cur}, C[{a[1]}], k);",
                       cost=lambda k: 1, lane_calls="SHIFT", consts=1),
    "csub": Operation("u = c - a: u_0 = c - a_0, u_k = -a_k (c a constant)",
                      lambda u, a: f"{u}[k] = k == 0 ? T_SUB(C[{a[1]}], {a[0]}[0]) : T_NEG({a[0]}[k]);",
                      lambda u, a: f"LANES_CSUB({u.cur}, C[{a[1]}], {a[0].cur}, k);",
                      cost=lambda k: 1, lane_calls="CSUB", consts=1),
    "mul": Operation("u_k = sum_{j=0..k} a_j b_{k-j}",
                     lambda u, a: f"{u}[k] = TAYLOR_MUL({a[0]}, {a[1]}, k);",
                     lambda u, a: f"LANES_MUL({u.cur}, {a[0].row}, {a[1].row}, k);",
                     history=_operands, cost=lambda k: 2 * k + 1, calls="MUL", lane_calls="MUL"),
    "square": Operation("u = a a: u_k = 2 sum_{j<k/2} a_j a_{k-j} (+ a_{k/2}^2, k even)",
                        lambda u, a: f"{u}[k] = TAYLOR_SQUARE({a[0]}, k);",
                        lambda u, a: f"LANES_SQUARE({u.cur}, {a[0].row}, k);",
                        history=_operands, cost=_square_cost, calls="SQUARE", lane_calls="SQUARE"),
    "div": Operation("u = a / b: u_k = (a_k - sum_{j=1..k} b_j u_{k-j}) / b_0",
                     lambda u, a: f"{u}[k] = TAYLOR_DIV({a[0]}[k], {a[1]}, {u}, k);",
                     lambda u, a: f"LANES_DIV({u.row}, {a[0].cur}, {a[1].row}, k);",
                     history=_quotient, cost=lambda k: 2 * k + 1, calls="DIV", lane_calls="DIV"),
    "inv": Operation("u = 1 / b: u_k = ([k = 0] - sum_{j=1..k} b_j u_{k-j}) / b_0",
                     lambda u, a: f"{u}[k] = TAYLOR_DIV(T_INT(k == 0), {a[0]}, {u}, k);",
                     lambda u, a: f"LANES_DIV({u.row}, 0, {a[0].row}, k);",
                     history=_quotient, cost=lambda k: 2 * k + 1, calls="DIV", lane_calls="DIV"),
    "sqrt": Operation("u = sqrt(a): u_k = (a_k - sum_{j=1..k-1} u_j u_{k-j}) / (2 u_0)",
                      lambda u, a: f"{u}[k] = TAYLOR_SQRT({a[0]}, {u}, k);",
                      lambda u, a: f"LANES_SQRT({u.row}, {a[0].cur}, k);",
                      history=_own, cost=lambda k: _square_cost(k) + 1, calls="SQRT", lane_calls="SQRT"),
    # one statement computes the pair (the products j a_j shared): sin's, with its cos
    "sin": Operation("s = sin a (c = cos a, its pair): s_k = (1/k) sum_{j=1..k} j a_j c_{k-j}",
                     lambda u, a: f"TAYLOR_SINCOS({u}, {a[1]}, {a[0]}, k);",
                     lambda u, a: f"LANES_SINCOS({u.row}, {a[1].row}, {a[0].row}, k);",
                     history=_chain, cost=lambda k: 5 * k + 1, calls="SINCOS", lane_calls="SINCOS"),
    "cos": Operation("c = cos a (s = sin a, its pair): c_k = -(1/k) sum_{j=1..k} j a_j s_{k-j}",
                     None, None, history=_chain, with_previous="sin"),
    "exp": Operation("u = exp a: u_k = (1/k) sum_{j=1..k} j a_j u_{k-j}",
                     lambda u, a: f"{u}[k] = TAYLOR_EXP({a[0]}, {u}, k);",
                     lambda u, a: f"LANES_EXP({u.row}, {a[0].row}, k);",
                     history=_chain, cost=lambda k: 3 * k, calls="EXP", lane_calls="EXP"),
}
# the recurrences of derive_taylor.h a jet may call (DERIVE_TAYLOR_USES_<NAME>: the others left out)
TAYLOR_CALLS = tuple(sorted({row.calls for row in OPERATIONS.values()} - {None}))


def operation(op: Op) -> Operation:
    if op.kind not in OPERATIONS:                # pragma: no cover (the builder makes no other)
        raise SpecError(f"unknown Taylor operation {op.kind}")
    return OPERATIONS[op.kind]


def operands(op: Op, ref: Callable) -> list:
    """The statement's a: each node argument through ref (None stays None), then the
    constants' indices."""
    n = len(op.args) - operation(op).consts
    return [None if x is None else ref(x) for x in op.args[:n]] + list(op.args[n:])


def history_nodes(d: Decomposition) -> set[int]:
    """The nodes whose every coefficient so far is read (operands of products, quotients'
    divisors and the quotients, square roots, sin/cos and exp and their arguments); the
    others are read only at the order being computed."""
    return {j for i, op in enumerate(d.ops) for j in operation(op).history(i, op.args)}


def uses(d: Decomposition, lanes: bool = False) -> set[str]:
    """The recurrences the jet's operations call: derive_taylor.h's, or with `lanes`
    derive_taylor_lanes.h's."""
    return {operation(op).lane_calls if lanes else operation(op).calls for op in d.ops} - {None}


def jet_cost(d: Decomposition, order: int) -> int:
    """The additions, multiplications and divisions of one jet to `order` past order 0
    (which is the libm calls and the constants): the recurrences and the outputs'
    divisions by k + 1."""
    return sum(operation(op).cost(k) for k in range(1, order) for op in d.ops) + d.n * (order - 1)


# -- C: the statements of the jet ------------------------------------------------------

def c_statements(d: Decomposition, variant: dict, slots: dict) -> dict:
    """The C the template lays out: the constants (once per step) and one statement per
    operation computing its coefficient k (J[i][k]; C[c] the constants), written with
    the template's arithmetic macros (T_ADD, T_MUL, ...: operators for the native
    types, functions for double-double)."""
    if variant["native_constants"]:
        pr = CPrinter(slots, variant["ctype"])
        consts = [pr.doprint_checked(c) for c in d.constants]
    else:
        consts = [macro_expression(c, slots) for c in d.constants]

    def ref(i):                  # a state's coefficients are X[i] itself (no copy)
        op = d.ops[i]
        return f"X[{op.index}]" if op.kind == "var" else f"J[{i}]"

    lines = [operation(op).scalar(ref(i), operands(op, ref)) for i, op in enumerate(d.ops)
             if operation(op).scalar]
    outputs = []
    for i, (kind, j) in enumerate(d.outputs):
        src = f"{ref(j)}[k]" if kind == "node" else f"(k == 0 ? C[{j}] : T_INT(0))"
        outputs.append(f"X[{i}][k + 1] = T_DIVI({src}, k + 1);")
    return {"constants": consts, "ops": lines, "outputs": outputs,
            "guards": [f"{ref(g)}[0]" for g in d.guards]}


# -- C: the compact jet ----------------------------------------------------------------

def jet_levels(d: Decomposition) -> list[int]:
    """Each node's level: 0 for a state, else one more than the deepest of the nodes it
    reads at the order being computed.  Nodes of one level are independent at an order, so
    they may be computed in any order among themselves (the compact jet's segments).

    Which arguments are read at the current order: those made before the node.  The
    decomposition is in dependency order (computing its nodes one by one is the unrolled
    jet), so an argument made after the node (sin's cos, cos's sin is before it) can only
    be read at lower orders, which the previous pass of the order loop has finished."""
    level = []
    for i, op in enumerate(d.ops):
        if op.kind == "var":
            level.append(0)
            continue
        nodes = op.args[:len(op.args) - operation(op).consts]
        level.append(1 + max((level[j] for j in nodes if j is not None and j < i), default=0))
    return level


def compact_statements(d: Decomposition) -> dict:
    """The compact jet (heyoka's compact mode, in C): the nodes renumbered into rows of one
    array J (the states first, J[i] for state i, then level by level), the nodes of one
    level whose statements read alike in one segment, a loop over its rows.  A segment's
    statement is its operation's scalar statement (OPERATIONS) written for row u, its
    operands read from index tables (A0[u], A1[u], ...: the rows of the node arguments,
    the indices of the constants), so each row of OPERATIONS supplies its compact form.  A
    node without a statement of its own (cos: its sin's sincos writes it) has a row and no
    segment.

    The C is then one loop per segment and a few integers per node, whatever the order:
    its size and compile time grow with the model, not with the model times the order
    squared as the unrolled jet's do.  Each node is the same expression of the same
    operands as in the unrolled jet, so the coefficients are the same numbers.

    Returns
    -------
    dict
        segments ((first row, past the last, statement)), tables ({name: every row's
        operand}: A0, A1, ...), outputs and guards (as c_statements' but on J's rows; the
        outputs write J[i][k + 1], copied to X at the end) and row (each node's row).
    """
    level = jet_levels(d)
    width = max((len(op.args) for op in d.ops), default=0)

    def statement(op: Op) -> str:
        entry = operation(op)
        nodes = len(op.args) - entry.consts
        a = [None if x is None else f"J[A{j}[u]]" for j, x in enumerate(op.args[:nodes])]
        a += [f"A{j}[u]" for j in range(nodes, len(op.args))]
        return entry.scalar("J[u]", a)

    # a state's row is its index; the other nodes by level, then by statement, then as made
    groups: dict[tuple[int, str], list[int]] = {}
    for i, op in enumerate(d.ops):
        if op.kind != "var" and operation(op).scalar:
            groups.setdefault((level[i], statement(op)), []).append(i)
    row = {i: op.index for i, op in enumerate(d.ops) if op.kind == "var"}
    segments = []
    for (_, text), members in sorted(groups.items(), key=lambda g: (g[0][0], g[1][0])):
        first = len(row)
        row.update((i, first + m) for m, i in enumerate(members))
        segments.append((first, len(row), text))
    for i in range(len(d.ops)):         # the nodes another's statement writes (cos: its sin's sincos)
        if i not in row:
            row[i] = len(row)
    if sorted(row.values()) != list(range(len(d.ops))):      # pragma: no cover (one var per state)
        raise SpecError("the Taylor decomposition's states are not its first rows")

    tables = [[0] * len(d.ops) for _ in range(width)]
    for i, op in enumerate(d.ops):
        nodes = len(op.args) - operation(op).consts
        for j, x in enumerate(op.args):
            tables[j][row[i]] = x if j >= nodes else (0 if x is None else row[x])
    outputs = []
    for i, (kind, j) in enumerate(d.outputs):
        src = f"J[{row[j]}][k]" if kind == "node" else f"(k == 0 ? C[{j}] : T_INT(0))"
        outputs.append(f"J[{i}][k + 1] = T_DIVI({src}, k + 1);")
    used = {f"A{j}": tables[j] for j in range(width) if any(f"A{j}[u]" in text for _, _, text in segments)}
    return {"segments": segments, "tables": used, "outputs": outputs,
            "guards": [f"J[{row[g]}][0]" for g in d.guards], "row": row}


TABLE_LINE = 16                 # a table's integers per line of C


def compact_context(compact: dict) -> dict:
    """A compact jet's dict (compact_statements, taylor_lanes.compact_lane_statements) as
    its template lays it out: each table as (name, its lines of C)."""
    def lines(values: list[int]) -> list[str]:
        rows = [", ".join(map(str, values[i:i + TABLE_LINE])) for i in range(0, len(values), TABLE_LINE)]
        return [line + ("," if i < len(rows) - 1 else "") for i, line in enumerate(rows)]
    return dict(compact, tables=[(name, lines(values)) for name, values in compact["tables"].items()])


# The jet's cost (jet_cost) up to which derive_taylor.h inlines the recurrences at a fixed
# order: unrolled, the jet's code is about 11 bytes an operation (x86-64, AVX-512 build) on
# some 4 KB of the rest, and past 32 KB it outgrows the instruction cache of most x86-64
# cores, after which calls of the recurrences (their loops: some 20 KB in all) run as fast
# and steadier.  Planar (jet_cost, us a step inlined / called, one AVX-512 build): order 13
# (2766) 0.38 / 0.59; 14 (3190) 0.49 to 0.74 / 0.60, the inlined figure varying from one
# build of the same file to the next by where its code lands in memory; 16 (4131) 0.77 / 0.73.
INLINE_BUDGET = 2800


# The unrolled jet's size, and its compile time, grow as its operations' cost at the order
# (jet_cost: about the nodes times the order squared); past UNROLL_COST the compact jet is
# the default.  Measured on the development machine (bench/taylor_jet_forms.py; docs/
# methods.md, "The jet's two forms"): the scalar unrolled jet steps faster than the
# compact one while its recurrences are all inlined (INLINE_BUDGET: planar 0.42 against
# 0.56 us a step at order 13, the 3-link chain 1.88 / 2.20 at 8); past it the unrolled jet
# calls them as the compact one does, with more code: planar even at orders 15 and 18
# (0.70 / 0.69, 0.93 / 1.02 us), the double spherical pendulum slower at every order (1.59
# against 1.33 us at 8, 5.87 / 4.30 at 18).  The lanes' unrolled jet stays the faster one,
# so its limit is the compile: LANES_UNROLL_COST keeps the two-link models unrolled
# through the double tolerances (order 19) and takes a larger model compact before its
# compile outgrows seconds and a gigabyte.
UNROLL_COST = INLINE_BUDGET
LANES_UNROLL_COST = 8000


def unroll_max(d: Decomposition, cost: int = UNROLL_COST) -> int:
    """The largest fixed order whose unrolled jet costs at most `cost` (jet_cost); 1: none
    (the orders start at TAYLOR_ORDER_MIN = 2)."""
    order, total = 1, jet_cost(d, 1)
    while order < TAYLOR_ORDER_MAX:         # jet_cost(d, order + 1), one order more at a time
        total += sum(operation(op).cost(order) for op in d.ops) + d.n
        if total > cost:
            break
        order += 1
    return order


# pi to about 2^-160 as a sum of three doubles: what double-double and binary128 need
_PI_PARTS = ("3.141592653589793", "1.2246467991473532e-16", "-2.9947698097183397e-33")
_EXACT_INT = 2 ** 53                   # integers a double holds exactly


def _int(n: int) -> str:
    if abs(n) > _EXACT_INT:
        raise SpecError(f"the integer {n} in a constant is beyond what the precision ladder prints exactly")
    return f"T_INT({n})"


def _float_parts(e: sp.Float) -> str:
    """A Float wider than a double (a value folded in exactly: derive/codegen/specialise.py)
    as the sum of three doubles, each the rounding of what the ones before leave, as pi's
    parts: its binary value to about 2^-160, whatever its decimal digits."""
    rest, parts = sp.Rational(e), []
    for _ in range(3):
        part = float(rest)
        parts.append(f"T_D({part!r})")
        rest -= sp.Rational(part)
    return f"T_ADD(T_ADD({parts[0]}, {parts[1]}), {parts[2]})"


def macro_expression(expr, slots: dict) -> str:
    """A state-free expression (parameters, inputs, numbers) in the template's arithmetic
    macros, for the types without C operators (double-double) or literals C99 has not
    (binary128): rationals exact, decimal numbers as the rational they write, pi to
    2^-160, integer and half-integer powers as products and square roots."""
    e = sp.sympify(expr)
    if e.is_Symbol:
        if e not in slots:
            raise SpecError(f"unknown symbol {e} in a Taylor constant")
        return slots[e]
    if e.is_Integer:
        return _int(int(e))
    if e.is_Rational:
        return f"T_DIV({_int(int(e.p))}, {_int(int(e.q))})"
    if e.is_Float and e._prec > 53:
        return _float_parts(e)
    if e.is_Float:
        return macro_expression(sp.Rational(repr(float(e))), slots)
    if e is sp.pi:
        a, b, c = _PI_PARTS
        return f"T_ADD(T_ADD(T_D({a}), T_D({b})), T_D({c}))"
    if e is sp.E:
        return "T_EXP(T_INT(1))"
    if e.is_Add:
        terms = list(e.args)
        pos = [t for t in terms if not _negated(t)]
        neg = [-t for t in terms if _negated(t)]
        acc = macro_expression(pos[0], slots) if pos else f"T_NEG({macro_expression(neg.pop(0), slots)})"
        for t in pos[1:]:
            acc = f"T_ADD({acc}, {macro_expression(t, slots)})"
        for t in neg:
            acc = f"T_SUB({acc}, {macro_expression(t, slots)})"
        return acc
    if e.is_Mul:
        coeff, rest = e.as_coeff_Mul()
        if coeff < 0:
            return f"T_NEG({macro_expression(-e, slots)})"
        num = [f for f in e.args if not (f.is_Pow and f.exp.is_negative)]
        den = [1 / f for f in e.args if f.is_Pow and f.exp.is_negative]
        acc = None
        for f in num:
            acc = macro_expression(f, slots) if acc is None else f"T_MUL({acc}, {macro_expression(f, slots)})"
        if den:
            d = macro_expression(sp.Mul(*den), slots)
            acc = f"T_DIV({acc or 'T_INT(1)'}, {d})"
        return acc
    if e.is_Pow:
        base, k = e.base, e.exp
        if k.is_Integer or (k.is_Rational and k.q == 2):
            b = macro_expression(base, slots)
            if not k.is_Integer:
                b, k = f"T_SQRT({b})", sp.Integer(k.p)
            n = abs(int(k))
            if n == 0:
                return "T_INT(1)"
            acc = b
            for _ in range(n - 1):
                acc = f"T_MUL({acc}, {b})"
            return acc if k > 0 else f"T_DIV(T_INT(1), {acc})"
    fn = {sp.sin: "T_SIN", sp.cos: "T_COS", sp.exp: "T_EXP"}.get(type(e))
    if fn:
        return f"{fn}({macro_expression(e.args[0], slots)})"
    raise SpecError(f"the precision ladder (double-double, binary128) has no translation for {e}")


def counts(d: Decomposition) -> dict:
    return dict(Counter(op.kind for op in d.ops))


# -- rendering -------------------------------------------------------------------------

COST_ORDER = 12          # the order at which jets' costs are weighed (taylor_order(1e-9) is 11)


def inline_max(d: Decomposition) -> int:
    """The largest order whose jet costs at most INLINE_BUDGET (0: none): unroll_max's
    search with that budget (whose 1 means none)."""
    top = unroll_max(d, INLINE_BUDGET)
    return top if top >= 2 else 0


@forget_on_model_change
@lru_cache(maxsize=None)
def rhs_decomposition(name: str) -> Decomposition:
    """The decomposition of model `name`'s rhs, made once: the C backend asks whether there
    is one, then renders it.

    Two are made and the cheaper jet (jet_cost at COST_ORDER) kept: from the kernels' one
    CSE pass, whose compound angles are rewritten for the scalar kernels (sin(a - b) as
    sin a cos b - cos a sin b: one libm call fewer, emit.compound_angle_rewrites), and from
    a CSE pass of the rhs alone with the angles whole.  For a jet the trade differs: the
    rewrite costs four products and two sums a order, the pair sin/cos(a - b) about two
    products, so the whole angle is usually the cheaper."""
    _, bodies = kernels(name)
    body = next(b for b in bodies if b.kernel.name == "rhs")
    whole = _WHOLE_ANGLES[name] if name in _WHOLE_ANGLES else whole_angles_decomposition(name)
    jets = [whole, decompose(body, *_jet_variables(body.kernel))]
    return min(jets, key=lambda d: jet_cost(d, COST_ORDER))


def _jet_variables(rhs) -> tuple:
    """(state symbols, time symbol or None) of an rhs kernel: the jet's variables."""
    state = next(i.vector.symbols for i in rhs.inputs if i.vector.key == "state")
    time = next((i.vector.symbols[0] for i in rhs.inputs if i.vector.key == "time"), None)
    return tuple(state), time


@forget_on_model_change
@lru_cache(maxsize=None)
def whole_angles_decomposition(name: str) -> Decomposition:
    """The jet of model `name`'s rhs from a CSE pass of the rhs alone with its compound
    angles whole (rhs_decomposition weighs it against the kernels' own): it needs the
    model's spec only, so the C backend has it made in a worker while the kernels' CSE
    runs (Backend.early_work)."""
    spec = model_spec_of(name)
    rhs = next(k for k in spec.kernels if k.name == "rhs")
    body = next(iter(cse_file(replace(spec, kernels=(rhs,)), compound_angles=False)))
    return decompose(body, *_jet_variables(rhs))


_WHOLE_ANGLES: dict[str, Decomposition] = {}     # made by a worker: prefetch_whole_angles


def prefetch_whole_angles(name: str) -> Decomposition | None:
    """whole_angles_decomposition(name) made in a worker (None where the rhs has no jet:
    the C backend then says why, as without the worker)."""
    try:
        return whole_angles_decomposition(name)
    except SpecError:
        return None


def keep_whole_angles(name: str, d: Decomposition | None) -> None:
    """Keep (or, given None, forget) a worker's whole_angles_decomposition of `name` for
    this process's rhs_decomposition."""
    if d is None:
        _WHOLE_ANGLES.pop(name, None)
    else:
        _WHOLE_ANGLES[name] = d


def _slots(name: str) -> dict:
    """Parameters p[i], then inputs p[n_params + i] (the integrators' p = (params, inputs))."""
    _, bodies = kernels(name)
    body = next(b for b in bodies if b.kernel.name == "rhs")
    slots, offset = {}, 0
    for inp in body.kernel.inputs:
        if inp.vector.key in ("state", "time"):      # the jet's own variables, not p's
            continue
        for i, s in enumerate(inp.vector.symbols):
            slots[s] = f"p[{offset + i}]"
        offset += len(inp.vector.symbols)
    return slots


def _sincos(m: str) -> str:
    """sin and cos of a into s and c in the C type of <math.h> suffix m: derive_taylor_math.h's
    function (the lanes' too) for the types with lanes, libm's (quadmath's) for the others."""
    if m in ("", "f", "l"):
        return f"derive_sincos{m}(a, &(s), &(c))"
    return f"((s) = sin{m}(a), (c) = cos{m}(a))"


def _native_ops(ctype: str, m: str) -> list[tuple[str, str]]:
    """The arithmetic macros of a C floating type (m: its <math.h> suffix, q: quadmath)."""
    return [("T_ADD(a, b)", "((a) + (b))"), ("T_SUB(a, b)", "((a) - (b))"), ("T_MUL(a, b)", "((a) * (b))"),
            ("T_DIV(a, b)", "((a) / (b))"), ("T_NEG(a)", "(-(a))"), ("T_MULI(a, i)", f"((a) * ({ctype})(i))"),
            ("T_DIVI(a, i)", f"((a) / ({ctype})(i))"), ("T_INT(i)", f"(({ctype})(i))"), ("T_D(x)", f"(({ctype})(x))"),
            ("T_SQRT(a)", f"sqrt{m}(a)"), ("T_SIN(a)", f"sin{m}(a)"), ("T_COS(a)", f"cos{m}(a)"),
            ("T_SINCOS(a, s, c)", _sincos(m)),
            ("T_EXP(a)", f"exp{m}(a)"), ("T_S(a)", "(a)"), ("T_ABS(a)", f"fabs{m}(a)"), ("T_FROMS(x)", "(x)"),
            ("T_LE(a, b)", "((a) <= (b))"), ("T_SEXP(x)", f"exp{m}(x)"),
            ("T_SROOT(x, y)", f"derive_root{m}(x, y)" if m in ("", "f", "l") else f"pow{m}(x, y)"),
            # C99's isnan is type-generic; C++'s overloads know no __float128
            ("T_SNAN(x)", "isnanq(x)" if m == "q" else "isnan(x)")]


_DD_OPS = [("T_ADD(a, b)", "dd_add(a, b)"), ("T_SUB(a, b)", "dd_sub(a, b)"), ("T_MUL(a, b)", "dd_mul(a, b)"),
           ("T_DIV(a, b)", "dd_div(a, b)"), ("T_NEG(a)", "dd_neg(a)"), ("T_MULI(a, i)", "dd_mul_d(a, (double)(i))"),
           ("T_DIVI(a, i)", "dd_div_d(a, (double)(i))"), ("T_INT(i)", "dd_d((double)(i))"), ("T_D(x)", "dd_d(x)"),
           ("T_SQRT(a)", "dd_sqrt(a)"), ("T_SIN(a)", "dd_sin(a)"), ("T_COS(a)", "dd_cos(a)"),
           ("T_SINCOS(a, s, c)", "((s) = dd_sin(a), (c) = dd_cos(a))"), ("T_EXP(a)", "dd_exp(a)"), ("T_S(a)", "((a).hi)"), ("T_ABS(a)", "fabs((a).hi)"),
           ("T_FROMS(x)", "dd_d(x)"), ("T_LE(a, b)", "dd_le(a, b)"), ("T_SEXP(x)", "exp(x)"),
           ("T_SROOT(x, y)", "derive_root(x, y)"), ("T_SNAN(x)", "isnan(x)")]


# x87 arithmetic (long double) is bound by its operations (80-bit loads and stores), not by
# fetching them: its jet runs faster with the recurrences inlined at every fixed order, past
# INLINE_BUDGET too (planar: 5.19 against 5.61 us a step at order 15, 6.16 / 6.68 at 17, 8.9
# / 9.4 at 22), so derive_taylor.h is told (T_INLINE_ALL) to inline them for it.
X87_INLINE = [("T_INLINE_ALL", "1")]


def _skip_key(ctype: str) -> str:
    """The variant's name in -D<M>_TAYLOR_SKIP_<KEY>."""
    return {"derive_dd": "DOUBLE_DOUBLE", "derive_quad": "QUAD"}.get(ctype, ctype.upper().replace(" ", "_"))


def _variant(name, ctype, stype, suffix, m, nan, ops, native_constants, tag):
    """One precision: its C types, names and arithmetic macros; `tag` names the static
    functions of derive_taylor.h for it (derive_taylor_mul_d, ...)."""
    return {"name": name, "key": _skip_key(ctype), "ctype": ctype, "stype": stype, "s": suffix, "m": m, "nan": nan,
            "ops": [(k, v) for k, v in ops] + [("T_NAN", nan)], "native_constants": native_constants, "tag": tag}


# The precision ladder of the Taylor integrator, as data: (file, variants).  The native
# C types and double-double in <model>_taylor.c (C99, <math.h> only), IEEE binary128 in
# <model>_taylor_quad.c (GCC's __float128 and <quadmath.h>, kept apart so the other
# file compiles wherever C99 does).
TAYLOR_VARIANTS = {
    "double": _variant("double", "double", "double", "", "", 'nan("")', _native_ops("double", ""), True, "_d"),
    "float": _variant("float", "float", "float", "_f", "f", 'nanf("")', _native_ops("float", "f"), True, "_f"),
    "long double": _variant("long double", "long double", "long double", "_l", "l", 'nanl("")',
                            _native_ops("long double", "l") + X87_INLINE, True, "_l"),
    "double-double": _variant("double-double", "derive_dd", "double", "_dd", "", 'dd_d(nan(""))', _DD_OPS,
                              False, "_dd"),
    "quad": _variant("IEEE binary128 (__float128)", "derive_quad", "derive_quad", "_q", "q", 'nanq("")',
                     _native_ops("derive_quad", "q"), False, "_q"),
}
TAYLOR_FILES = {"taylor": ("double", "float", "long double", "double-double"), "taylor_quad": ("quad",)}


def taylor_skip_flags(model: str, ctype: str) -> tuple[str, ...]:
    """-D<M>_TAYLOR_SKIP_<KEY> for every variant of <model>_taylor.c but the one of C type
    `ctype` (contract.Precision.ctype): a run compiles only the precision it runs in, which
    at a fixed, unrolled order is most of the compile time."""
    keep = _skip_key(ctype)
    keys = [TAYLOR_VARIANTS[v]["key"] for v in TAYLOR_FILES["taylor"]]
    if keep not in keys:
        raise ValueError(f"{model}_taylor.c has no {ctype} variant")
    return tuple(f"-D{model.upper()}_TAYLOR_SKIP_{k}" for k in keys if k != keep)


# The public functions of <model>_taylor.c, each a call of derive_taylor.h's static one:
# (return type, name, parameters, the arguments); {R}: the real type, {P}: the model.
# The prototypes are <model>_taylor.h's.
PUBLIC = (
    ("int", "taylor_coefficients", "const {R} *y, const {R} *p, int order, {R} *coef, double sine_min",
     "y, p, order, coef, sine_min"),
    ("int", "taylor", "const {R} *y0, const {R} *p, long nt, const {R} *t_out, {R} *y_out, "
     "const {P}_integrate_options *opt, {P}_integrate_info *info", "y0, p, nt, t_out, y_out, opt, info"),
    ("long", "taylor_batch", "long n, const {R} *y0, long y0_stride, const {R} *p, long p_stride, long nt, "
     "const {R} *t, {R} *y_out, const {P}_integrate_options *opt, {P}_integrate_info *info",
     "n, y0, y0_stride, p, p_stride, nt, t, y_out, opt, info"),
)
LIBRARY = ("derive_dd.h", "derive_taylor_math.h", "derive_taylor.h")      # derive/codegen/backends/c/library/


# a time-dependent model's taylor_coefficients takes the time first, as its kernels do (t[0])
TIMED_COEFFICIENTS = ("const {R} *t, ", "t, ")


def _public(P: str, v: dict, timed: bool = False) -> list[dict]:
    out = []
    for ret, fn, params, args in PUBLIC:
        if timed and fn == "taylor_coefficients":
            params, args = TIMED_COEFFICIENTS[0] + params, TIMED_COEFFICIENTS[1] + args
        out.append({"head": f"{ret} {P}_{fn}{v['s']}({params.format(R=v['ctype'], P=P)})",
                    "body": f"return derive_{fn}{v['tag']}({args});"})
    return out


def library_context(name: str, info) -> dict:
    """What derive_taylor.h (and derive_taylor_lanes.h) need of a model, once per file: the
    status codes, the info's scalars to clear and the order rule (contract.py), rendered."""
    M = name.upper()
    return {"status_names": [(f"{M}_INTEGRATE_{s.macro}", f"DERIVE_{s.macro}") for s in STATUS_TABLE],
            "info_clear": " ".join(f"(info)->{f.name} = 0;" for f in INFO if not f.length),
            "order_for": TAYLOR_ORDER_RULE}


def render_taylor(name: str) -> dict[str, str]:
    """<name>_taylor.{h,c} and <name>_taylor_quad.{h,c}: the jet of one model on the
    precision ladder and the glue that includes derive_taylor.h for each precision (C
    backend artifact), from one template; the library headers copied beside them."""
    info = model_info(name)
    d = rhs_decomposition(name)
    slots = _slots(name)
    kinds = counts(d)
    M = name.upper()
    called = uses(d)
    compact = compact_context(compact_statements(d))
    out = {}
    for stem, names in TAYLOR_FILES.items():
        variants = [dict(TAYLOR_VARIANTS[v], taylor=c_statements(d, TAYLOR_VARIANTS[v], slots),
                         public=_public(name, TAYLOR_VARIANTS[v], d.timed)) for v in names]
        header = f"{name}_{stem}.h"
        ctx = {"P": name, "M": M, "title": info.title, "variants": variants, "nops": len(d.ops),
               "uses": {k: k in called for k in TAYLOR_CALLS},
               "nconst": len(d.constants), "timed": d.timed, "inline_max": inline_max(d), "reads_time": d.reads_time,
               "compact": compact, "unroll_max": unroll_max(d), **ORDER_RULE, **library_context(name, info), "header": header,
               "guard": f"{M}_{stem.upper()}_H", "quad": "quad" in names, "dd": "double-double" in names,
               "precisions": _precisions([TAYLOR_VARIANTS[v] for v in names]),
               "op_summary": ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())),
               "nparams": f"{M}_N_PARAMS + {M}_N_INPUTS" if info.n_inputs else f"{M}_N_PARAMS"}
        out[f"c/{header}"] = render("c/taylor.h.jinja", dict(ctx, template="templates/c/taylor.h.jinja"))
        out[f"c/{name}_{stem}.c"] = render("c/taylor.c.jinja", dict(ctx, template="templates/c/taylor.c.jinja"))
    out.update(library_files(LIBRARY))
    return out


def _precisions(variants: list[dict]) -> str:
    parts = [f"{v['name']} (suffix {v['s']})" if v["s"] else f"{v['name']} (no suffix)" for v in variants]
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def taylor_problem(name: str) -> str | None:
    """Why model `name` has no Taylor integrator (an operation without a recurrence), or
    None.  Explicit time is no problem: t is a variable of the jet."""
    try:
        rhs_decomposition(name)
    except SpecError as exc:
        return str(exc)
    return None

