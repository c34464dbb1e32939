"""CSE, ordering and rendering: from kernel specs to text.

One CSE pass (SymEngine's, derivation/symbolic.py; ``sympy.cse`` where SymEngine
cannot take an expression) runs over every stage, guard and output of a file.  Each kernel then takes the temporaries it needs, in
dependency order, renumbered t0, t1, ... so that one kernel's code does not
depend on which other kernels share the file.  Integer powers of compound
expressions get their base as a temporary, so printers can write x*x.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from functools import cache, lru_cache
from pathlib import Path

import jinja2
import sympy as sp
from sympy.core.basic import _args_sortkey

from ..derivation.symbolic import engine_cse
from ..errors import PackageDataError
from .. import paths
from .names import internal
from .opcount import count_ops
from .spec import Kernel, ModelSpec



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
        yield internal(f"{prefix}{i}")
        i += 1


def _free_names(exprs) -> set[sp.Symbol]:
    out = set()
    for e in exprs:
        out |= free_names(sp.sympify(e))
    return out


_PLAIN = (sp.Add, sp.Mul, sp.Pow, sp.Function)


def replaced(expr, rules: dict, memo: dict, renaming: bool = False):
    """expr.xreplace(rules), each node of the roots once (`memo`, kept across the roots of
    a file for this `rules`: they share most of their subtrees, which xreplace walks anew
    for each root).

    A `renaming` (rules from symbols to symbols, one to one) changes no term's coefficient
    and merges no terms, only where each name sorts: a sum or product is then its renamed
    arguments sorted as SymPy sorts them (``_args_sortkey``), without the cost of SymPy's
    evaluation; every other node is rebuilt as usual.
    """
    if not rules:
        return expr
    found = memo.get(expr)
    if found is not None:
        return found
    if expr in rules:
        found = rules[expr]
    elif not expr.args:
        found = expr
    else:
        args = tuple(replaced(a, rules, memo, renaming) for a in expr.args)
        if args == expr.args:
            found = expr
        elif renaming and (expr.is_Add or expr.is_Mul):
            found = expr.func._from_args(sorted(args, key=_args_sortkey))
        else:
            found = expr.func(*args)
    memo[expr] = found
    return found


def renamed(expr, names: dict, memo: dict):
    """expr.xreplace(names) for a renaming (symbols to symbols, one to one), the same
    expression with its arguments in the same order: `replaced` with renaming=True.

    Examples
    --------
    >>> import sympy as sp
    >>> a, b, t0, t1 = sp.symbols("a b t0 t1")
    >>> e = 2*b*sp.sin(a) + a**2*b
    >>> names = {a: t1, b: t0}
    >>> renamed(e, names, {}), renamed(e, names, {}).args == e.xreplace(names).args
    (t0*t1**2 + 2*t0*sin(t1), True)
    """
    return replaced(expr, names, memo, renaming=True)


@lru_cache(maxsize=1 << 18)
def free_names(expr) -> frozenset:
    """expr.free_symbols, each node's remembered: the backends ask it of every assignment
    of every kernel again and again, and free_symbols walked the whole tree each time.

    Parameters
    ----------
    expr : sympy.Basic

    Returns
    -------
    frozenset of sympy.Symbol
    """
    if expr.is_Symbol:
        return frozenset((expr,))
    if not expr.args:
        return frozenset()
    if not isinstance(expr, _PLAIN):             # Piecewise, Integral...: SymPy's own rules
        return frozenset(expr.free_symbols)
    return frozenset().union(*(free_names(a) for a in expr.args))


@lru_cache(maxsize=1 << 18)
def trig_calls(expr) -> tuple:
    """The sin(x) and cos(x) in expr (atoms(sin, cos)), in default_sort_key order, each
    node's remembered."""
    found: set = set()
    stack = [expr]
    while stack:
        e = stack.pop()
        if isinstance(e, (sp.sin, sp.cos)):
            found.add(e)
        stack.extend(e.args)
    return tuple(sorted(found, key=sp.default_sort_key)) if found else ()


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


