"""`derive latex MODEL`: the derivation of one model as a standalone .tex file.

Python decides what goes in (which sections, the LaTeX of each expression);
the Jinja2 template ``templates/latex/derivation.tex.j2`` only lays it out.
The template uses \\VAR{...} and \\BLOCK{...} delimiters so LaTeX braces stay
untouched.
"""
from __future__ import annotations

import re
from pathlib import Path

import jinja2
import sympy as sp

from ..derivation import Derivation
from ..derivation.lagrange import pivot_position
from ..derivation.symbols import t as time_symbol
from ..errors import PackageDataError
from ..model.description import in_words
from ..model.expressions import parse_expression
from .. import paths

from . import typeset as ts
from ..verification import claims, judge
from ..verification.errata import errata_by_key
from ..codegen.sources import provenance

PAPERS = {"a4": "a4paper", "letter": "letterpaper"}
CLAIM_WIDTH = 54      # display width beside the "printed:" / "derived:" labels


def symbol_names(d: Derivation) -> dict:
    return ts.Names(ts.names_for(d))


def _entries(m: sp.Matrix, names, symbol: str, symmetric: bool = False, budget=ts.WIDTH - 8):
    """Nonzero entries of a matrix (upper triangle when symmetric), each split over lines."""
    rows = []
    for i in range(m.rows):
        for j in range(m.cols):
            if m[i, j] == 0 or (symmetric and j < i):
                continue
            idx = f"{i + 1}{j + 1}" if m.cols > 1 else f"{i + 1}"
            rows.append({"name": f"{symbol}_{{{idx}}}", "lines": ts.expr_lines(m[i, j], names, budget)})
    return rows


def _loop(d: Derivation, names) -> dict | None:
    """A closed loop's constraints, their Jacobian and the acceleration-level right side,
    for the section that closes the equations with multipliers; None for an open chain."""
    c = d.constraints
    if c is None:
        return None
    return {"count": c.J.rows, "Phi": _entries(c.Phi, names, r"\Phi"), "J": _entries(c.J, names, "J"),
            "gamma": _entries(c.gamma, names, r"\gamma")}


def _energy(d: Derivation) -> str:
    """What the document says of E = T + V: "conserved"; "balance" (dE/dt = q'.Q - q'.dR/dq',
    forces or dissipation without explicit time in L); or "jacobi" where L itself depends on t
    (a moving pivot): E is not conserved and Jacobi's h = q'.dL/dq' - L obeys
    dh/dt = q'.Q - q'.dR/dq' - dL/dt|explicit, the balance derive verify checks."""
    if d.model.is_conservative:
        return "conserved"
    return "jacobi" if time_symbol in (d.T - d.V).free_symbols else "balance"


def _vector(v, names) -> str:
    return ts.full_size(r"\begin{pmatrix}" + r" \\ ".join(ts.tex(x, names) for x in v) + r"\end{pmatrix}")


def _joint(model, link, i: int, n) -> str:
    """How link i hangs: its length and chart, or its slider's or hinge's axis, and where
    it sits when that is not the previous link's tip."""
    length = ts.tex(sp.Symbol(link.length), n)
    params = {x: sp.Symbol(x) for x in model.parameters}

    def vector(texts) -> str:
        return "$(" + ", ".join(ts.tex(parse_expression(x, params, "link"), n) for x in texts) + ")$"
    axis = vector(link.axis)
    if link.joint == "prismatic":
        text = f"slides along {axis} in its parent's frame (a prismatic joint)"
    elif link.joint == "revolute":
        text = f"has length ${length}$ and turns about {axis} in its parent's frame (a revolute joint)"
    else:
        text = f"has length ${length}$, chart \\texttt{{{_escape(link.chart.name)}}}"
    if link.parent != i - 2 or link.offset is not None:
        where = "the pivot" if link.parent < 0 else f"link {link.parent + 1}"
        at = "" if link.offset is None else f" at {vector(link.offset)} in its frame"
        text += f", hangs from {where}{at}"
    if link.prescribed:
        timed = {**params, "t": sp.Symbol("t")}
        what = "length it slides" if link.joint == "prismatic" else "angle"
        value = ts.tex(parse_expression(link.prescribed[0], timed, "link"), n)
        text += f", driven: its {what} is prescribed, ${value}$ (no coordinate of the state)"
    return text


