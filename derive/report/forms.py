"""`derive verify --json`: every seed formula with its printed and derived forms (LaTeX and
SymPy text), the verdict, an erratum's discrepancy and corrected form; the physics checks."""
from __future__ import annotations

from . import typeset as ts
from ..verification import claims, judge
from ..verification.errata import errata_by_key
from .latex import symbol_names


def _form(obj, names) -> dict:
    return {"latex": ts.latex_text(obj, names), "sympy": ts.sympy_text(obj)}


def formula_rows(results) -> list[dict]:
    table, errata = judge.claims_by_key(), errata_by_key()
    rows = []
    for r in results:
        row = {"seed": r.seed, "equation": r.equation, "what": r.what, "model": r.model,
               "verdict": r.verdict, "summary": r.summary, "printed": None, "derived": None,
               "discrepancy": None, "corrected": None, "origin": None}
        claim = table.get(r.key)
        if claim is not None:
            c = claims.context(claim.model)
            n = symbol_names(c.d)
            row["printed"] = _form(claim.printed(c), n)
            row["derived"] = _form(claim.derived(c), n)
            e = errata.get(r.key)
            if e is not None:
                row["discrepancy"] = _form(e.discrepancy(c), n)
                row["corrected"] = _form(e.corrected(c), n)
                row["origin"] = e.origin
        rows.append(row)
    return rows


def check_rows(checks) -> list[dict]:
    return [{"name": c.name, "passed": c.passed, "detail": c.detail,
             "models": list(getattr(c, "models", ())), "states": getattr(c, "states", 0),
             "tolerance": getattr(c, "tolerance", ""), "worst": getattr(c, "worst", "")}
            for c in checks]


def verification_json(results, checks) -> dict:
    return {"formulas": formula_rows(results), "physics_checks": check_rows(checks)}
