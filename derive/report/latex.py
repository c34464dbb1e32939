"""`derive latex MODEL`: the derivation of one model as a standalone .tex file.

Python decides what goes in (which sections, the LaTeX of each expression);
the Jinja2 template ``templates/latex/derivation.tex.j2`` only lays it out.
The template uses \\VAR{...} and \\BLOCK{...} delimiters so LaTeX braces stay
untouched.
"""
from __future__ import annotations


import jinja2
import sympy as sp

from ..derivation import Derivation
from ..errors import PackageDataError
from .. import paths

LINE_BUDGET = 110   # characters of LaTeX source per displayed line, roughly


def symbol_names(d: Derivation) -> dict[sp.Symbol, str]:
    """theta1 -> \\theta_{1}, theta1_dot -> \\dot{\\theta}_{1}, p_theta1 -> p_{\\theta_{1}}."""
    names, k = {}, 0
    for i, link in enumerate(d.model.links, 1):
        for tex in link.chart.latex:
            base = tex.rstrip("'")
            prime = "'" * (len(tex) - len(base))
            names[d.symbols.q[k]] = f"{base}{prime}_{{{i}}}"
            names[d.symbols.qd[k]] = f"\\dot{{{base}}}{prime}_{{{i}}}"
            names[d.symbols.p[k]] = f"p_{{{base}{prime}_{{{i}}}}}"
            k += 1
    return names


def _tex(expr, names) -> str:
    return sp.latex(expr, symbol_names=names)


def split_sum(expr: sp.Expr, names) -> list[str]:
    """A long sum as several lines of at most about LINE_BUDGET characters."""
    terms = sp.Add.make_args(sp.expand(expr)) if isinstance(expr, sp.Add) else [expr]
    lines, current = [], ""
    for term in terms:
        piece = _tex(term, names)
        if current and not piece.startswith("-"):
            piece = "+ " + piece
        if current and len(current) + len(piece) > LINE_BUDGET:
            lines.append(current)
            current = piece
        else:
            current = f"{current} {piece}".strip()
    lines.append(current)
    return lines


def _matrix_entries(m: sp.Matrix, names, symbol: str, symmetric: bool = False):
    rows = []
    for i in range(m.rows):
        for j in range(m.cols):
            if m[i, j] == 0 or (symmetric and j < i):
                continue
            rows.append({"name": f"{symbol}_{{{i + 1}{j + 1}}}" if m.cols > 1 else f"{symbol}_{{{i + 1}}}",
                         "lines": split_sum(m[i, j], names)})
    return rows


def context(d: Derivation, results) -> dict:
    n = symbol_names(d)
    s = d.symbols
    ctx = {
        "title": _escape(d.model.title), "name": _escape(d.model.name),
        "source": _escape(d.model.source),
        "coordinates": ", ".join(f"${_tex(q, n)}$" for q in s.q),
        "parameters": ", ".join(f"${_tex(p, n)}$" for p in s.params),
        "links": [{"index": i, "chart": link.chart.name, "body": link.body.kind,
                   "tip": _tex(tip.T, n), "centre": _tex(c.T, n)}
                  for i, (link, tip, c) in enumerate(zip(d.model.links, d.tips, d.centres), 1)],
        "T": split_sum(d.T, n), "V": split_sum(d.V, n),
        "mass_matrix": _matrix_entries(d.M, n, "M", symmetric=True),
        "forcing": _matrix_entries(d.F, n, "F"),
        "accelerations": r"\begin{pmatrix}" + r" \\ ".join(
            n[qd].replace(r"\dot{", r"\ddot{", 1) for qd in s.qd) + r"\end{pmatrix}",
        "hamiltonian": None, "paper": None,
        "results": [{"seed": r.seed, "equation": _escape(r.equation), "verdict": r.verdict,
                     "summary": _escape(r.summary if r.verdict != "match" else
                                        f"{r.what}: {r.summary}")} for r in results],
    }
    if d.hamiltonian is not None:
        h = d.hamiltonian
        ctx["hamiltonian"] = {"M_inv": _matrix_entries(h.M_inv, n, r"(M^{-1})", symmetric=True),
                              "dL_dq": _matrix_entries(h.dL_dq, n, r"\dot{p}")}
    if d.paper is not None:
        P = d.paper
        mu = sp.Symbol("mu", positive=True)
        m1, m2 = s.param("m1"), s.param("m2")
        to_mu = lambda e: sp.factor_terms(sp.expand(e).subs(m1, (mu - 1) * m2))
        ctx["paper"] = {name: _tex(getattr(P, name).applyfunc(to_mu), n)
                        for name in ("Q", "G_red")}
        ctx["paper"]["B_red"] = _matrix_entries(P.B_red.applyfunc(to_mu), n, r"\tilde{B}")
        ctx["paper"]["w"] = _tex(P.w.T, n) + "^{T}"
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


def render(d: Derivation, results) -> str:
    try:
        template = environment().get_template("derivation.tex.j2")
    except jinja2.TemplateNotFound as exc:
        raise PackageDataError(f"template latex/{exc.name} is missing from {paths.templates_dir()}; "
                               f"reinstall derive") from None
    return template.render(**context(d, results))
