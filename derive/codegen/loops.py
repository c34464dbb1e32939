"""Batched fixed-step RK4 for throughput: many trajectories at once, in C and NumPy.

`derive generate` writes, for every model without chart guards (its rhs is
defined everywhere, so a batch never needs a chart switch):

* generated/c/<model>_throughput.{h,c} (templates/c/throughput.*.jinja): classical
  RK4 on n trajectories in structure-of-arrays layout.  The innermost loop runs
  over the trajectories of a block (BLOCK lanes held in L1), so the compiler
  vectorises the whole step, sin and cos included: with glibc on x86-64 the
  source declares sin/cos `omp declare simd` and the build passes
  `-fopenmp-simd -fno-builtin-sin -fno-builtin-cos -lmvec`, so the calls become
  libmvec's vector variants (no -ffast-math: NaN and infinity keep their IEEE
  meaning).  Finiteness is checked with integer bit tests after every step: a
  trajectory that becomes non-finite keeps its last finite state and stops
  counting steps, as the scalar integrator stops there.
* generated/numpy/<model>_throughput.py (templates/numpy/throughput.py.jinja):
  the same step on whole (n_states, B) arrays;
* generated/c/<model>_fixed.{h,c} (templates/c/fixed.*.jinja): one trajectory,
  fixed step, the rhs inlined and no driver bookkeeping, for the methods of
  FIXED_METHODS: rk4, rk8 (the 8th-order formula of DOP853 at a fixed step, 12
  evaluations per step; no rejected steps, no error estimate) and abm12 (12-step
  Adams-Bashforth-Moulton in PECE mode, 2 evaluations per step after an rk8
  start): the fastest single-trajectory paths when the step is known.  At a final
  error of 1e-8 on the planar benchmark problems abm12 needs about half the rhs
  evaluations of rk8; its price is a small stability region (too large a step
  blows up, and the loop stops at the first non-finite state).

Python prepares every expression (the rhs printed with the same printers and
CSE as the kernels, the RK4 combinations from rk4.toml with the same literals
as the scalar integrator), so the arithmetic is the scalar path's except for
the vector sin/cos (a few ulp); tests check agreement to 1e-12 over spans
inside the trust horizon.  The fixed loops take the rhs's sin/cos as lanes
(emit.trig_lanes), as the kernels do, and are built by loader.build_fastest
(libmvec's vector sin/cos where they build): that pays for abm12 and costs rk4 and
rk8 a little against the portable build.

    tp = throughput_library("planar")
    y, status, steps = tp.rk4(y0s, p, h, nsteps, threads=2)     # y0s (B, 4)
    y, done = fixed_library("planar").run("abm12", y0, p, h, nsteps)
"""
from __future__ import annotations

import re
from functools import lru_cache


from .emit import half_angle_sincos, lanes_context, render, trig_lanes
from .names import VECTOR_MATH
from .names import numpy_slots
from .printers import CPrinter, PyNumPyPrinter
from .sources import kernels
from ..derivation import derive
from ..model import model_names
from ..model.description import forget_on_model_change
from . import tableau as tb

BLOCK = 64                 # lanes per block: 4 states x 64 doubles stay in L1
TEMPLATE_C = "templates/c/throughput.c.jinja"
TEMPLATE_H = "templates/c/throughput.h.jinja"
TEMPLATE_PY = "templates/numpy/throughput.py.jinja"


def throughput_models() -> list[str]:
    """Models whose rhs has no chart guard (every model is listed in the catalog)."""
    return [m for m in model_names() if not derive(m).polar_sines]


@forget_on_model_change
@lru_cache(maxsize=None)
def _rhs_body(name: str):
    return next(b for b in kernels(name)[1] if b.kernel.name == "rhs")


def _inputs(body):
    """(state symbols, parameter symbols, time symbols) of the rhs kernel; the loops take
    the run-time inputs as parameters after the model's own (p = (params, inputs), as the
    integrators), and the time (a time-dependent model's rhs: [t]; else []) as each
    stage's own."""
    state, params, inputs, time = None, None, [], []
    for inp in body.kernel.inputs:
        if inp.vector.key == "param":
            params = list(inp.vector.symbols)
        elif inp.vector.key == "input":
            inputs = list(inp.vector.symbols)
        elif inp.vector.key == "time":
            time = list(inp.vector.symbols)
        else:
            state = list(inp.vector.symbols)
    return state, params + inputs, time


def takes_time(name: str) -> bool:
    """Whether the loops of model `name` take the start time t_start (its rhs has t)."""
    return bool(_inputs(_rhs_body(name))[2])