def varying_symbols(spec: ModelSpec) -> set[sp.Symbol]:
    """Symbols that change from state to state: the state inputs and every stage that
    depends on them.  Parameters (and stages of parameters only) are constant over a batch."""
    varying = {s for v in spec.vectors if v.key != "param" for s in v.symbols}
    for k in spec.kernels:
        for sym, expr in k.stages:
            if sp.sympify(expr).free_symbols & varying:
                varying.add(sym)
    return varying


class _Varies:
    """Whether an expression depends on a varying symbol, each node answered once (the
    roots share their subtrees; free_symbols walked each one's whole tree again)."""

    def __init__(self, varying: set):
        self.varying, self.known = varying, {}

    def __call__(self, expr) -> bool:
        if expr in self.varying:
            return True
        if not expr.args:
            return False
        answer = self.known.get(expr)
        if answer is None:
            answer = self.known[expr] = any(self(a) for a in expr.args)
        return answer


def _split(term: sp.Expr, varies: _Varies) -> tuple[tuple, tuple]:
    """term = Mul(*constant factors) * Mul(*varying factors), as the two tuples of factors
    (in the product's own order: equal varying parts are equal tuples, no product built)."""
    factors = term.args if term.is_Mul else (term,)
    return tuple(f for f in factors if not varies(f)), tuple(f for f in factors if varies(f))


def collect_constants(expr: sp.Expr, varying: set, memo: dict, varies: _Varies | None = None) -> sp.Expr:
    """a*V + b*V -> (a + b)*V when a, b are constant over a batch and V varies.

    Expanded derivations repeat a state-dependent factor with several parameter
    coefficients (g*m1*sin(theta1) + g*m2*sin(theta1)); collecting them saves
    operations on every state (and whole-array operations in NumPy).  `memo` keeps each
    node's result, `varies` (made from `varying` when not given) each node's dependence.
    """
    if expr in memo:
        return memo[expr]
    if expr.is_Atom:
        return expr
    varies = varies or _Varies(varying)
    args = tuple(collect_constants(a, varying, memo, varies) for a in expr.args)
    new = expr.func(*args) if args != expr.args else expr
    if new.is_Add:
        groups: dict[tuple, list[tuple]] = {}
        for term in new.args:
            const, var = _split(term, varies)
            groups.setdefault(var, []).append(const)
        if len(groups) < len(new.args):
            new = sp.Add(*[sp.Add(*[sp.Mul(*c) for c in consts]) * sp.Mul(*var) for var, consts in groups.items()])
    memo[expr] = new
    return new


HOT_KERNEL = "rhs"      # the kernel a file is tuned for: integrators call it at every stage


def _trig_arguments(exprs) -> set[sp.Expr]:
    return {f.args[0] for e in exprs for f in sp.sympify(e).atoms(sp.sin, sp.cos)}


def compound_angle_rewrites(spec: ModelSpec) -> dict[sp.Expr, sp.Expr]:
    """sin(a - b) -> sin(a) cos(b) - cos(a) sin(b) (and cos, and sums of more angles) for
    every compound angle of the hot kernel whose parts are angles it takes sin/cos of anyway.

    A sine and a cosine of one argument cost one sincos (C compilers fuse them; the NumPy
    printer shares one half-angle tangent), so the planar rhs needs sincos(theta1),
    sincos(theta2) instead of those two plus sincos(theta1 - theta2): one transcendental
    call fewer per evaluation for a few multiplications.  Where a part appears in no other
    sin/cos (phi1 - phi2 of the spherical rhs) the angle stays whole, as expanding it would
    add calls.  The rewrite applies to the whole file (stages are shared between kernels).
    """
    hot = [k for k in spec.kernels if k.name == HOT_KERNEL]
    exprs = [e for k in hot for _, e in k.stages] + [e for k in hot for out in k.outputs for e in out.exprs]
    args = _trig_arguments(exprs)
    simple = {a for a in args if not a.is_Add}
    out = {}
    for a in args:
        if a.is_Add and all(t in simple or (-t) in simple for t in a.args):
            for f in (sp.sin, sp.cos):
                out[f(a)] = sp.expand_trig(f(a))
    return out


