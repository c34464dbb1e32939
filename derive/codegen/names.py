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

import sympy as sp

PYTHON_RESERVED = frozenset(keyword.kwlist) | frozenset(keyword.softkwlist) | frozenset(dir(builtins))
# the kernels' own identifiers: arguments, outputs, module names, helpers of the templates
KERNEL_NAMES = frozenset({"numpy", "y", "p", "u", "x", "ydot", "xdot", "M", "F", "E", "pos", "J",
                          "sines", "y_out", "shape", "dtype", "status", "out", "h", "nsteps", "s", "f",
                          "K", "Y", "S", "N", "alive", "ok", "everyone", "clean", "steps", "kernels"})
# stage names of codegen/solve.py and emit.py: M01, F0, qdd1, D0, rD0, L10, v_z1, dtheta1_0, t3, ...
GENERATED = re.compile(r"^(t|F|qdd|v|D|rD|xr|rs|f)\d+$|^(M|L|Q)\d\d+$|^(M|L)\d+_\d+$|^dv\d+_\d+$"
                       r"|^(qdd|v|d\w+)_z?\d+$|^lane_\w+$|^(det|rdet|Aa|Ab|AaAb|D[12]_\d+|rD[12])$")


class _Internal(sp.Symbol):
    """A symbol of the code generator's own: equal to no model symbol of the same name.

    It is a Symbol in everything SymPy orders by (the class name, the length and order of
    the hashable content, the sort key), so every product and sum it is part of keeps the
    order, and the generated code the text, a plain Symbol of its name would give.  Only
    the name SymPy compares carries a NUL, a character no model name can contain.
    """
    __slots__ = ()

    def _hashable_content(self):
        return (self.name + "\0",) + self._assumptions0

    def sort_key(self, order=None):
        return self.class_key(), (1, (self.name + "\0",)), sp.S.One.sort_key(), sp.S.One


# SymPy orders the factors of a product by class name first: named otherwise, a stage
# would move within every product it is part of (and the generated text change)
_Internal.__name__ = "Symbol"


def internal(name: str, real: bool = True) -> sp.Symbol:
    """A symbol of the code generator's own: a stage (M01, F0, qdd1, ...), a temporary (t3).

    Parameters
    ----------
    name : str
        The name the generated code gives it.
    real : bool, optional
        Declared real (the stages are), else without assumptions.

    Returns
    -------
    sympy.Symbol
        A symbol that never equals a model's parameter, input or coordinate of the same
        name, so a model may call an input F, M01 or t0.  Printed names can still clash:
        C prints every model symbol as an array slot (u[0]), NumPy renames a clashing
        input local (numpy_slots).
    """
    return _Internal(name, real=True) if real else _Internal(name)


def numpy_identifier(name: str, taken: set[str] = frozenset()) -> str:
    """`name` as a NumPy kernel local: unchanged where it is free, else with underscores."""
    out = name
    while _needs(out) or out in taken:     # ends: a trailing underscore leaves every pattern
        out += "_"
    return out


def numpy_slots(symbols, taken=frozenset()) -> dict:
    """{symbol: local name} for the input symbols of a NumPy kernel (distinct names).

    Parameters
    ----------
    symbols : iterable of sympy.Symbol
        The kernel's input symbols (state, parameters, inputs), in order.
    taken : set of str, optional
        Names the kernel assigns itself (its stages and temporaries): an input of such a
        name is renamed, as one of the reserved names is.

    Returns
    -------
    dict
        Each symbol's local name: its own where free, else with trailing underscores.
    """
    slots, used = {}, set(taken)
    for s in symbols:
        slots[s] = numpy_identifier(s.name, used) if _needs(s.name) or s.name in used else s.name
        used.add(slots[s])
    return slots


def _needs(name: str) -> bool:
    return name in PYTHON_RESERVED or name in KERNEL_NAMES or bool(GENERATED.match(name))

# The libm functions the generated C declares `omp declare simd` (templates/c/vector_math.jinja):
# a build with glibc's libmvec turns their calls in a loop over lanes into vector calls.
VECTOR_MATH = ("sin", "cos")
