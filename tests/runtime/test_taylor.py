"""The generated Taylor integrator: its coefficients, its convergence, its use."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import derive
from derive.errors import SimulationInputError
from derive.codegen.contract import taylor_order
from derive.runtime.taylor_library import taylor_library
from derive.measurement.peers import derivation_rhs

EXAMPLES = Path(__file__).parents[2] / "examples" / "models"
from tests.parameters import UNIT_VECTOR as PLANAR


def _lie_coefficients(model: str, y0, params, K: int) -> np.ndarray:
    """y^[k] = (d/dt)^k y / k! at y0 by repeated Lie derivatives of the derived rhs
    (g_1 = f, g_{k+1} = (dg_k/dy) f), in SymPy at 40 digits: no recurrence of the toolkit."""
    (state, par), exprs = derivation_rhs(model)
    values = dict(zip(par, [sp.Rational(str(v)) for v in params]))
    f = sp.Matrix([e.xreplace(values) for e in exprs])
    point = dict(zip(state, [sp.Float(str(v), 40) for v in y0]))
    rows, g = [[float(v) for v in y0]], f
    for k in range(1, K + 1):
        rows.append([float(v) / float(sp.factorial(k)) for v in g.evalf(40, subs=point)])
        if k < K:
            g = g.jacobian(sp.Matrix(state)) * f
    return np.array(rows).T


@pytest.mark.parametrize("model, y0, params, K", [
    pytest.param("planar", [0.7, -0.4, 0.3, 0.9], [1.2, 0.8, 1.1, 0.9, 9.81], 4,
                 marks=pytest.mark.slow),         # SymPy's Lie derivatives to K = 4: about 45 s
    ("compound", [0.5, 1.9, -0.6, 0.4], [1.1, 0.7, 1.3, 0.8, 0.2, 0.05, 9.81], 3),
])
def test_coefficients_are_the_series_of_the_solution(model, y0, params, K):
    ours_status, ours = taylor_library(model, K).coefficients(np.array(y0, float), np.array(params, float))
    ref = _lie_coefficients(model, y0, params, K)
    assert ours_status == 0 and ours.shape == ref.shape
    assert np.allclose(ours, ref, rtol=1e-12, atol=1e-13 * np.abs(ref).max())


def _reference(y0, t_end):
    r = derive.simulate("planar", y0, [0, t_end], PLANAR, method="dop853", rtol=2e-18, atol=1e-22,
                        dtype="longdouble")
    assert r.ok
    return np.asarray(r.y[-1], float)


def test_error_follows_the_tolerance():
    """Regular motion to t = 10: the error falls with the tolerance and stays near it."""
    y0 = [1.0, 0.5, 0.0, 0.0]
    ref = _reference(y0, 10.0)
    errors = []
    for tol in (1e-6, 1e-9, 1e-12):
        r = derive.simulate("planar", y0, np.linspace(0, 10, 11), PLANAR, method="taylor", rtol=tol)
        assert r.ok and r.rtol == tol and r.nfev == r.nsteps > 0
        errors.append(float(np.max(np.abs(r.y[-1] - ref))))
        assert errors[-1] < 10 * tol
    assert errors[0] > errors[1] > errors[2]


def test_dense_output_is_the_series_and_outputs_do_not_change_the_steps():
    y0 = [2.5, 2.0, 0.0, 0.0]
    few = derive.simulate("planar", y0, [0, 2.0], PLANAR, method="taylor", rtol=1e-12)
    many = derive.simulate("planar", y0, np.linspace(0, 2.0, 401), PLANAR, method="taylor", rtol=1e-12)
    assert few.nsteps == many.nsteps
    assert np.array_equal(few.y[-1], many.y[-1])
    dop = derive.simulate("planar", y0, np.linspace(0, 2.0, 401), PLANAR, method="dop853", rtol=1e-13)
    assert np.max(np.abs(many.y - dop.y)) < 1e-9


def test_long_double_chaotic_run():
    y0 = [2.5, 2.0, 0.0, 0.0]
    ref = _reference(y0, 5.0)
    r = derive.simulate("planar", y0, [0, 5.0], PLANAR, method="taylor", rtol=2e-18, dtype="longdouble")
    assert r.ok and taylor_order(2e-18) == 22
    assert np.max(np.abs(np.asarray(r.y[-1], float) - ref)) < 1e-12


@pytest.mark.parametrize("name", [pytest.param("triple", marks=pytest.mark.slow),   # derives and compiles a triple
                                  "driven"])
def test_user_models_agree_with_dop853(name):
    path = EXAMPLES / f"{name}.toml"
    from derive.model import load_model
    d = load_model(path)
    params = {n: (9.81 if n == "g" else 0.2 if n.startswith("c") else 1.0) for n in d.parameters}
    n = len(d.state_names)
    y0 = np.r_[np.full(n // 2, 0.6), np.full(n // 2, -0.2)]
    kw = {"inputs": [0.5] * len(d.inputs)} if d.inputs else {}
    t = np.linspace(0, 3, 7)
    a = derive.simulate(path, y0, t, params, method="taylor", rtol=1e-12, **kw)
    b = derive.simulate(path, y0, t, params, method="dop853", rtol=1e-13, **kw)
    assert a.ok and b.ok
    assert np.max(np.abs(a.y - b.y)) < 1e-9


@pytest.mark.slow     # spherical_std's Taylor integrator at order 13: about two minutes of compiling
def test_chart_singularity_stops_the_run():
    # link 1 starts on the standard chart's axis: polar sine 0 < sine_min
    y0 = [0.0, 0.3, 1.0, 0.2, 0.0, 0.0, 0.0, 0.0]
    from derive.model import load_model
    names = load_model("spherical_std").parameters
    r = derive.simulate("spherical_std", y0, [0, 1], {n: (9.81 if n == "g" else 1.0) for n in names},
                        method="taylor", rtol=1e-10)
    assert r.status_name.startswith("chart singular")


@pytest.mark.parametrize("kwargs, message", [
    (dict(backend="numpy"), "the Taylor integrator runs in generated C"),
    (dict(model="spherical"), "the Taylor integrator runs in generated C"),
    (dict(rtol=1e-17), r"rtol = 1e-17 is outside \[10 eps, 1\) for float64"),
])
def test_refusals_are_one_line(kwargs, message):
    args = dict(model="planar")
    args.update(kwargs)
    y0 = [1.0, 0.5, 0.0, 0.0] if args["model"] == "planar" else {"cartesian": [1, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0]}
    with pytest.raises(SimulationInputError, match=message) as info:
        derive.simulate(args.pop("model"), y0, [0, 1], PLANAR, method="taylor", **args)
    assert "\n" not in str(info.value)
