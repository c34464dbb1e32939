"""The JAX backend: one module per model, <model>_jax.py, of jax.numpy kernels that
`jax.jit`, `jax.grad` and `jax.vmap` accept (pure functions, no in-place writes).

Its artifacts: per model jax/<model>_jax.py (every kernel the NumPy module has: rhs,
energy, the mass matrix, ...; templates/jax/module.py.jinja), nothing per atlas and no
integrators: a JAX user steps the rhs with their own loop (jax.lax.fori_loop, diffrax)
and differentiates through it.  The module imports jax, which is the `jax` extra, so the
backend is rendered only on request (`by_default = False`: derive generate MODEL
--backend jax --out DIR); the golden generated/ and the run time do not hold it.

Unlike the NumPy backend it keeps sin and cos as they are (no half-angle tangent: XLA
has its own vectorised sin/cos, and the tangent's pole at pi would make gradients
there NaN).  Parameters become kernel locals, renamed as in NumPy where they clash
(derive/codegen/names.py), and `jax` itself is never a local.
"""
from __future__ import annotations

import sympy as sp
from sympy.printing.numpy import JaxPrinter
from ...emit import live_assignments, render
from ...names import KERNEL_NAMES, PYTHON_RESERVED, numpy_slots
from ...printers import SlotPrinting
from ..base import Backend, common_context, slot_doc, wrap

MODULE_NAMES = frozenset({"jax"})       # the kernels' module: never a local's name


class JaxSlotPrinter(SlotPrinting, JaxPrinter):
    """jax.numpy, symbols printed as their local name; small integer powers as products.

    Parameters
    ----------
    slots : dict
        symbol -> the local it is read from in the kernel.

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> JaxSlotPrinter({x: "theta1"}).doprint_checked(sp.sin(x) * y**2 + 1 / y)
    '1.0/y + y*y*jax.numpy.sin(theta1)'
    """

    def __init__(self, slots: dict):
        super().__init__({"fully_qualified_modules": True})
        self._settings_slots = slots

    LANGUAGE_NAME = "JAX"

    def _print_Pow(self, expr, rational=False):
        small = self._small_power(expr)
        if small is not None:
            return small
        if expr.exp == sp.S.Half:
            return f"jax.numpy.sqrt({self._print(expr.base)})"
        return super()._print_Pow(expr, rational=rational)


def kernel_context(body) -> dict:
    """What templates/jax/module.py.jinja prints of one kernel (after the file's CSE).

    Parameters
    ----------
    body : derive.codegen.emit.Body
        The kernel after the file's CSE pass.

    Returns
    -------
    dict
        Its name, documentation, inputs, the locals unpacked and computed (printed in
        jax.numpy), and its outputs' cells.

    Raises
    ------
    PrintError
        An expression with no jax.numpy translation.

    Examples
    --------
    >>> from derive.codegen.sources import kernels
    >>> spec, bodies = kernels("planar")
    >>> rhs = kernel_context(bodies[0])
    >>> rhs["name"], [i["name"] for i in rhs["inputs"]], len(rhs["outputs"][0]["cells"])
    ('rhs', ['y', 'p'], 4)
    """
    k = body.kernel
    flat = [e for exprs in body.outputs for e in exprs]
    kept = live_assignments(body.assignments, flat)        # guards have no JAX counterpart
    needed = set().union(*(sp.sympify(e).free_symbols for e in flat), *(e.free_symbols for _, e in kept))
    slots = numpy_slots([s for inp in k.inputs for s in inp.vector.symbols],
                        {s.name for s, _ in kept} | MODULE_NAMES)
    pr = JaxSlotPrinter(slots)
    return {
        "name": k.name, "doc": wrap(k.doc, 80), "ops": body.ops,
        "inputs": [{"name": i.name, "size": i.size, "doc": f"{i.vector.doc}: ({slot_doc(i.vector)})"}
                   for i in k.inputs],
        "unpack": [{"name": slots[s], "source": f"{inp.name}[..., {i}]"}
                   for inp in k.inputs for i, s in enumerate(inp.vector.symbols) if s in needed],
        "unpack_target": "(" + ", ".join(i.name for i in k.inputs) + ("," if len(k.inputs) == 1 else "") + ")",
        "locals": [{"name": s.name, "value": pr.doprint_checked(e)} for s, e in kept],
        "outputs": [{"name": out.name, "cells": [pr.doprint_checked(e) for e in exprs],
                     "shape_py": repr(tuple(out.shape)),
                     "shape_doc": "(" + ", ".join(["..."] + [str(d) for d in out.shape]) + ")",
                     "doc": out.doc}
                    for out, exprs in zip(k.outputs, body.outputs)],
    }


class JaxBackend(Backend):
    """One module per model, <model>_jax.py, of pure jax.numpy kernels.

    Examples
    --------
    >>> BACKEND.name, BACKEND.by_default
    ('jax', False)
    """
    name = "jax"
    suffixes = (".py",)
    printer = JaxSlotPrinter
    reserved = PYTHON_RESERVED | KERNEL_NAMES | MODULE_NAMES
    by_default = False

    def kernel_files(self, spec, bodies):
        ctx = common_context(spec, "templates/jax/module.py.jinja")
        ctx["kernels"] = [kernel_context(b) for b in bodies]
        return {f"jax/{spec.name}_jax.py": render("jax/module.py.jinja", ctx)}


BACKEND = JaxBackend()