def cse_file(spec: ModelSpec, also: ModelSpec | None = None, compound_angles: bool = True) -> list[Body]:
    """One CSE pass over all outputs of the file, split back into kernels.

    `also`: a second file whose kernels repeat most of this one's expressions (the model's
    <model>_linearize: A is the jacobian kernel's J).  Its roots join the one pass, those
    equal to one of this file's counted once (so this file's own bodies are what they are
    without it), and its bodies follow this file's in the list returned: the second file
    costs no second CSE pass, and its printers meet expressions already printed.  Without
    `compound_angles`, sin/cos of a compound angle stay whole (compound_angle_rewrites is
    for the scalar kernels: Taylor's jet weighs it by its own costs, codegen/taylor.py)."""
    files = [spec] + ([also] if also is not None else [])
    stage_defs: dict[sp.Symbol, sp.Expr] = {}
    for f in files:
        for k in f.kernels:
            for sym, expr in k.stages:
                stage_defs.setdefault(sym, expr)
    stage_syms = list(stage_defs)
    varying = set().union(*(varying_symbols(f) for f in files))
    roots: list[sp.Expr] = [stage_defs[s] for s in stage_syms]
    spans: list[list[int]] = []
    for k in spec.kernels:
        start = len(roots)
        roots += list(k.guards)
        for out in k.outputs:
            roots += list(out.exprs)
        spans.append(list(range(start, len(roots))))
    first = {}
    for i, r in enumerate(roots):
        first.setdefault(r, i)
    for k in (also.kernels if also is not None else ()):
        span = []
        for r in list(k.guards) + [e for out in k.outputs for e in out.exprs]:
            if r not in first:
                first[r] = len(roots)
                roots.append(r)
            span.append(first[r])
        spans.append(span)
    memo: dict = {}
    varies = _Varies(varying)
    angles = compound_angle_rewrites(spec) if compound_angles else {}
    rewritten: dict = {}
    roots = [collect_constants(replaced(sp.sympify(r), angles, rewritten), varying, memo, varies) for r in roots]

    fresh = _numbered("_cse")
    found = engine_cse(roots, fresh)        # SymEngine's (derivation/symbolic.py), else SymPy's
    repl, reduced = found if found is not None else sp.cse(roots, symbols=_numbered("_cse"), order="canonical")
    defs: dict[sp.Symbol, sp.Expr] = dict(repl)
    for sym, expr in zip(stage_syms, reduced):
        defs[sym] = expr
    reduced = _lift_powers(defs, reduced, _numbered("_pow"))
    position = {sym: i for i, sym in enumerate(list(defs))}

    bodies = []
    counted: dict = {}          # kernels share assignments (stages, the linearize file's A): counted once
    done_renaming: dict = {}    # a kernel's renamed assignments, by what shapes them
    subcounts: dict = {}

    def count(e) -> int:
        if e not in counted:
            counted[e] = count_ops(e, subcounts)
        return counted[e]

    all_kernels = [k for f in files for k in f.kernels]
    for k, span in zip(all_kernels, spans):
        mine = [reduced[i] for i in span]
        order: list[sp.Symbol] = []
        done: set[sp.Symbol] = set()

        def visit(sym):
            if sym in done:
                return
            done.add(sym)
            for dep in sorted(free_names(defs[sym]) & defs.keys(), key=position.__getitem__):
                visit(dep)
            order.append(sym)

        mine = [sp.sympify(e) for e in mine]
        for expr in mine:
            for dep in sorted(free_names(expr) & defs.keys(), key=position.__getitem__):
                visit(dep)
        # a stage of this kernel defined as a bare temporary takes that temporary's
        # place (no copies); done per kernel so stage names stay in their kernels
        kstages = {s for s, _ in k.stages}
        alias: dict[sp.Symbol, sp.Symbol] = {}
        for sym in order:
            target = defs[sym]
            if sym in kstages and target.is_Symbol and target.name.startswith("_") \
                    and target in done and target not in alias:
                alias[target] = sym
        owner = {v: k_ for k_, v in alias.items()}
        order = [alias.get(s, s) for s in order if not (s in owner and defs[s] == owner[s])]
        aliased: dict = {}
        local = {s: renamed(defs[owner[s]], alias, aliased) for s in owner}
        mine = [renamed(e, alias, aliased) for e in mine]
        # every output and guard becomes a name or a number: stored once, checked
        # from registers (no reload of the output array), printed once
        lifted: dict[sp.Expr, sp.Symbol] = {}
        for j, expr in enumerate(mine):
            if not (expr.is_Symbol or expr.is_Number):
                if expr not in lifted:
                    lifted[expr] = internal(f"_out{j}", real=False)
                    local[lifted[expr]] = expr
                    order.append(lifted[expr])
                mine[j] = lifted[expr]
        rename, n = {}, 0
        for sym in order:
            if sym.name.startswith("_"):
                rename[sym] = internal(f"t{n}")
                n += 1
        # alias, then rename, as one substitution (xreplace is simultaneous)
        both = {a: rename.get(b, b) for a, b in alias.items()}
        both.update((a, b) for a, b in rename.items() if a not in both)
        key = (tuple(order), tuple(both.items()), tuple(local.items()))
        by_rename, by_both = {}, {}
        if key not in done_renaming:      # the linearize file's A: the jacobian kernel's assignments again
            done_renaming[key] = [(rename.get(s, s), renamed(local[s], rename, by_rename) if s in local
                                   else renamed(defs[s], both, by_both)) for s in order]
        assignments = done_renaming[key]
        mine = [renamed(sp.sympify(e), rename, by_rename) for e in mine]
        guards = mine[:len(k.guards)]
        outputs, i = [], len(k.guards)
        for out in k.outputs:
            outputs.append(mine[i:i + out.size])
            i += out.size
        # a renaming leaves the count as it is: counted before it, once per expression of the file
        ops = sum(count(local[s] if s in local else defs[s]) for s in order) + sum(count(e) for e in mine)
        used = _free_names([e for _, e in assignments] + mine)
        unused = [inp.name for inp in k.inputs if not (set(inp.vector.symbols) & used)]
        bodies.append(Body(k, assignments, outputs, guards, int(ops), unused))
    return bodies