# Fixed-step methods of the single-trajectory loops, as data:
# - "rk": an explicit Runge-Kutta tableau at a fixed step, no error estimate, no rejected
#   steps: rk4 (classical, seed 001) and rk8, the 8th-order formula of DOP853
#   (Dormand-Prince), 12 rhs evaluations per step;
# - "adams": the k-step Adams-Bashforth-Moulton pair in PECE mode (predict with AB, evaluate,
#   correct with AM, evaluate): 2 rhs evaluations per step whatever the order, which pays
#   when the rhs dominates and the tolerance is tight; the first k-1 steps (the history) are
#   taken with the "start" method at the same step.  Weights derived in tableau.adams.
#   Order 12: on the planar problems abm9 needs more time for a final error of 1e-8,
#   abm16 is unstable at every step of the sweep (its weights reach 1e3 and amplify
#   rounding).
FIXED_METHODS = {
    "rk4": {"kind": "rk", "tableau": "rk4", "title": "classical RK4 (rk4.toml)"},
    "rk8": {"kind": "rk", "tableau": "dop853",
            "title": "the 8th-order Dormand-Prince formula of DOP853 (dop853.toml) at a fixed step"},
    "abm12": {"kind": "adams", "steps": 12, "start": "rk8",
              "title": "12-step Adams-Bashforth-Moulton, PECE (order 12), started with rk8"},
}


def evaluations(method: str, nsteps: int) -> int:
    """rhs evaluations of nsteps steps of a fixed-step loop (all of them completed)."""
    m = FIXED_METHODS[method]
    if m["kind"] == "rk":
        return (len(_explicit(method)[0]) + 1) * nsteps
    start = min(nsteps, m["steps"] - 1)
    return 1 + evaluations(m["start"], start) + 2 * (nsteps - start) if nsteps else 0


@lru_cache(maxsize=None)
def _nodes(method: str) -> tuple[str, ...]:
    """Each stage's node c_i as a C double literal (a time-dependent rhs's stage time)."""
    return tuple(tb.literal(c, "double") for c in tb.load(FIXED_METHODS[method]["tableau"]).c)


@lru_cache(maxsize=None)
def _explicit(method: str) -> tuple[list[list[tuple[int, str]]], list[tuple[int, str]]]:
    """Stage rows 1..s-1 and weights as C double literals (zeros dropped), as the scalar
    integrator prints them."""
    t = tb.load(FIXED_METHODS[method]["tableau"])
    nstages = len(t.b)
    rows = [[(j, tb.literal(v, "double")) for j, v in t.row(i) if v != 0] for i in range(1, nstages)]
    b = [(j, tb.literal(v, "double")) for j, v in enumerate(t.b) if v != 0]
    return rows, b


def _combo(terms, name) -> str:
    return " + ".join(f"{lit} * {name(j)}" for j, lit in terms)


@forget_on_model_change
@lru_cache(maxsize=None)
def _rhs_parts(name: str, lanes: bool):
    """(sin/cos lanes or None, assignments, outputs) of the rhs: emit.trig_lanes once per model,
    without lanes where the loop around the rhs is itself the vector one."""
    body = _rhs_body(name)
    return trig_lanes(body.assignments, body.outputs[0]) if lanes else (None, body.assignments, body.outputs[0])


_STATE_TOKEN = re.compile("\x00([0-9]+)\x00")     # state component c, before it is named
_TIME_TOKEN = "\x00t\x00"                         # the stage's time, before it is named


def _state_token(c: int) -> str:
    return f"\x00{c}\x00"


_printed: dict[int, tuple] = {}        # id(parts) -> (parts, its printed rhs)


def _printed_rhs(parts, state, params, time=()) -> dict:
    """The rhs (_rhs_parts) printed once, the state components as tokens (_STATE_TOKEN) that
    each stage then names: a stage's rhs differs from another's in those names only (a
    symbol prints as its slot, whatever the slot's text), and printing is the generator's
    largest cost for a large model."""
    key = id(parts)
    if key in _printed and _printed[key][0] is parts:
        return _printed[key][1]
    lanes, assignments, outputs = parts
    slots = {s: f"p{i}" for i, s in enumerate(params)}
    slots.update({s: _state_token(i) for i, s in enumerate(state)})
    slots.update({s: _TIME_TOKEN for s in time})
    pr = CPrinter(slots, "double")
    printed = {"lanes": lanes_context(lanes, pr),
               "lines": [f"const double {sym.name} = {pr.doprint_checked(e)};" for sym, e in assignments],
               "outputs": [pr.doprint_checked(e) for e in outputs]}
    _printed[key] = (parts, printed)
    return printed


