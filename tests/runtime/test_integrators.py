"""The generated integrators: orders, dense output, C vs NumPy, batch, statuses, bad input.

Bounds are stated in each test; measured figures are in the assertion messages.
"""
from __future__ import annotations

import ctypes
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import derive
from derive.runtime import SimulationInputError, simulate
from derive.runtime.build import integrator_library
from derive.codegen.generate import render_everything
from derive.runtime.simulate import numpy_module

from tests.parameters import UNIT_PARAMS as PLANAR
COMPOUND = [1.0, 2.0, 1.0, 0.7, 1.0 / 12, 2.0 * 0.49 / 12, 9.81]
Y0 = [1.0, 0.5, 0.0, 0.0]


@pytest.fixture(scope="module")
def reference():
    """planar y(1) from DOP853 in long double at rtol 1e-17."""
    r = simulate("planar", Y0, [0.0, 1.0], PLANAR, method="dop853", rtol=1e-17, atol=1e-20,
                 dtype="longdouble")
    assert r.ok, r.message
    return r.y[-1]


def _err_fixed(method, h, ref, dtype="float64", backend="c"):
    r = simulate("planar", Y0, [0.0, 1.0], PLANAR, method=method, step=h, dtype=dtype, backend=backend)
    assert r.ok, r.message
    return float(np.max(np.abs(r.y[-1] - ref)))


@pytest.mark.parametrize("method, order, h", [("rk4", 4, 0.01), ("midpoint", 2, 0.01), ("gauss2", 4, 0.04)])
def test_fixed_step_convergence_order(method, order, h, reference):
    """Error ratio on halving the step: 2^order within 15%."""
    e = [_err_fixed(method, h / 2 ** k, reference, dtype="longdouble") for k in range(3)]
    ratios = [e[k] / e[k + 1] for k in range(2)]
    for r in ratios:
        assert abs(r / 2 ** order - 1) < 0.15, f"{method}: errors {e}, ratios {ratios}"


def _fixed_explicit(name, h, T=1.0, dtype=np.longdouble):
    """Fixed steps of an embedded method through the NumPy step function (its tableau)."""
    mod = numpy_module("planar_integrate")
    y = np.asarray(Y0, dtype)
    p = np.asarray([PLANAR[k] for k in ("m1", "m2", "l1", "l2", "g")], dtype)
    opt = dict(mod.DEFAULTS)
    info = mod.new_info()
    K = np.zeros((16, 4), dtype)
    n = int(round(T / h))
    for _ in range(n):
        st, K[0] = mod.system.eval(y, p, opt, info)
        st, y, _ = mod.library.explicit_step(mod.system, name, y, dtype(h), p, K, opt, info)
        assert st == 0
    return y


@pytest.mark.parametrize("name, order, h", [("dopri5", 5, 0.04), ("dop853", 8, 0.1)])
def test_embedded_method_order_with_fixed_steps(name, order, h):
    """The DOPRI5 / DOP853 tableaus (from the .toml data), fixed steps in long double:
    the differences of successive halvings fall at least like 2^order (ratio >= 0.8 * 2^order;
    DOP853's principal error constant is small, so its measured ratios exceed 256)."""
    ys = [_fixed_explicit(name, h / 2 ** k) for k in range(4)]
    d = [float(np.max(np.abs(ys[k] - ys[k + 1]))) for k in range(3)]
    ratios = [d[k] / d[k + 1] for k in range(2)]
    for r in ratios:
        assert 0.8 * 2 ** order <= r < 2 ** (order + 4), f"{name}: differences {d}, ratios {ratios}"


