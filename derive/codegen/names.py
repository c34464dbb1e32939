"""Identifiers in generated code for the names a model chooses.

A model may call its parameters what its author likes (M, p, lambda, F, y, int, ...).
In C they never become identifiers: the printer writes every input as an array slot
(p[3]).  In NumPy they are locals of the kernel (m1 = p[..., 0]), so a name that is a
Python keyword or builtin, one of the kernel's own names (its arguments y, p, u, x,
its outputs, numpy), a CSE temporary (t<N>) or a stage the code generator makes
(M01, qdd0, ...) gets a trailing underscore, and more until it is free.  The name
tables of the generated code keep the model's own names.
"""
from __future__ import annotations

import builtins
import keyword
import re

PYTHON_RESERVED = frozenset(keyword.kwlist) | frozenset(keyword.softkwlist) | frozenset(dir(builtins))
# the kernels' own identifiers: arguments, outputs, module names, helpers of the templates
KERNEL_NAMES = frozenset({"numpy", "y", "p", "u", "x", "ydot", "xdot", "M", "F", "E", "pos", "J",
                          "sines", "y_out", "shape", "dtype", "status", "out", "h", "nsteps", "s", "f",
                          "K", "Y", "S", "N", "alive", "ok", "everyone", "clean", "steps", "kernels"})
# stage names of codegen/solve.py and emit.py: M01, F0, qdd1, D0, rD0, L10, v_z1, dtheta1_0, t3, ...
GENERATED = re.compile(r"^(t|F|qdd|v|D|rD|xr|rs|f)\d+$|^(M|L|Q)\d\d+$|^(M|L)\d+_\d+$|^dv\d+_\d+$"
                       r"|^(qdd|v|d\w+)_z?\d+$|^lane_\w+$|^(det|rdet|Aa|Ab|AaAb|D[12]_\d+|rD[12])$")


def numpy_identifier(name: str, taken: set[str] = frozenset()) -> str:
    """`name` as a NumPy kernel local: unchanged where it is free, else with underscores."""
    out = name
    while _needs(out) or out in taken:     # ends: a trailing underscore leaves every pattern
        out += "_"
    return out


def numpy_slots(symbols) -> dict:
    """{symbol: local name} for the input symbols of a NumPy kernel (distinct names)."""
    slots, used = {}, set()
    for s in symbols:
        slots[s] = numpy_identifier(s.name, used) if _needs(s.name) else s.name
        used.add(slots[s])
    return slots


def _needs(name: str) -> bool:
    return name in PYTHON_RESERVED or name in KERNEL_NAMES or bool(GENERATED.match(name))

# The libm functions the generated C declares `omp declare simd` (templates/c/vector_math.jinja):
# a build with glibc's libmvec turns their calls in a loop over lanes into vector calls.
VECTOR_MATH = ("sin", "cos")
