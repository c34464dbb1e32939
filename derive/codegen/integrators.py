"""Render the integrators: C (float, double, long double) and NumPy, per model, and the atlas.

The C method code is a hand-written library, derive/codegen/backends/c/library/
(derive_integrators.h: the methods and a model's context; derive_driver.h: the stepping
loop, shared with the atlas), copied verbatim beside the generated files; what is
rendered is per model a thin <model>_integrate.c (the model's kernels, guards and
structs given to the library, included once per real type, and the public functions)
and once for every model derive_tableaus.h, the coefficients.  Python decides
everything numeric here (tableau literals per precision, the linear combinations of
stages, which system the implicit methods use); the templates under
templates/c/integrate*.jinja, templates/c/tableaus.h.jinja, templates/c/atlas*.jinja and
templates/numpy/integrate*.jinja, templates/numpy/atlas*.jinja only lay it out.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import mpmath

from .emit import render
from .printers import CPrinter, PyNumPyPrinter
from ..derivation import derive
from ..model.description import forget_on_model_change
from . import contract, tableau as tb
from ..model import load_chart, load_model
from ..model.atlas import ATLAS, load_atlas
from ..derivation.chart_rule import RULE_CHARTS, _sines_of_unit, rule_models, rule_sines
from .contract import (ADAPTIVE, ATLAS_CHARTS, IMPLICIT, METHODS,  # noqa: F401  (re-exported)
                       SINE_MIN, SINE_RULE, SINE_SWITCH)
from ..errors import SpecError
from ..paths import VERSION as __version__, c_library_file, numpy_library_file

NEWTON_THETA_MAX = "0.5"  # implicit methods: a contraction rate above this re-evaluates the Jacobian
NEWTON_THETA_DIVERGE = "2"   # implicit methods: an increment growing this much is NEWTON at once


_C_VARIANTS = (("double", "", ""), ("float", "_f", "f"), ("long double", "_l", "l"))
_EPS = {"double": "2.220446049250313e-16", "float": "1.1920929e-07f",
        "long double": "1.08420217248550443401e-19L"}
_NAN = {"double": 'nan("")', "float": 'nanf("")', "long double": 'nanl("")'}


@dataclass(frozen=True)
class ModelInfo:
    name: str
    title: str
    n: int
    n_params: int
    has_ham: bool
    nguards: int
    state_names: tuple[str, ...]
    param_names: tuple[str, ...]
    input_names: tuple[str, ...] = ()      # run-time inputs: the integrators take them after p

    @property
    def n_inputs(self) -> int:
        return len(self.input_names)


@forget_on_model_change
@lru_cache(maxsize=None)
def model_info(name: str) -> ModelInfo:
    d = derive(name)
    s = d.symbols
    return ModelInfo(name, d.model.title, len(s.state), len(s.params), d.hamiltonian is not None,
                     len(d.polar_sines), tuple(x.name for x in s.state), tuple(x.name for x in s.params),
                     tuple(x.name for x in s.u))


def _combo(terms, ctype: str, array: str = "K", index: str = "k") -> str:
    """sum_j coef_j * K[j][k] with the literals of ctype; zero coefficients dropped."""
    parts = []
    for j, v in terms:
        if v == 0:
            continue
        lit = tb.literal(v, ctype)
        parts.append(f"{lit} * {array}[{j}][{index}]")
    return " + ".join(parts) if parts else "0"


def _stages(t: tb.Tableau, rows, ctype: str) -> list[dict]:
    """Stages `rows` of tableau t: each one's combination of the stages before it and its
    node c_i (the stage's time is t + c_i h: a time-dependent model's rhs reads it)."""
    return [{"index": i, "combo": _combo(t.row(i), ctype), "c": tb.literal(t.c[i], ctype)} for i in rows]


def _explicit(ctype: str) -> list[dict]:
    out = []
    rk4 = tb.load("rk4")
    out.append({"name": "rk4", "title": "Classical RK4 (seed 001).", "error": "none",
                "stages": _stages(rk4, range(1, 4), ctype),
                "b_combo": _combo(list(enumerate(rk4.b)), ctype)})
    d5 = tb.load("dopri5")
    out.append({"name": "dopri5", "title": "Dormand-Prince 5(4): stages 1-5, y_new, FSAL stage 6, error.",
                "error": "dopri5", "fsal": 6,
                "stages": _stages(d5, range(1, 6), ctype),
                "b_combo": _combo(d5.row(6), ctype),
                "e_combo": _combo(sorted(d5.extra["e"].items()), ctype)})
    d8 = tb.load("dop853")
    b = dict(d8.row(12))
    e3 = [(j, b.get(j, mpmath.mpf(0)) - d8.extra["e3_minus"].get(j, mpmath.mpf(0))) for j in range(12)]
    with mpmath.workdps(tb.DIGITS):
        e3 = [(j, b.get(j, mpmath.mpf(0)) - d8.extra["e3_minus"].get(j, mpmath.mpf(0))) for j in range(12)]
    out.append({"name": "dop853", "title": "Dormand-Prince 8(5,3): stages 1-11, y_new, error as in Hairer's DOP853.",
                "error": "dop853",
                "stages": _stages(d8, range(1, 12), ctype),
                "b_combo": _combo(d8.row(12), ctype),
                "e3_combo": _combo(e3, ctype),
                "e5_combo": _combo(sorted(d8.extra["e5"].items()), ctype)})
    return out


def _dopri5_dense(ctype: str) -> tuple[list[dict], str]:
    d5 = tb.load("dopri5")
    p = d5.extra["p"]
    rows, combo = [], []
    for k in range(7):
        coefs = [p.get((k, j), mpmath.mpf(0)) for j in range(4)]
        if all(c == 0 for c in coefs):
            continue
        expr = tb.literal(coefs[3], ctype)
        for j in (2, 1, 0):
            expr = f"{tb.literal(coefs[j], ctype)} + theta * ({expr})"
        rows.append({"index": k, "poly": f"theta * ({expr})"})
        combo.append(f"b{k} * K[{k}][k]")
    return rows, " + ".join(combo)


def _dop853_dense(ctype: str) -> tuple[list[dict], list[dict]]:
    d8 = tb.load("dop853")
    extra = _stages(d8, range(13, 16), ctype)
    d = d8.extra["d"]
    rows = []
    for r in range(4):
        rows.append({"index": 3 + r, "combo": _combo(sorted((j, v) for (i, j), v in d.items() if i == r), ctype)})
    return extra, rows


def _gauss(ctype: str) -> list[dict]:
    out = []
    for name, title in (("midpoint", "The implicit midpoint rule (1-stage Gauss-Legendre, order 2)."),
                        ("gauss2", "2-stage Gauss-Legendre (order 4).")):
        t = tb.load(name)
        ns = t.stages
        A = [t.a.get((i, j), mpmath.mpf(0)) for i in range(ns) for j in range(ns)]
        out.append({"name": name, "title": title, "ns": ns,
                    "A": ", ".join(tb.literal(x, ctype) for x in A),
                    "c": ", ".join(tb.literal(x, ctype) for x in t.c),
                    "d": ", ".join(tb.literal(x, ctype) for x in tb.gauss_d(t))})
    return out


ABM_STEPS = 12        # abm12: the k of the Adams pair (the benchmark loops' sweet spot, throughput.py)


def _adams(ctype: str) -> dict:
    """abm12's weights (tableau.adams: exact rationals) as literals of ctype."""
    ab, am = tb.adams(ABM_STEPS)
    lits = lambda w: ", ".join(tb.literal(tb.value(str(x)), ctype) for x in w)
    milne = tb.literal(tb.value(str(tb.adams_milne(ABM_STEPS))), ctype)
    return {"k": ABM_STEPS, "ab": lits(ab), "am": lits(am), "milne": milne}