def _c_rhs(parts, state, params, src: str, target, time=(), at: str = "tk") -> dict:
    """The rhs (_rhs_parts) printed on the state held in src<c> (or src[c]), output c stored to
    target(c), at the time `at` (a C expression; for a time-dependent rhs, `time` its time
    symbol): its sin/cos lanes and the lines after them."""
    printed = _printed_rhs(parts, state, params, time)
    def named(text: str) -> str:
        return _STATE_TOKEN.sub(lambda m: src.format(c=int(m.group(1))), text).replace(_TIME_TOKEN, at)

    lanes = printed["lanes"]
    if lanes is not None:
        lanes = dict(lanes, angles=named(lanes["angles"]))
    return {"lanes": lanes,
            "lines": [named(line) for line in printed["lines"]]
                     + [f"{target(i)} = {named(e)};" for i, e in enumerate(printed["outputs"])]}


def _c_stages(parts, state, params, rows, b, time=(), nodes=()) -> tuple[list[dict], list[str]]:
    """Each stage: the rhs printed on its input (y for the first, s after) at its time
    (tk + c_i h, a time-dependent rhs's), its outputs k<stage>_<c>, then the next stage's
    input s<c> = y<c> + h * (...); finally n<c> = y<c> + h * (b . k)."""
    n = len(state)
    stages = []
    for stage in range(len(rows) + 1):
        at = "tk" if stage == 0 or not time else f"(tk + {nodes[stage]} * h)"
        rhs = _c_rhs(parts, state, params, "y{c}" if stage == 0 else "s{c}", lambda i: f"k{stage}_{i}", time, at)
        combo = None
        if stage < len(rows):
            combo = [f"s{c} = y{c} + h * ({_combo(rows[stage], lambda j: f'k{j}_{c}')});" for c in range(n)]
        stages.append({"index": stage, "rhs": rhs, "next": combo})
    final = [f"n{c} = y{c} + h * ({_combo(b, lambda j: f'k{j}_{c}')});" for c in range(n)]
    return stages, final


def _adams_context(parts, state, params, method: str, time=()) -> dict:
    """The PECE step of a k-step Adams pair: history f[j] = rhs j steps back, hab/ham = h * weights."""
    k = FIXED_METHODS[method]["steps"]
    ab, am = tb.adams(k)
    n = len(state)
    def literals(weights) -> str:
        return ", ".join(tb.literal(tb.value(str(w)), "double") for w in weights)

    predict = [f"s{c} = y{c} + ({' + '.join(f'hab[{j}] * f[{j}][{c}]' for j in range(k))});" for c in range(n)]
    correct = [f"n{c} = y{c} + ({' + '.join(['ham[0] * fp' + str(c)] + [f'ham[{j}] * f[{j - 1}][{c}]' for j in range(1, k)])});"
               for c in range(n)]
    return {"k": k, "start": FIXED_METHODS[method]["start"], "ab": literals(ab), "am": literals(am),
            "rhs_y": _c_rhs(parts, state, params, "y{c}", lambda i: f"fn{i}", time),
            "rhs_s": _c_rhs(parts, state, params, "s{c}", lambda i: f"fp{i}", time),
            "rhs_n": _c_rhs(parts, state, params, "n{c}", lambda i: f"fn{i}", time),
            "predict": predict, "correct": correct,
            "fp_decl": ", ".join(f"fp{c}" for c in range(n)), "fn_decl": ", ".join(f"fn{c}" for c in range(n))}


def _used_params(body, params) -> list[int]:
    used = set()
    for _, e in body.assignments:
        used |= e.free_symbols
    for e in body.outputs[0]:
        used |= e.free_symbols
    return [i for i, s in enumerate(params) if s in used]


def c_context(name: str) -> dict:
    body = _rhs_body(name)
    state, params, time = _inputs(body)
    n = len(state)
    rows, b = _explicit("rk4")
    stages, final = _c_stages(_rhs_parts(name, False), state, params, rows, b, time, _nodes("rk4"))
    return {"P": name, "M": name.upper(), "title": derive(name).model.title, "n": n, "timed": bool(time),
            "n_params": len(params), "block": BLOCK,
            "params_used": _used_params(body, params), "stages": stages, "final": final,
            "vector_math": list(VECTOR_MATH), "ops": body.ops,
            "state_names": ", ".join(s.name for s in state),
            "param_names": ", ".join(s.name for s in params),
            "k_decl": ", ".join(f"k{j}_{c}" for j in range(len(rows) + 1) for c in range(n)),
            "s_decl": ", ".join(f"s{c}" for c in range(n)),
            "n_decl": ", ".join(f"n{c}" for c in range(n))}


