"""Kernel specifications: what each generated function computes, as SymPy data.

A kernel is named inputs (vectors of symbols, one symbol per array slot),
named outputs (arrays of expressions in row-major order), an ordered list of
*stages* (intermediate symbols defined by expressions of the inputs and of
earlier stages; the in-code linear solve lives here) and *guards* (the polar
sines: the chart is singular where one of them is small).

``model_spec(derivation)`` builds the kernels of one model.  It is the same
function for every model and looks only at what the derivation has: a
Hamiltonian form, the seed's reduced (paper) forms, polar sines, and which
other models share its link structure (chart conversions).
"""
from __future__ import annotations

import keyword
import re
from dataclasses import dataclass, field
from math import prod

import sympy as sp
from sympy.core.function import AppliedUndef

from ..errors import SpecError
from ..model import load_model, model_names
from ..model.atlas import atlas_family
from ..derivation.symbolic import by_engine
from ..derivation.symbols import t as TIME
from . import chart_kernels as charts, solve
from .names import internal


@dataclass(frozen=True)
class Vector:
    """An input vector kind: its symbols in slot order and the names of its slots."""
    key: str                          # 'state', 'param', 'canonical'
    count: str                        # size macro stem: STATES, PARAMS, CANONICAL
    table: str                        # name table: state_names, param_names, ...
    symbols: tuple[sp.Symbol, ...]
    doc: str

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.symbols)

    @property
    def size(self) -> int:
        return len(self.symbols)


@dataclass(frozen=True)
class Input:
    name: str                         # argument name in the generated code
    vector: Vector

    @property
    def size(self) -> int:
        return self.vector.size


@dataclass(frozen=True)
class Output:
    name: str
    shape: tuple[int, ...]
    exprs: tuple[sp.Expr, ...]        # row-major
    doc: str

    @property
    def size(self) -> int:
        return prod(self.shape)


@dataclass(frozen=True)
class Kernel:
    name: str
    doc: str
    inputs: tuple[Input, ...]
    outputs: tuple[Output, ...]
    stages: tuple[tuple[sp.Symbol, sp.Expr], ...] = ()
    guards: tuple[sp.Expr, ...] = ()  # chart singular where |guard| < POLAR_SINE_MIN


@dataclass(frozen=True)
class ModelSpec:
    name: str
    title: str
    source: str
    vectors: tuple[Vector, ...]
    kernels: tuple[Kernel, ...] = field(default=())
    # what C function names start with (<prefix>_<kernel>); the file name when None.  A
    # model's second file (<model>_linearize) keeps the model's: planar_linearize()
    function_prefix: str | None = None

    @property
    def prefix(self) -> str:
        return self.function_prefix or self.name

    @property
    def is_time_dependent(self) -> bool:
        """Whether some kernel takes the time t (the model is time-dependent)."""
        return any(v.key == "time" for v in self.vectors)

    @property
    def has_guards(self) -> bool:
        return any(k.guards for k in self.kernels)


# -- checks -------------------------------------------------------------------

_IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_TEMP = re.compile(r"^t[0-9]+$")          # reserved for CSE temporaries
RESERVED = frozenset(keyword.kwlist) | {
    # C keywords and names the generated C or Python code uses itself
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef",
    "union", "unsigned", "void", "volatile", "while", "status", "k", "n", "i", "numpy", "shape",
    "dtype", "out", "self", "all", "point_status", "check", "arrays", "value", "size", "name", "kernel", "args",
}


def _where(model: str, kernel: Kernel) -> str:
    return f"model '{model}', kernel '{kernel.name}'"


_NON_REAL = (sp.zoo, sp.oo, -sp.oo, sp.nan, sp.I)      # in the order check_kernel names them


@dataclass
class _Found:
    undefined: set = field(default_factory=set)      # applied undefined functions, q(t)
    derivative: bool = False
    non_real: set = field(default_factory=set)
    symbols: set = field(default_factory=set)        # free symbols