@lru_cache(maxsize=None)
def c_variants() -> list[dict]:
    out = []
    for ctype, suffix, m in _C_VARIANTS:
        dense5, combo5 = _dopri5_dense(ctype)
        extra8, d8 = _dop853_dense(ctype)
        out.append({"ctype": ctype, "s": suffix, "m": m, "eps": _EPS[ctype], "nan": _NAN[ctype],
                    "explicit": _explicit(ctype), "dopri5_dense": dense5, "dopri5_dense_combo": combo5,
                    "dop853_extra": extra8, "dop853_d": d8, "gauss": _gauss(ctype), "abm": _adams(ctype)})
    return out


def _wrap(head: str, items: list[str], close: str, width: int) -> str:
    """head + items joined by ", ", wrapped greedily at `width` under the opening bracket."""
    indent, lines, cur = " " * len(head), [], head
    for i, item in enumerate(items):
        piece = item + (close if i == len(items) - 1 else ",")
        if cur.strip() and cur != head and len(cur) + 1 + len(piece) > width:
            lines.append(cur)
            cur = indent + piece
        else:
            cur += ("" if cur == head else " ") + piece
    return "\n".join(lines + [cur])


def _c_decl(f, n: str) -> str:
    if f.ctype.endswith("*"):
        return f"{f.ctype}{f.name};"
    return f"{f.ctype} {f.name}[{n}];" if f.length else f"{f.ctype} {f.name};"


