"""The NumPy backend: one module per model that imports only numpy; every kernel
broadcasts over leading axes of its arrays.

Its artifacts: per model <model>.py (the kernels, templates/numpy/module.py.jinja),
<model>_integrate.py (a few lines giving the kernels to the integrators' library), for a
model without chart guards <model>_throughput.py; per atlas <atlas>.py; for every model
alike derive_integrators.py (the methods and the stepping loop, hand-written in library/
and copied verbatim) and derive_tableaus.py (the run contract and the coefficients it
reads, rendered once; both derive/codegen/integrators.py).  Parameters become
kernel locals, so names Python reserves or the kernels use are renamed
(derive/codegen/names.py: `reserved` below is that list).
"""
from __future__ import annotations

import sympy as sp

from ...emit import free_names, half_angle_sincos, live_assignments, render
from ...names import KERNEL_NAMES, PYTHON_RESERVED, numpy_slots
from ...printers import PyNumPyPrinter, shared_printer
from ..base import Backend, common_context, own, slot_doc, unflatten, wrap
from ...integrators import render_atlas, render_numpy
from ...loops import render_loops


class NumPyBackend(Backend):
    """One module per model, importing only numpy; arrays of states broadcast."""
    name = "numpy"
    suffixes = (".py",)
    printer = PyNumPyPrinter
    reserved = PYTHON_RESERVED | KERNEL_NAMES

    def kernel_files(self, spec, bodies):
        ctx = common_context(spec, "templates/numpy/module.py.jinja")
        kernels = []
        for b in bodies:
            k = b.kernel
            assignments, flat = half_angle_sincos(b.assignments, [e for exprs in b.outputs for e in exprs])
            slots = numpy_slots([s for inp in k.inputs for s in inp.vector.symbols],
                                {s.name for s, _ in assignments})
            varying = {s for inp in k.inputs if inp.vector.key != "param" for s in inp.vector.symbols}
            outputs = unflatten(flat, b.outputs)
            for sym, e in assignments:
                if free_names(e) & varying:
                    varying.add(sym)
            pr = shared_printer(PyNumPyPrinter, slots, varying)    # the linearize file's A: the jacobian's texts
            # only what the outputs need (guards have no NumPy counterpart)
            kept = live_assignments(assignments, flat)
            needed = set().union(*(free_names(sp.sympify(e)) for e in flat), *(free_names(e) for _, e in kept))
            unpack = [{"name": slots[s], "source": f"{inp.name}[..., {i}]"}
                      for inp in k.inputs for i, s in enumerate(inp.vector.symbols) if s in needed]
            # free each temporary after its last use: fewer live arrays, memory reused
            local_syms = {s for s, _ in kept}
            uses = [free_names(e) for _, e in kept] + \
                [free_names(sp.sympify(e)) for exprs in outputs for e in exprs]
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
                "name": k.name, "doc": wrap(k.doc, 80), "ops": b.ops,
                "inputs": [{"name": i.name, "size": i.size,
                            "doc": f"{i.vector.doc}: ({slot_doc(i.vector)})"} for i in k.inputs],
                "unpack": unpack,
                "unpack_target": "(" + ", ".join(i.name for i in k.inputs) + ("," if len(k.inputs) == 1 else "") + ")",
                "locals": locals_,
                "outputs": outs})
        ctx["kernels"] = kernels
        return {f"numpy/{spec.name}.py": render("numpy/module.py.jinja", ctx)}

    def integrator_files(self, name, timed=False):
        return render_numpy(name)       # a time-dependent model's too: the library passes each stage's t

    def loop_files(self, name):
        return render_loops(name, self.name)

    def atlas_files(self, name):
        return own(render_atlas(name), self.name)


BACKEND = NumPyBackend()
