"""Every call the benchmark makes into derive's integrators, loops and kernels.

The rest of the package reaches the generated code only through the functions here,
one a kind of run: an integration to t_end (C, NumPy, the spherical atlas) and the
scalar RK4 over a batch, both through the run time's runner (derive.runtime.runner, the
dispatch derive.simulate and derive.ensemble take); the single-trajectory fixed-step
loops, the batched RK4 (C and NumPy) and the energy kernel, through the run time's
wrappers of those kernels; and the C loop that times one rhs evaluation.  Each returns
a prepared callable: building libraries, options and arrays happens when it is made, so
that a timed call is the integration alone, as the peers' calls are.  (The untimed runs
that go through derive.simulate, the public API, are not here.)
"""
from __future__ import annotations

import ctypes

import numpy as np

from ..reference import comparison_vector
from ...codegen.contract import MULTISTEP, SINE_MIN, STATUS, STATUS_NAMES
from ...codegen.sources import c_source
from ...model.atlas import ATLAS
from ...paths import bench_c_dir
from ...runtime.atlas_runner import ATLAS_CHARTS
from ...runtime.loader import CompiledModel, build_fastest, load
from ...runtime.runner import runner_for
from ...runtime.throughput import fixed_library, throughput_library, throughput_numpy
from .problems import np_dtype, prepared


def integrator_options(rtol, step) -> dict:
    """The options of one integrator run: rtol (atol = rtol 1e-3) or the fixed step h; a
    fixed step's rtol and atol are simulate's defaults (abm12's guard: 1e-9, 1e-12)."""
    return {"rtol": rtol if rtol is not None else 1e-9, "atol": (rtol if rtol is not None else 1e-9) * 1e-3,
            "h": step or 0.0, "hmin": 0.0, "hmax": 0.0, "max_steps": 100_000_000, "newton_tol": 0.0,
            "newton_max": 30, "sine_min": float(SINE_MIN)}


def integrator_run(problem, method: str, backend: str, dtype: str, rtol, step):
    """One integration of `problem` from 0 to t_end by a generated integrator, called
    through the run time's runner (derive.runtime.runner: the dispatch simulate and
    ensemble take) without simulate's argument checks and result object.

    Parameters
    ----------
    problem : Problem
    method : str
        One of derive.codegen.contract.METHODS.
    backend : {"c", "numpy"}
    dtype : {"float32", "float64", "longdouble"}
    rtol : float or None
        The tolerance of an adaptive method; None for a fixed step.
    step : float or None
        The step of a fixed-step method; None for an adaptive one.

    Returns
    -------
    callable
        run() -> (comparison vector at t_end, rhs evaluations, ok, message).
    """
    dt = np_dtype(dtype)
    state, chart, p = prepared(problem)
    y0, pd, t = np.asarray(state, dt), np.asarray(p, dt), np.array([0.0, problem.t_end], dt)
    r = runner_for(problem.model, method, dtype, backend)
    opt = r.options(integrator_options(rtol, step))
    vec = lambda y, ch: comparison_vector(problem.model, y, ch, p)
    if problem.model == ATLAS:
        if backend == "c":
            return _c_atlas_run(r, chart, y0, pd, t, opt, vec)
        return _numpy_atlas_run(r, method, chart, y0, pd, t, dt, opt, vec)
    if backend == "c":
        return _c_run(r, y0, pd, t, opt, vec)
    return _numpy_run(r, method, y0, pd, t, dt, opt, vec)


def status_text(status: int, method: str, opt) -> str:
    """A run's status in words, as a failed row's note gives it.

    Parameters
    ----------
    status : int
        The integrator's status code.
    method : str
    opt : dict or ctypes.Structure
        The run's options (integrator_options, or the runner's struct of them).

    Returns
    -------
    str
        The status's name; for a multistep run its guard stopped, the guard and its threshold.
    """
    text = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else f"status {status}"
    if status == STATUS["MULTISTEP_UNSTABLE"] and method in MULTISTEP:
        get = opt.get if isinstance(opt, dict) else lambda key: getattr(opt, key)
        text += (f": Milne's error estimate above atol + rtol |y| (rtol {get('rtol'):.3g}, "
                 f"atol {get('atol'):.3g}, simulate's defaults)")
    return text


def _c_run(r, y0, pd, t, opt, vec):
    y0b = y0[None, :]

    def run():
        y, infos, _ = r.batch(y0b, pd, t, opt)
        inf = infos[0]
        return vec(y[0, -1], None), inf.nfev, inf.status == 0, status_text(inf.status, r.method, opt)
    return run


def _c_atlas_run(r, chart, y0, pd, t, opt, vec):
    y0b, c0 = y0[None, :], [ATLAS_CHARTS.index(chart)]

    def run():
        y, charts, infos = r.atlas_batch(c0, y0b, pd, t, opt)
        inf = infos[0]
        ch = ATLAS_CHARTS[charts[0, -1]] if charts[0, -1] >= 0 else None
        return vec(y[0, -1], ch), inf.nfev, inf.status == 0, f"status {inf.status}"
    return run