def _c_struct(fields, n: str, M: str) -> list[str]:
    """One field a line, comments from column 24 (<M>_integrate.h)."""
    out = []
    for f in fields:
        decl = _c_decl(f, n)
        if f.doc:
            decl = (decl.ljust(20) if len(decl) < 20 else decl + "   ") + f"/* {f.doc.format(M=M)} */"
        out.append("    " + decl)
    return out


def _c_struct_grouped(fields, n: str) -> list[str]:
    """Consecutive fields of one C type on one line, commented ones alone (spherical_atlas.h)."""
    out, group = [], []

    def flush():
        if group:
            out.append(f"    {group[0].ctype} {', '.join(g.name for g in group)};")
            group.clear()
    for f in fields:
        if f.atlas_doc or f.length or (group and group[0].ctype != f.ctype):
            flush()
        if f.atlas_doc or f.length:
            decl = _c_decl(f, n)
            pad = decl.ljust(21) if len(decl) < 21 else decl + " "
            out.append("    " + (pad + f"/* {f.atlas_doc} */" if f.atlas_doc else decl))
        else:
            group.append(f)
    flush()
    return out


def contract_c(M: str, prefix: str, n: str, sine_min_macro: str) -> dict:
    """The run contract (derive/codegen/contract.py) as the C templates print it:
    `prefix` names the macros (<M>_METHOD_*, <prefix>_*), `n` the state array's length."""
    width = max(len(s.macro) for s in contract.STATUS_TABLE) + len("_INTEGRATE_") + 2
    doc = []
    for s in contract.STATUS_TABLE:
        lines = [x.format(theta_max=NEWTON_THETA_MAX, theta_diverge=NEWTON_THETA_DIVERGE) for x in s.doc]
        doc.append(f" *   {M}{('_INTEGRATE_' + s.macro).ljust(width)}{s.code}  {lines[0]}")
        doc += [" *" + " " * 40 + x for x in lines[1:]]
    defaults = [(f.name, f.c_default or sine_min_macro) for f in contract.OPTIONS]
    return {
        "method_defines": [(f"{M}_METHOD_{m.macro}", m.index) for m in contract.METHOD_TABLE],
        "method_docs": [f"{m.macro.ljust(10)}{m.doc}" for m in contract.METHOD_TABLE],
        "status_defines": [(f"{prefix}_{s.macro}", s.code) for s in contract.STATUS_TABLE],
        "status_cases": [(f"{prefix}_{s.macro}", s.name) for s in contract.STATUS_TABLE],
        "status_doc": doc,
        "option_defaults": defaults,
        "options_fields": _c_struct(contract.OPTIONS, n, M),
        "info_fields": _c_struct(contract.INFO, n, M),
        "atlas_options_fields": _c_struct_grouped(contract.OPTIONS + contract.ATLAS_OPTIONS, n),
        "atlas_info_fields": _c_struct_grouped(contract.INFO + contract.ATLAS_INFO, n),
    }


