"""Languages: each is a printer (printers.py), a folder under templates/, and the
Python below that names things and prints every expression.  Templates only
lay out the strings prepared here; there is no type dispatch inside Jinja.

Adding a language: a printer subclass, a `Language` subclass with `files()`,
a folder templates/<name>/, and an entry in LANGUAGES.
"""
from __future__ import annotations

import textwrap
from dataclasses import dataclass

import sympy as sp

from .emit import Body, half_angle_sincos, lanes_context, live_assignments, render, trig_lanes
from .loader import VECTOR_MATH
from .names import numpy_slots
from .printers import CPrinter, PyNumPyPrinter
from .spec import ModelSpec

POLAR_SINE_MIN = "1e-6"      # default chart-singularity threshold (overridable in C)


def _wrap(text: str, width: int = 88) -> list[str]:
    return textwrap.wrap(" ".join(text.split()), width) or [""]


def _join_terms(terms: list[str], sep: str, width: int) -> list[str]:
    """terms joined by sep, broken into lines between terms, never inside one."""
    lines, line = [], ""
    for term in terms:
        piece = term if not line else sep + term
        if line and len(line) + len(piece) > width:
            lines.append(line + sep.rstrip())
            line = term
        else:
            line += piece
    return lines + [line] if line else lines


def _slot_doc(vector) -> str:
    return ", ".join(vector.names)


def _common(spec: ModelSpec, bodies: list[Body], template: str) -> dict:
    return {
        "template": template,
        "model": spec.name,
        "title": spec.title,
        "source": spec.source,
        "vectors": [{"count": v.count, "table": v.table, "size": v.size,
                     "names": list(v.names), "names_py": repr(tuple(v.names)),
                     "names_c": ", ".join(f'"{n}"' for n in v.names), "doc": v.doc}
                    for v in spec.vectors],
        "has_guards": spec.has_guards,
        "polar_sine_min": POLAR_SINE_MIN,
    }


@dataclass(frozen=True)
class Variant:
    ctype: str        # C type of the variant
    suffix: str       # appended to every function name
    label: str


def _unflatten(flat: list, like: list[list]) -> list[list]:
    """flat, cut into lists of the lengths of like's."""
    out, i = [], 0
    for exprs in like:
        out.append(flat[i:i + len(exprs)])
        i += len(exprs)
    return out


class Language:
    name: str

    def files(self, spec: ModelSpec, bodies: list[Body]) -> dict[str, str]:
        raise NotImplementedError


class C(Language):
    """Standalone C99: <model>.h and <model>.c, float/double/long double from one template."""
    name = "c"
    variants = (Variant("double", "", "double"), Variant("float", "_f", "float"),
                Variant("long double", "_l", "long double"))

    def files(self, spec, bodies):
        ctx = self.context(spec, bodies)
        return {f"c/{spec.name}.h": render("c/header.h.jinja", dict(ctx, template="templates/c/header.h.jinja")),
                f"c/{spec.name}.c": render("c/source.c.jinja", dict(ctx, template="templates/c/source.c.jinja"))}

    def context(self, spec, bodies):
        ctx = _common(spec, bodies, "")
        macro = spec.name.upper()
        ctx.update(prefix=spec.name, macro=macro, vector_math=list(VECTOR_MATH),
                   variants=[{"ctype": v.ctype, "suffix": v.suffix, "label": v.label}
                             for v in self.variants])
        kernels = []
        for b in bodies:
            k = b.kernel
            slots = {s: f"{inp.name}[{i}]" for inp in k.inputs for i, s in enumerate(inp.vector.symbols)}
            kmacro = f"{macro}_{k.name.upper()}"
            args = []
            for inp in k.inputs:
                args.append({"name": inp.name, "const": True, "size": inp.size,
                             "macro": f"{kmacro}_{inp.name.upper()}", "rank": 1, "shape": [inp.size],
                             "doc": f"{inp.vector.doc}: ({_slot_doc(inp.vector)})"})
            for out in k.outputs:
                args.append({"name": out.name, "const": False, "size": out.size,
                             "macro": f"{kmacro}_{out.name.upper()}", "rank": len(out.shape),
                             "shape": list(out.shape), "doc": out.doc})
            variants = []
            for v in self.variants:
                pr = CPrinter(slots, v.ctype)
                roots = b.outputs + [b.guards]
                lanes, assignments, flat = None, b.assignments, [e for exprs in roots for e in exprs]
                if v.ctype == "double":     # libmvec has vector sin/cos for double only
                    lanes, assignments, flat = trig_lanes(assignments, flat)
                *outputs, guard_exprs = _unflatten(flat, roots)
                locals_ = [{"name": s.name, "value": pr.doprint_checked(e)} for s, e in assignments]
                assigns = []
                for out, exprs in zip(k.outputs, outputs):
                    for i, e in enumerate(exprs):
                        assigns.append({"target": f"{out.name}[{i}]", "value": pr.doprint_checked(e)})
                guards = [f"!({pr.doprint_checked(sp.Abs(g))} >= ({v.ctype}){macro}_POLAR_SINE_MIN)"
                          for g in guard_exprs]
                terms = [f"({a['value']} - {a['value']})" for a, e in
                         zip(assigns, [e for exprs in outputs for e in exprs]) if not e.is_Number]
                check = _join_terms(terms, " + ", 84)
                variants.append({"ctype": v.ctype, "suffix": v.suffix, "lanes": lanes_context(lanes, pr),
                                 "locals": locals_,
                                 "assigns": assigns, "guards": guards, "check": check})
            kernels.append({
                "name": k.name, "cname": f"{spec.name}_{k.name}", "macro": kmacro,
                "doc": _wrap(k.doc, 76), "ops": b.ops, "args": args,
                "inputs": [a for a in args if a["const"]], "outputs": [a for a in args if not a["const"]],
                "unused": b.unused_inputs, "has_guards": bool(b.guards), "variants": variants})
        ctx["kernels"] = kernels
        return ctx


