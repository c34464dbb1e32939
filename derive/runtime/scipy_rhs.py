"""`derive.scipy_rhs(model, params, inputs=None)`: the generated kernels as `fun(t, y)` and
`jac(t, y)` for scipy.integrate.solve_ivp (or any integrator with that convention).

    fun, jac = derive.scipy_rhs("planar", {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81})
    scipy.integrate.solve_ivp(fun, (0, 10), y0, method="Radau", jac=jac, rtol=1e-10)

It returns a ScipyRHS, a named tuple (fun, jac): unpack it, or use .fun and .jac.  Both
are backed by the model's compiled C kernels (`rhs`, `jacobian`, through the loader's
ctypes batch entry points, in double); without a C compiler, or with backend="numpy",
by the generated NumPy kernels.  fun accepts y of shape (n,) or (n, k) (solve_ivp's
vectorized=True); jac returns the (n, n) matrix d(ydot)/dy.

For a time-independent model t only matters for inputs given as a function u(t, y):
those are evaluated at every (t, y) the integrator asks (a continuous input, as simulate
does without hold="zoh").  A time-dependent model's kernels take t (t in its forces,
dissipation or pivot): fun and jac pass the t the integrator asks.  A kernel that
cannot evaluate a state (a chart model's polar sine below its threshold) gives NaN,
which solve_ivp reports as a failed step.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

from ..errors import CompilerMissingError, SimulationInputError
from ..model import load_model
from ..model.atlas import ATLAS
from .model_sizes import model_info
from .simulate import HeldInputs, normalise_inputs, normalise_params, resolve_model
from .loader import load, numpy_module


class ScipyRHS(NamedTuple):
    fun: Callable         # fun(t, y) -> ydot, shape of y
    jac: Callable         # jac(t, y) -> (n, n)


def scipy_rhs(model, params, inputs=None, backend: str = "c") -> ScipyRHS:
    """The generated kernels of a model as ``fun(t, y)`` and ``jac(t, y)`` for SciPy.

    Parameters
    ----------
    model : str or path
        A catalogue model name or the path of a model file (one chart: not the atlas).
    params : mapping or sequence
        The parameters, by name or in the model's order.
    inputs : mapping, sequence or callable, optional
        The model's run-time inputs; a function of t is evaluated at every t asked.
    backend : {"c", "numpy"}
        The compiled C kernels (the default; NumPy without a C compiler) or the NumPy ones.

    Returns
    -------
    ScipyRHS
        A named tuple ``(fun, jac)``: ``fun`` takes y of shape (n,) or (n, k), ``jac``
        returns the (n, n) matrix d(ydot)/dy; a state a kernel cannot evaluate gives NaN.

    Raises
    ------
    SimulationInputError
        An unknown model or backend, the chart atlas, parameters or inputs that do not fit.
    BuildError
        backend "c": the model's kernels do not compile (without a compiler at all the NumPy
        kernels are used instead, not an error).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.integrate import solve_ivp
    >>> import derive
    >>> params = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
    >>> fun, jac = derive.scipy_rhs("planar", params, backend="numpy")
    >>> bool(np.all(fun(0.0, [0.0, 0.0, 0.0, 0.0]) == 0))      # at rest, hanging
    True
    >>> jac(0.0, [0.0, 0.0, 0.0, 0.0]).shape
    (4, 4)
    >>> sol = solve_ivp(fun, (0.0, 1.0), [1.0, 0.5, 0.0, 0.0], method="DOP853", rtol=1e-10, atol=1e-10)
    >>> r = derive.simulate("planar", [1.0, 0.5, 0.0, 0.0], [0.0, 1.0], params, rtol=1e-10,
    ...                     backend="numpy")
    >>> bool(abs(sol.y[:, -1] - r.y[-1]).max() < 1e-7)
    True
    """
    model = resolve_model(model, explicit_time=True)
    if model == ATLAS:
        raise SimulationInputError(f"scipy_rhs: the chart atlas '{ATLAS}' switches charts, which solve_ivp "
                                   f"cannot do; give one chart model (spherical_std, spherical_alt, spherical_rot)")
    if backend not in ("c", "numpy"):
        raise SimulationInputError(f"unknown backend {backend!r} (use 'c' or 'numpy')")
    p = np.asarray(normalise_params(model, params), np.float64)
    u = normalise_inputs(model, inputs)
    info = model_info(model)
    rhs, jacobian = _kernels(model, backend)
    timed = load_model(model).is_time_dependent
    if timed:                                   # the kernels' first argument: the time, one slot
        rhs, jacobian = _at_time(rhs), _at_time(jacobian)

    def arguments(t: float, y) -> tuple:
        """The kernels' arguments after y: (p,), or (p, u) for a model with inputs."""
        if u is None:
            return (p,)
        if not isinstance(u, HeldInputs):
            return (p, np.asarray(u, np.float64))
        if np.ndim(y) == 2:                  # one input vector per column of y
            return (p, np.array([u.at(t, column) for column in np.asarray(y).T], np.float64))
        return (p, np.asarray(u.at(t, y), np.float64))

    time = (lambda t: (t,)) if timed else (lambda t: ())
    # one state at a time, the parameters (and fixed inputs) bound once: what solve_ivp calls
    fast = hasattr(rhs, "at_point") and not timed and not isinstance(u, HeldInputs)
    point = rhs.at_point(*arguments(0.0, None)) if fast else None
    jac_point = jacobian.at_point(*arguments(0.0, None)) if fast else None

    def fun(t, y):
        y = np.asarray(y, np.float64)
        if y.ndim == 2:                      # solve_ivp(vectorized=True): (n, k)
            return np.asarray(rhs(*time(t), np.ascontiguousarray(y.T), *arguments(t, y))).T
        if point is not None:
            return point(y)
        return np.asarray(rhs(*time(t), y.reshape(info.n), *arguments(t, y)))

    def jac(t, y):
        y = np.asarray(y, np.float64).reshape(info.n)
        if jac_point is not None:
            return jac_point(y)
        return np.asarray(jacobian(*time(t), y, *arguments(t, y)))

    return ScipyRHS(fun, jac)


def _at_time(kernel):
    """kernel(t, y, ...) as a function of (t, y, ...) with t a number: t as its one-slot
    vector, one per state of a batch y."""
    def call(t, y, *rest):
        return kernel(np.full(y.shape[:-1] + (1,), t, np.float64), y, *rest)
    return call


def _kernels(model: str, backend: str):
    """(rhs, jacobian) of the model, C when a compiler is there, else NumPy."""
    if backend == "c":
        try:
            m = load(model)
            return m.rhs, m.jacobian
        except CompilerMissingError:
            pass                             # the NumPy kernels: the same generated expressions
    m = numpy_module(model)

    def quiet(kernel):
        def call(*args):
            with np.errstate(all="ignore"):
                return kernel(*args)
        return call

    return quiet(m.rhs), quiet(m.jacobian)