def contract_numpy() -> dict:
    """The run contract as the NumPy templates print it."""
    names = [f'"{x}"' for x in contract.STATUS_NAMES]
    init = {"int": "0", "long": "0", "double": "0.0"}      # the status field: OK (0)
    info = [f'"{f.name}": {"None" if f.length else init[f.ctype]}' for f in contract.INFO]
    return {
        "status_unpack": f"{', '.join(s.macro for s in contract.STATUS_TABLE)} = range({len(contract.STATUS_TABLE)})",
        "status_codes": _wrap("STATUS_CODES = {", [f'"{s.macro}": {s.code}' for s in contract.STATUS_TABLE], "}", 88),
        "status_names": _wrap("STATUS_NAMES = (", names, ")", 88),
        "methods": "METHODS = (" + ", ".join(f'"{m}"' for m in contract.METHODS) + ")",
        "defaults": _wrap("DEFAULTS = {", [f'"{f.name}": {f.py_default}' for f in contract.OPTIONS], "}", 88),
        "info": _wrap("INFO = {", info, "}", 88),
    }


SOURCES = "rk4.toml, dopri5.toml, dop853.toml, gauss.toml in derive/codegen/tableaus"


TABLEAU_TAGS = {"double": "_d", "float": "_f", "long double": "_l"}   # derive_tableaus.h's name tags
LIBRARY = ("derive_integrators.h", "derive_driver.h")     # derive/codegen/backends/c/library/
LIBRARY_SOURCE = "codegen/backends/c/library"


def _combo_macros(prefix: str, stages: list[dict], tag: str) -> list[tuple[str, str]]:
    """Each stage's combination DERIVE_<M>_A<i>, then its node DERIVE_<M>_C<i>."""
    return [macro for row in stages for macro in
            ((f"DERIVE_{prefix}_A{row['index']}{tag}(K, k)", f"({row['combo']})"),
             (f"DERIVE_{prefix}_C{row['index']}{tag}", row["c"]))]


def _tableau_macros(v: dict) -> list[tuple[str, str]]:
    """The coefficients of one C type as (macro, replacement): each stage's combination
    sum_j a_ij K[j][k] (zero coefficients dropped), the weights, the error estimators,
    the dense-output formulas, the implicit and multistep methods' arrays."""
    tag = TABLEAU_TAGS[v["ctype"]]
    out = []
    for m in v["explicit"]:
        M = m["name"].upper()
        out += _combo_macros(M, m["stages"], tag)
        out.append((f"DERIVE_{M}_B{tag}(K, k)", f"({m['b_combo']})"))
        for key, macro in (("e_combo", "E"), ("e3_combo", "E3"), ("e5_combo", "E5")):   # error estimators
            if key in m:
                out.append((f"DERIVE_{M}_{macro}{tag}(K, k)", f"({m[key]})"))
    out += _combo_macros("DOP853", v["dop853_extra"], tag)
    out += [(f"DERIVE_DOP853_D{d['index']}{tag}(K, k)", f"({d['combo']})") for d in v["dop853_d"]]
    weights = ", ".join(f"b[{b['index']}] = {b['poly']}" for b in v["dopri5_dense"])
    out.append((f"DERIVE_DOPRI5_DENSE_WEIGHTS{tag}(b, theta)", f"({weights})"))
    dense = " + ".join(f"b[{b['index']}] * K[{b['index']}][k]" for b in v["dopri5_dense"])
    out.append((f"DERIVE_DOPRI5_DENSE{tag}(b, K, k)", f"({dense})"))
    for g in v["gauss"]:
        out += [(f"DERIVE_{g['name'].upper()}_{x.upper()}{tag}", f"{{ {g[x]} }}") for x in ("A", "c", "d")]
    out += [(f"DERIVE_ABM12_AB{tag}", f"{{ {v['abm']['ab']} }}"), (f"DERIVE_ABM12_AM{tag}", f"{{ {v['abm']['am']} }}"),
            (f"DERIVE_ABM12_MILNE{tag}", v["abm"]["milne"])]
    return out