def _body(link, n) -> str:
    b = link.body
    if b is None:
        return "no mass (a frame for the links it carries)"
    mass = ts.tex(sp.sympify(b.mass), n)
    if b.kind == "point":
        return f"a point mass ${mass}$ at its tip"
    if b.kind == "rigid":
        rows = r" \\ ".join(" & ".join(ts.tex(sp.sympify(x), n) for x in row) for row in b.tensor)
        return (f"a rigid body of mass ${mass}$ with its centre of mass at "
                + ("its tip" if b.centre is None else "$(" + ", ".join(ts.tex(sp.sympify(c), n) for c in b.centre)
                   + ")$ in its frame")
                + r" and inertia tensor $\begin{pmatrix}" + rows + r"\end{pmatrix}$ about it")
    com = sp.sympify(b.com)
    inertia = ts.tex(sp.sympify(b.inertia), n)
    at = f"{com.p}/{com.q}" if isinstance(com, sp.Rational) and com.q != 1 else ts.tex(com, n)
    return (f"a rod of mass ${mass}$ with its centre of mass at ${at}$ of its length "
            f"and moment of inertia ${inertia}$ about it")


def _forces(d, n) -> list[dict]:
    """Dissipation and applied forces, where the derivation has them: Rayleigh's R and
    -dR/dq', the generalized forces Q (and the run-time inputs they use)."""
    out, s = [], d.symbols
    if d.dissipation is not None:
        lines = [f"R = {ts.tex(d.dissipation, n)}"]
        lines += [rf"-\frac{{\partial R}}{{\partial {ts.tex(v, n)}}} = "
                  rf"{ts.tex(sp.collect(sp.expand(-d.dissipation.diff(v)), list(s.params)), n)}"
                  for v in s.qd if d.dissipation.diff(v) != 0]
        out.append({"title": "Dissipation",
                    "intro": "Rayleigh's dissipation function and the generalized forces it exerts:",
                    "lines": lines})
    if d.forces is not None:
        lines = [f"Q_{{{ts.tex(q, n)}}} = {ts.tex(Q, n)}" for q, Q in zip(s.q, d.forces) if Q != 0]
        intro = "The applied generalized forces (the virtual work of the applied forces per coordinate)"
        if s.u:
            intro += "; " + ", ".join(f"${ts.tex(u, n)}$" for u in s.u) + " are run-time inputs"
        out.append({"title": "Applied forces", "intro": intro + ":", "lines": lines})
    return out


def physics_rows(checks, names) -> list[dict]:
    rows = []
    for c in checks:
        exprs = [f"${ts.symbol_tex(k)} = {ts.tex(v, names)}$" for k, v in getattr(c, "exprs", {}).items()]
        states = getattr(c, "states", 0)
        models = getattr(c, "models", ())
        detail = re.sub(r"\bTrue\b", "yes", re.sub(r"\bFalse\b", "no", c.detail))
        rows.append({"name": ts.prose(c.name, literal=models), "passed": c.passed,
                     "states": str(states) if states else "exact",
                     "tolerance": _num(getattr(c, "tolerance", "")),
                     "worst": _num(getattr(c, "worst", "")),
                     "detail": ts.prose(detail) if not exprs else ", ".join(exprs)})
    return rows


def _num(text: str) -> str:
    if not text:
        return "--"
    if text == "exact":
        return "exact"
    prefix = ""
    for op in ("> ", ">= ", "< "):
        if text.startswith(op):
            prefix, text = {"> ": "> ", ">= ": r"\ge ", "< ": "< "}[op], text[len(op):]
    try:
        x = float(text)
    except ValueError:
        return ts.prose(text)
    if x != 0 and (abs(x) < 1e-3 or abs(x) >= 1e4):
        mant, exp = f"{x:.2e}".split("e")
        mant = mant.rstrip("0").rstrip(".")
        body = (f"10^{{{int(exp)}}}" if mant == "1" else rf"{mant}\times 10^{{{int(exp)}}}")
    else:
        body = f"{x:g}"
    return f"${prefix}{body}$"


def _equation_label(eq: str) -> str:
    if re.fullmatch(r"\d+(\.\d+)*", eq):
        return f"({eq})"
    return ts.prose(eq)