def _numpy_run(r, method, y0, pd, t, dt, opt, vec):
    mod = r.numpy_integrator()

    def run():
        st, y, inf = mod.integrate(method, y0, pd, t, dt, **opt)
        return vec(y[-1], None), int(inf["nfev"]), st == 0, status_text(st, method, opt)
    return run


def _numpy_atlas_run(r, method, chart, y0, pd, t, dt, opt, vec):
    mod, c0 = r.numpy_integrator(), ATLAS_CHARTS.index(chart)

    def run():
        st, y, charts, inf = mod.integrate(method, c0, y0, pd, t, dt, **opt)
        ch = ATLAS_CHARTS[charts[-1]] if charts[-1] >= 0 else None
        return vec(y[-1], ch), int(inf["nfev"]), st == 0, f"status {st}"
    return run


def loop_run(model: str):
    """The generated single-trajectory fixed-step loops of a model (<model>_fixed_<method>).

    Returns
    -------
    callable
        run(method, y0, p, h, nsteps) -> (state after the steps completed, steps completed).
    """
    return fixed_library(model).run


def scalar_rk4(model: str, h: float):
    """The generated scalar RK4 integrator at step h, run over a batch one trajectory after another.

    Returns
    -------
    callable
        run(y0 (B, n), p, nsteps) -> the states after nsteps steps, (B, n).
    """
    r = runner_for(model, "rk4")
    o = r.options({"h": h})

    def run(y0, p, nsteps):
        y, _, _ = r.batch(y0, p, np.array([0.0, h * nsteps]), o)
        return y[:, -1]
    return run


def c_batch_rk4(model: str, soa: bool = False):
    """The generated batched RK4 in C (<model>_throughput_rk4).

    Parameters
    ----------
    model : str
    soa : bool
        True: run(Y, p, h, nsteps, threads) on states Y (n, B), in place, -> (status, steps);
        False: run(y0 (B, n), p, h, nsteps, threads) -> (y, status, steps).
    """
    tp = throughput_library(model)
    return tp.rk4_soa if soa else tp.rk4


def c_batch_vector_math(model: str) -> bool:
    """Whether the batched C RK4 was built with libmvec's vector sin and cos."""
    return throughput_library(model).vector_math


def numpy_batch_rk4(model: str):
    """The generated batched RK4 in NumPy: run(Y (n, B), p, h, nsteps) -> (Y, status, steps)."""
    return throughput_numpy(model).rk4


def energy_of(problem):
    """y -> the energy of state y under the problem's parameters (the generated C kernel)."""
    m = load(problem.model)
    p = np.asarray(problem.params, np.float64)
    return lambda y: float(m.energy(np.asarray(y, np.float64), p))


def _rhs_cost_loop(model: str):
    """derive/measurement/c/rhs_cost.c compiled against the model's generated C as the integrators are
    (loader.build_fastest: libmvec's vector sin/cos where they build)."""
    path, _ = build_fastest(f"{model}_rhs_cost", [c_source(model, f"{model}.c"), bench_c_dir() / "rhs_cost.c"],
                            extra=(f"-DRHS={model}_rhs", "-include", f"{model}.h"))
    # the loader opens the library; the loop is not a batch kernel of a header, so its
    # C signature is declared here
    fn = CompiledModel(f"{model}_rhs_cost", path, "").lib.rhs_cost_loop
    fn.restype = ctypes.c_double
    fn.argtypes = [ctypes.c_long, ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                   ctypes.c_long, ctypes.c_int, ctypes.c_double]
    return fn


def rhs_cost_run(model: str, y: np.ndarray, p: np.ndarray, reps: int, chained: bool):
    """The generated C rhs of `model` evaluated `reps` times over the states y, in a C loop.

    Parameters
    ----------
    model : str
        A model or chart with a generated rhs.
    y : ndarray, (n, dim)
        The states, float64.
    p : ndarray
        The parameters, float64.
    reps : int
        Passes over the states.
    chained : bool
        Each evaluation's input depends on the previous output, as in an integrator.

    Returns
    -------
    callable
        run() -> None, one call of the loop (the arrays are held and passed as made).
    """
    fn = _rhs_cost_loop(model)
    y, p = np.ascontiguousarray(y, np.float64), np.ascontiguousarray(p, np.float64)
    out = np.empty_like(y)
    args = (len(y), y.shape[1], y.ctypes.data, p.ctypes.data, out.ctypes.data, reps, int(chained), 0.0)
    held = (y, p, out)      # the C loop reads and writes these addresses: they live as long as run

    def run():
        fn(*args)
        return held
    return run