def render_tableaus() -> dict[str, str]:
    """c/derive_tableaus.h: the coefficients of every method in every C type, the same for
    every model (its first line names no model)."""
    ctx = {"version": __version__, "sources": SOURCES, "template": "templates/c/tableaus.h.jinja",
           "abm_steps": ABM_STEPS, "theta_max": NEWTON_THETA_MAX, "theta_diverge": NEWTON_THETA_DIVERGE,
           "types": [{"ctype": v["ctype"], "tag": TABLEAU_TAGS[v["ctype"]], "macros": _tableau_macros(v)}
                     for v in c_variants()]}
    return {"c/derive_tableaus.h": render("c/tableaus.h.jinja", ctx)}


def library_files(names=LIBRARY) -> dict[str, str]:
    """The hand-written C library, copied verbatim into a generated tree (c/<file>) under
    one first line that names the derive that copied it; the same for every model."""
    files = {}
    for file in names:
        text = c_library_file(file).read_text()
        files[f"c/{file}"] = (f"/* Copied by derive {__version__} from {LIBRARY_SOURCE}/{file} "
                              f"for every model; do not edit. */\n{text}")
    return files


# The public functions of <model>_integrate.c that call the library (derive_integrators.h):
# (return type, name, parameters, the library function's arguments); {R}: the real type,
# {P}: the model.  The prototypes are <model>_integrate.h's.
@lru_cache(maxsize=None)
def _public_functions() -> tuple:
    return (
        ("int", "integrate", "int method, const {R} *restrict y0, const {R} *restrict p, long nt, const {R} *restrict t, "
         "{R} *restrict y_out, const {P}_integrate_options *opt, {P}_integrate_info *info",
         "method, y0, p, nt, t, y_out, opt, info"),
        ("long", "integrate_batch", "long n, int method, const {R} *restrict y0, long y0_stride, const {R} *restrict p, "
         "long p_stride, long nt, const {R} *restrict t, {R} *restrict y_out, const {P}_integrate_options *opt, "
         "{P}_integrate_info *info", "n, method, y0, y0_stride, p, p_stride, nt, t, y_out, opt, info"),
        *((("int", f"{m['name']}_step", "const {R} *restrict y, {R} h, const {R} *restrict p, {R} (*restrict K)[N], "
            "{R} *restrict y_new, {R} *restrict err, const {P}_integrate_options *opt, {P}_integrate_info *info",
            "y, h, p, K, y_new, err, opt, info") for m in _explicit("double"))),
        ("void", "dopri5_dense", "const {R} *restrict y, {R} h, {R} (*restrict K)[N], {R} theta, {R} *restrict out",
         "y, h, K, theta, out"),
        ("int", "dop853_dense_prepare", "const {R} *restrict y, const {R} *restrict y_new, {R} h, const {R} *restrict p, "
         "{R} (*restrict K)[N], {R} (*restrict F)[N], const {P}_integrate_options *opt, {P}_integrate_info *info",
         "y, y_new, h, p, K, F, opt, info"),
        ("void", "dop853_dense", "const {R} *restrict y, {R} (*restrict F)[N], {R} theta, {R} *restrict out",
         "y, F, theta, out"),
        *((("int", f"{m}_step", "const {R} *restrict x, {R} h, const {R} *restrict p, {R} *restrict x_new, "
            "const {P}_integrate_options *opt, {P}_integrate_info *info", "x, h, p, x_new, opt, info")
           for m in IMPLICIT)),
    )


# the building blocks that evaluate the rhs: a time-dependent model's take the step's start time
_EVALUATING = ("rk4_step", "dopri5_step", "dop853_step", "dop853_dense_prepare", "midpoint_step", "gauss2_step")