def result_rows(results) -> list[dict]:
    """Each verdict with the printed and derived formulas (and an erratum's discrepancy
    and corrected form) typeset from the claim objects."""
    table, errata = judge.claims_by_key(), errata_by_key()
    rows = []
    for r in results:
        claim = table.get(r.key)
        row = {"seed": r.seed[:3], "equation": _equation_label(r.equation), "what": ts.prose(r.what, display=True),
               "verdict": r.verdict, "summary": "", "printed": [], "derived": [], "same": False,
               "discrepancy": [], "corrected": [], "origin": ""}
        if r.verdict != "match" or r.summary != "printed = derived (exact and numeric)":
            row["summary"] = ts.prose(r.summary)
        if claim is not None:
            c = claims.context(claim.model)
            n = symbol_names(c.d)
            show = lambda obj: ts.abridge(ts.object_lines(obj, n, CLAIM_WIDTH))
            row["printed"] = show(claim.printed(c))
            row["derived"] = show(claim.derived(c))
            row["same"] = row["printed"] == row["derived"]
            e = errata.get(r.key)
            if e is not None:
                row["discrepancy"] = show(e.discrepancy(c))
                row["corrected"] = show(e.corrected(c))
                row["origin"] = ts.prose(e.origin)
        rows.append(row)
    return rows


def _seed_groups(rows) -> list[dict]:
    titles = {"000": 'H. Inou, \\emph{Double pendulum} (2018), seed 000',
              "001": "the compound double pendulum note, seed 001"}
    groups: list[dict] = []
    for row in rows:
        if not groups or groups[-1]["seed"] != row["seed"]:
            groups.append({"seed": row["seed"], "title": titles.get(row["seed"], row["seed"]), "rows": []})
        groups[-1]["rows"].append(row)
    return groups


def _title(text: str) -> str:
    return ts.text(text)


def context(d: Derivation, results, checks=(), paper: str = "a4") -> dict:
    n = symbol_names(d)
    s = d.symbols
    ctx = {
        "paper": PAPERS[paper], "title": _title(d.model.title), "name": _escape(d.model.name),
        "source": ts.prose(d.model.source) if d.model.source else
        (r"the model file \texttt{" + _escape(Path(d.model.origin).name) + "}" if d.model.origin else "the catalogue"),
        "conservative": d.model.is_conservative,
        "coordinates": ", ".join(f"${ts.tex(q, n)}$" for q in s.q),
        "parameters": ", ".join(f"${ts.tex(p, n)}$" for p in s.params),
        "links": [{"index": i, "joint": _joint(d.model, link, i, n), "body": _body(link, n),
                   "tip": _vector(tip, n), "centre": _vector(c, n),
                   "same": sp.simplify(tip - c) == sp.zeros(*tip.shape)}
                  for i, (link, tip, c) in enumerate(zip(d.model.links, d.tips, d.centres), 1)],
        "T": ts.expr_lines(d.T, n), "V": ts.expr_lines(d.V, n),
        "mass_matrix": _entries(d.M, n, "M", symmetric=True),
        "forcing": _entries(d.F, n, "F"),
        "accelerations": r"\bigl(" + ", ".join(
            n[qd].replace(r"\dot{", r"\ddot{", 1) for qd in s.qd) + r"\bigr)",
        "rates": _vector(s.qd, n), "momenta": _vector(s.p, n),
        "hamiltonian": None, "seedforms": None, "forces": _forces(d, n),
        "groups": _seed_groups(result_rows(results)), "n_results": len(results),
        "checks": physics_rows(checks, n),
        "loop": _loop(d, n),
        "pivot": _vector(pivot_position(d.model, s), n) if d.model.pivot is not None else None,
        "energy": _energy(d),
        "explicit_time": in_words([w.replace("the moving pivot", "the moving pivot does work")
                                   for w in d.model.work_done_by
                                   if w in ("the moving pivot", "the time-dependent potential")]),
        "F_args": r"q, \dot q" + (", u" if d.model.inputs else "") + (", t" if d.model.is_time_dependent else ""),
    }
    if d.hamiltonian is not None and d.hamiltonian.H is None:
        # beyond two coordinates no closed-form inverse is written: the code solves M q' = p
        ctx["hamiltonian"] = {"closed": False, "dL_dq": _entries(d.hamiltonian.dL_dq, n, r"\dot{p}"),
                              "solve": rf"an $L D L^{{T}}$ factorisation of the ${len(s.q)} \times {len(s.q)}$ "
                                       "mass matrix, emitted in the generated code"}
    elif d.hamiltonian is not None:
        h = d.hamiltonian
        det = sp.factor(d.M.det())
        ctx["hamiltonian"] = {"closed": True, "det": ts.expr_lines(det, n),
                              "M_inv": _entries((d.M.adjugate()).applyfunc(sp.expand), n,
                                                r"\bigl(\det M\; M^{-1}\bigr)", symmetric=True),
                              "H": ts.expr_lines(sp.expand((sp.Matrix(s.p).T * d.M.adjugate()
                                                            * sp.Matrix(s.p))[0, 0]), n),
                              "qdot": _entries((h.qdot * det).applyfunc(sp.expand), n,
                                               r"\det M\; \dot{q}"),
                              "dL_dq": _entries(h.dL_dq, n, r"\dot{p}")}
    if d.paper is not None:
        P = d.paper
        mu = sp.Symbol("mu", positive=True)
        m1, m2 = s.param("m1"), s.param("m2")
        to_mu = lambda e: sp.factor_terms(sp.expand(e).subs(m1, (mu - 1) * m2))
        ctx["seedforms"] = {
            "A": _entries(P.A.applyfunc(to_mu), n, "A", symmetric=True),
            "B": _entries(P.B.applyfunc(to_mu), n, "B"),
            "G": _entries(P.G.applyfunc(to_mu), n, "G"),
            "Q": ts.matrix_lines(P.Q.applyfunc(to_mu), n),
            "G_red": ts.matrix_lines(P.G_red.applyfunc(to_mu), n),
            "B_red": _entries(P.B_red.applyfunc(to_mu), n, r"\tilde{B}"),
            "D1": _entries(P.D1.applyfunc(to_mu), n, "(D_{1})", symmetric=True),
            "D2": _entries(P.D2.applyfunc(to_mu), n, "(D_{2})", symmetric=True),
            "w": ts.tex(P.w.T, n) + "^{T}",
        }
    return ctx