def half_angle_sincos(assignments: list[tuple[sp.Symbol, sp.Expr]], outputs: list[sp.Expr]
                      ) -> tuple[list[tuple[sp.Symbol, sp.Expr]], list[sp.Expr]]:
    """Every sin(x) and cos(x) from one tangent of the half angle (for NumPy):
    T = tan(x/2), u = T*T, r = 1/(1 + u), sin x = 2 T r, cos x = (1 - u) r.

    NumPy evaluates float64 sin and cos element by element through libm, but tan through
    its SIMD loops (where NumPy ships them, e.g. SVML on AVX-512), several times cheaper
    per element, so one tan and five array operations replace a sin/cos pair for less.
    Accuracy: a few ulp absolute (tested against mpmath); x/2 is exact and |tan(x/2)|
    stays far below overflow for every double x (no double lies within 1e-19 of an odd
    multiple of pi/2).  The new names are sin_<x>/cos_<x> (tan_half_<x>, ...) for a
    named x, numbered otherwise.
    """
    args: list[sp.Expr] = []                 # in order of first use
    for e in [e for _, e in assignments] + [sp.sympify(e) for e in outputs]:
        for f in trig_calls(e):
            if f.args[0] not in args:
                args.append(f.args[0])
    if not args:
        return assignments, outputs
    lowered: dict[sp.Expr, list[tuple[sp.Symbol, sp.Expr]]] = {}
    repl: dict[sp.Expr, sp.Symbol] = {}
    tags: set[str] = set()
    for i, x in enumerate(args):
        tag = x.name if x.is_Symbol else f"a{i}"
        while tag in tags:                   # an input called a0 beside a numbered angle
            tag += "_"
        tags.add(tag)
        T, u, r, sn, cs = (internal(f"{n}_{tag}") for n in ("tan_half", "tan_half_sq", "rho", "sin", "cos"))
        lowered[x] = [(T, sp.tan(sp.Float(0.5) * x)), (u, T ** 2), (r, 1 / (1 + u)),
                      (sn, 2 * T * r), (cs, (1 - u) * r)]
        repl[sp.sin(x)], repl[sp.cos(x)] = sn, cs
    out: list[tuple[sp.Symbol, sp.Expr]] = []
    for sym, e in assignments:
        for f in trig_calls(e):
            out.extend(lowered.pop(f.args[0], []))
        e = e.xreplace(repl)
        if e in repl.values():           # t3 = sin(x): use sin_x itself
            repl[sym] = e
            continue
        out.append((sym, e))
    for x in args:                       # used by outputs only
        out.extend(lowered.pop(x, []))
    return out, [sp.sympify(e).xreplace(repl) for e in outputs]