def _scan(expr, seen: set) -> _Found:
    """What check_kernel looks for in `expr`, in one walk over its nodes that skips the
    nodes in `seen` (checked before) and adds the others to it.

    One walk over the expression's graph, each shared subtree once, where atoms(), has()
    and free_symbols walked the whole tree (a Jacobian entry repeats its subtrees many
    times) once for each of the seven things looked for."""
    found = _Found()
    stack = [(expr, False)]
    while stack:
        node, bound = stack.pop()
        if node in seen:
            continue
        seen.add(node)
        if node.is_Symbol:
            if not bound:
                found.symbols.add(node)
            continue
        if node.is_Atom:
            if node in _NON_REAL:
                found.non_real.add(node)
            continue
        if isinstance(node, AppliedUndef):
            found.undefined.add(node)
        elif isinstance(node, sp.Derivative):
            found.derivative = True
        inner = bound
        if not bound and getattr(node, "bound_symbols", ()):     # Lambda, Subs, Sum, ...: its own free symbols
            found.symbols |= node.free_symbols
            inner = True
        stack.extend((a, inner) for a in node.args)
    return found


def check_kernel(model: str, kernel: Kernel) -> None:
    """Raise SpecError with a readable message when a kernel cannot be generated."""
    where = _where(model, kernel)
    names: dict[str, str] = {}

    def claim(name: str, what: str) -> None:
        if not _IDENT.match(name) or name in RESERVED or _TEMP.match(name):
            raise SpecError(f"{where}: the {what} name '{name}' is not a usable identifier "
                            "(reserved word, CSE temporary name t<N>, or not [A-Za-z][A-Za-z0-9_]*)")
        if name in names and names[name] != what:
            raise SpecError(f"{where}: the name '{name}' is used both as {names[name]} and as {what}")
        names[name] = what

    known: set[sp.Symbol] = set()
    for inp in kernel.inputs:
        claim(inp.name, "input")
        for s in inp.vector.symbols:
            # a model's own names (M, p, lambda, ...): NumPy renames clashing ones
            # (codegen/names.py); C prints every slot as an array element
            if not _IDENT.match(s.name):
                raise SpecError(f"{where}: the slot name '{s.name}' of input '{inp.name}' is not "
                                "an identifier ([A-Za-z][A-Za-z0-9_]*)")
            known.add(s)
    for out in kernel.outputs:
        claim(out.name, "output")
        if len(out.exprs) != out.size:
            raise SpecError(f"{where}: output '{out.name}' has shape {out.shape} "
                            f"but {len(out.exprs)} expressions")

    def inputs_text() -> str:
        return "; ".join(f"{i.name} = ({', '.join(i.vector.names)})" for i in kernel.inputs)

    seen: set = set()           # nodes already checked, in this kernel's earlier expressions

    def check_expr(expr: sp.Expr, what: str) -> None:
        found = _scan(sp.sympify(expr), seen)
        if found.undefined:
            raise SpecError(f"{where}: {what} contains the function '{min(found.undefined, key=str)}'; "
                            "replace q(t) by plain symbols before generating code")
        if found.derivative:
            raise SpecError(f"{where}: {what} contains an unevaluated derivative")
        for bad in _NON_REAL:
            if bad in found.non_real:
                raise SpecError(f"{where}: {what} contains the non-real number {bad}")
        free = sorted(found.symbols - known, key=lambda s: s.name)
        if free:
            raise SpecError(f"{where}: {what} uses '{free[0].name}', which is no input "
                            f"and no earlier stage (inputs: {inputs_text()})")

    for sym, expr in kernel.stages:
        check_expr(expr, f"stage '{sym.name}'")
        if sym in known:
            raise SpecError(f"{where}: stage '{sym.name}' is defined twice or shadows an input")
        claim(sym.name, "stage")
        known.add(sym)
    for j, g in enumerate(kernel.guards):
        check_expr(g, f"guard {j}")
    for out in kernel.outputs:
        for j, e in enumerate(out.exprs):
            check_expr(e, f"output '{out.name}'[{j}]")


def check_spec(spec: ModelSpec) -> None:
    seen: dict[str, Kernel] = {}
    stages: dict[sp.Symbol, sp.Expr] = {}
    for k in spec.kernels:
        if k.name in seen:
            raise SpecError(f"model '{spec.name}': two kernels are named '{k.name}'")
        seen[k.name] = k
        check_kernel(spec.name, k)
        for sym, expr in k.stages:
            if sym in stages and stages[sym] != expr:
                raise SpecError(f"{_where(spec.name, k)}: stage '{sym.name}' is defined "
                                "differently in another kernel of the same file")
            stages[sym] = expr


# -- building the kernels of a model -----------------------------------------

