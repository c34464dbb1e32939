"""The Taylor integrator in SIMD lanes (derive.ensemble, method="taylor"): each lane is a
trajectory of its own, bit for bit what simulate(method="taylor") gives it."""
from __future__ import annotations

import numpy as np
import pytest

import derive
from derive.runtime.build import integrator_library
from derive.runtime.shared_library import info_state
from derive.codegen.contract import STATUS
from derive.runtime.simulate import run_options
from derive.runtime.taylor_lanes_library import simd_build, taylor_lanes_library
from derive.codegen.contract import taylor_order
from derive.runtime.taylor_library import taylor_library

LANES = simd_build("float64")[1]          # what ensemble runs with on this machine
from tests.parameters import UNIT_VECTOR as PLANAR


def _states(B, seed=4):
    rng = np.random.default_rng(seed)
    y0 = np.zeros((B, 4))
    y0[:, :2] = rng.uniform(-1.5, 1.5, (B, 2))
    y0[:, 2:] = rng.uniform(-1, 1, (B, 2))
    return y0


def _params(B, seed=6):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0.5, 2, (B, 4)), np.full(B, 9.81)])


def _assert_simulate(r, y0, t, params, **kw):
    """Every trajectory of ensemble result r is the simulate run of its row, bit for bit
    (NaN rows too), with the same status and counters."""
    for b in range(len(y0)):
        s = derive.simulate(r.model, y0[b], t, params[b], method="taylor", **kw)
        assert np.array_equal(r.y[b], s.y, equal_nan=True), (b, np.nanmax(np.abs(r.y[b] - s.y)))
        assert (r.status[b], r.nfev[b], r.nsteps[b]) == (s.status, s.nfev, s.nsteps), b


@pytest.mark.parametrize("B", sorted({1, 3, LANES + 1, 100}))
def test_every_lane_is_simulate_with_its_own_parameters(B):
    """Lanes refilled as trajectories end (B not a multiple of the lanes), per-trajectory
    parameters, dense output at several times."""
    y0, params = _states(B), _params(B)
    t = np.linspace(0, 2, 9)
    r = derive.ensemble("planar", y0, t, params, method="taylor", rtol=1e-10, threads=2)
    assert r.all_ok and r.y.shape == (B, 9, 4)
    _assert_simulate(r, y0, t, params, rtol=1e-10)


def test_backwards_in_time_and_float32():
    y0, params = _states(11, seed=8), _params(11, seed=9)
    back = np.linspace(0, -1.5, 4)
    r = derive.ensemble("planar", y0, back, params, method="taylor", rtol=1e-10)
    assert r.all_ok
    _assert_simulate(r, y0, back, params, rtol=1e-10)
    t = [0, 0.5, 1.0]
    f = derive.ensemble("planar", y0, t, params, method="taylor", rtol=1e-5, dtype="float32")
    assert f.all_ok and f.y.dtype == np.float32
    _assert_simulate(f, y0, t, params, rtol=1e-5, dtype="float32")


def test_a_failing_lane_spoils_no_other():
    """Rows that overflow (non-finite) among good ones: their status, NaN rows after the
    failure, and the lanes beside them unchanged."""
    y0 = _states(2 * LANES + 3, seed=10)
    y0[[1, LANES + 2]] = [0.0, 0.0, 1e300, 0.0]
    params = np.tile(PLANAR, (len(y0), 1))
    t = [0, 1, 2]
    r = derive.ensemble("planar", y0, t, params, method="taylor", rtol=1e-10)
    bad = np.zeros(len(y0), bool)
    bad[[1, LANES + 2]] = True
    assert r.status_names[1] == "non-finite state or derivative"
    assert np.all(r.status[bad] != 0) and np.all(r.status[~bad] == 0)
    assert np.all(np.isnan(r.y[bad, 1:])) and np.all(np.isfinite(r.y[~bad]))
    _assert_simulate(r, y0, t, params, rtol=1e-10)