def live_assignments(assignments: list[tuple[sp.Symbol, sp.Expr]], roots: list[sp.Expr]
                     ) -> list[tuple[sp.Symbol, sp.Expr]]:
    """The assignments the roots need, directly or through other assignments, in order."""
    needed = _free_names(roots)
    kept = []
    for sym, e in reversed(assignments):
        if sym in needed:
            needed |= free_names(e)
            kept.append((sym, e))
    return kept[::-1]


@dataclass
class TrigLanes:
    """sin/cos of a kernel's angles as lanes of one vector call each (see trig_lanes)."""
    angles: list[sp.Expr]                     # lane k holds angles[k], arithmetic on the inputs
    values: list[tuple[sp.Symbol, str, int]]  # (name, "sin"|"cos", lane): lane_<f>[k] copied out


def _inline_arithmetic(expr: sp.Expr, defs: dict) -> sp.Expr | None:
    """expr with every temporary replaced by its definition, or None when one of them
    calls a function (only angles of plain arithmetic on the inputs become lanes)."""
    while expr.free_symbols & defs.keys():
        expr = expr.xreplace({s: defs[s] for s in expr.free_symbols & defs.keys()})
    return None if expr.atoms(sp.Function) else expr


def trig_lanes(assignments: list[tuple[sp.Symbol, sp.Expr]], outputs: list[sp.Expr]
               ) -> tuple[TrigLanes | None, list[tuple[sp.Symbol, sp.Expr]], list[sp.Expr]]:
    """Gather the sin(x) and cos(x) of a kernel whose angle x is arithmetic on its inputs
    into lanes: one loop over the angles computes them all (C, double).

    Compiled with glibc's libmvec (-DDERIVE_VECTOR_MATH; see loader.VECTOR_MATH_FLAGS) the
    loop is one 2-lane vector sin and one vector cos per pair of angles instead of a
    scalar sincos per angle, which is cheaper.  Compiled without it, the loop is plain C
    and costs what the scalar calls cost.  libmvec's sin/cos are accurate to 4 ulp (glibc's manual), against
    1 ulp for the scalar ones.  Needs two angles at least; returns (None, unchanged) else.
    """
    defs = dict(assignments)
    named = {e: sym for sym, e in reversed(assignments) if isinstance(e, (sp.sin, sp.cos))}
    angles: list[sp.Expr] = []
    repl: dict[sp.Expr, sp.Symbol] = {}
    values: list[tuple[sp.Symbol, str, int]] = []
    for e in [e for _, e in assignments] + [sp.sympify(e) for e in outputs]:
        for f in trig_calls(e):
            angle = _inline_arithmetic(f.args[0], defs)
            if f in repl or angle is None:
                continue
            if angle not in angles:
                angles.append(angle)
            kind, k = f.func.__name__, angles.index(angle)
            # a temporary t = sin(x) keeps its name, so the rest prints as before: GCC's
            # schedule follows the printed operand order (fresh names, sorting
            # differently, give the abm12 loop a slower schedule)
            repl[f] = named.get(f) or internal(f"{kind}_lane{k}")
            values.append((repl[f], kind, k))
    if len(angles) < 2:
        return None, assignments, outputs
    lanes = {sym for sym, _, _ in values}
    out = [(sym, e.xreplace(repl)) for sym, e in assignments if sym not in lanes]
    outputs = [sp.sympify(e).xreplace(repl) for e in outputs]
    # a temporary that only fed an angle (phi1 - phi2, now inlined into its lane) is dropped
    return TrigLanes(angles, values), live_assignments(out, outputs), outputs


def lanes_context(lanes: TrigLanes | None, printer) -> dict | None:
    """What templates/c/vector_math.jinja's lanes macro prints, the angles by `printer`."""
    if lanes is None:
        return None
    n = len(lanes.angles)
    kinds = [f for f in ("sin", "cos") if any(kind == f for _, kind, _ in lanes.values)]
    return {"n": n, "angles": ", ".join(printer.doprint_checked(a) for a in lanes.angles),
            "sin": "sin" in kinds, "cos": "cos" in kinds, "arrays": ", ".join(f"lane_{f}[{n}]" for f in kinds),
            # copied into scalars: GCC keeps them in registers (read from the arrays where they
            # are used, the abm12 loop ran 25% slower here)
            "values": [{"name": sym.name, "kind": kind, "lane": k} for sym, kind, k in lanes.values]}