def _vectors(d) -> tuple[Vector, Vector, Vector | None]:
    s = d.symbols
    state = Vector("state", "STATES", "state_names", s.state,
                   "the state: coordinates, then their rates")
    params = Vector("param", "PARAMS", "param_names", s.params, "the parameters")
    canonical = None
    if d.hamiltonian is not None:
        canonical = Vector("canonical", "CANONICAL", "canonical_names", s.q + s.p,
                           "the canonical state: coordinates, then their momenta")
    return state, params, canonical


def dynamics(d) -> solve.Dynamics:
    """The in-code solve of M q'' = F: the seed's block inverse when the paper forms
    are there, else the closed-form 2x2, or L D L^T for any other number of coordinates."""
    if d.paper is not None:
        return solve.ReducedDynamics(d)
    if d.constraints is not None:
        return solve.ConstrainedDynamics(d)
    return solve.MassMatrixDynamics(d)


def model_spec(d) -> ModelSpec:
    model, s = d.model, d.symbols
    state, params, canonical = _vectors(d)
    y, p = Input("y", state), Input("p", params)
    # run-time inputs (u): an argument of their own, of the kernels whose outputs use them
    inputs = Vector("input", "INPUTS", "input_names", s.u, "the run-time inputs") if s.u else None
    yp = (y, p) if inputs is None else (y, p, Input("u", inputs))
    nq, n, dim = len(s.q), len(s.state), model.dimension
    guards = tuple(d.polar_sines)
    dyn = dynamics(d)
    mass = solve.MassMatrixStages(d.M)
    kernels = []

    ydot = list(s.qd) + list(dyn.qdd)
    kernels.append(Kernel(
        "rhs", "The first-order state derivative y' = f(y; p): (q', q'') with M q'' = F "
               f"solved in the code ({dyn.method}).",
        yp, (Output("ydot", (n,), tuple(ydot), "y' in state order"),),
        tuple(dyn.stages), guards))

    kernels.append(Kernel(
        "mass_matrix", "The mass matrix M(q) of M q'' = F (reads the coordinates of y only).",
        (y, p), (Output("M", (nq, nq), tuple(mass.symbols_flat), "M, row-major"),),
        tuple(mass.stages), guards))

    kernels.append(Kernel(
        "forcing", "The forcing F(q, q') of M q'' = F" + ("" if d.model.is_conservative else
                   " (with the applied forces Q and the dissipation -dR/dq')") + ".",
        yp, (Output("F", (nq,), tuple(d.F), "F"),)))

    kernels.append(Kernel(
        "energy", "The total energy T + V.",
        (y, p), (Output("E", (), (d.energy,), "T + V"),)))

    pos = [c for tip in d.tips for c in tip]
    kernels.append(Kernel(
        "positions", f"Cartesian positions of the bobs (link tips), shape ({len(d.tips)}, {dim}); "
                     "gravity points along -" + "xyz"[dim - 1] + ".",
        (y, p), (Output("pos", (len(d.tips), dim), tuple(pos), "tip k, axis j at [k][j]"),)))

    # d pos / dt = (d pos / dq) q' + the partial in t (a moving pivot's; zero otherwise),
    # differentiated and expanded by SymEngine (derivation/symbolic.by_engine)
    def tip_velocities(expand, coordinates, q, qd, time):
        return [expand(sum(c.diff(qk) * vk for qk, vk in zip(q, qd)) + c.diff(time[0])) for c in coordinates]

    vel = by_engine(tip_velocities, pos, s.q, s.qd, [TIME])
    kernels.append(Kernel(
        "velocities", f"Cartesian velocities of the bobs (link tips), shape ({len(d.tips)}, {dim}): "
                      "d pos / dt = (d pos / dq) q'" + (" + d pos / dt at fixed q."
                                                          if d.model.is_time_dependent else "."),
        (y, p), (Output("vel", (len(d.tips), dim), tuple(vel), "tip k, axis j at [k][j]"),)))

    if d.constraints is not None:
        kernels += _constraint_kernels(d, dyn, yp, y, p, guards)

    jac = solve.jacobian(dyn, s)
    kernels.append(Kernel(
        "jacobian", "The Jacobian of rhs with respect to y, J[i][k] = d f_i / d y_k, by "
                    "differentiating M q'' = F implicitly and reusing the solve of rhs.",
        yp, (Output("J", (n, n), tuple(jac.exprs), "row-major"),),
        tuple(dyn.stages) + tuple(jac.stages), guards))

    if canonical is not None:
        x = Input("x", canonical)
        h = d.hamiltonian
        qdot = mass.solve(list(s.p), "v")
        pdot = [e.xreplace(dict(zip(s.qd, qdot.symbols))) for e in h.dL_dq]
        kernels.append(Kernel(
            "hamiltonian_rhs", "Hamilton's equations x' = (q', p') for x = (q, p): "
                               "q' = M^-1 p (solved in the code), p' = dL/dq at that q' (seed 001 (3)).",
            (x, p), (Output("xdot", (n,), tuple(qdot.symbols) + tuple(pdot), "x' in canonical order"),),
            tuple(mass.stages) + tuple(qdot.stages)))
        kernels.append(_hamiltonian_jacobian(d, x, p, mass, qdot))
        momenta = [sum(d.M[i, j] * s.qd[j] for j in range(nq)) for i in range(nq)]
        kernels.append(Kernel(
            "to_canonical", "The canonical state x = (q, M q') of a state y = (q, q').",
            (y, p), (Output("x", (n,), tuple(s.q) + tuple(momenta), "x in canonical order"),)))
        vel = mass.solve(list(s.p), "v")
        kernels.append(Kernel(
            "from_canonical", "The state y = (q, M^-1 p) of a canonical state x = (q, p).",
            (x, p), (Output("y", (n,), tuple(s.q) + tuple(vel.symbols), "y in state order"),),
            tuple(mass.stages) + tuple(vel.stages)))

    if guards:
        kernels.append(Kernel(
            "polar_sines", "The chart-quality indicator: the polar sine of each link; "
                           "the chart is singular where one vanishes.",
            (Input("y", state),), (Output("sines", (len(guards),), guards, "one per link"),), (), guards))
        for target in conversion_targets(model):
            conv = charts.conversion(model, load_model(target), s)
            kernels.append(Kernel(
                f"to_{target}", f"The same configuration and motion in the chart of model "
                                f"'{target}' (seed 000 (5.1)-(5.14), robust atan2 forms; rates "
                                "via the chart Jacobians).",
                (Input("y", state),),
                (Output("y_out", (n,), tuple(conv.exprs), f"state of '{target}'"),),
                tuple(conv.stages), tuple(conv.guards)))

    kernels, time = _with_time(kernels, d)
    vectors = (state, params) + ((inputs,) if inputs is not None else ()) + \
        ((canonical,) if canonical is not None else ()) + ((time,) if time is not None else ())
    spec = ModelSpec(model.name, model.title, model.source, vectors,
                     tuple(_normalise(k) for k in kernels))
    check_spec(spec)
    return spec