def _public(P: str, v: dict, timed: bool = False) -> list[dict]:
    """The public functions of one C type: each calls the library's derive_<name>_<tag>;
    for a time-dependent model (timed) the building blocks that evaluate take t first."""
    out = []
    for ret, name, params, args in _public_functions():
        if timed and name in _EVALUATING:
            params, args = "{R} t, " + params, "t, " + args
        call = f"derive_{name}{TABLEAU_TAGS[v['ctype']]}({args});"
        out.append({"head": f"{ret} {P}_{name}{v['s']}({params.format(R=v['ctype'], P=P)})",
                    "body": call if ret == "void" else f"return {call}"})
    return out


def _library_names(M: str) -> list[tuple[str, str]]:
    """(the model's macro, the library's name for it): the method and status codes."""
    return ([(f"{M}_METHOD_{m.macro}", f"DERIVE_METHOD_{m.macro}") for m in contract.METHOD_TABLE]
            + [(f"{M}_INTEGRATE_{s.macro}", f"DERIVE_{s.macro}") for s in contract.STATUS_TABLE])


def _takes_time(name: str, kernel: str) -> bool:
    """Whether the model's generated `kernel` takes the time t first (its expressions use t)."""
    from .sources import kernels         # here: sources imports the backends, which import this
    spec = kernels(name)[0]
    return any(i.vector.key == "time" for k in spec.kernels if k.name == kernel for i in k.inputs)


def render_c(name: str) -> dict[str, str]:
    """c/<model>_integrate.{h,c} and the shared library files.  A time-dependent model's
    (t in its forces, dissipation or pivot) defines DERIVE_TIMED: the library then passes
    every stage's own time to the rhs (derive_integrators.h)."""
    info = model_info(name)
    rhs_t, jac_t = (_takes_time(name, k) for k in ("rhs", "jacobian"))
    timed = rhs_t or jac_t        # a model whose motion has t (not only, say, its energy)
    if timed and info.has_ham:
        # a rheonomic H(q, p, t) would need its own canonical map at every stage's time
        raise SpecError(f"{name}: a Hamiltonian form with explicit time is not supported by the "
                              f"implicit methods (they run on H(q, p) without t)")
    ctx = {"P": name, "M": name.upper(), "title": info.title, "has_ham": info.has_ham, "timed": timed,
           "rhs_t": rhs_t, "jac_t": jac_t,
           "has_guards": info.nguards > 0, "nguards": info.nguards, "sine_min": SINE_MIN,
           "has_inputs": info.n_inputs > 0,
           "theta_max": NEWTON_THETA_MAX, "theta_diverge": NEWTON_THETA_DIVERGE, "sources": SOURCES,
           "variants": [dict(v, tag=TABLEAU_TAGS[v["ctype"]], public=_public(name, v, timed)) for v in c_variants()],
           "library_names": _library_names(name.upper()),
           "contract": contract_c(name.upper(), f"{name.upper()}_INTEGRATE", f"{name.upper()}_N_STATES",
                                  f"{name.upper()}_INTEGRATE_SINE_MIN")}
    return {
        f"c/{name}_integrate.h": render("c/integrate.h.jinja", dict(ctx, template="templates/c/integrate.h.jinja")),
        f"c/{name}_integrate.c": render("c/integrate.c.jinja", dict(ctx, template="templates/c/integrate.c.jinja")),
        **render_tableaus(), **library_files(),
    }


