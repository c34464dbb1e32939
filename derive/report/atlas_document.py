"""`derive latex spherical`: the chart atlas of the double spherical pendulum as a document.

Not one derivation but three chart models (spherical_std, spherical_alt, spherical_rot),
the rule of seed 000 section 5.1 that picks one of them, the thresholds the integrators
use, and the coordinate changes the generated <a>_to_<b> kernels compute.
"""
from __future__ import annotations


from ..derivation import derive
from ..derivation.charts import chart_change
from ..codegen.integrators import ATLAS_CHARTS, SINE_MIN, SINE_RULE, SINE_SWITCH
from . import typeset as ts
from .latex import PAPERS, _seed_groups, _stamped, _template, physics_rows, result_rows, symbol_names


def _chart(name: str) -> dict:
    d = derive(name)
    n = symbol_names(d)
    link = d.model.links[0]
    u = list(d.symbols.q[:2])
    e = link.chart.unit_vector(u)
    sine = link.chart.polar_sine_of(u)
    return {"model": name.replace("_", r"\_"), "chart": link.chart.name, "title": ts.text(d.model.title),
            "source": ts.prose(link.chart.source if hasattr(link.chart, "source") else d.model.source),
            "unit": r"\begin{pmatrix}" + r" \\ ".join(ts.tex(x, n) for x in e) + r"\end{pmatrix}",
            "coords": ", ".join(f"${ts.tex(x, n)}$" for x in u),
            "sine": ts.tex(sine, n),
            "axis": getattr(link.chart, "singular_axis", "") or ""}


def _change(a: str, b: str) -> dict:
    da, db = derive(a), derive(b)
    change = chart_change(da.model, db.model)
    na, nb = symbol_names(da), symbol_names(db)
    names = ts.Names({**na})
    for stand_in, q in zip(change.target_q, db.symbols.q):
        names[stand_in] = nb[q]
    rows = []
    k = len(db.model.links[0].chart.coordinates)          # link 1; link 2 is alike
    for q, expr in list(zip(db.symbols.q, change.coordinates))[:k]:
        rows.append({"name": nb[q], "lines": ts.expr_lines(expr, names, ts.WIDTH - 8)})
    for qd, expr in list(zip(db.symbols.qd, change.rates))[:k]:
        rows.append({"name": nb[qd], "lines": ts.expr_lines(expr, names, ts.WIDTH - 8)})
    return {"source": a, "target": b, "kernel": f"{a}_to_{b}".replace("_", r"\_"), "rows": rows}


def atlas_context(results, checks, paper: str = "a4") -> dict:
    d = derive(ATLAS_CHARTS[0])
    n = symbol_names(d)
    seen, unique = set(), []
    for c in checks:
        if c.name not in seen:
            seen.add(c.name)
            unique.append(c)
    return {
        "paper": PAPERS[paper], "charts": [_chart(m) for m in ATLAS_CHARTS],
        "sine_rule": SINE_RULE, "sine_switch": SINE_SWITCH, "sine_min": SINE_MIN,
        "changes": [_change(a, b) for a in ATLAS_CHARTS for b in ATLAS_CHARTS if a != b],
        "groups": _seed_groups(result_rows(results)), "n_results": len(results),
        "checks": physics_rows(unique, n),
    }


def render_atlas(results, checks, paper: str = "a4") -> str:
    """The atlas document's LaTeX source (templates/latex/atlas.tex.j2), stamped."""
    return _stamped("spherical", _template("atlas.tex.j2").render(**atlas_context(results, checks, paper)))
