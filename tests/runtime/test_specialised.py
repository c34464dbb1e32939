"""simulate(..., specialise=True) and ensemble(..., specialise=True): the kernels with the
parameter values folded in (derive/codegen/specialise.py, derive/runtime/specialised.py)
give the general kernels' results to rounding, are built once per model and value set, and
refuse what they do not run in one line."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.errors import SimulationInputError
from derive.paths import cache_dir
from derive.runtime.loader import load

ROOT = Path(__file__).resolve().parents[2]
PARAMS = {"m1": 1.0, "m2": 0.6, "l1": 0.7, "l2": 1.3, "g": 9.81}
Y0 = [1.0, 0.5, 0.0, 0.0]
T = np.linspace(0.0, 2.0, 5)
# a fixed step and Taylor's method: the same steps, so the runs differ by rounding alone
# (measured: at most 42 eps over these runs); an adaptive RK method's accept and reject
# decisions may tip on rounding, so that the runs differ within their tolerance
ROUNDING_EPS = 100
STEPPED = [("rk4", {"step": 1e-3}), ("rk8", {"step": 1e-2}), ("taylor", {})]
DTYPES = ("float64", "longdouble", "float32")


def _both(model, y0, t, params, **options):
    return (derive.simulate(model, y0, t, params, specialise=True, **options),
            derive.simulate(model, y0, t, params, **options))


def _difference(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a.y, np.longdouble) - np.asarray(b.y, np.longdouble))))


def test_the_kernels_agree_with_the_general_ones_to_rounding():
    """rhs and energy at 500 random states: within 100 eps of the general kernels' values
    (relative to max(1, |value|)), in every precision."""
    rng = np.random.default_rng(3)
    y = np.column_stack([rng.uniform(-3, 3, (500, 2)), rng.uniform(-4, 4, (500, 2))])
    name = derive.simulate("planar", Y0, [0.0], PARAMS, specialise=True).model
    assert name.startswith("planar_s")
    p = np.array(list(PARAMS.values()))
    for suffix, dt in (("", np.float64), ("_l", np.longdouble), ("_f", np.float32)):
        for kernel in ("rhs", "energy"):
            ours = getattr(load(name), kernel + suffix)(y.astype(dt), p.astype(dt))
            general = getattr(load("planar"), kernel + suffix)(y.astype(dt), p.astype(dt))
            scale = np.maximum(1, np.abs(general))
            assert np.max(np.abs(ours - general) / scale) <= ROUNDING_EPS * np.finfo(dt).eps, (kernel, dt)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("method,options", STEPPED, ids=[m for m, _ in STEPPED])
def test_fixed_step_and_taylor_runs_agree_to_rounding(method, options, dtype):
    if method == "taylor":
        options = {"rtol": 1e-5 if dtype == "float32" else 1e-10}
    a, b = _both("planar", Y0, T, PARAMS, method=method, dtype=dtype, **options)
    assert a.ok and b.ok and a.nsteps == b.nsteps
    assert a.model != b.model == "planar"
    assert _difference(a, b) <= ROUNDING_EPS * float(np.finfo(np.dtype(dtype)).eps)


@pytest.mark.parametrize("dtype", DTYPES)
def test_adaptive_runs_agree_to_their_tolerance(dtype):
    rtol = 1e-5 if dtype == "float32" else 1e-10
    a, b = _both("planar", Y0, T, PARAMS, method="dop853", rtol=rtol, dtype=dtype)
    assert a.ok and b.ok and _difference(a, b) <= 10 * rtol
    assert abs(a.sol(1.3) - b.sol(1.3)).max() <= 10 * rtol            # the dense output too


def test_an_integer_frequency_keeps_its_digits():
    """w = 20 in cos(w t) (a driven pivot): the folded kernel agrees with the general one to
    rounding (a degree-20 polynomial for cos(20 t), the multiple angle expanded, was 1e-9 off)."""
    model = str(ROOT / "examples" / "models" / "driven_pivot.toml")
    params = {"m": 1.0, "l": 1.0, "g": 9.81, "a": 0.1, "w": 20.0}
    a, b = _both(model, [0.1, 0.0], np.linspace(0, 2, 11), params, method="rk4", step=1e-3)
    assert _difference(a, b) <= ROUNDING_EPS * np.finfo(np.float64).eps


def test_the_ensemble_folds_what_every_trajectory_shares():
    """Shared parameters: the same specialised model as simulate's; per-trajectory rows: the
    columns that vary stay run-time parameters (each row its own m2), the rest folded."""
    y0 = np.array([Y0, [0.3, -0.2, 0.1, 0.0]])
    one = derive.ensemble("planar", y0, T, PARAMS, method="rk4", step=1e-3, specialise=True)
    assert one.model == derive.simulate("planar", Y0, T, PARAMS, method="rk4", step=1e-3, specialise=True).model
    rows = np.array([list(PARAMS.values())] * 2)
    rows[1, 1] = 2.0                                     # m2 varies
    ours = derive.ensemble("planar", y0, T, rows, method="rk4", step=1e-3, specialise=True)
    general = derive.ensemble("planar", y0, T, rows, method="rk4", step=1e-3)
    assert ours.model not in (one.model, "planar")
    assert "m2" not in derive.load_model(ours.model).title.split("specialised:")[1]
    assert np.max(np.abs(ours.y - general.y)) <= ROUNDING_EPS * np.finfo(np.float64).eps


def _libraries(name: str) -> set:
    """The compiled libraries of model `name` in the build cache (other tests may build
    other models' at the same time)."""
    return set((cache_dir() / "c-build").glob(f"*/lib{name}*.so"))


def test_one_build_per_value_set_reused_by_a_new_process():
    """The same values (1 or 1.0) run the same specialised model, whose library a new process
    finds built; other values are another model."""
    params = {**PARAMS, "m1": 1.5}
    a = derive.simulate("planar", Y0, T, params, method="rk4", step=1e-3, specialise=True)
    again = derive.simulate("planar", Y0, T, list(params.values()), method="rk4", step=1e-3, specialise=True)
    assert again.model == a.model and np.array_equal(again.y, a.y)
    other = derive.simulate("planar", Y0, T, {**params, "m1": 1.25}, method="rk4", step=1e-3, specialise=True)
    assert other.model != a.model
    before = _libraries(a.model)
    assert before                              # its kernels' and integrators' libraries
    code = ("import derive; print(derive.simulate('planar', [1.0, 0.5, 0.0, 0.0], [0.0, 2.0], "
            f"{params!r}, method='rk4', step=1e-3, specialise=True).model)")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == a.model and _libraries(a.model) == before    # nothing compiled again


@pytest.mark.parametrize("params,options,message", [
    ({"m1": 1.0}, {}, "missing parameter 'm2'"),
    ({**PARAMS, "g": float("nan")}, {}, "NaN"),
    ({**PARAMS, "l1": -1.0}, {}, "l1 = -1 must be positive"),
    (PARAMS, {"specialise": "yes"}, "specialise must be True or False"),
    (PARAMS, {"backend": "numpy"}, "backend='c'"),
    (PARAMS, {"dtype": "quad"}, "extended precisions read p at run time"),
    (([1.0], 0.6, 0.7, 1.3, 9.81), {}, "params must be numbers"),          # a tuple that is no key
])
def test_bad_input_is_one_line(params, options, message):
    options = {"specialise": True, **options}
    with pytest.raises(SimulationInputError, match=message) as info:
        derive.simulate("planar", Y0, T, params, **options)
    assert "\n" not in str(info.value)


def test_the_atlas_is_refused_in_one_line():
    params = {n: 1.0 for n in derive.load_model("spherical_std").parameters} | {"g": 9.81}
    with pytest.raises(SimulationInputError, match="not the chart atlas"):
        derive.simulate("spherical", {"cartesian": [1, 0, 0, 2, 0, 0, 0, 1, 0, 0, 1, 0]}, T, params,
                        specialise=True)
    with pytest.raises(SimulationInputError, match="specialise must be True or False"):
        derive.ensemble("planar", np.array([Y0]), T, PARAMS, specialise=1)