@lru_cache(maxsize=None)
def atlas_rule(atlas: str = ATLAS) -> dict:
    """The rule of seed 000 section 5.1 as the atlas templates need it, from the chart data:
    which member of `atlas` uses the standard, second and rotated chart, and the standard
    chart's |sin theta| and |sin phi| of a link direction u printed per C type and for
    NumPy; `sines`: the polar sine of u in each of the three charts (for N >= 3 links)."""
    X, st, az = rule_sines()
    sines = [_sines_of_unit(load_chart(c), X)[0] for c in RULE_CHARTS]
    c_slots = {x: f"u[i][{k}]" for k, x in enumerate(X)}
    np_slots = {x: f"ui[{k}]" for k, x in enumerate(X)}
    out = dict(rule_models(atlas))
    out["c"] = {ctype: {"st": CPrinter(c_slots, ctype).doprint_checked(st),
                        "sp": CPrinter(c_slots, ctype).doprint_checked(az),
                        "sines": [CPrinter(c_slots, ctype).doprint_checked(e) for e in sines]}
                for ctype, _, _ in _C_VARIANTS}
    out["numpy"] = {"st": PyNumPyPrinter(np_slots).doprint_checked(st),
                    "sp": PyNumPyPrinter(np_slots).doprint_checked(az),
                    "sines": [PyNumPyPrinter(np_slots).doprint_checked(e) for e in sines]}
    return out


# the atlas's functions derive_driver.h calls (<prefix>_<hook><suffix>, DERIVE_DRIVER_<HOOK>)
ATLAS_DRIVER_HOOKS = ("eval", "step", "dense_prepare", "dense", "in", "out", "switch", "set_y")


def render_atlas(name: str = ATLAS) -> dict[str, str]:
    """The atlas's own files (its members' are their models'): <prefix>.h, .c and .py.
    Sizes come from the standard member's description."""
    atlas = load_atlas(name)
    P = atlas.prefix
    info = model_info(atlas.charts[0])
    ctx = {"P": P, "M": P.upper(), "title": atlas.title, "charts": list(atlas.charts),
           "n_links": len(load_model(atlas.charts[0]).links), "n_states": info.n, "n_params": info.n_params,
           "sine_min": atlas.sine_min, "sine_switch": atlas.sine_switch,
           "sine_rule": atlas.sine_rule, "rule": atlas_rule(name),
           "variants": [dict(v, tag=TABLEAU_TAGS[v["ctype"]]) for v in c_variants()],
           "library_names": _library_names(P.upper()), "driver_hooks": [(f"DERIVE_DRIVER_{h.upper()}", h) for h in ATLAS_DRIVER_HOOKS],
           "contract": contract_c(P.upper(), f"{P.upper()}_INTEGRATE", str(info.n), f"{P.upper()}_SINE_MIN"),
           "contract_py": contract_numpy()}
    files = {
        f"c/{P}.h": render("c/atlas.h.jinja", dict(ctx, template="templates/c/atlas.h.jinja")),
        f"c/{P}.c": render("c/atlas.c.jinja", dict(ctx, template="templates/c/atlas.c.jinja")),
    }
    files.update(library_files(("derive_driver.h",)))
    files[f"numpy/{P}.py"] = render(
        "numpy/atlas.py.jinja", dict(ctx, template="templates/numpy/atlas.py.jinja", explicit=None))
    files.update(numpy_library_files())
    return files


def _py_row(terms) -> list[tuple[int, str]]:
    return [(j, tb.py_literal(v)) for j, v in terms if v != 0]


def _py_nodes(t: tb.Tableau) -> str:
    """Every stage's node c_i (its time t + c_i h: a time-dependent model's rhs reads it)."""
    return repr([tb.py_literal(x) for x in t.c])