@pytest.mark.parametrize("name, order", [("dopri5", 4), ("dop853", 7)])
def test_dense_output_order(name, order):
    """Dense output inside one step: the error at theta = 0.37 falls at least like h^(order+1)
    (ratio >= 0.8 * 2^(order+1))."""
    mod = numpy_module("planar_integrate")
    dtype = np.longdouble
    p = np.asarray([1.0, 1.0, 1.0, 1.0, 9.81], dtype)
    opt, info = dict(mod.DEFAULTS), mod.new_info()
    y = np.asarray(Y0, dtype)
    errs = []
    for h in (0.2, 0.1, 0.05):
        K = np.zeros((16, 4), dtype)
        _, K[0] = mod.system.eval(y, p, opt, info)
        _, yn, _ = mod.library.explicit_step(mod.system, name, y, dtype(h), p, K, opt, info)
        theta = dtype(0.37)
        if name == "dop853":
            _, K[12] = mod.system.eval(yn, p, opt, info)
            _, F = mod.library.dop853_dense_prepare(mod.system, y, yn, dtype(h), p, K, opt, info)
            yd = mod.library.dop853_dense(y, F, theta)
        else:
            yd = mod.library.dopri5_dense(y, dtype(h), K, theta)
        ref = simulate("planar", Y0, [0.0, float(theta * dtype(h))], PLANAR, method="dop853",
                       rtol=1e-17, atol=1e-20, dtype="longdouble").y[-1]
        errs.append(float(np.max(np.abs(yd - ref))))
    ratios = [errs[k] / errs[k + 1] for k in range(2)]
    for r in ratios:
        assert 0.8 * 2 ** (order + 1) <= r < 2 ** (order + 5), f"{name}: errors {errs}, ratios {ratios}"


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_adaptive_meets_tolerance(method, reference):
    """Global error below 100 rtol on a smooth run, and smaller for smaller rtol."""
    errs = []
    for rtol in (1e-6, 1e-9, 1e-12):
        r = simulate("planar", Y0, [0.0, 1.0], PLANAR, method=method, rtol=rtol, atol=rtol * 1e-3)
        assert r.ok, r.message
        err = float(np.max(np.abs(r.y[-1] - reference.astype(float))))
        assert err < 100 * rtol, f"{method}: rtol {rtol} error {err}"
        errs.append(err)
    assert errs[0] > errs[1] > errs[2] or errs[2] < 1e-13, errs


@pytest.mark.parametrize("model, params", [("planar", PLANAR), ("compound", COMPOUND),
                                           ("spherical_std", [1.0, 1.5, 1.0, 0.8, 9.81])])