def fixed_context(name: str) -> dict:
    """The single-trajectory fixed-step loops (<model>_fixed.c): rk4 and rk8, rhs inlined."""
    body = _rhs_body(name)
    state, params, time = _inputs(body)
    n = len(state)
    methods = []
    for method, m in FIXED_METHODS.items():
        entry = {"name": method, "title": m["title"], "kind": m["kind"]}
        if m["kind"] == "rk":
            rows, b = _explicit(method)
            stages, final = _c_stages(_rhs_parts(name, True), state, params, rows, b, time, _nodes(method))
            entry.update(nstages=len(rows) + 1, stages=stages, final=final,
                         k_decl=", ".join(f"k{j}_{c}" for j in range(len(rows) + 1) for c in range(n)))
        else:
            entry.update(_adams_context(_rhs_parts(name, True), state, params, method, time))
        methods.append(entry)
    return {"P": name, "M": name.upper(), "title": derive(name).model.title, "n": n, "timed": bool(time),
            "n_params": len(params), "params_used": _used_params(body, params), "methods": methods,
            "vector_math": list(VECTOR_MATH), "ops": body.ops, "state_names": ", ".join(s.name for s in state),
            "param_names": ", ".join(s.name for s in params),
            "s_decl": ", ".join(f"s{c}" for c in range(n)), "n_decl": ", ".join(f"n{c}" for c in range(n)),
            "y_decl": ", ".join(f"y{c} = y[{c}]" for c in range(n))}


def numpy_context(name: str) -> dict:
    body = _rhs_body(name)
    state, params, time = _inputs(body)
    varying = set(state) | set(time)
    assignments, outs = half_angle_sincos(body.assignments, list(body.outputs[0]))
    for sym, e in assignments:
        if e.free_symbols & varying:
            varying.add(sym)
    slots = numpy_slots(time + state + params, {s.name for s, _ in assignments})
    pr = PyNumPyPrinter(slots, varying)
    const = [{"name": s.name, "value": pr.doprint_checked(e)} for s, e in assignments
             if s not in varying]
    var = [{"name": s.name, "value": pr.doprint_checked(e)} for s, e in assignments
           if s in varying]
    outs = [pr.doprint_checked(e) for e in outs]
    t = tb.load("rk4")
    stages = []
    for stage in range(t.stages):
        last = stage == t.stages - 1
        terms = [(j, v) for j, v in (enumerate(t.b) if last else t.row(stage + 1)) if v != 0]
        # whole (n, B) arrays: the same operations, in the same order, as the scalar C
        combo = " + ".join(f"K[{j}]" if v == 1 else f"{tb.py_literal(v)} * K[{j}]" for j, v in terms)
        stages.append({"index": stage, "arg": "Y" if stage == 0 else "S",
                       "at": "T" if stage == 0 else f"T + {tb.literal(t.c[stage], 'double')} * h",
                       "next": f"{'N' if last else 'S'} = Y + h * ({combo})"})
    return {"P": name, "title": derive(name).model.title, "template": TEMPLATE_PY,
            "timed": bool(time), "time": slots[time[0]] if time else None,
            "n": len(state), "n_params": len(params),
            "state": [slots[s] for s in state], "params": [slots[s] for s in params],
            "state_repr": repr(tuple(s.name for s in state)),
            "params_repr": repr(tuple(s.name for s in params)),
            "const": const, "var": var, "outs": outs, "ops": body.ops, "stages": stages}


def render_loops(name: str, language: str | None = None) -> dict[str, str]:
    """The batched RK4 and the fixed-step loops of one model whose rhs has no chart guard:
    path -> text, in every language, or in `language` ("c" or "numpy") only (each backend
    renders its own in its worker: the other language's contexts cost as much again)."""
    files = {}
    if language in (None, "c"):
        ctx = c_context(name)
        fctx = fixed_context(name)
        files.update({
            f"c/{name}_throughput.h": render("c/throughput.h.jinja", dict(ctx, template=TEMPLATE_H)),
            f"c/{name}_throughput.c": render("c/throughput.c.jinja", dict(ctx, template=TEMPLATE_C)),
            f"c/{name}_fixed.h": render("c/fixed.h.jinja", dict(fctx, template="templates/c/fixed.h.jinja")),
            f"c/{name}_fixed.c": render("c/fixed.c.jinja", dict(fctx, template="templates/c/fixed.c.jinja"))})
    if language in (None, "numpy"):
        files[f"numpy/{name}_throughput.py"] = render("numpy/throughput.py.jinja", numpy_context(name))
    return files
