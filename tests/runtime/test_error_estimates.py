"""Every result's estimate of its own error (issue 15 item 1): the free local-error sum of
the methods that have one, and error_estimate="rerun", checked against the true error of
a regular motion (a tight long double reference)."""
from __future__ import annotations

import numpy as np
import pytest

import derive
from derive.errors import SimulationInputError
from derive.codegen.contract import LOCAL_ERROR_METHODS, RUN_METHODS

from tests.parameters import UNIT_PARAMS as PLANAR
REGULAR = [0.3, 0.2, 0.0, 0.0]               # a small swing: errors grow about linearly
T = np.linspace(0.0, 10.0, 51)
SETTINGS = {"dopri5": dict(rtol=1e-7), "dop853": dict(rtol=1e-7), "taylor": dict(rtol=1e-7),
            "rk4": dict(step=0.01), "rk8": dict(step=0.05), "abm12": dict(step=0.01),
            "midpoint": dict(step=0.002), "gauss2": dict(step=0.02)}


@pytest.fixture(scope="module")
def reference():
    r = derive.simulate("planar", REGULAR, T, PLANAR, method="dop853", rtol=1e-16, atol=1e-18,
                        dtype="longdouble")
    assert r.ok
    return r


def _true_error(r, reference) -> np.ndarray:
    return np.asarray(np.abs(np.asarray(r.y, np.longdouble) - reference.y), float)


@pytest.mark.parametrize("method", RUN_METHODS)
def test_the_rerun_estimate_is_the_true_global_error(method, reference):
    """Within a factor 1.5 of the true error, overall and at the last output, on a regular
    motion (each setting's error far above roundoff); error_y is per row and state."""
    r = derive.simulate("planar", REGULAR, T, PLANAR, method=method, error_estimate="rerun",
                        **SETTINGS[method])
    true = _true_error(r, reference)
    assert r.ok and r.error_kind.startswith("rerun at ") and r.error_y.shape == r.y.shape
    assert true.max() > 1e-13, "the setting's error must be well above roundoff (450 eps)"
    assert 1 / 1.5 < r.error_estimate / true.max() < 1.5, (r.error_estimate, true.max())
    assert 1 / 1.5 < r.error_y[-1].max() / true[-1].max() < 1.5
    assert r.error_y[0].max() == 0


@pytest.mark.parametrize("method", RUN_METHODS)
def test_the_local_sum_is_there_for_the_methods_that_have_one(method, reference):
    """dopri5, dop853, abm12, taylor: a sum of local estimates at least the true error of
    this regular run and at most 100 times it (each step's estimate is pessimistic); the
    others: None, and error_kind None.  No second run is made for it."""
    r = derive.simulate("planar", REGULAR, T, PLANAR, method=method, **SETTINGS[method])
    if method not in LOCAL_ERROR_METHODS:
        assert r.error_estimate is None and r.error_kind is None and r.error_y is None
        return
    true = _true_error(r, reference).max()
    assert r.error_kind == "local sum" and r.error_y is None
    assert true <= r.error_estimate <= 100 * true, (r.error_estimate, true)


@pytest.mark.parametrize("method", ["dopri5", "dop853", "abm12"])
def test_the_backends_sum_the_same_local_estimates(method):
    kw = SETTINGS[method]
    c = derive.simulate("planar", REGULAR, T, PLANAR, method=method, **kw)
    n = derive.simulate("planar", REGULAR, T, PLANAR, method=method, backend="numpy", **kw)
    assert c.nsteps == n.nsteps and c.error_estimate == pytest.approx(n.error_estimate, rel=0.05)


def test_a_tolerance_at_the_limit_is_rerun_in_a_wider_dtype(reference):
    """rtol = 1e-14 in double: rtol / 100 is below 10 eps, so the reference runs in long
    double and error_kind says so; in long double at its own limit: one line, no traceback."""
    r = derive.simulate("planar", REGULAR, T, PLANAR, method="dop853", rtol=1e-14, error_estimate="rerun")
    assert r.error_kind == "rerun at rtol=1e-16 in longdouble"
    true = _true_error(r, reference).max()
    assert 1 / 3 < r.error_estimate / true < 3, (r.error_estimate, true)
    with pytest.raises(SimulationInputError, match="no tighter tolerance") as info:
        derive.simulate("planar", REGULAR, T, PLANAR, method="dop853", dtype="longdouble", rtol=1.1e-18,
                        error_estimate="rerun")
    assert "\n" not in str(info.value)


