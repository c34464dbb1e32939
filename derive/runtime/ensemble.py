"""`derive.ensemble`: many trajectories of one model in one call.

    r = ensemble("planar", y0, t, params, method="dop853", rtol=1e-10)
    r.y        (B, len(t), n)      every trajectory at every output time
    r.status   (B,)                per trajectory (contract status codes; r.status_names)
    r.nfev ... (B,)                per-trajectory counters

y0 has shape (B, n); params shape (n_params,) (one vector for all) or (B, n_params)
(one per trajectory); inputs likewise (n_inputs,) or (B, n_inputs).  The trajectories
run in the model's compiled batch entry point (<model>_integrate_batch, the same C
code as `simulate`, so each trajectory agrees with `simulate` bit for bit), split into
`threads` contiguous blocks that run concurrently: ctypes releases the GIL for the
duration of a foreign call, so the blocks use every core.  Each trajectory keeps its
own step control (per-trajectory adaptive steps).

method="taylor" runs in SIMD lanes (<model>_taylor_lanes.c, derive/runtime/
taylor_lanes.py): within a block, the Taylor jet of several trajectories at once, each
lane with its own step, time and outputs, and each trajectory bit for bit what
`simulate(method="taylor")` gives (long double, which has no vector instructions, runs
the scalar integrator).

The other methods run one trajectory after another within a block (no SIMD lanes).
A time-dependent model (t in its forces, dissipation or pivot) runs the same way: its
generated integrators pass each stage's own time to the rhs.
The chart atlas ("spherical") and inputs given as a function u(t, y) are refused here: they
run through `simulate`.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import SimulationInputError
from .build import dtype_key
from .model_sizes import model_info
from ..codegen.contract import COUNTERS, DEFAULT_METHOD, RUN_METHODS, STATUS_NAMES, TOLERANCE_METHODS
from .simulate import (_atlas, _check_size, _dtype, _finite_array, check_parameter_values,
                       normalise_t, resolve_model, run_options)
from ..model import load_model
from .runner import runner_for
from . import constraints, specialised


@dataclass(repr=False)
class EnsembleResult:
    """B runs of derive.ensemble on one output grid: each row is the `derive.simulate` run
    of its initial state, bit for bit.

    A trajectory that stopped early is kept, not raised: its ``status`` says why and its
    rows after ``t_stop`` are NaN.

    Attributes
    ----------
    model, method, dtype : str
        What ran: the model, the method and the floating-point type.
    t : ndarray, shape (nt,)
        The output times, shared by every trajectory.
    y : ndarray, shape (B, nt, n)
        The states, coordinates then rates; NaN after a trajectory stopped.
    status : ndarray of int, shape (B,)
        Each trajectory's contract status, 0 for a run to its end
        (derive.codegen.contract.STATUS_TABLE lists them).
    t_stop : ndarray, shape (B,)
        The time each trajectory reached.
    nfev, njev, nsteps, naccepted, nrejected, nnewton : ndarray of int, shape (B,)
        Each trajectory's counters, as a SimulationResult's.
    threads : int
        How many blocks ran at once.
    rtol, step : float or None
        The tolerance or the fixed step the run used.
    ok : ndarray of bool, shape (B,)
        ``status == 0`` per trajectory.
    status_names : list of str
        The name of each trajectory's status (``"ok"`` or why it stopped).
    all_ok : bool
        Whether every trajectory ran to its end.

    See Also
    --------
    derive.ensemble : which returns it.
    derive.SimulationResult : one trajectory.

    Examples
    --------
    >>> import numpy as np, derive
    >>> runs = derive.ensemble("planar", np.array([[1.0, 0.5, 0, 0], [0.2, 0, 0, 0]]),
    ...                        [0.0, 1.0], {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81})
    >>> runs.y.shape, runs.all_ok
    ((2, 2, 4), True)
    """
    model: str
    method: str
    dtype: str
    t: np.ndarray              # (nt,)
    y: np.ndarray              # (B, nt, n); rows after a trajectory stopped are NaN
    status: np.ndarray         # (B,) contract status codes
    t_stop: np.ndarray         # (B,) time each trajectory reached
    nfev: np.ndarray           # (B,) and the other counters
    njev: np.ndarray
    nsteps: np.ndarray
    naccepted: np.ndarray
    nrejected: np.ndarray
    nnewton: np.ndarray
    threads: int
    rtol: float | None = None
    step: float | None = None
    # a closed loop: per trajectory, its largest constraint residuals (derive/runtime/constraints.py)
    constraint_drift: tuple | None = None

    @property
    def ok(self) -> np.ndarray:
        return self.status == 0

    @property
    def status_names(self) -> list[str]:
        return [STATUS_NAMES[s] for s in self.status]

    @property
    def all_ok(self) -> bool:
        return bool(np.all(self.status == 0))

    def __repr__(self) -> str:
        """One line: what ran, how many ended ok, the arrays by shape (not every value)."""
        knob = (f", rtol {self.rtol:.3g}" if self.rtol is not None else "") + \
            (f", step {self.step:.3g}" if self.step is not None else "")
        stopped = {name: self.status_names.count(name) for name in set(self.status_names) - {"ok"}}
        ends = f"{int(np.sum(self.ok))} of {len(self.status)} ok" + (f", stopped {stopped}" if stopped else "")
        span = f", t = {float(self.t[0]):.6g}..{float(self.t[-1]):.6g}" if len(self.t) else ""
        return (f"<EnsembleResult {self.model}: {self.method} {self.dtype}{knob}; {ends}; "
                f"y {tuple(np.shape(self.y))}{span}; threads {self.threads}>")


def _per_trajectory(value, B: int, names, what: str, model: str) -> np.ndarray:
    """(B, k) values from a (k,) vector for all, a (B, k) array, or a mapping of either."""
    if isinstance(value, dict):
        unknown = sorted(set(value) - set(names))
        if unknown:
            raise SimulationInputError(f"unknown {what[:-1]} '{unknown[0]}' for model '{model}' "
                                       f"({what}: {', '.join(names)})")
        missing = [n for n in names if n not in value]
        if missing:
            raise SimulationInputError(f"missing {what[:-1]} '{missing[0]}' for model '{model}' "
                                       f"({what}: {', '.join(names)})")
        columns = [np.broadcast_to(_finite_array(value[n], f"{what}['{n}']"), (B,)) for n in names]
        return np.stack(columns, axis=1)
    a = _finite_array(value, what)
    k = len(names)
    if a.shape == (k,):
        return np.broadcast_to(a, (B, k))
    if a.shape == (B, k):
        return a
    raise SimulationInputError(f"{what} must have shape ({k},) or ({B}, {k}) for model '{model}' "
                               f"({', '.join(names)}), got {a.shape}")


def ensemble(model, y0, t, params, method: str = DEFAULT_METHOD, rtol: float | None = None,
             atol: float | None = None, step: float | None = None, dtype="float64",
             threads: int | None = None, inputs=None, max_steps: int | None = None,
             hmax: float | None = None, newton_tol: float | None = None,
             newton_max: int | None = None, sine_min: float | None = None,
             specialise: bool = False) -> EnsembleResult:
    """Integrate B trajectories of `model` (y0 of shape (B, n)) to every output time in t.

    Each trajectory is bit for bit the same `derive.simulate` call; with method="taylor"
    the blocks run in SIMD lanes (docs/sweeps.md, "Ensembles").

    Parameters
    ----------
    model : str or path
        A catalogue name or the path of a model file (one chart: not the atlas).
    y0 : array_like, shape (B, n)
        The initial states, one row per trajectory.
    t : sequence
        The output times, shared by every trajectory.
    params, inputs : optional
        One vector for all or one row per trajectory, or a mapping by name of scalars or
        (B,) arrays.
    method, rtol, atol, step, dtype, max_steps, hmax, newton_tol, newton_max, sine_min : optional
        As for `derive.simulate`.
    threads : int, optional
        How many blocks run at once (None: one per core).
    specialise : bool, optional
        True: kernels with the parameters that are the same for every trajectory folded in
        as constants (derive.simulate's specialise=; a parameter that varies stays a
        run-time one); result.model names the specialised model.

    Returns
    -------
    EnsembleResult
        ``y`` of shape (B, len(t), n), ``status`` (B,) and per-trajectory counters.

    Raises
    ------
    SimulationInputError
        As derive.simulate's, and a y0 that is not (B, n), params or inputs of neither one
        vector nor B rows, the chart atlas (one chart only).
    BuildError
        The model's library cannot be compiled; CompilerMissingError, a BuildError, where
        there is no C compiler (the ensemble runs compiled C only).

    Examples
    --------
    >>> import numpy as np
    >>> import derive
    >>> y0 = np.array([[1.0, 0.5, 0.0, 0.0], [0.5, 1.0, 0.0, 0.0]])
    >>> params = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
    >>> ens = derive.ensemble("planar", y0, [0.0, 0.5, 1.0], params, rtol=1e-8, threads=1)
    >>> ens.y.shape, ens.status_names
    ((2, 3, 4), ['ok', 'ok'])
    >>> one = derive.simulate("planar", y0[1], [0.0, 0.5, 1.0], params, rtol=1e-8)
    >>> bool(np.array_equal(ens.y[1], one.y))            # bit for bit one derive.simulate call
    True
    """
    model = resolve_model(model, explicit_time=True)
    if _atlas(model) is not None:
        raise SimulationInputError("ensemble runs single-chart models; the chart atlas "
                                   f"'{model}' runs through derive.simulate")
    if not isinstance(method, str) or method not in RUN_METHODS:
        raise SimulationInputError(f"unknown method {method!r} (known: {', '.join(RUN_METHODS)})")
    info = model_info(model)
    description = load_model(model)
    dt = _dtype(dtype)
    ys = _finite_array(y0, "y0")
    if ys.ndim != 2 or ys.shape[1] != info.n:
        raise SimulationInputError(f"y0 must have shape (B, {info.n}) for model '{model}' "
                                   f"({', '.join(info.state_names)}), got {ys.shape}")
    B = ys.shape[0]
    p = _per_trajectory(params, B, info.param_names, "parameters", model)
    for row in np.unique(p, axis=0) if B else ():
        check_parameter_values(description, dict(zip(info.param_names, row)))
    if specialised.check_specialise(specialise) and B:
        specialised.refuse_unspecialisable("c", dtype_key(dt), False, "ensemble")
        model = specialised.folded_model(model, info.param_names, p[0], np.all(p == p[0], axis=0))
    if description.inputs:
        if inputs is None or callable(inputs):
            raise SimulationInputError(f"model '{model}' needs its inputs ({', '.join(description.inputs)}) "
                                       "as numbers (one vector or one row per trajectory)")
        p = np.concatenate([p, _per_trajectory(inputs, B, description.inputs, "inputs", model)], axis=1)
    elif inputs is not None:
        raise SimulationInputError(f"model '{model}' has no inputs; got inputs={inputs!r}")
    loop = description.is_constrained
    if loop:
        constraints.check_initial_states(model, ys, p)
    ts = normalise_t(t)
    opt = run_options(method, dt, ts, rtol=rtol, atol=atol, step=step, hmax=hmax, max_steps=max_steps,
                      newton_tol=newton_tol, newton_max=newton_max, sine_min=sine_min)
    _check_size(method, ts, np.zeros(info.n * max(B, 1)), opt, dt)
    if threads is None:
        threads = os.cpu_count() or 1
    if not isinstance(threads, (int, np.integer)) or threads < 1:
        raise SimulationInputError(f"threads = {threads!r} must be a positive integer")
    y, infos, used = _run_blocks(model, method, ys.astype(dt), p.astype(dt), ts.astype(dt), opt, int(threads))
    status = np.array([i.status for i in infos], np.intc)
    counters = {k: np.array([getattr(i, k) for i in infos], np.int64) for k in COUNTERS}
    drift = tuple(constraints.drift(model, rows, pb) for rows, pb in zip(y, p)) if loop else None
    return EnsembleResult(model=model, method=method, dtype=np.dtype(dt).name, t=ts.astype(dt), y=y,
                          status=status, t_stop=np.array([i.t for i in infos], float), threads=used,
                          rtol=opt["rtol"] if method in TOLERANCE_METHODS else None,
                          step=None if method in TOLERANCE_METHODS else opt["h"],
                          constraint_drift=drift, **counters)


def _run_blocks(model: str, method: str, y0: np.ndarray, p: np.ndarray, t: np.ndarray, opt: dict,
                threads: int):
    """The runner's batch call over `threads` contiguous blocks of trajectories at once."""
    r = runner_for(model, method, dtype_key(y0.dtype))
    return r.batch(y0, p, t, r.options(opt), threads)
