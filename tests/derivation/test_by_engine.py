"""The derivation's sums in SymEngine (symbolic.by_engine) are SymPy's: the Christoffel form of
F and the kinetic energy T, expression for expression, against the same formulas written here
with SymPy's matrices, diff and expand (the derivation's long way)."""
from __future__ import annotations

import pytest
import sympy as sp

from derive.derivation import lagrange
from derive.derivation.symbolic import by_engine
from derive.derivation.symbols import model_symbols
from derive.model import load_model

MODELS = ["planar", "compound", "spherical_std", "examples/models/triple.toml",
          "examples/models/pendulum_tree.toml", "examples/models/elastic_pendulum.toml",
          "examples/models/governor.toml", "examples/models/spinning_body.toml",
          "examples/models/four_bar.toml"]


def _form(model):
    s = model_symbols(model)
    if model.is_chain:
        return lagrange.chain_form(model, s), s
    return lagrange.tree_form(model, s, lagrange.tree_geometry(model, s))[0], s


@pytest.mark.parametrize("name", MODELS)
def test_the_christoffel_forcing_and_the_kinetic_energy_are_sympys(name):
    model = load_model(name)
    form, s = _form(model)
    qd = sp.Matrix(s.qd)
    dM = [form.M.diff(qk) for qk in s.q]
    Mqd_dot = sum((dM[k] * qd * s.qd[k] for k in range(len(s.q))), sp.zeros(len(s.q), 1))
    F = sp.Matrix([(qd.T * dM[j] * qd)[0, 0] / 2 - Mqd_dot[j] - form.V.diff(s.q[j]) for j in range(len(s.q))])
    assert lagrange.forcing(form, s) == F.applyfunc(lambda f: sp.factor_terms(form.filled(sp.expand(f))))
    M = lagrange.mass_matrix(form)
    assert lagrange.kinetic_energy(M, s) == sp.expand((qd.T * M * qd)[0, 0] / 2)


def test_a_formula_symengine_cannot_take_runs_in_sympy():
    """An abs is no node the converters take: the formula runs on SymPy's expressions."""
    x, y = sp.symbols("x y", real=True)

    def square(expand, xs):
        return [expand((xs[0] + xs[1]) ** 2)]

    assert by_engine(square, [sp.Abs(x), y]) == [sp.expand((sp.Abs(x) + y) ** 2)]
    assert by_engine(square, [x, y]) == [x ** 2 + 2 * x * y + y ** 2]
