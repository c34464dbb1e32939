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
from .taylor import ORDER_RULE, TAYLOR_VARIANTS, Decomposition, _slots, c_statements, counts, rhs_decomposition
from .integrators import _C_VARIANTS, c_variants, model_info
from .emit import render
from .contract import INFO

LANES_DEFAULT = 4        # the generic build's lanes (AVX2: four doubles)


def variant_number(suffix: str) -> int:
    """k of -D<M>_TAYLOR_LANES_ONLY=k, which compiles only the variant with this suffix
    ("", "_f", "_l"): its place among the C variants, from 1."""
    return [s for _, s, _ in _C_VARIANTS].index(suffix) + 1


def history_nodes(d: Decomposition) -> set[int]:
    """The nodes whose every coefficient so far is read (operands of products, quotients'
    divisors and the quotients, square roots, sin/cos and exp and their arguments); the
    others are read only at the order being computed, so one row of lanes holds them."""
    keep = set()
    for i, op in enumerate(d.ops):
        if op.kind in ("mul", "square"):
            keep.update(op.args)
        elif op.kind in ("div", "inv"):
            keep.update((op.args[-1], i))
        elif op.kind == "sqrt":
            keep.add(i)
        elif op.kind in ("sin", "cos", "exp"):
            keep.update((op.args[0], i))
    return keep


def lane_statements(d: Decomposition, P: str, s: str) -> dict:
    """The jet body of one variant: one call per operation computing coefficient k in every
    lane, the outputs X[i][k + 1] and the guards.  Coefficients live in X (the states), H
    (history_nodes: H[h] + k * L) or T (the others, the current order only: T[t]); C[c]
    are the lane's constants.  Only the nodes read at other orders take ORDER_DIM rows:
    the planar jet's working set is then about half, within a 32 KB L1 cache."""
    hist = history_nodes(d)
    slot, nh, nt = {}, 0, 0
    for i, op in enumerate(d.ops):
        if op.kind == "var":
            slot[i] = f"X[{op.index}]"
        elif i in hist:
            slot[i], nh = f"H[{nh}]", nh + 1
        else:
            slot[i], nt = f"T[{nt}]", nt + 1

    def row(i):                  # every coefficient of node i (a state's: X[i] itself)
        assert slot[i][0] in "XH", (i, d.ops[i])
        return slot[i]

    def cur(i):                  # coefficient k of node i
        return slot[i] if slot[i][0] == "T" else f"{slot[i]} + k * L"

    def fn(name):
        return f"{P}_l{name}{s}"

    lines = []
    for i, op in enumerate(d.ops):
        if op.kind == "var":
            continue
        if op.kind in ("add", "sub"):
            lines.append(f"{fn(op.kind)}({cur(i)}, {cur(op.args[0])}, {cur(op.args[1])});")
        elif op.kind == "scale":
            lines.append(f"{fn('scale')}({cur(i)}, C[{op.args[1]}], {cur(op.args[0])});")
        elif op.kind == "shift":
            base = "0" if op.args[0] is None else cur(op.args[0])
            lines.append(f"{fn('shift')}({cur(i)}, {base}, C[{op.args[1]}], k);")
        elif op.kind in ("mul", "square"):
            a = row(op.args[0])
            b = a if op.kind == "square" else row(op.args[1])
            lines.append(f"{fn('mul')}({cur(i)}, {a}, {b}, k);")
        elif op.kind == "div":
            lines.append(f"{fn('div')}({row(i)}, {cur(op.args[0])}, {row(op.args[1])}, k);")
        elif op.kind == "inv":
            lines.append(f"{fn('div')}({row(i)}, 0, {row(op.args[0])}, k);")
        elif op.kind == "sqrt":
            lines.append(f"{fn('sqrt')}({row(i)}, {cur(op.args[0])}, k);")
        elif op.kind == "sin":            # with its cos (the next operation): one sincos
            lines.append(f"{fn('sincos')}({row(i)}, {row(op.args[1])}, {row(op.args[0])}, k);")
        elif op.kind == "cos":
            if d.ops[i - 1].kind != "sin" or d.ops[i - 1].args != (op.args[0], i):   # pragma: no cover
                raise SpecError("a cos without its sin before it in the Taylor decomposition")
        elif op.kind == "exp":
            lines.append(f"{fn('exp')}({row(i)}, {row(op.args[0])}, k);")
        else:                                   # pragma: no cover (every kind above)
            raise SpecError(f"unknown Taylor operation {op.kind}")
    outputs = []
    for i, (kind, j) in enumerate(d.outputs):
        if kind == "node":
            outputs.append(f"{fn('out')}(X[{i}] + (k + 1) * L, {cur(j)}, k);")
        else:
            outputs.append(f"{fn('outc')}(X[{i}] + (k + 1) * L, C[{j}], k);")
    return {"ops": lines, "outputs": outputs, "guards": [cur(g) for g in d.guards],
            "nhist": nh, "ncur": nt}


def render_taylor_lanes(name: str) -> dict[str, str]:
    """<name>_taylor_lanes.h and .c: the lane-parallel Taylor integrator (C backend artifact)."""
    info = model_info(name)
    d = rhs_decomposition(name)
    slots = _slots(name)
    variants = [dict(v, constants=c_statements(d, TAYLOR_VARIANTS[v["ctype"]], slots)["constants"],
                     lanes=lane_statements(d, name, v["s"])) for v in c_variants()]
    kinds = counts(d)
    M = name.upper()
    uses = {"mul": bool(kinds.keys() & {"mul", "square"}), "div": bool(kinds.keys() & {"div", "inv"}),
            "sqrt": "sqrt" in kinds, "sincos": "sin" in kinds, "exp": "exp" in kinds,
            "add": "add" in kinds, "sub": "sub" in kinds, "scale": "scale" in kinds, "shift": "shift" in kinds,
            "outc": any(kind == "const" for kind, _ in d.outputs)}
    ctx = {"P": name, "M": M, "title": info.title, "variants": variants, "nops": len(d.ops), "uses": uses,
           "nconst": len(d.constants), **ORDER_RULE, "lanes_default": LANES_DEFAULT,
           "nstore": d.n + len(history_nodes(d) - {i for i, op in enumerate(d.ops) if op.kind == "var"}),
           "info_scalars": [f.name for f in INFO if not f.length],
           "nparams": f"{M}_N_PARAMS + {M}_N_INPUTS" if info.n_inputs else f"{M}_N_PARAMS"}
    return {f"c/{name}_taylor_lanes.h": render("c/taylor_lanes.h.jinja",
                                                 dict(ctx, template="templates/c/taylor_lanes.h.jinja")),
            f"c/{name}_taylor_lanes.c": render("c/taylor_lanes.c.jinja",
                                                 dict(ctx, template="templates/c/taylor_lanes.c.jinja"))}