def test_a_nan_state_in_the_c_batch_is_bad_input_for_its_lane_only():
    """The C entry point checks each trajectory (the public API refuses NaN before it)."""
    y0 = _states(LANES + 2, seed=12)
    y0[2, 1] = np.nan
    t = np.array([0.0, 1.0])
    opt = integrator_library("planar").options(run_options("taylor", np.float64, t, rtol=1e-10))
    y, infos = taylor_lanes_library("planar", taylor_order(1e-10)).run(y0, np.array(PLANAR, float), t, opt)
    status = [i.status for i in infos]
    assert status[2] == STATUS["BAD_INPUT"] and status.count(0) == len(y0) - 1
    assert np.all(np.isnan(y[2])) and np.all(np.isfinite(np.delete(y, 2, axis=0)))
    for b in (0, 3, LANES + 1):
        assert np.array_equal(y[b], derive.simulate("planar", y0[b], t, PLANAR, method="taylor", rtol=1e-10).y)


def test_every_info_field_is_the_scalar_integrators():
    """The C entry points side by side: every field of every trajectory's info (counters,
    time, last step, state, the local-error sum, rows written), good runs and failed ones."""
    y0 = _states(LANES + 3, seed=18)
    y0[1, 0] = np.nan                       # bad input
    y0[LANES, 2] = 1e300                    # overflows in its first step
    params = _params(len(y0), seed=19)
    t = np.linspace(0, 1.5, 4)
    opt = integrator_library("planar").options(run_options("taylor", np.float64, t, rtol=1e-10))
    order = taylor_order(1e-10)
    y, lanes = taylor_lanes_library("planar", order).run(y0, params, t, opt)
    ref, scalar = taylor_library("planar", order).run(y0, params, t, opt)
    assert np.array_equal(y, ref, equal_nan=True)
    def field(info, name):                  # y: a long double array (numpy reads it from the buffer)
        return info_state(info, y0.shape[1], np.longdouble) if name == "y" else getattr(info, name)
    for a, b in zip(lanes, scalar):
        for name, _ in a._fields_:
            assert np.array_equal(field(a, name), field(b, name), equal_nan=True), name
    assert sorted({i.status for i in lanes}) == [0, STATUS["NONFINITE"], STATUS["BAD_INPUT"]]
    assert all(i.local_error > 0 for i in lanes if i.status == 0)


@pytest.mark.slow        # the spherical chart's integrators take minutes to compile
def test_a_chart_guard_stops_its_lane_alone():
    """A spherical state on its chart's pole is CHART_SINGULAR in its lane alone."""
    rng = np.random.default_rng(14)
    B = LANES + 3
    y0 = np.column_stack([rng.uniform(1.2, 1.9, (B, 4)), rng.uniform(-0.3, 0.3, (B, 4))])
    y0[:, [5, 7]] = 2.0                     # swinging round: far from the poles for t <= 0.5
    y0[4, 0] = 0.0                          # sin(theta1) = 0: the chart's singularity
    params = np.tile(PLANAR, (B, 1))
    t = [0, 0.25, 0.5]
    r = derive.ensemble("spherical_std", y0, t, params, method="taylor", rtol=1e-10)
    assert r.status_names[4] == "chart singular (polar sine below threshold)"
    assert np.count_nonzero(r.status) == 1
    _assert_simulate(r, y0, t, params, rtol=1e-10)


def test_a_step_budget_ends_each_lane_where_simulate_ends():
    y0, params = _states(5), np.tile(PLANAR, (5, 1))
    t = [0, 0.5, 3.0]
    few = derive.ensemble("planar", y0, t, params, method="taylor", rtol=1e-10, max_steps=3)
    assert few.status_names == ["maximum number of steps reached"] * 5
    _assert_simulate(few, y0, t, params, rtol=1e-10, max_steps=3)


@pytest.mark.parametrize("lanes", [1, pytest.param(3, marks=pytest.mark.slow)])   # 3: one more lanes build
def test_the_number_of_lanes_changes_no_result(lanes):
    """Any lane count (and the portable build without vector flags) gives the same numbers."""
    y0, params = _states(10, seed=16), _params(10, seed=17)
    t = np.linspace(0, 1, 3)
    opt = integrator_library("planar").options(run_options("taylor", np.float64, t, rtol=1e-10))
    order = taylor_order(1e-10)
    ref, _ = taylor_lanes_library("planar", order).run(y0, params, t, opt)
    y, infos = taylor_lanes_library("planar", order, lanes=lanes, simd=()).run(y0, params, t, opt)
    assert all(i.status == 0 for i in infos) and np.array_equal(y, ref)