def _constraint_kernels(d, dyn, yp, y: Input, p: Input, guards) -> list[Kernel]:
    """A closed loop's kernels: the residuals (Phi, J q') the run time reports as the
    drift, J for projecting a state onto the constraints, and the multipliers lambda
    (the constraint forces J^T lambda) from the solve of rhs."""
    c, nq = d.constraints, len(d.symbols.q)
    m = c.J.rows
    q = sp.Matrix(d.symbols.q)
    # d(Phi, J q')/dy: its null space is the tangent space of the constrained motion's states
    G = sp.Matrix(sp.BlockMatrix([[c.J, sp.zeros(m, nq)], [c.velocity.jacobian(q), c.J]]))
    return [
        Kernel("constraints", "The loop closure's residuals: Phi(q) and J q', both zero on the "
                              "constrained motion (the drift a run reports).",
               (y, p), (Output("phi", (m,), tuple(c.Phi), "Phi, one per constraint"),
                        Output("phi_dot", (m,), tuple(c.velocity), "J q', one per constraint"))),
        Kernel("constraint_jacobian", "J = dPhi/dq, shape (constraints, coordinates) (reads the "
                                      "coordinates of y only).",
               (y, p), (Output("Jc", (m, nq), tuple(c.J), "row-major"),)),
        Kernel("constraint_state_jacobian", "G = d(Phi, J q')/dy, shape (2 constraints, states): "
                                            "its null space is the tangent space of the states on "
                                            "the loop (a variational vector stays in it).",
               (y, p), (Output("G", (2 * m, 2 * nq), tuple(G.applyfunc(sp.expand)), "row-major"),)),
        Kernel("multipliers", "The Lagrange multipliers lambda of M q'' + J^T lambda = F, J q'' = gamma "
                              f"({dyn.method}); J^T lambda is the generalized constraint force, with "
                              "the sign of a force the loop takes out of F.",
               yp, (Output("lam", (m,), tuple(dyn.multipliers), "lambda, one per constraint"),),
               tuple(dyn.stages), guards),
    ]


