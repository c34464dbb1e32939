"""The printers' text computes its expression: NumPy's evaluated by Python, C's compiled and
run in each floating type, against SymPy's own value of the expression at the same point.

The printers write sums, products and powers themselves (derive/codegen/printers.py), so
what is checked here is their arithmetic: signs, denominators, powers written as
products (x/y**2 must read x/(y*y), never x/y*y), and the grouping NumPy's printer gives a
batch's constant part."""
from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
import sympy as sp

from derive.codegen.backends.jax import JaxSlotPrinter
from derive.codegen.printers import CPrinter, CVariantPrinter, PyNumPyPrinter

x, y, z = sp.symbols("x y z", real=True)
POINT = {x: sp.Rational(7, 10), y: sp.Rational(-13, 10), z: sp.Rational(23, 10)}

EXPRESSIONS = [
    x / y ** 2, x / (y ** 2 * z), 1 / y ** 2, -x / (2 * y ** 3), x * (y + z) ** 2, -sp.sin(x) / (y + z),
    x / 3, sp.Float(2.5) * x / y, sp.Abs(y) ** sp.Float(-0.5), sp.sqrt(z), 1 / sp.sqrt(z), -(x + y), x - y,
    2 - x, -x * y + 3 * z - sp.Rational(1, 2), (x + y) ** -1, (x + y) ** -2, (x - y) ** 3 / (y + z) ** 4,
    z ** y / (y + 1), 1 / (x * y), x ** 5, y ** -5, sp.Float(2.5) * x ** 2, x / sp.sqrt(y + z),
    -(x * y) ** 2 / z, (x + 1) / (y - 1) / (z + 2), sp.Rational(-7, 3) * x * y / z ** 2,
    sp.cos(x - y) ** 2 * sp.sin(z) / (x * z ** 3) - sp.exp(-x) * y, sp.atan2(y, x) - sp.pi * x ** 4,
    sp.Integer(3) / 7 - x, 1 - 1 / (1 + x ** 2), -1 / (x - z), x * y * z - x * y - sp.Float(1e-3),
]
FUNCTIONS = {"sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "exp": np.exp, "atan2": np.arctan2,
             "pow": np.power, "fabs": np.abs}


def exact(e) -> float:
    return float(e.subs(POINT).evalf(30))


@pytest.mark.parametrize("varying", [set(), {x}, {y, z}, {x, y, z}])
def test_numpy_text_computes_the_expression(varying):
    slots = {x: "x", y: "y", z: "z"}
    printer = PyNumPyPrinter(slots, varying)
    values = {"x": 0.7, "y": -1.3, "z": 2.3, "numpy": np}
    for e in EXPRESSIONS:
        text = printer.doprint_checked(e)
        assert eval(text, {}, values) == pytest.approx(exact(e), rel=1e-14), (e, text)


def test_jax_text_reads_as_numpy_text():
    """The JAX printer writes the same arithmetic (its module's name aside)."""
    slots = {x: "x", y: "y", z: "z"}
    for e in EXPRESSIONS:
        text = JaxSlotPrinter(slots).doprint_checked(e).replace("jax.numpy.", "numpy.")
        assert eval(text, {}, {"x": 0.7, "y": -1.3, "z": 2.3, "numpy": np}) == pytest.approx(exact(e), rel=1e-14)


@pytest.mark.parametrize("ctype, fmt, rel", [("float", "%.9e", 2e-6), ("double", "%.17e", 1e-14),
                                             ("long double", "%.21Le", 1e-17)])
def test_c_text_computes_the_expression(ctype, fmt, rel, tmp_path):
    """Compiled (gcc -std=c99 -Wall -Wextra -Werror) in each type: every expression's value."""
    cc = shutil.which("gcc")
    assert cc, "gcc is needed (tests/run.sh installs it)"
    shared = CVariantPrinter({x: "x", y: "y", z: "z"})
    cast = "" if ctype == "long double" else "(double)"
    lines = [f'    printf("{fmt}\\n", {cast}({shared.text(e, ctype)}));' for e in EXPRESSIONS]
    for e in EXPRESSIONS:
        assert shared.text(e, ctype) == CPrinter({x: "x", y: "y", z: "z"}, ctype).doprint_checked(e)
    suffix = {"float": "F", "double": "", "long double": "L"}[ctype]
    source = "\n".join([
        "#include <math.h>", "#include <stdio.h>", "int main(int argc, char **argv) {",
        "    (void)argv;",
        # read through argc so the compiler cannot fold the expressions at compile time
        f"    const {ctype} x = 0.7{suffix} * (argc > 0), y = -1.3{suffix} * (argc > 0), z = 2.3{suffix} * (argc > 0);",
        *lines, "    return 0;", "}", ""])
    (tmp_path / "e.c").write_text(source)
    subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O0", "e.c", "-o", "e", "-lm"],
                   cwd=tmp_path, check=True)
    out = subprocess.run([str(tmp_path / "e")], capture_output=True, text=True, check=True).stdout.split()
    assert len(out) == len(EXPRESSIONS)
    for e, text in zip(EXPRESSIONS, out):
        assert float(text) == pytest.approx(exact(e), rel=rel), (e, shared.text(e, ctype))


def _kernel_models():
    from derive.model import model_names
    return [*model_names(), "examples/models/cart_pole.toml", "examples/models/four_bar.toml",
            "examples/models/driven_gyroscope.toml", "examples/models/elastic_pendulum.toml"]


@pytest.mark.parametrize("model", _kernel_models())
def test_operation_counts_are_sympys(model):
    """The "Total ops" of every kernel: count_ops (derive/codegen/opcount.py) gives SymPy's
    count_ops number for every assignment, output and guard of the model's kernels."""
    from derive.codegen.opcount import count_ops
    from derive.codegen.sources import kernels
    _, bodies = kernels(model)
    exprs = {e for b in bodies for e in [x for _, x in b.assignments] + [x for o in b.outputs for x in o] + list(b.guards)}
    memo: dict = {}
    assert len(exprs) > 20
    for e in exprs:
        assert count_ops(e, memo) == sp.count_ops(e), e