_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
            "_": r"\_", "{": r"\{", "}": r"\}", "^": r"\^{}", "~": r"\~{}"}
# Unicode in verdict summaries -> LaTeX math (pdflatex has no Greek text font).
_MATH = {"θ": r"\theta", "ϑ": r"\vartheta", "φ": r"\varphi", "ϕ": r"\phi", "μ": r"\mu",
         "π": r"\pi", "Δ": r"\Delta", "∂": r"\partial", "·": r"\cdot", "×": r"\times",
         "²": "^2", "′": "'", "−": "-"}
_ACCENTS = {"\u0307": r"\dot", "\u0308": r"\ddot"}


def _escape(text: str) -> str:
    """Plain text with Unicode symbols as a LaTeX paragraph fragment."""
    out: list[str] = []
    for ch in text:
        if ch in _ACCENTS and out:
            out[-1] = f"${_ACCENTS[ch]}{{{out[-1].strip('$')}}}$"
        elif ch in _MATH:
            out.append(f"${_MATH[ch]}$")
        elif ch == "§":
            out.append(r"\S{}")
        else:
            out.append(_SPECIAL.get(ch, ch))
    return "".join(out).replace("$$", "")


def environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(paths.templates_dir() / "latex")), undefined=jinja2.StrictUndefined,
        block_start_string=r"\BLOCK{", block_end_string="}",
        variable_start_string=r"\VAR{", variable_end_string="}",
        comment_start_string=r"\#{", comment_end_string="}",
        trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True, autoescape=False)


def _template(name: str):
    try:
        return environment().get_template(name)
    except jinja2.TemplateNotFound as exc:
        raise PackageDataError(f"template latex/{exc.name} is missing from {paths.templates_dir()}; "
                               f"reinstall derive") from None


def render(d: Derivation, results, checks=(), paper: str = "a4") -> str:
    return _stamped(d.name, _template("derivation.tex.j2").render(**context(d, results, checks, paper)))





def _stamped(name: str, text: str) -> str:
    """The document's first line names the derive version and the model's content hash, as
    every generated file does (codegen/sources.provenance)."""
    return provenance(name, {"tex": text})["tex"]