class NumPy(Language):
    """One module per model, importing only numpy; arrays of states broadcast."""
    name = "numpy"

    def files(self, spec, bodies):
        ctx = _common(spec, bodies, "templates/numpy/module.py.jinja")
        kernels = []
        for b in bodies:
            k = b.kernel
            slots = numpy_slots([s for inp in k.inputs for s in inp.vector.symbols])
            varying = {s for inp in k.inputs if inp.vector.key != "param" for s in inp.vector.symbols}
            assignments, flat = half_angle_sincos(b.assignments, [e for exprs in b.outputs for e in exprs])
            outputs = _unflatten(flat, b.outputs)
            for sym, e in assignments:
                if e.free_symbols & varying:
                    varying.add(sym)
            pr = PyNumPyPrinter(slots, varying)
            # only what the outputs need (guards have no NumPy counterpart)
            kept = live_assignments(assignments, flat)
            needed = set().union(*(sp.sympify(e).free_symbols for e in flat), *(e.free_symbols for _, e in kept))
            unpack = [{"name": slots[s], "source": f"{inp.name}[..., {i}]"}
                      for inp in k.inputs for i, s in enumerate(inp.vector.symbols) if s in needed]
            # free each temporary after its last use: fewer live arrays, memory reused
            local_syms = {s for s, _ in kept}
            uses = [e.free_symbols for _, e in kept] + \
                [sp.sympify(e).free_symbols for exprs in outputs for e in exprs]
            last = {}
            for i, used in enumerate(uses):
                for s in used & local_syms:
                    last[s] = i
            dels = [[] for _ in uses]
            for s, i in last.items():
                dels[i].append(s.name)
            dels = [", ".join(sorted(d)) for d in dels]
            locals_ = [{"name": s.name, "value": pr.doprint_checked(e), "dels": dels[i]}
                       for i, (s, e) in enumerate(kept)]
            outs, pos = [], len(kept)
            for out, exprs in zip(k.outputs, outputs):
                items = []
                for flat, e in enumerate(exprs):
                    idx, rest = [], flat
                    for dim in reversed(out.shape):
                        idx.insert(0, rest % dim)
                        rest //= dim
                    target = f"{out.name}[..., {', '.join(map(str, idx))}]" if idx else f"{out.name}[...]"
                    items.append({"target": target, "value": pr.doprint_checked(e), "dels": dels[pos]})
                    pos += 1
                outs.append({"name": out.name, "shape": list(out.shape), "cells": items,
                             "shape_py": repr(tuple(out.shape)),
                             "shape_doc": "(" + ", ".join(["..."] + [str(d) for d in out.shape]) + ")",
                             "doc": out.doc})
            kernels.append({
                "name": k.name, "doc": _wrap(k.doc, 80), "ops": b.ops,
                "inputs": [{"name": i.name, "size": i.size,
                            "doc": f"{i.vector.doc}: ({_slot_doc(i.vector)})"} for i in k.inputs],
                "unpack": unpack,
                "unpack_target": "(" + ", ".join(i.name for i in k.inputs) + ("," if len(k.inputs) == 1 else "") + ")",
                "locals": locals_,
                "outputs": outs})
        ctx["kernels"] = kernels
        return {f"numpy/{spec.name}.py": render("numpy/module.py.jinja", ctx)}


LANGUAGES: tuple[Language, ...] = (C(), NumPy())