@lru_cache(maxsize=None)
def numpy_tableaus() -> tuple[list[dict], list[dict]]:
    explicit = []
    rk4 = tb.load("rk4")
    explicit.append({"name": "rk4", "rows": repr([_py_row(rk4.row(i)) for i in range(1, 4)]),
                     "b": repr(_py_row(enumerate(rk4.b))), "extra": [("c", _py_nodes(rk4))]})
    d5 = tb.load("dopri5")
    p = d5.extra["p"]
    poly = [(k, [tb.py_literal(p.get((k, j), mpmath.mpf(0))) for j in range(4)])
            for k in range(7) if any(p.get((k, j), 0) != 0 for j in range(4))]
    explicit.append({"name": "dopri5", "rows": repr([_py_row(d5.row(i)) for i in range(1, 6)]),
                     "b": repr(_py_row(d5.row(6))),
                     "extra": [("e", repr(_py_row(sorted(d5.extra["e"].items())))), ("p", repr(poly)),
                               ("c", _py_nodes(d5))]})
    d8 = tb.load("dop853")
    b = dict(d8.row(12))
    with mpmath.workdps(tb.DIGITS):
        e3 = [(j, b.get(j, mpmath.mpf(0)) - d8.extra["e3_minus"].get(j, mpmath.mpf(0))) for j in range(12)]
    d = d8.extra["d"]
    explicit.append({"name": "dop853", "rows": repr([_py_row(d8.row(i)) for i in range(1, 12)]),
                     "b": repr(_py_row(d8.row(12))),
                     "extra": [("e3", repr(_py_row(e3))),
                               ("e5", repr(_py_row(sorted(d8.extra["e5"].items())))),
                               ("extra", repr([(i, _py_row(d8.row(i))) for i in range(13, 16)])),
                               ("d", repr([_py_row(sorted((j, v) for (i, j), v in d.items() if i == r))
                                           for r in range(4)])),
                               ("c", _py_nodes(d8))]})
    gauss = []
    for name in IMPLICIT:
        t = tb.load(name)
        ns = t.stages
        gauss.append({"name": name, "ns": ns,
                      "A": repr([[tb.py_literal(t.a.get((i, j), mpmath.mpf(0))) for j in range(ns)]
                                 for i in range(ns)]),
                      "c": repr([tb.py_literal(x) for x in t.c]),
                      "d": repr([tb.py_literal(x) for x in tb.gauss_d(t)])})
    return explicit, gauss


def _adams_py() -> dict:
    ab, am = tb.adams(ABM_STEPS)
    return {"ab": repr([tb.py_literal(tb.value(str(x))) for x in ab]),
            "am": repr([tb.py_literal(tb.value(str(x))) for x in am]),
            "milne": repr(tb.py_literal(tb.value(str(tb.adams_milne(ABM_STEPS)))))}


NUMPY_LIBRARY = ("derive_integrators.py",)     # derive/codegen/backends/numpy/library/
NUMPY_LIBRARY_SOURCE = "codegen/backends/numpy/library"


def render_numpy_tableaus() -> dict[str, str]:
    """numpy/derive_tableaus.py: the run contract and every method's coefficients as the
    NumPy library reads them, the same for every model (its first line names no model)."""
    explicit, gauss = numpy_tableaus()
    ctx = {"version": __version__, "template": "templates/numpy/tableaus.py.jinja", "sources": SOURCES,
           "sine_min": SINE_MIN, "theta_max": NEWTON_THETA_MAX, "theta_diverge": NEWTON_THETA_DIVERGE,
           "abm_steps": ABM_STEPS, "explicit": explicit, "gauss": gauss, "adams": _adams_py(),
           "contract_py": contract_numpy()}
    return {"numpy/derive_tableaus.py": render("numpy/tableaus.py.jinja", ctx)}


def numpy_library_files() -> dict[str, str]:
    """The hand-written NumPy library, copied verbatim into a generated tree (numpy/<file>)
    under one first line that names the derive that copied it, and its rendered data:
    the same for every model, beside every model's thin <model>_integrate.py."""
    files = {}
    for file in NUMPY_LIBRARY:
        text = numpy_library_file(file).read_text()
        files[f"numpy/{file}"] = (f"# Copied by derive {__version__} from {NUMPY_LIBRARY_SOURCE}/{file} "
                                  f"for every model; do not edit.\n{text}")
    files.update(render_numpy_tableaus())
    return files


def render_numpy(name: str) -> dict[str, str]:
    """numpy/<model>_integrate.py, a few lines that give the model's kernels to the shared
    library (numpy_library_files, written beside it)."""
    info = model_info(name)
    ctx = {"P": name, "title": info.title, "n": info.n, "n_params": info.n_params + info.n_inputs,
           "has_inputs": info.n_inputs > 0, "template": "templates/numpy/integrate.py.jinja"}
    return {f"numpy/{name}_integrate.py": render("numpy/integrate.py.jinja", ctx), **numpy_library_files()}
