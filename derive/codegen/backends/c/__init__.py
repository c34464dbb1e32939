"""The C backend: standalone C99 (only <math.h>), float, double and long double from
one template, reentrant (no globals).

Its artifacts: per model <model>.h/.c (the kernels, templates/c/header.h.jinja and
source.c.jinja), <model>_integrate.h/.c (the integrators, rendered by
derive/codegen/integrators.py: a thin file that includes the method code of the
library/ folder here, derive_integrators.h and derive_driver.h, copied verbatim beside
it with the tableaus' derive_tableaus.h, the same for every model), the Taylor integrator, scalar and in SIMD lanes
(<model>_taylor.*, <model>_taylor_lanes.*, for a model whose rhs has recurrences:
derive/codegen/taylor.py, taylor_lanes.py), and for a model without chart
guards the batched and fixed-step loops (<model>_throughput.*, <model>_fixed.*; derive/runtime/
throughput.py); per atlas <atlas>.h/.c.  Model parameters never become C
identifiers (the printer writes array slots, p[3]), so a parameter may be called
`int` or `double`; the model name is only ever a prefix (planar_rhs).
"""
from __future__ import annotations

import sympy as sp

from ...emit import lanes_context, render, trig_lanes
from ...names import VECTOR_MATH
from ...printers import CPrinter, CVariantPrinter, shared_printer
from ..base import Backend, Variant, common_context, join_terms, own, slot_doc, unflatten, wrap
from ...integrators import render_atlas, render_c
from ...taylor import keep_whole_angles, prefetch_whole_angles, render_taylor, taylor_problem
from ...taylor_lanes import render_taylor_lanes
from ...loops import render_loops

# C99 keywords (6.4.1) and the identifiers <math.h> declares that a generated file uses
C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum extern
float for goto if inline int long register restrict return short signed sizeof static struct
switch typedef union unsigned void volatile while _Bool _Complex _Imaginary""".split())


class CBackend(Backend):
    """Standalone C99: <model>.h and <model>.c, float/double/long double from one template."""
    name = "c"
    suffixes = (".c", ".h")
    printer = CPrinter
    reserved = C_KEYWORDS
    variants = (Variant("double", "", "double"), Variant("float", "_f", "float"),
                Variant("long double", "_l", "long double"))

    def kernel_files(self, spec, bodies):
        ctx = self.context(spec, bodies)
        return {f"c/{spec.name}.h": render("c/header.h.jinja", dict(ctx, template="templates/c/header.h.jinja")),
                f"c/{spec.name}.c": render("c/source.c.jinja", dict(ctx, template="templates/c/source.c.jinja"))}

    def context(self, spec, bodies):
        ctx = common_context(spec, "")
        macro = spec.name.upper()
        ctx.update(prefix=spec.name, macro=macro, vector_math=list(VECTOR_MATH),
                   variants=[{"ctype": v.ctype, "suffix": v.suffix, "label": v.label}
                             for v in self.variants])
        kernels = []
        for b in bodies:
            k = b.kernel
            slots = {s: f"{inp.name}[{i}]" for inp in k.inputs for i, s in enumerate(inp.vector.symbols)}
            kmacro = f"{spec.prefix.upper()}_{k.name.upper()}"     # planar_linearize(): PLANAR_LINEARIZE_A_SIZE
            args = []
            for inp in k.inputs:
                args.append({"name": inp.name, "const": True, "size": inp.size,
                             "macro": f"{kmacro}_{inp.name.upper()}", "rank": 1, "shape": [inp.size],
                             "doc": f"{inp.vector.doc}: ({slot_doc(inp.vector)})"})
            for out in k.outputs:
                args.append({"name": out.name, "const": False, "size": out.size,
                             "macro": f"{kmacro}_{out.name.upper()}", "rank": len(out.shape),
                             "shape": list(out.shape), "doc": out.doc})
            variants = []
            shared = shared_printer(CVariantPrinter, slots)   # each expression printed once for the three types
            for v in self.variants:
                pr = shared.typed(v.ctype)
                roots = b.outputs + [b.guards]
                lanes, assignments, flat = None, b.assignments, [e for exprs in roots for e in exprs]
                if v.ctype == "double":     # libmvec has vector sin/cos for double only
                    lanes, assignments, flat = trig_lanes(assignments, flat)
                *outputs, guard_exprs = unflatten(flat, roots)
                locals_ = [{"name": s.name, "value": pr.doprint_checked(e)} for s, e in assignments]
                assigns = []
                for out, exprs in zip(k.outputs, outputs):
                    for i, e in enumerate(exprs):
                        assigns.append({"target": f"{out.name}[{i}]", "value": pr.doprint_checked(e)})
                guards = [f"!({pr.doprint_checked(sp.Abs(g))} >= ({v.ctype}){macro}_POLAR_SINE_MIN)"
                          for g in guard_exprs]
                terms = [f"({a['value']} - {a['value']})" for a, e in
                         zip(assigns, [e for exprs in outputs for e in exprs]) if not e.is_Number]
                check = join_terms(terms, " + ", 84)
                variants.append({"ctype": v.ctype, "suffix": v.suffix, "lanes": lanes_context(lanes, pr),
                                 "locals": locals_,
                                 "assigns": assigns, "guards": guards, "check": check})
            kernels.append({
                "name": k.name, "cname": f"{spec.prefix}_{k.name}", "macro": kmacro,
                "doc": wrap(k.doc, 76), "ops": b.ops, "args": args,
                "inputs": [a for a in args if a["const"]], "outputs": [a for a in args if not a["const"]],
                "unused": b.unused_inputs, "has_guards": bool(b.guards), "variants": variants})
        ctx["kernels"] = kernels
        return ctx

    def integrator_files(self, name, timed=False):
        files = render_c(name)      # a time-dependent model's too: the library passes each stage's t
        files.update(self.taylor_files(name))
        return files

    def early_work(self, name):
        """The Taylor jet with whole angles (taylor.whole_angles_decomposition) needs only
        the model's spec: made in a worker while the kernels' CSE runs."""
        return prefetch_whole_angles, keep_whole_angles

    def taylor_files(self, name):
        """The Taylor integrator, scalar and in SIMD lanes (none for a model with an
        operation no recurrence covers); a time-dependent model's has t in its jet."""
        files = {}
        if taylor_problem(name) is None:
            files.update(render_taylor(name))
            files.update(render_taylor_lanes(name))
        return files

    def loop_files(self, name):
        return render_loops(name, self.name)

    def atlas_files(self, name):
        return own(render_atlas(name), self.name)


BACKEND = CBackend()