@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853", "midpoint", "gauss2"])
def test_c_and_numpy_agree(model, params, method):
    """The same logic in C and NumPy.  Fixed steps: the same steps, states within 1e-10.
    Adaptive: NumPy's sin/cos come from half-angle tangents, a few ulp from libm's, so a
    controller at the edge of accepting a step can decide differently and the two take
    slightly different step sequences: step counts equal up to a few (measured: 3 of 162,
    dop853 on the compound pendulum), states within 20 rtol (measured 4.6e-10 at rtol
    1e-10 there, t = 2)."""
    y0 = Y0 if model != "spherical_std" else [1.0, 0.2, 1.3, -0.4, 0.3, 0.5, -0.2, 0.8]
    t = np.linspace(0.0, 2.0 if model != "spherical_std" else 0.5, 5)
    fixed = method in ("rk4", "midpoint", "gauss2")
    kw = dict(step=0.01) if fixed else dict(rtol=1e-10)
    rc = simulate(model, y0, t, params, method=method, backend="c", **kw)
    rn = simulate(model, y0, t, params, method=method, backend="numpy", **kw)
    assert rc.ok and rn.ok, (rc.message, rn.message)
    for a, b in ((rc.nsteps, rn.nsteps), (rc.naccepted, rn.naccepted)):
        assert a == b if fixed else abs(a - b) <= max(3, a // 30), (a, b)
    bound = 1e-10 if fixed else 20 * kw["rtol"]
    assert np.max(np.abs(rc.y - rn.y)) < bound
    assert np.max(np.abs(rc.energy - rn.energy)) < bound
    assert rc.positions.shape == (5, 2, 2 if model != "spherical_std" else 3)


def test_batch_entry_point_matches_single_runs():
    lib = integrator_library("planar")
    opt = lib.defaults()
    rng = np.random.default_rng(1)
    y0 = rng.uniform(-1, 1, (6, 4))
    p = np.array([1.0, 2.0, 1.0, 0.5, 9.81])
    t = np.linspace(0, 3, 7)
    y, infos = lib.run(2, y0, p, t, opt)
    assert all(i.status == 0 for i in infos)
    for k in range(6):
        r = simulate("planar", y0[k], t, p, method="dop853", rtol=1e-9, atol=1e-12)
        assert np.array_equal(r.y, y[k])
    mod = numpy_module("planar_integrate")
    st, yn, _ = mod.integrate_batch("dop853", y0, p, t)
    assert not st.any() and np.max(np.abs(yn - y)) < 1e-10


def _counting(kernels):
    """The kernel module with its rhs counting its calls (calls[0])."""
    import types
    counted, calls = types.ModuleType(kernels.__name__), [0]
    counted.__dict__.update(kernels.__dict__)

    def rhs(*args):
        calls[0] += 1
        return kernels.rhs(*args)
    counted.rhs = rhs
    return counted, calls


@pytest.mark.parametrize("model,method,dtype,options", [
    ("planar", "dop853", np.float64, {}), ("planar", "dopri5", np.float32, {"rtol": 1e-5}),
    ("planar", "rk4", np.float64, {"h": 0.03}), ("planar", "rk8", np.longdouble, {"h": 0.1}),
    ("spherical_std", "dop853", np.float64, {})])
def test_the_numpy_batch_is_integrate_row_by_row_in_array_calls(model, method, dtype, options):
    """integrate_batch of the generated NumPy integrators: each row bit for bit what
    integrate gives it (outputs, status, counters, where it stopped, a bad row's reason),
    rows ending early (bad input, a non-finite state, a singular chart) or not; and the
    batch calls rhs about as often as its longest row needs (every running row in each
    call), not once a row."""
    mod = numpy_module(f"{model}_integrate")
    lib, kernels = mod.library, mod.kernels
    rng = np.random.default_rng(3)
    n = len(kernels.STATE_NAMES)
    y0 = np.column_stack([rng.uniform(0.5, 2.0, (6, n // 2)), rng.uniform(-1, 1, (6, n // 2))]).astype(dtype)
    y0[1, 0] = np.nan                       # bad input
    y0[2, n // 2] = np.finfo(dtype).max ** dtype(0.6)      # its square overflows: a non-finite state
    if model == "spherical_std":
        y0[3, 0] = 0.01                     # at the standard chart's pole: chart singular
    p = np.tile([1.0, 1.0, 1.0, 1.0, 9.81], (6, 1))
    p[:, 4] = rng.uniform(1.0, 20.0, 6)     # one parameter vector a row
    t = np.linspace(1.0, 0.0, 5)            # backwards in time
    counted, calls = _counting(kernels)
    st, y, infos = lib.integrate_batch(lib.System(counted), method, y0, p, t, dtype, **options)
    assert y.dtype == dtype and y.shape == (6, 5, n)
    keys = ("status", "nfev", "nsteps", "naccepted", "nrejected", "nout", "t", "h", "h_end", "local_error", "reason")
    for k in range(6):
        sk, yk, ik = lib.integrate(lib.System(kernels), method, y0[k], p[k], t, dtype, **options)
        assert st[k] == sk and np.array_equal(y[k], yk, equal_nan=True), k
        assert {key: infos[k][key] for key in keys} == {key: ik[key] for key in keys}, k
        assert infos[k]["y"].dtype == ik["y"].dtype and np.array_equal(infos[k]["y"], ik["y"], equal_nan=True), k
    names = {lib.STATUS_NAMES[s] for s in st}
    assert {"ok", "bad input", "non-finite state or derivative"} <= names
    assert model != "spherical_std" or "chart singular (polar sine below threshold)" in names
    assert "y0 has a value that is not finite" in infos[1]["reason"]
    nfev, nsteps = [i["nfev"] for i in infos], [i["nsteps"] for i in infos]
    # one call a stage of the step the longest row attempts (rows reject at different steps,
    # so a row reusing its first stage after a rejection does not save the others' call),
    # the first step's two, and dop853's dense-output stages at steps where only others output
    stages = {"rk4": 4, "rk8": 13, "dopri5": 7, "dop853": 12}[method]
    bound = stages * max(nsteps) + 2 + 3 * len(t) * len(y0)
    assert calls[0] <= bound and calls[0] < sum(nfev) / 2, (calls[0], bound, nfev)


def test_float_double_long_double_same_run():
    """RK4, 2000 steps of 5e-3: float within 1e-3 of long double, double within 1e-12."""
    t = np.linspace(0, 10, 3)
    out = {dt: simulate("planar", Y0, t, PLANAR, method="rk4", step=5e-3, dtype=dt).y.astype(np.longdouble)
           for dt in ("float32", "float64", "longdouble")}
    ef = float(np.max(np.abs(out["float32"] - out["longdouble"])))
    ed = float(np.max(np.abs(out["float64"] - out["longdouble"])))
    assert ef < 1e-3 and ed < 1e-12, (ef, ed)
    assert out["float32"].dtype == np.longdouble
    r = simulate("planar", Y0, t, PLANAR, method="dop853", dtype="float32")
    assert r.ok and r.y.dtype == np.float32 and r.energy.dtype == np.float32


def test_forward_then_backward_returns():
    """Gauss2 is symmetric: back to y0 within 1e-10 (rounding only); DOP853 at rtol 1e-12 within 1e-8."""
    T = 5.0
    for method, kw, tol in (("gauss2", dict(step=1e-3), 1e-10), ("dop853", dict(rtol=1e-12, atol=1e-15), 1e-8),
                            ("rk4", dict(step=1e-3), 1e-8)):
        f = simulate("planar", Y0, [0.0, T], PLANAR, method=method, **kw)
        b = simulate("planar", f.y[-1], [T, 0.0], PLANAR, method=method, **kw)
        assert f.ok and b.ok
        err = float(np.max(np.abs(b.y[-1] - Y0)))
        assert err < tol, (method, err)


def test_symplectic_energy_bounded_rk4_drifts_over_a_million_steps():
    """10^6 steps of h = 0.01 (t = 10^4), planar, in C.
    Gauss2: |E - E0| < 5e-4 throughout and no growth (second half max < 2x first half max).
    RK4: drifts: |E(T) - E0| > 0.1 and grows (|E(T)-E0| > 1.5 |E(T/2)-E0|)."""
    y0, t = [2.0, 1.0, 0.0, 0.0], np.linspace(0, 1e4, 1001)
    g = simulate("planar", y0, t, PLANAR, method="gauss2", step=0.01)
    r = simulate("planar", y0, t, PLANAR, method="rk4", step=0.01)
    assert g.ok and r.ok and g.nsteps == 10 ** 6 and r.nsteps == 10 ** 6
    dg, dr = g.energy - g.energy[0], r.energy - r.energy[0]
    assert np.abs(dg).max() < 5e-4, np.abs(dg).max()
    assert np.abs(dg[500:]).max() < 2 * np.abs(dg[:501]).max()
    assert abs(dr[-1]) > 0.1 and abs(dr[-1]) > 1.5 * abs(dr[500]), (dr[500], dr[-1])
    c = simulate("compound", [2.0, 1.0, 0.0, 0.0], np.linspace(0, 1e3, 1001), COMPOUND,
                 method="gauss2", step=0.005)
    assert c.ok and np.abs(c.energy - c.energy[0]).max() < 5e-4     # measured 1.6e-4 (E = 6.5)


def test_newton_re_evaluates_the_jacobian_when_convergence_is_slow():
    """l1/l2 = 1e-2 (rho_max = 99): with the Jacobian fixed at the step start the simplified
    Newton iteration stalled (NEWTON at t = 0.14 for Gauss2 h = 1e-2, t = 0.23 for midpoint
    h = 4.5e-3); re-evaluated at the stage values when the rate exceeds 0.5 or an increment
    grows, both run through t = 5 (measured: 49 and 25 re-evaluations, energy within
    2.4e-5 and 9.5e-5 of the scale (m1 + m2) g (l1 + l2)); C and NumPy take the same
    decisions up to a few of some 4000 Newton iterations (NumPy's sin and cos come from
    half-angle tangents, a few ulp from libm's, which moves iterations at the threshold)."""
    p = [1.0, 1.0, 0.01, 1.0, 9.81]
    scale = 2 * 9.81 * 1.01
    t = np.linspace(0, 5, 51)
    for method, h, bound in (("gauss2", 1e-2, 1e-4), ("midpoint", 4.5e-3, 4e-4)):
        rc = simulate("planar", [1.0, -0.5, 0.3, 0.8], t, p, method=method, step=h)
        rn = simulate("planar", [1.0, -0.5, 0.3, 0.8], t, p, method=method, step=h, backend="numpy")
        assert rc.ok and rn.ok, (rc.message, rn.message)
        assert rc.njev > rc.nsteps, (rc.njev, rc.nsteps)
        for a, b in ((rc.njev, rn.njev), (rc.nnewton, rn.nnewton), (rc.nfev, rn.nfev)):
            assert abs(a - b) <= 0.005 * a, (a, b)
        assert np.max(np.abs(rc.y - rn.y)) < 1e-9
        assert np.max(np.abs(rc.energy - rc.energy[0])) < bound * scale


# -- no silent failure ----------------------------------------------------------

@pytest.mark.parametrize("kwargs, fragment", [
    (dict(model="nope"), "unknown model"),
    (dict(method="euler"), "unknown method"),
    (dict(y0=[1.0, float("nan"), 0, 0]), "NaN"),
    (dict(y0=[1.0, 0.0, 0.0]), "4 numbers"),
    (dict(params={"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81, "mu": 2}), "unknown parameter 'mu'"),
    (dict(params={"m1": 1, "m2": 1, "l1": 1, "g": 9.81}), "missing parameter 'l2'"),
    (dict(params=[1, 1, -1, 1, 9.81]), "l1"),
    (dict(params=[1, 1, 1, 1]), "5 parameters"),
    (dict(t=[0.0, 1.0, 0.5]), "strictly"),
    (dict(t=[0.0, float("inf")]), "t contains"),
    (dict(method="rk4", step=None), "step"),
    (dict(method="rk4", step=-0.1), "step"),
    (dict(rtol=1e-20), "rtol"),
    (dict(dtype="float16"), "dtype"),
    (dict(backend="fortran"), "backend"),
])
def test_bad_input_is_a_value_error_with_one_line(kwargs, fragment):
    args = dict(model="planar", y0=Y0, t=[0.0, 1.0], params=PLANAR, method="dop853")
    args.update(kwargs)
    with pytest.raises(SimulationInputError) as exc:
        simulate(**args)
    msg = str(exc.value)
    assert fragment in msg and "\n" not in msg, msg
    assert isinstance(exc.value, ValueError)


def test_derive_exports_simulate():
    assert derive.simulate is simulate


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_failures_say_why_where_and_in_which_state(backend):
    t = np.linspace(0, 10, 11)
    # max steps
    r = simulate("planar", Y0, t, PLANAR, method="rk4", step=0.01, max_steps=250, backend=backend)
    assert r.status == 2 and r.status_name.startswith("maximum") and abs(r.t_stop - 2.5) < 1e-12
    assert np.isnan(r.y[3:]).all() and not np.isnan(r.y[:3]).any() and np.isfinite(r.y_stop).all()
    assert "t = 2.5" in r.message and "theta1=" in r.message
    # step-size underflow: hmin larger than any step the tolerance allows
    r = simulate("planar", [2.5, -2.0, 8.0, -9.0], t, PLANAR, method="dop853", rtol=1e-13, atol=1e-16,
                 backend=backend, hmax=1e-3) if False else None
    mod_kw = dict(rtol=1e-12, atol=1e-15)
    lib_hmin = 0.5
    r = _with_hmin(backend, lib_hmin, mod_kw)
    assert r["status"] == 1, r
    # Newton divergence: an implicit step far too large for the motion
    r = simulate("planar", [2.5, -2.0, 20.0, -25.0], t, PLANAR, method="gauss2", step=2.0, backend=backend)
    assert r.status == 3 and r.t_stop == 0.0, r.message
    # non-finite: an overflowing state
    r = simulate("planar", [1.0, 0.5, 1e200, -1e200], t, PLANAR, method="rk4", step=0.01, backend=backend)
    assert r.status == 4 and r.status_name.startswith("non-finite"), r.message
    with pytest.raises(Exception, match="non-finite"):
        r.raise_for_status()


def _with_hmin(backend, hmin, kw):
    """A run whose hmin (0.5) is far above what rtol 1e-12 needs: step-size underflow."""
    t = np.linspace(0, 10, 3)
    p = np.array([1.0, 1.0, 1.0, 1.0, 9.81])
    if backend == "c":
        lib = integrator_library("planar")
        opt = lib.defaults()
        opt.rtol, opt.atol, opt.hmin = kw["rtol"], kw["atol"], hmin
        _, infos = lib.run(2, np.array([Y0]), p, t, opt)
        return {"status": infos[0].status, "t": infos[0].t}
    mod = numpy_module("planar_integrate")
    st, _, info = mod.integrate("dop853", Y0, p, t, hmin=hmin, **kw)
    return {"status": st, "t": info["t"]}


def test_c_bad_input_status():
    lib = integrator_library("planar")
    opt = lib.defaults()
    y, infos = lib.run(2, np.array([[1.0, np.nan, 0, 0]]), np.array([1.0, 1, 1, 1, 9.81]),
                       np.array([0.0, 1.0]), opt)
    assert infos[0].status == 6 and np.isnan(y).all()
    name = lib.lib.planar_integrate_status_name
    name.restype = ctypes.c_char_p
    assert name(5) == b"chart singular (polar sine below threshold)"


@pytest.mark.slow     # renders every model's integrators again
def test_generated_integrators_are_deterministic():
    a = render_everything(fresh=True)         # rendered now, twice, neither from a cache
    b = render_everything(fresh=True)
    assert a == b and "c/spherical_atlas.c" in a and "numpy/planar_integrate.py" in a


# slow: the integrators (and the atlas) are among the files every compiler builds with these
# warnings and more in test_generate_and_compile.py's slow test_generated_c_compiles_warning_free
@pytest.mark.slow
@pytest.mark.parametrize("cc", ["gcc", "clang", "g++"])
def test_integrators_compile_warning_free(cc, tmp_path):
    GENERATED_C = Path(__file__).resolve().parents[2] / "generated" / "c"
    flags = ["-std=c99", "-pedantic"] if cc != "g++" else ["-x", "c++"]
    for src in sorted(GENERATED_C.glob("*_integrate.c")) + [GENERATED_C / "spherical_atlas.c"]:
        cmd = [cc, *flags, "-Wall", "-Wextra", "-Werror", "-O2", "-c", str(src), "-o", str(tmp_path / "x.o")]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize("kwargs, fragment", [
    (dict(method="rk4", step=1e-30), "means 5e+30 steps"),
    (dict(hmax=1e-300), "hmax = 1e-300 over a span of 5"),
])
def test_runs_that_could_never_finish_are_refused_before_any_work(kwargs, fragment):
    with pytest.raises(derive.SimulationInputError, match=re.escape(fragment)):
        derive.simulate("planar", [1, 0, 0, 0], [0, 5], PLANAR, **kwargs)


def test_more_output_times_than_memory_is_refused_before_any_copy():
    with pytest.raises(derive.SimulationInputError, match="more than one run can hold"):
        derive.simulate("planar", [1, 0, 0, 0], np.zeros(50_000_000), PLANAR)


def test_atol_zero_is_pure_relative_control_that_works_at_rest():
    """Exactly at rest, atol = 0 used to make the first step NaN and then reject 1e8 steps."""
    rest = derive.simulate("planar", [0, 0, 0, 0], [0, 5], PLANAR, atol=0.0)
    assert rest.ok and np.all(rest.y[-1] == 0)
    moving = derive.simulate("planar", [1, 0.5, 0, 0], [0, 5], PLANAR, atol=0.0, rtol=1e-10)
    tight = derive.simulate("planar", [1, 0.5, 0, 0], [0, 5], PLANAR, rtol=1e-13)
    assert moving.ok and np.max(np.abs(moving.y[-1] - tight.y[-1])) < 1e-7
