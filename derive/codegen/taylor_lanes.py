"""Taylor's method across trajectories in SIMD lanes (heyoka's batch mode), emitted per
model as standalone C99: <model>_taylor_lanes.{h,c}.

The scalar integrator (taylor.py, <model>_taylor.c) computes the jet of one
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

The run time (the recurrences for L lanes, the step, dense output, the lanes' bookkeeping)
is the hand-written derive_taylor_lanes.h (derive/codegen/backends/c/library/), included
once per precision; a model's file is its jet (OPERATIONS' lane statements, taylor.py),
its constants and the public entry points.
"""
from __future__ import annotations

from ..errors import SpecError
from .taylor import (COST_ORDER, LANES_UNROLL_COST, ORDER_RULE, TAYLOR_VARIANTS, Decomposition, _slots,
                     compact_context, c_statements, history_nodes, jet_cost, jet_levels, library_context,
                     operands, operation, rhs_decomposition, unroll_max, uses)
from .integrators import _C_VARIANTS, c_variants, library_files, model_info
from .emit import render

LANES_DEFAULT = 4        # the generic build's lanes (AVX2: four doubles)


def variant_number(suffix: str) -> int:
    """k of -D<M>_TAYLOR_LANES_ONLY=k, which compiles only the variant with this suffix
    ("", "_f", "_l"): its place among the C variants, from 1."""
    return [s for _, s, _ in _C_VARIANTS].index(suffix) + 1


class _Lanes:
    """A node's coefficients in the lanes' jet: X[i] (a state), H[h] (history_nodes: every
    order, coefficient k at + k * L) or T[t] (the others: the current order only)."""

    def __init__(self, slot: str):
        self.slot = slot

    @property
    def row(self) -> str:        # every coefficient (a state's: X[i] itself)
        assert self.slot[0] in "XH", self.slot
        return self.slot

    @property
    def cur(self) -> str:        # coefficient k
        return self.slot if self.slot[0] == "T" else f"{self.slot} + k * L"


def lane_statements(d: Decomposition) -> dict:
    """The jet body (the same text in every precision: the recurrences' names are macros of
    derive_taylor_lanes.h): one call per operation computing coefficient k in every lane
    (OPERATIONS' lane statements), the outputs X[i][k + 1] and the guards.  Coefficients
    live in X (the states), H (history_nodes: H[h] + k * L) or T (the others, the current
    order only: T[t]); C[c] are the lane's constants.  Only the nodes read at other orders
    take ORDER_DIM rows: the planar jet's working set is then about half, within a 32 KB
    L1 cache."""
    hist = history_nodes(d)
    slot, nh, nt = {}, 0, 0
    for i, op in enumerate(d.ops):
        if op.kind == "var":
            slot[i] = _Lanes(f"X[{op.index}]")
        elif i in hist:
            slot[i], nh = _Lanes(f"H[{nh}]"), nh + 1
        else:
            slot[i], nt = _Lanes(f"T[{nt}]"), nt + 1

    lines = []
    for i, op in enumerate(d.ops):
        entry = operation(op)
        if entry.with_previous:            # cos: its sin's statement computes it (one sincos)
            before = d.ops[i - 1] if i else None
            if before is None or before.kind != entry.with_previous or before.args != (op.args[0], i):
                raise SpecError(f"a {op.kind} without its {entry.with_previous} before it in the Taylor "
                                "decomposition")    # pragma: no cover (the builder pairs them)
        elif entry.lane:
            lines.append(entry.lane(slot[i], operands(op, slot.__getitem__)))
    outputs = []
    for i, (kind, j) in enumerate(d.outputs):
        if kind == "node":
            outputs.append(f"LANES_OUT(X[{i}] + (k + 1) * L, {slot[j].cur}, k);")
        else:
            outputs.append(f"LANES_OUTC(X[{i}] + (k + 1) * L, C[{j}], k);")
    return {"ops": lines, "outputs": outputs, "guards": [slot[g].cur for g in d.guards],
            "nhist": nh, "ncur": nt, "reads_constants": any("C[" in line for line in lines + outputs)}