LINEARIZE = "linearize"      # the kernel, and the suffix of its file: <model>_linearize


def linearize_spec(d, model: ModelSpec | None = None) -> ModelSpec:
    """The file <model>_linearize: one kernel writing A = df/dy and (for a model with
    inputs) B = df/du of y' = f(y; p, u), both by differentiating M q'' = F implicitly,
    d q''/dz = M^-1 (dF/dz - (dM/dz) q''), through the in-code solve of rhs (derive/codegen/
    solve.py): M^-1 F is never formed, whatever the size of the model.  A file of its own,
    so the model's kernel file stays as it was; its A is the model file's jacobian J, taken
    from `model` (its ModelSpec) when given rather than differentiated again.

    Parameters
    ----------
    d : Derivation
        The model's derivation.
    model : ModelSpec, optional
        model_spec(d), whose jacobian kernel's J and stages A reuses.

    Returns
    -------
    ModelSpec
        Named <model>_linearize, its C functions prefixed with the model's name.
    """
    s = d.symbols
    state, params, _ = _vectors(d)
    y, p = Input("y", state), Input("p", params)
    dyn = dynamics(d)
    nq, n = len(s.q), len(s.state)
    known = next((k for k in model.kernels if k.name == "jacobian"), None) if model is not None else None
    if known is not None:           # J of the model file: its expressions and stages, as they are
        exprs, stages = known.outputs[0].exprs, list(known.stages)
    else:
        jac = solve.jacobian(dyn, s)
        exprs, stages = tuple(jac.exprs), list(dyn.stages) + list(jac.stages)
    outputs = [Output("A", (n, n), tuple(exprs), "A = df/dy, row-major")]
    inputs, vectors = (y, p), (state, params)
    if s.u:
        u_vector = Vector("input", "INPUTS", "input_names", s.u, "the run-time inputs")
        inputs, vectors = (y, p, Input("u", u_vector)), (state, params, u_vector)
        B = sp.zeros(n, len(s.u))
        for k, uk in enumerate(s.u):
            col, st = dyn.derivative(uk)
            stages += st
            for i in range(nq):
                B[nq + i, k] = col[i]
        outputs.append(Output("B", (n, len(s.u)), tuple(B), "B = df/du, row-major"))
    doc = ("The linearisation of rhs at (y, u): A = df/dy" + (", B = df/du" if s.u else "") +
           ", by differentiating M q'' = F implicitly and reusing the solve of rhs.")
    kernel = Kernel(LINEARIZE, doc, inputs, tuple(outputs), tuple(stages), tuple(d.polar_sines))
    (kernel,), time = _with_time([kernel], d)        # at the time t, for a time-dependent model
    vectors += (time,) if time is not None else ()
    spec = ModelSpec(f"{d.model.name}_{LINEARIZE}", d.model.title, d.model.source, vectors,
                     (_normalise(kernel),), function_prefix=d.model.name)
    check_spec(spec)
    return spec


def _with_time(kernels: list[Kernel], d) -> tuple[list[Kernel], Vector | None]:
    """A time-dependent model's kernels whose expressions use the time t take it as their
    first argument, a vector of one slot (`<m>_rhs(t, y, p, ydot)` with `const double *t`
    in C, `rhs(t, y, p)` with t of shape (..., 1) in NumPy: batched like y, each point at
    its own time).  Every other kernel, and every time-independent model's, is as before."""
    if not d.model.is_time_dependent:
        return kernels, None
    time = Vector("time", "TIME", "time_names", (TIME,),
                  "the time t (a time-dependent model's kernels that use it take it first)")
    used = [any(TIME in sp.sympify(e).free_symbols
                for e in (*(e for o in k.outputs for e in o.exprs), *(e for _, e in k.stages), *k.guards))
            for k in kernels]
    return [Kernel(k.name, k.doc, (Input("t", time), *k.inputs), k.outputs, k.stages, k.guards)
            if uses else k for k, uses in zip(kernels, used)], time