def test_the_rerun_estimate_on_the_atlas_compares_only_rows_in_the_same_chart():
    """Rows whose two runs are in different charts are NaN in error_y, never a false comparison."""
    r = derive.simulate("spherical", [1.0, 0.2, 1.2, 0.5, 0.1, 0.3, 0.0, 0.2], np.linspace(0, 2, 21), PLANAR,
                        method="dop853", rtol=1e-8, error_estimate="rerun")
    assert r.ok and r.error_kind == "rerun at rtol=1e-10" and 0 < r.error_estimate < 1e-5
    differ = np.asarray(r.chart) != np.asarray(derive.simulate(
        "spherical", [1.0, 0.2, 1.2, 0.5, 0.1, 0.3, 0.0, 0.2], np.linspace(0, 2, 21), PLANAR,
        method="dop853", rtol=1e-10).chart)
    assert np.isnan(r.error_y[differ]).all() and np.isfinite(r.error_y[~differ]).all()


def test_a_bad_error_estimate_is_one_line():
    for bad in ("global", 1, None):
        with pytest.raises(SimulationInputError, match="error_estimate must be 'local'") as info:
            derive.simulate("planar", REGULAR, [0, 1], PLANAR, error_estimate=bad)
        assert "\n" not in str(info.value)


def test_the_start_alone_needs_no_rerun():
    r = derive.simulate("planar", REGULAR, [0.0], PLANAR, method="rk4", error_estimate="rerun")
    assert r.error_estimate == 0.0 and r.error_y.shape == (1, 4) and not r.error_y.any()


def test_the_energy_error_is_relative_to_a_scale_that_cannot_vanish():
    """Released at rest with both links horizontal, E0 is 0 to rounding: |E - E0| / |E0|
    would be far above 1 for an accurate run.  r.energy_error is relative to max(|E0|, m g l)
    = 9.81 (1 + 2) for unit masses and lengths, the potential well's depth."""
    r = derive.simulate("planar", [np.pi / 2, np.pi / 2, 0, 0], np.linspace(0, 5, 101), PLANAR, rtol=1e-10)
    change = float(np.max(np.abs(r.energy - r.energy[0])))
    assert abs(r.energy[0]) < 1e-12 and change / abs(r.energy[0]) > 1          # the old figure
    assert r.energy_scale == pytest.approx(29.43) and r.energy_error == pytest.approx(change / 29.43)
    assert r.energy_error < 1e-8
    fast = derive.simulate("planar", [0.0, 0.0, 20.0, 0.0], [0, 1], PLANAR)       # |E0| above m g l
    assert fast.energy_scale == pytest.approx(abs(float(fast.energy[0])))


def test_the_benchmark_and_a_run_give_one_relative_energy_error():
    """One division (energy_error.relative_change) by one scale: the benchmark's figure of a
    run's energies is the run's own, on a motion with E0 = 0 as on any other."""
    from derive.measurement.bench.problems import Problem, relative_energy_error
    for y0 in ([np.pi / 2, np.pi / 2, 0, 0], [1.0, 0.5, 0, 0]):
        r = derive.simulate("planar", y0, np.linspace(0, 5, 41), PLANAR, rtol=1e-10)
        problem = Problem("zero", "planar", tuple(y0), 5.0, tuple(PLANAR[n] for n in ("m1", "m2", "l1", "l2", "g")), "")
        assert relative_energy_error(r.energy, problem) == pytest.approx(r.energy_error, rel=1e-12)
        assert 0 < r.energy_error < 1e-8


def test_a_double_double_energy_error_is_the_runs_not_its_rounding():
    """Above long double the energies are evaluated from the exact states: the figure is
    the run's own drift (about 1e-25 at rtol 1e-22), not 0 nor long double's 1e-19."""
    r = derive.simulate("planar", [2.5, 2.0, 0, 0], np.linspace(0, 1, 11), PLANAR, dtype="double-double", rtol=1e-22)
    assert 0 < r.energy_error < 1e-22 and r.energy_scale == pytest.approx(29.43)


def test_an_energy_that_overflows_is_an_infinite_error_not_the_largest_finite_one():
    """rk4 at step 100 on a small swing: the energy at t = 200 overflows; the figure is inf,
    not the change up to t = 100, which would read as a (huge) measurement."""
    r = derive.simulate("planar", [0.1, 0.1, 0, 0], [0.0, 100.0, 200.0], PLANAR, method="rk4", step=100.0)
    assert r.ok and np.isinf(r.energy[-1]) and np.isfinite(r.energy[1])
    assert r.energy_error == np.inf and r.energy_scale == pytest.approx(29.43)