def compact_lane_statements(d: Decomposition) -> dict:
    """The lanes' compact jet (taylor.compact_statements for L lanes): the nodes in the
    same three arrays as lane_statements' (X the states, H the nodes read at every order,
    T the others), each node of H and T renumbered so that the nodes of one level whose
    lane statements read alike are consecutive rows, one loop per segment; the statement
    is its operation's lane statement (OPERATIONS) written for row u, its operands from
    index tables (HA0[u], ... for a segment in H, TA0[u], ... in T: the rows of the node
    arguments, the indices of the constants).  A node without a statement of its own (cos:
    its sin's sincos writes it) has a row and no segment.

    Returns
    -------
    dict
        segments ((first row, past the last, statement)), tables ({name: every row's
        operand}: HA0, TA1, ...), nhist, ncur, outputs and guards (lane_statements'),
        space and row (each node's array, X, H or T, and its row there).
    """
    hist = history_nodes(d)
    level = jet_levels(d)
    space = {i: "X" if op.kind == "var" else "H" if i in hist else "T" for i, op in enumerate(d.ops)}

    def statement(i: int, op) -> str:
        entry = operation(op)
        nodes = len(op.args) - entry.consts
        a = [None if x is None else _Lanes(f"{space[x]}[{space[i]}A{j}[u]]") for j, x in enumerate(op.args[:nodes])]
        a += [f"{space[i]}A{j}[u]" for j in range(nodes, len(op.args))]
        return entry.lane(_Lanes(f"{space[i]}[u]"), a)

    groups: dict[tuple[int, str, str], list[int]] = {}
    for i, op in enumerate(d.ops):
        if op.kind != "var" and operation(op).lane:
            groups.setdefault((level[i], space[i], statement(i, op)), []).append(i)
    row = {i: op.index for i, op in enumerate(d.ops) if op.kind == "var"}
    used = {"H": 0, "T": 0}
    segments = []
    for (_, where, text), members in sorted(groups.items(), key=lambda g: (g[0][0], g[1][0])):
        first = used[where]
        row.update((i, first + m) for m, i in enumerate(members))
        used[where] += len(members)
        segments.append((first, used[where], text))
    for i in range(len(d.ops)):            # the nodes another's statement writes (cos)
        if i not in row:
            row[i], used[space[i]] = used[space[i]], used[space[i]] + 1

    width = max((len(op.args) for op in d.ops), default=0)
    tables = {f"{where}A{j}": [0] * used[where] for where in "HT" for j in range(width)}
    for i, op in enumerate(d.ops):
        if space[i] == "X":
            continue
        nodes = len(op.args) - operation(op).consts
        for j, x in enumerate(op.args):
            tables[f"{space[i]}A{j}"][row[i]] = x if j >= nodes else (0 if x is None else row[x])
    tables = {name: values for name, values in tables.items()
              if any(f"{name}[u]" in text for _, _, text in segments)}

    def cur(j: int) -> str:
        return f"T[{row[j]}]" if space[j] == "T" else f"{space[j]}[{row[j]}] + k * L"

    outputs = [f"LANES_OUT(X[{i}] + (k + 1) * L, {cur(j)}, k);" if kind == "node" else
               f"LANES_OUTC(X[{i}] + (k + 1) * L, C[{j}], k);" for i, (kind, j) in enumerate(d.outputs)]
    return {"segments": segments, "tables": tables, "nhist": used["H"], "ncur": used["T"], "outputs": outputs,
            "space": space, "row": row,
            "guards": [cur(g) for g in d.guards],
            "reads_constants": any("C[" in line for _, _, line in segments) or any("C[" in o for o in outputs)}


LIBRARY = ("derive_taylor_math.h", "derive_taylor_lanes.h")        # derive/codegen/backends/c/library/
# the recurrences of derive_taylor_lanes.h a jet may leave out (DERIVE_LANES_USES_<NAME>)
LANES_RECURRENCES = ("ADD", "SUB", "SCALE", "SHIFT", "CSUB", "MUL", "SQUARE", "DIV", "SQRT", "SINCOS", "EXP", "OUT",
                     "OUTC", "GUARD")


def lanes_uses(d: Decomposition) -> dict[str, bool]:
    """Which of derive_taylor_lanes.h's recurrences the jet calls: the operations' (the
    table), the outputs' (a node's, a constant's) and the chart guard."""
    called = uses(d, lanes=True)
    called |= {"OUT" if kind == "node" else "OUTC" for kind, _ in d.outputs}
    called |= {"GUARD"} if d.guards else set()
    return {name: name in called for name in LANES_RECURRENCES}


def render_taylor_lanes(name: str) -> dict[str, str]:
    """<name>_taylor_lanes.h and .c: the lane-parallel Taylor integrator (C backend artifact):
    the model's jet and constants and the glue that includes derive_taylor_lanes.h for each
    precision; the library header copied beside them."""
    info = model_info(name)
    d = rhs_decomposition(name)
    slots = _slots(name)
    variants = [dict(v, constants=c_statements(d, TAYLOR_VARIANTS[v["ctype"]], slots)["constants"],
                     tag=TAYLOR_VARIANTS[v["ctype"]]["tag"]) for v in c_variants()]
    M = name.upper()
    ctx = {"P": name, "M": M, "title": info.title, "variants": variants, "nops": len(d.ops),
           "uses": lanes_uses(d), "jet": lane_statements(d), "nconst": len(d.constants),
           "compact": compact_context(compact_lane_statements(d)), "unroll_max": unroll_max(d, LANES_UNROLL_COST),
           "timed": d.timed, "reads_time": d.reads_time, **ORDER_RULE,
           **library_context(name, info), "lanes_default": LANES_DEFAULT,
           "cost": jet_cost(d, COST_ORDER), "cost_order": COST_ORDER,
           "nstore": d.n + len(history_nodes(d) - {i for i, op in enumerate(d.ops) if op.kind == "var"}),
           "nparams": f"{M}_N_PARAMS + {M}_N_INPUTS" if info.n_inputs else f"{M}_N_PARAMS"}
    return {f"c/{name}_taylor_lanes.h": render("c/taylor_lanes.h.jinja",
                                                 dict(ctx, template="templates/c/taylor_lanes.h.jinja")),
            f"c/{name}_taylor_lanes.c": render("c/taylor_lanes.c.jinja",
                                                 dict(ctx, template="templates/c/taylor_lanes.c.jinja")),
            **library_files(LIBRARY)}