def _hamiltonian_jacobian(d, x: Input, p: Input, mass, qdot) -> Kernel:
    """J of hamiltonian_rhs with respect to x = (q, p), by the chain rule through the
    in-code solve v = q' = M^-1 p: dv/dq_k = -M^-1 (dM/dq_k) v, dv/dp = M^-1, and
    p' = dL/dq(q, v) gives dp'/dx_k = d(dL/dq)/dq_k + sum_j d(dL/dq)/dq'_j dv_j/dx_k.
    Used by the implicit Gauss-Legendre integrators (owned by derive/integration)."""
    s, h = d.symbols, d.hamiltonian
    nq, n = len(s.q), 2 * len(s.q)
    v = list(qdot.symbols)
    at_v = dict(zip(s.qd, v))
    cols = []
    for k, qk in enumerate(s.q):
        r = [-sum(d.M[i, j].diff(qk) * v[j] for j in range(nq)) for i in range(nq)]
        cols.append(mass.apply(r) if any(e != 0 for e in r) else [sp.S.Zero] * nq)
    for k in range(nq):
        cols.append(mass.apply([sp.S.One if i == k else sp.S.Zero for i in range(nq)]))
    stages, dv = [], [[None] * n for _ in range(nq)]
    for k in range(n):
        for j in range(nq):
            e = sp.sympify(cols[k][j])
            if e.is_number:
                dv[j][k] = e
            else:
                dv[j][k] = internal(f"dv{j}_{k}")
                stages.append((dv[j][k], e))
    J = sp.zeros(n, n)
    for i in range(nq):
        g = h.dL_dq[i]
        for k in range(n):
            J[i, k] = dv[i][k]
            e = sum(g.diff(s.qd[j]).xreplace(at_v) * dv[j][k] for j in range(nq))
            if k < nq:
                e += g.diff(s.q[k]).xreplace(at_v)
            J[nq + i, k] = e
    return Kernel(
        "hamiltonian_jacobian", "The Jacobian of hamiltonian_rhs with respect to x = (q, p), "
                                "J[i][k] = d x'_i / d x_k, by the chain rule through q' = M^-1 p "
                                "(solved in the code).",
        (x, p), (Output("J", (n, n), tuple(J), "row-major"),),
        tuple(mass.stages) + tuple(qdot.stages) + tuple(stages))


def _multiple_angles(expr: sp.Expr) -> sp.Expr:
    """sin(2u) -> 2 sin(u) cos(u), cos(2u) -> its polynomial in sin(u), cos(u): one
    trigonometric call fewer, the same accuracy.  Only the double angle: sin(n u) for a
    larger n is a polynomial of degree n whose terms cancel (cos(20 t) written so loses
    about nine digits), and it is cheaper as the one call it is."""
    expr = sp.sympify(expr)
    reps = {f: sp.expand_trig(f) for f in expr.atoms(sp.sin, sp.cos)
            if f.args[0].is_Mul and f.args[0].args[0] in (2, -2)}
    return expr.xreplace(reps) if reps else expr


def _normalise(k: Kernel) -> Kernel:
    return Kernel(k.name, k.doc, k.inputs,
                  tuple(Output(o.name, o.shape, tuple(_multiple_angles(e) for e in o.exprs), o.doc)
                        for o in k.outputs),
                  tuple((s, _multiple_angles(e)) for s, e in k.stages),
                  tuple(_multiple_angles(g) for g in k.guards))


def conversion_targets(model) -> list[str]:
    """The other members of the model's chart atlas (catalogue, or its chain's: see
    derive/model/atlas.py); for a spherical model in no atlas, the catalogue models
    with the same link structure in different spherical charts."""
    if not model.is_chain or not all(charts.is_spherical(link.chart) for link in model.links):
        return []               # (a tree's links are not a catalogue chain's in other charts)
    family = atlas_family(model)
    if family is not None:
        return sorted(m for m in family.charts if m != model.name)
    out = []
    for name in model_names():
        if name == model.name:
            continue
        other = load_model(name)
        if (other.dimension == model.dimension and len(other.links) == len(model.links)
                and all(charts.is_spherical(link.chart) for link in other.links)
                and [l.chart.name for l in other.links] != [l.chart.name for l in model.links]):
            out.append(name)
    return out
