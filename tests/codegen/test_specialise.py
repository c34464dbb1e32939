"""Specialised models (derive/codegen/specialise.py): the derivation with parameter values
folded in exactly, a name per value set, clean C; the runs: tests/runtime/test_specialised.py."""
from __future__ import annotations

import shutil
from pathlib import Path

import mpmath
import numpy as np
import pytest
import sympy as sp

from derive.codegen import specialise as spz
from derive.codegen.sources import model_sources
from derive.codegen.taylor import macro_expression
from derive.derivation import derive
from derive.errors import SpecError
from derive.model import load_model
from derive.paths import cache_dir

from .test_generate_and_compile import COMPILERS, ROOT, _compile_all, quad_flags

VALUES = {"m1": 1.0, "m2": 0.6, "l1": 0.7, "l2": 1.3, "g": 9.81}


def _at(expr, point: dict, digits: int = 80):
    """`expr` at `point` (symbol -> exact number) in mpmath at `digits` digits."""
    with mpmath.workdps(digits):
        return mpmath.mpf(sp.N(expr.xreplace(point), digits))


def test_the_folded_derivation_is_the_derivation_at_the_exact_values():
    """Every entry of M and F of the specialised planar pendulum is the general one at the
    exact binary values (to 1e-70: folding loses nothing a double or long double holds), and
    no folded parameter is left in it; g, not folded, stays a symbol."""
    values = dict(VALUES)
    del values["g"]
    name = spz.specialise("planar", values)
    general, folded = derive("planar"), derive(name)
    params = {s.name: s for s in general.symbols.params}
    exact = {params[k]: sp.Rational(*float(v).as_integer_ratio()) for k, v in values.items()}
    point = {**{q: sp.Rational(k + 3, 7) for k, q in enumerate(general.symbols.state)}, params["g"]: sp.Rational(981, 100)}
    for a, b in [*zip(general.M, folded.M), *zip(general.F, folded.F)]:
        assert not (b.free_symbols & set(exact)), b
        assert abs(_at(a, {**exact, **point}) - _at(b, point)) < mpmath.mpf("1e-70")
    assert params["g"] in folded.F.free_symbols
    assert load_model(name).parameters == load_model("planar").parameters      # p keeps its layout


def test_values_fold_exactly_and_only_unit_integers_as_integers():
    assert spz.folded_number((1, 1)) == sp.Integer(1) and spz.folded_number((0, 1)).is_Integer
    assert spz.folded_number((20, 1)).is_Float            # not an Integer inside sin(20 t)
    for value in (0.7, 9.81, 1e-300, np.longdouble(1) / 3):
        ratio = spz.exact_value(value)
        assert sp.Rational(spz.folded_number(ratio)) == sp.Rational(*ratio)
    with pytest.raises(SpecError):
        spz.exact_value(float("nan"))


def test_the_name_is_one_per_model_and_value_set():
    """Equal values (1 and 1.0) name the same model; the next double, a long double's extra
    bits, another model each name another."""
    model = load_model("planar")

    def name(**changes):
        return spz.specialised_name(model, {k: spz.exact_value(v) for k, v in {**VALUES, **changes}.items()})
    assert name(m1=1) == name(m1=1.0)
    others = {name(l1=np.nextafter(0.7, 1.0)), name(l1=np.longdouble("0.7")), name(g=9.80)}
    assert len(others | {name()}) == 4
    assert spz.specialised_name(load_model("compound"), {}) != spz.specialised_name(model, {})


def test_values_that_leave_an_expression_undefined_are_refused():
    """l1 = 0 (which the run time refuses before) would divide by zero in M^-1."""
    with pytest.raises(SpecError, match="undefined"):
        spz.specialise("planar", {**VALUES, "l1": 0.0})
    with pytest.raises(SpecError, match="no parameter 'zz'"):
        spz.specialise("planar", {"zz": 1.0})


def test_the_extended_rungs_print_a_folded_value_exactly():
    """double-double and quad print a Float wider than a double as three doubles that add up
    to it (to 2^-150), whatever its decimal digits (0.7 * 1.3 has seventeen)."""
    value = sp.Float(sp.Rational(*(0.7).as_integer_ratio()) * sp.Rational(*(1.3).as_integer_ratio()), precision=256)
    text = macro_expression(value, {})
    parts = [sp.Rational(float(x)) for x in text.replace("T_ADD(", "").replace("T_D(", "").replace(")", "").split(",")]
    assert abs(sum(parts) - sp.Rational(value)) < sp.Rational(1, 2 ** 150)


CASES = [("planar", {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 0.0}),       # every parameter gone
         ("planar", {"l1": 0.7, "l2": 1.3})]                                       # some folded, some read


@pytest.mark.parametrize("model,values", CASES, ids=["all-folded", "partly"])
def test_specialised_c_is_clean_under_every_compilers_warnings(model, values, tmp_path):
    """Every C file of a specialised model (where p may be read by no kernel at all) passes
    each compiler's warnings as errors (the front end: -fsyntax-only), and it lives in the
    cache, never in generated/."""
    name = spz.specialise(model, values)
    folder = model_sources(name) / "c"
    assert cache_dir() in folder.parents and not (ROOT / "generated" / "c" / f"{name}.c").exists()
    sources = sorted(folder.glob(f"{name}*.c"))
    assert {f"{name}.c", f"{name}_integrate.c", f"{name}_taylor.c", f"{name}_taylor_lanes.c"} <= \
        {s.name for s in sources}
    commands = []
    for compiler, flags in COMPILERS:
        if shutil.which(compiler) is None:
            pytest.fail(f"{compiler} is required here (tests/run.sh installs it)")
        commands += [[compiler, *flags, *quad_flags(compiler, s), "-I", str(folder), "-fsyntax-only", str(s)]
                     for s in sources]
    _compile_all(commands, Path(tmp_path))