def environment() -> jinja2.Environment:
    """The Jinja2 environment of the code templates (derive/templates/).

    Returns
    -------
    jinja2.Environment
        One per templates folder and process: a template (and every macro file it imports)
        is compiled once, however many files render it; one whose compiled form ships in
        templates/compiled/ (and is current) is not compiled at all.
    """
    return _environment(str(paths.templates_dir()))


_SETTINGS = dict(undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
                 keep_trailing_newline=True, autoescape=False)
COMPILED = "compiled"           # templates/compiled/: the code templates as Jinja2 compiles them
MANIFEST = "manifest.json"      # there: the Jinja2 version and each template's SHA-256


@cache
def _environment(folder: str) -> jinja2.Environment:
    source = jinja2.FileSystemLoader(folder)
    compiled = Path(folder) / COMPILED
    if not (compiled / MANIFEST).is_file():
        return jinja2.Environment(loader=source, **_SETTINGS)
    return jinja2.Environment(loader=jinja2.ChoiceLoader([_Precompiled(compiled, Path(folder)), source]),
                              **_SETTINGS)


@cache
def _source_environment(folder: str) -> jinja2.Environment:
    """The environment that compiles every template from its source (what
    templates/compiled/ is made with)."""
    return jinja2.Environment(loader=jinja2.FileSystemLoader(folder), **_SETTINGS)


class _Precompiled(jinja2.ModuleLoader):
    """The templates of templates/compiled/, each only while it is current: made by the
    Jinja2 in use from the template's present text (manifest.json holds both), else the
    next loader compiles the template from its source.

    Why: compiling the C and NumPy templates (parsing, generating Python, compiling that)
    took about 0.13 s of every fresh process, a sixth of `derive generate` of a small
    model; the compiled modules ship in the package as .py files (pip byte-compiles them
    on install), as derive's own modules do."""

    def __init__(self, compiled: Path, sources: Path):
        super().__init__(str(compiled))
        self.sources = sources
        manifest = json.loads((compiled / MANIFEST).read_text())
        self.digests = manifest["templates"] if manifest.get("jinja2") == jinja2.__version__ else {}

    def load(self, environment, name, globals=None):
        digest = self.digests.get(name)
        path = self.sources / name
        if digest is None or not path.is_file() or _digest(path.read_bytes()) != digest:
            raise jinja2.TemplateNotFound(name)
        return super().load(environment, name, globals)


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _code_template(name: str) -> bool:
    return name.endswith(".jinja") and not name.startswith(COMPILED + "/")


def compiled_templates() -> dict[str, str]:
    """templates/compiled/ as the Jinja2 in use makes it from the templates now: file name ->
    text (a module per code template, and manifest.json).  `derive generate` writes it
    beside the golden generated/ and `derive generate --check` compares it.

    Returns
    -------
    dict
        ``{"tmpl_<sha1 of the name>.py": Python source, ..., "manifest.json": ...}``.
    """
    folder = paths.templates_dir()
    env = _source_environment(str(folder))
    files, digests = {}, {}
    for name in env.list_templates(filter_func=_code_template):
        text = (folder / name).read_text()
        files[jinja2.ModuleLoader.get_module_filename(name)] = env.compile(text, name, f"templates/{name}",
                                                                         raw=True, defer_init=True)
        digests[name] = _digest(text.encode())
    files[MANIFEST] = json.dumps({"jinja2": jinja2.__version__, "templates": digests}, indent=1,
                                 sort_keys=True) + "\n"
    return dict(sorted(files.items()))


def render(template: str, context: dict) -> str:
    try:
        found = environment().get_template(template)
    except jinja2.TemplateNotFound as exc:
        raise PackageDataError(f"template {exc.name} is missing from {paths.templates_dir()}; "
                               f"reinstall derive") from None
    return found.render(**context)
