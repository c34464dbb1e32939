"""Taylor's method across trajectories in SIMD lanes (heyoka's batch mode), emitted per
model as standalone C99: <model>_taylor_lanes.{h,c}.

The scalar integrator (taylor_codegen.py, <model>_taylor.c) computes the jet of one
trajectory, J[node][k]; this one computes it for L trajectories at once with the lane
innermost, J[node][k * L + lane], so every recurrence is a loop over L lanes the compiler
turns into vector instructions (plain C loops: no intrinsics, no vector extensions; on a
machine without SIMD they are scalar loops).  Each lane is a trajectory of its own: its
own parameters (the constants of its jet), step size, time, output rows and counters; a
lane whose trajectory ends takes the next one of the block, so no lane idles until the
block runs out.

Every lane does exactly the arithmetic of the scalar integrator, operation by operation
and in the same order (sums from j = 0 up, the same divisions, sin/cos/exp at order 0 by
the scalar libm call per lane), so with floating-point contraction off
(-ffp-contract=off: no fused multiply-adds, which the scalar build does not use either)
each trajectory is bit for bit what `simulate(method="taylor")` gives.
"""
from __future__ import annotations

from ..errors import SpecError
from .taylor_codegen import Decomposition, _slots, c_statements, counts, rhs_decomposition, ORDER_MAX

LANES_DEFAULT = 4        # the generic build's lanes (AVX2: four doubles)


def variant_number(suffix: str) -> int:
    """k of -D<M>_TAYLOR_LANES_ONLY=k, which compiles only the variant with this suffix
    ("", "_f", "_l"): its place among the C variants, from 1."""
    from .codegen import _C_VARIANTS
    return [s for _, s, _ in _C_VARIANTS].index(suffix) + 1


def lane_statements(d: Decomposition, P: str, s: str) -> dict:
    """The jet body of one variant: one call per operation computing coefficient k in every
    lane (J[i] + k * L; C[c] the lane's constants), the outputs X[i][k + 1] and the guards."""
    def ref(i):                  # a state's coefficients are X[i] itself (no copy)
        op = d.ops[i]
        return f"X[{op.index}]" if op.kind == "var" else f"J[{i}]"

    def fn(name):
        return f"{P}_l{name}{s}"

    lines = []
    for i, op in enumerate(d.ops):
        if op.kind == "var":
            continue
        u = ref(i)
        uk = f"{u} + k * L"
        if op.kind in ("add", "sub"):
            a, b = (ref(x) for x in op.args)
            lines.append(f"{fn(op.kind)}({uk}, {a} + k * L, {b} + k * L);")
        elif op.kind == "scale":
            lines.append(f"{fn('scale')}({uk}, C[{op.args[1]}], {ref(op.args[0])} + k * L);")
        elif op.kind == "shift":
            base = "0" if op.args[0] is None else f"{ref(op.args[0])} + k * L"
            lines.append(f"{fn('shift')}({uk}, {base}, C[{op.args[1]}], k);")
        elif op.kind in ("mul", "square"):
            a = ref(op.args[0])
            b = a if op.kind == "square" else ref(op.args[1])
            lines.append(f"{fn('mul')}({uk}, {a}, {b}, k);")
        elif op.kind == "div":
            lines.append(f"{fn('div')}({u}, {ref(op.args[0])} + k * L, {ref(op.args[1])}, k);")
        elif op.kind == "inv":
            lines.append(f"{fn('div')}({u}, 0, {ref(op.args[0])}, k);")
        elif op.kind == "sqrt":
            lines.append(f"{fn('sqrt')}({u}, {ref(op.args[0])}, k);")
        elif op.kind == "sin":            # with its cos (the next operation): one sincos
            lines.append(f"{fn('sincos')}({u}, {ref(op.args[1])}, {ref(op.args[0])}, k);")
        elif op.kind == "cos":
            if d.ops[i - 1].kind != "sin" or d.ops[i - 1].args != (op.args[0], i):   # pragma: no cover
                raise SpecError("a cos without its sin before it in the Taylor decomposition")
        elif op.kind == "exp":
            lines.append(f"{fn('exp')}({u}, {ref(op.args[0])}, k);")
        else:                                   # pragma: no cover (every kind above)
            raise SpecError(f"unknown Taylor operation {op.kind}")
    outputs = []
    for i, (kind, j) in enumerate(d.outputs):
        if kind == "node":
            outputs.append(f"{fn('out')}(X[{i}] + (k + 1) * L, {ref(j)} + k * L, k);")
        else:
            outputs.append(f"{fn('outc')}(X[{i}] + (k + 1) * L, C[{j}], k);")
    return {"ops": lines, "outputs": outputs, "guards": [ref(g) for g in d.guards]}


def render_taylor_lanes(name: str) -> dict[str, str]:
    """<name>_taylor_lanes.h and .c: the lane-parallel Taylor integrator (C backend artifact)."""
    from ..codegen.emit import render
    from .codegen import c_variants, model_info
    from .contract import INFO
    info = model_info(name)
    d = rhs_decomposition(name)
    slots = _slots(name)
    variants = [dict(v, constants=c_statements(d, v["ctype"], slots)["constants"],
                     lanes=lane_statements(d, name, v["s"])) for v in c_variants()]
    kinds = counts(d)
    M = name.upper()
    uses = {"mul": bool(kinds.keys() & {"mul", "square"}), "div": bool(kinds.keys() & {"div", "inv"}),
            "sqrt": "sqrt" in kinds, "sincos": "sin" in kinds, "exp": "exp" in kinds,
            "add": "add" in kinds, "sub": "sub" in kinds, "scale": "scale" in kinds, "shift": "shift" in kinds,
            "outc": any(kind == "const" for kind, _ in d.outputs)}
    ctx = {"P": name, "M": M, "title": info.title, "variants": variants, "nops": len(d.ops), "uses": uses,
           "nconst": len(d.constants), "order_max": ORDER_MAX, "lanes_default": LANES_DEFAULT,
           "info_scalars": [f.name for f in INFO if not f.length],
           "nparams": f"{M}_N_PARAMS + {M}_N_INPUTS" if info.n_inputs else f"{M}_N_PARAMS"}
    return {f"c/{name}_taylor_lanes.h": render("c/taylor_lanes.h.jinja",
                                                 dict(ctx, template="templates/c/taylor_lanes.h.jinja")),
            f"c/{name}_taylor_lanes.c": render("c/taylor_lanes.c.jinja",
                                                 dict(ctx, template="templates/c/taylor_lanes.c.jinja"))}
