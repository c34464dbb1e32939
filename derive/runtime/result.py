"""The result of a run: plain data (derive/runtime/simulate.py and atlas.py fill it).

What a run means for trust (its largest Lyapunov exponent, its trust horizon) is
measured from a result by derive/measurement/trust.py: trust.lyapunov_exponent(r),
trust.trust_horizon_of(r, target), public as derive.trust_horizon(r, target).
"""
from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields
from html import escape

import numpy as np

from ..codegen.contract import STATUS_NAMES, STATUS
from ..errors import ModelError, SimulationError, ToolMissingError
from ..model import load_model
from ..model.description import in_words
from ..model.atlas import atlas_for, find_atlas
from .energy_error import exact_energy_error, relative_energy_error
from .model_sizes import model_info
from .power import energy_balance


def _short(x) -> str:
    """A time as a repr shows it: a few digits."""
    return f"{float(x):.6g}"


@dataclass(repr=False)
class SimulationResult:
    """One run of derive.simulate: the states at the output times, and how the run went.

    A run that stopped early is returned, not raised (``ok`` is False, ``status_name``
    says why); ``raise_for_status()`` raises it as a SimulationError.

    Attributes
    ----------
    model, method, backend, dtype : str
        What ran: the model (``"spherical"`` for the chart atlas), the method, ``"c"`` or
        ``"numpy"``, and the floating-point type.
    t : ndarray, shape (len(t),)
        The output times.
    y : ndarray, shape (len(t), n)
        The state at each output time, coordinates then rates (a spherical model's in the
        chart then in use; NaN after a stop).
    energy : ndarray, shape (len(t),)
        The total energy at each output time (computed on first access).
    positions, velocities : ndarray, shape (len(t), bobs, dim)
        The Cartesian positions and velocities of the bobs (computed on first access).
    status : int
        The integrator's status, 0 for a run to its end (derive/codegen/contract.py lists them).
    status_name : str
        Its name: ``"ok"``, or the name of the status that stopped the run (derive.codegen.contract.STATUS_TABLE).
    ok : bool
        ``status == 0``.
    message : str
        What happened, in one line (a stop names its time, its state and the way out).
    t_stop : float
        The time reached (where the run stopped, on a stop).
    y_stop : ndarray, shape (n,)
        The state there.
    nfev, njev : int
        The evaluations of the right-hand side and of its Jacobian.
    nsteps, naccepted, nrejected : int
        The steps tried, accepted and rejected (an adaptive method's step-size control).
    nnewton : int
        The Newton iterations of an implicit method (gauss2).
    chart : ndarray of str or None
        On the chart atlas: the chart's model at each output time.
    switches : int
        On the chart atlas: the number of chart switches.
    chart_stop : str or None
        The chart in use at t_stop (the chart atlas and spherical models).
    params : ndarray
        The parameters (then the inputs held constant) in the model's order.
    rtol, step, last_step : float or None
        The tolerance of an adaptive method; the fixed step h of a fixed-step method and the
        shortened step to the last output (None where that is on the grid).
    y_exact : ndarray of mpmath numbers or None
        dtype "double-double" or "quad": the states exactly (y is rounded to long double).
    sol : callable or None
        Adaptive methods: ``r.sol(t)``, the continuous solution (derive/runtime/dense.py).
    error_estimate : float or None
        The run's estimate of its own error; ``error_kind`` says which (see the Notes).
    error_kind : str or None
        ``"local sum"``, ``"rerun at rtol=..."`` or ``"rerun at step=..."``.
    error_y : ndarray, shape (len(t), n), or None
        ``error_estimate="rerun"``: the estimate per output row and state.
    events : dict of EventRecord or None
        ``simulate(..., events=...)``: per event, in the order given, its crossings (t, y,
        direction); ``t_events`` and ``y_events`` hold them as SciPy's solve_ivp does.
    terminal_event : str or None
        The event that stopped the run at t_stop (status ok).
    guard : tuple of float or None
        abm12: the (rtol, atol) of its stability guard.
    energy_error, energy_scale : float
        The largest relative energy error over the outputs, and what it is relative to.
    constraint_drift : ConstraintDrift or None
        A closed loop (a model with constraints): the largest ``|Phi|`` and ``|J q'|`` over the
        outputs (``.phi``, ``.phi_dot``), and the bound (``.bound``) above which the message
        reports them (``.exceeded``); None for an open chain (derive/runtime/constraints.py).

    Notes
    -----
    The two kinds of error_estimate (error_kind says which):

    "local sum" (the default, free: the run computes it as it steps): the sum over the
    accepted steps of each step's local-error estimate, in the state's units (the
    largest component's tolerance scale times the step's scaled error norm): the embedded
    pair's estimate for dopri5 and dop853 (that of the lower-order solution, so usually
    larger than the propagated solution's own), Milne's predictor-corrector estimate for
    abm12 (its rk8 start steps are not counted), for taylor the first term left out of
    the series, estimated from the last.  It is no global error: the global error is
    this sum only if the errors neither grow nor cancel (they grow like exp(lambda t) in
    a chaotic motion, derive.measurement.trust).  None for rk4, rk8, midpoint and gauss2,
    which have no estimate of their own.

    "rerun at rtol=..." or "rerun at step=..." (simulate(..., error_estimate="rerun")):
    the largest difference, over the output rows and states, between this run and a
    second, more accurate run (rtol and atol / 100; a fixed step halved, the difference
    Richardson-scaled by 1 / (1 - 2^-order)): an estimate of the global error of r.y
    itself, per row and state in error_y (NaN where either run has no value, or, on the
    atlas, the two runs are in different charts).  Where the error is roundoff (about
    1e-13 and below in double) the difference underestimates it: a smaller step or
    tolerance does not reduce roundoff.

    Examples
    --------
    >>> import derive
    >>> r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 0.5, 1.0],
    ...                     {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}, rtol=1e-8, backend="numpy")
    >>> r.ok, r.status_name, r.method, r.y.shape, r.positions.shape
    (True, 'ok', 'dop853', (3, 4), (3, 2, 2))
    >>> r.energy_error < 1e-8, r.error_kind
    (True, 'local sum')
    >>> print(r.message)
    ok: planar with dop853 to t = 1
    """
    model: str
    method: str
    backend: str
    dtype: str
    t: np.ndarray
    y: np.ndarray                  # (len(t), n); chart states for spherical models
    energy: np.ndarray             # (len(t),)
    positions: np.ndarray          # (len(t), bobs, dim): Cartesian bob positions
    status: int
    status_name: str
    t_stop: float                  # time reached (where it stopped on failure)
    y_stop: np.ndarray             # the state there (in the chart then in use)
    nfev: int
    njev: int
    nsteps: int
    naccepted: int
    nrejected: int
    nnewton: int
    chart: np.ndarray | None = None        # spherical: chart model name at each output time
    switches: int = 0                      # spherical atlas: number of chart switches
    chart_stop: str | None = None
    params: np.ndarray = field(default=None, repr=False)
    rtol: float | None = None              # adaptive methods: the tolerance used
    step: float | None = None              # fixed-step methods: the step of the grid t0 + k step
    last_step: float | None = None         # ... the shortened step to the last output (None: on the grid)
    velocities: np.ndarray | None = field(default=None, repr=False)   # like positions: bob velocities
    # dtype double-double or quad: y exactly, as mpmath numbers (y itself is rounded to long double)
    y_exact: np.ndarray | None = field(default=None, repr=False)
    # energy, positions and velocities may be given as LAZY with `observe`, a function of no
    # arguments returning all three: simulate does so, and the kernels run on first access
    # (a run that only reads r.y pays nothing for them)
    observe: object = field(default=None, repr=False, compare=False)
    # adaptive runs: r.sol(t), the continuous solution (derive/runtime/dense.py)
    sol: object | None = field(default=None, repr=False)
    error_estimate: float | None = None   # see the class docstring and error_kind
    error_kind: str | None = None          # "local sum", "rerun at rtol=...", "rerun at step=..."
    error_y: np.ndarray | None = field(default=None, repr=False)   # rerun: (len(t), n) per row and state
    # simulate(..., events=...): per event (in the order given) its crossings
    events: dict[str, "EventRecord"] | None = None
    terminal_event: str | None = None      # the event that stopped the run at t_stop (status ok)
    # abm12: (rtol, atol) of its stability guard (a step whose Milne estimate exceeds atol + rtol |y|
    # is not taken): a run it stopped names them in its message
    guard: tuple[float, float] | None = None
    # a closed loop's run: its largest constraint residuals over the outputs (ConstraintDrift)
    constraint_drift: object | None = None

    def __repr__(self) -> str:
        """One line: what ran, how it ended, the arrays by shape.  The dataclass's repr
        printed every array and computed the lazy energy and positions to print them."""
        span = f"t = {_short(self.t[0])}..{_short(self.t[-1])}" if len(self.t) else "no outputs"
        knob = (f", rtol {self.rtol:.3g}" if self.rtol is not None else "") + \
            (f", step {self.step:.3g}" if self.step is not None else "")
        extra = "".join(f", {name} {value}" for name, value in (
            ("error_estimate", None if self.error_estimate is None else f"{self.error_estimate:.3g}"),
            ("switches", self.switches or None), ("terminal_event", self.terminal_event),
            ("events", None if not self.events else {k: len(v) for k, v in self.events.items()}),
            ("constraint_drift", self.constraint_drift)) if value is not None)
        return (f"<SimulationResult {self.model}: {self.method} {self.backend} {self.dtype}{knob}; "
                f"{self.status_name}; {len(self.t)} outputs {span}, y {tuple(np.shape(self.y))}; "
                f"nfev {self.nfev}, nsteps {self.nsteps}{extra}>")

    @property
    def t_events(self) -> list[np.ndarray]:
        """As SciPy's solve_ivp: per event, in the order given, the times of its crossings."""
        return [e.t for e in (self.events or {}).values()]

    @property
    def y_events(self) -> list[np.ndarray]:
        """As SciPy's solve_ivp: per event, the states at its crossings (k, n)."""
        return [e.y for e in (self.events or {}).values()]

    @property
    def ok(self) -> bool:
        return self.status == 0

    @property
    def message(self) -> str:
        """What happened, in one line: a stop names its status, the state there and the
        way out (the guard to loosen, the chart atlas that runs through a chart's pole)."""
        if self.ok:
            return self.stop_description + self._drift_note()
        return self.stop_description + self._pole_note() + self._drift_note()

    def _drift_note(self) -> str:
        """A closed loop's drift off its constraints, where it exceeds the bound."""
        drift = self.constraint_drift
        if drift is None or not drift.exceeded:
            return ""
        return (f"; the constraint drift exceeds {drift.bound:g}: {drift} (tighten rtol, or a "
                f"smaller step)")

    @property
    def stop_description(self) -> str:
        """message without the way out of a pole, which derive.simulate's caller takes
        (atlas=True) and a scene names by its own key (pendulum.atlas)."""
        if self.ok and self.terminal_event:
            return (f"ok: {self.model} with {self.method} stopped by the terminal event "
                    f"'{self.terminal_event}' at t = {self.t_stop:.17g}")
        if self.ok:
            return f"ok: {self.model} with {self.method} to t = {self.t_stop:.17g}"
        names = _state_names(self.chart_stop or self.model)
        state = ", ".join(f"{n}={v:.6g}" for n, v in zip(names, self.y_stop))
        where = f" in chart {self.chart_stop}" if self.chart_stop else ""
        return (f"integration stopped at t = {self.t_stop:.17g}: {self.status_name}{where}; "
                f"state {state}{self._guard_note()}")

    def _guard_note(self) -> str:
        """Which guard stopped a multistep run, at which threshold, and how to loosen it."""
        if self.status_name != MULTISTEP_STOP or self.guard is None:
            return ""
        rtol, atol = self.guard
        return (f"; the guard: Milne's error estimate above atol + rtol |y| (rtol {rtol:.3g}, "
                f"atol {atol:.3g}): loosen rtol (and atol), or take a smaller step")

    def _pole_note(self) -> str:
        """The way out of a one-chart run's stop at its chart's pole: the chain's atlas."""
        if self.status_name != CHART_SINGULAR or find_atlas(self.model) is not None:
            return ""
        try:
            atlas_for(self.model)
        except ModelError as exc:
            return (f"; the motion meets a pole of {self.model}'s chart ({exc}): write its links in a "
                    f"chart whose poles the motion avoids, e.g. chart = \"second\"")
        return (f"; the motion meets a pole of {self.model}'s chart: simulate(..., atlas=True) runs it "
                f"on the chain's chart atlas, which switches charts there")

    @property
    def energy_error(self) -> float:
        """The largest relative energy error ``max |E(t) - E0| / energy_scale`` over the run's
        outputs (NaN where none is finite); above long double from its exact states
        (derive/runtime/energy_error.py).  With applied forces or damping it is the work
        they did, not an error."""
        return self._energy_error()[0]

    @property
    def energy_scale(self) -> float:
        """What energy_error is relative to: ``max(|E0|, W)``, ``W = |g| sum_k m_k d_k`` the
        depth of the potential well (derive/model/energy_scale.py): it cannot vanish, as
        ``|E0|`` can for a motion like any other."""
        return self._energy_error()[1]

    def _energy_error(self) -> tuple[float, float]:
        if "_energy_error_of" not in self.__dict__:
            self.__dict__["_energy_error_of"] = (
                exact_energy_error(self) if self.y_exact is not None else
                relative_energy_error(self.energy, self.model, np.asarray(self.params, np.float64)))
        return self.__dict__["_energy_error_of"]

    def raise_for_status(self) -> "SimulationResult":
        """The run itself if it reached its end; a SimulationError naming the stop if not.

        Returns
        -------
        SimulationResult
            self, so that ``r = derive.simulate(...).raise_for_status()`` reads as one call.

        Raises
        ------
        SimulationError
            The run stopped before its end; the message is ``r.message``.

        Examples
        --------
        >>> import derive
        >>> r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], [1, 1, 1, 1, 9.81],
        ...                     backend="numpy").raise_for_status()
        >>> r.ok
        True
        """
        if not self.ok:
            raise SimulationError(self.message)
        return self

    def _repr_html_(self) -> str:
        """A short table of the run (Jupyter shows it for a result)."""
        return summary_html(self)

    def to_xarray(self):
        """The run as an xarray Dataset (xarray is in the `sweep` extra).

        Returns
        -------
        xarray.Dataset
            A dimension `t` (the output times) and one variable per state component, named
            as the model's state (theta1, theta1_dot, ...; on the chart atlas, with a `chart`
            variable naming the chart of each row, the chart's state names if the run stayed
            in one chart, else y0, y1, ...), and the energy; the
            attrs hold the model, method, dtype, status and the parameters by name.

        Raises
        ------
        ToolMissingError
            xarray is not installed.

        Examples
        --------
        >>> import derive
        >>> r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 0.5, 1.0],
        ...                     {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}, backend="numpy")
        >>> ds = r.to_xarray()
        >>> list(ds.data_vars)[:2], ds.sizes["t"], ds.attrs["method"]
        (['theta1', 'theta2'], 3, 'dop853')
        """
        return to_dataset(self)


MULTISTEP_STOP = STATUS_NAMES[STATUS["MULTISTEP_UNSTABLE"]]    # abm12's guard stopped the run
CHART_SINGULAR = STATUS_NAMES[STATUS["CHART_SINGULAR"]]         # a chart's pole stopped the run
LAZY = object()                # energy/positions/velocities not computed yet (see `observe`)
LOCAL_SUM = "local sum"        # error_kind of a run's own sum of local-error estimates
_OBSERVED = ("energy", "positions", "velocities")


def _observed(name: str) -> property:
    slot = "_" + name

    def get(self):
        value = self.__dict__.get(slot)
        if value is LAZY:
            self.__dict__.update(zip((f"_{n}" for n in _OBSERVED), self.observe()))
            value = self.__dict__[slot]
        return value

    def set_(self, value):
        self.__dict__[slot] = value

    return property(get, set_, doc=f"the run's {name} at every output time")


for _name in _OBSERVED:          # after @dataclass: its __init__ assigns through the property
    setattr(SimulationResult, _name, _observed(_name))


class LazySolution:
    """A result's continuous solution made on first access of r.sol: `make(result)` builds
    it (simulate's compiled call path: most runs never ask for it, and building it costs
    more than the run of a short span)."""
    __slots__ = ("make",)

    def __init__(self, make):
        self.make = make


def _solution_get(self):
    value = self.__dict__.get("_sol")
    if type(value) is LazySolution:
        value = self.__dict__["_sol"] = value.make(self)
    return value


def _solution_set(self, value):
    self.__dict__["_sol"] = value


SimulationResult.sol = property(_solution_get, _solution_set,
                                doc="adaptive methods: r.sol(t), the continuous solution (derive/runtime/dense.py)")


def result_factory(**constant):
    """A maker of results sharing the `constant` fields (one plan's model, method, dtype,
    ...): the dataclass __init__ runs once, here, and each result starts as a copy of that
    prototype's fields with the rest given by name: under a microsecond, where __init__'s
    thirty assignments (three through the observables' properties) take about four."""
    required = {f.name: None for f in fields(SimulationResult)
                if f.default is MISSING and f.default_factory is MISSING}
    prototype = SimulationResult(**{**required, **constant}).__dict__
    new = object.__new__

    def make(**varying) -> SimulationResult:
        result = new(SimulationResult)
        state = result.__dict__
        state.update(prototype)
        state.update(varying)
        return result
    make.prototype = prototype        # the compiled call path starts its results from it too
    return make


def as_fields(result: SimulationResult) -> dict:
    """The fields of a result by name (observables computed), to build another from it."""
    return {f.name: getattr(result, f.name) for f in fields(result) if f.name != "observe"}
@dataclass
class EventRecord:
    """The crossings of one event of a run: when, in which state, which way."""
    name: str
    expression: str
    t: np.ndarray                  # (k,) times, in the run's order
    y: np.ndarray                  # (k, n) states there
    direction: np.ndarray          # (k,) +1 rising through zero, -1 falling

    def __len__(self) -> int:
        return len(self.t)


def _state_names(model: str) -> tuple[str, ...]:
    return model_info(model).state_names


XARRAY_MISSING = "SimulationResult.to_xarray needs xarray, in the sweep extra: pip install 'derive[sweep]'"


def _row_model(result: SimulationResult) -> str:
    """The model whose state a row of r.y is: the model, or on the atlas its first chart."""
    return result.model if result.chart is None else str(result.chart[0])


def _parameters(result: SimulationResult) -> dict[str, float]:
    names = model_info(_row_model(result)).param_names
    return {n: float(v) for n, v in zip(names, np.asarray(result.params, np.float64).ravel())}


def to_dataset(result: SimulationResult):
    """The run as an xarray Dataset: see SimulationResult.to_xarray.

    Parameters
    ----------
    result : SimulationResult
        A run.

    Returns
    -------
    xarray.Dataset
        As SimulationResult.to_xarray.

    Raises
    ------
    ToolMissingError
        xarray is not installed.

    Examples
    --------
    >>> import derive
    >>> r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], [1, 1, 1, 1, 9.81], backend="numpy")
    >>> to_dataset(r).attrs["params"]
    'm1=1, m2=1, l1=1, l2=1, g=9.8100000000000005'
    """
    try:
        import xarray
    except ImportError:
        raise ToolMissingError(XARRAY_MISSING) from None
    # an atlas run that switched charts holds states of several charts: named by position
    names = (_state_names(_row_model(result)) if not result.switches else
             tuple(f"y{i}" for i in range(result.y.shape[1])))
    data = {n: ("t", np.asarray(result.y[:, i])) for i, n in enumerate(names)}
    data["energy"] = ("t", np.asarray(result.energy))
    if result.chart is not None:
        data["chart"] = ("t", np.asarray(result.chart, dtype=str))
    attrs = {"model": result.model, "method": result.method, "dtype": result.dtype,
             "backend": result.backend, "status": result.status_name, "ok": int(result.ok),
             "t_stop": float(result.t_stop), "nsteps": int(result.nsteps),
             "params": ", ".join(f"{k}={v:.17g}" for k, v in _parameters(result).items()),
             **{f"param_{k}": v for k, v in _parameters(result).items()}}
    for key in ("rtol", "step", "error_estimate", "error_kind"):
        if getattr(result, key) is not None:
            attrs[key] = getattr(result, key)
    return xarray.Dataset(data, coords={"t": np.asarray(result.t)}, attrs=attrs)


def summary_rows(result: SimulationResult) -> list[tuple[str, str]]:
    """(label, value) of what a glance at a run needs: the rows of its HTML summary.

    Parameters
    ----------
    result : SimulationResult
        A run.

    Returns
    -------
    list of (str, str)
        The model, method (with its tolerance or step), dtype, backend, status (the
        message of a failed run), steps, final time, error estimate where the run has
        one, energy error, and the trust horizons measured so far.

    Examples
    --------
    >>> import derive
    >>> r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], [1, 1, 1, 1, 9.81], backend="numpy")
    >>> dict(summary_rows(r))["final time"], dict(summary_rows(r))["status"]
    ('1', 'ok')
    """
    tol = (f"rtol {result.rtol:.3g}" if result.rtol is not None else
           f"step {result.step:.6g}" if result.step is not None else "")
    rows = [("model", result.model), ("method", " ".join(filter(None, [result.method, tol]))),
            ("dtype", result.dtype), ("backend", result.backend),
            ("status", result.status_name if result.ok else result.message),
            ("steps", f"{result.nsteps} ({result.naccepted} accepted, {result.nrejected} rejected)"),
            ("final time", f"{result.t_stop:.17g}")]
    if result.error_estimate is not None:
        rows.append(("error estimate", f"{result.error_estimate:.3g} ({result.error_kind})"))
    rows.append(_energy_row(result))
    if result.constraint_drift is not None:
        rows.append(("constraint drift", f"{result.constraint_drift} (bound {result.constraint_drift.bound:g})"))
    horizons = result.__dict__.get("_trust_horizons", {})
    rows.append(("trust horizon", "; ".join(f"t = {h:.6g} to {target:.0e}" if h is not None else
                                            f"none to {target:.0e}" for target, h in sorted(horizons.items()))
                 or "not measured: derive.trust_horizon(result, target)"))
    return rows


def _energy_row(result: SimulationResult) -> tuple[str, str]:
    """A conservative model's energy change is the run's error; a driven or damped one's is
    mostly the work of what drives or damps it (Model.work_done_by), which a table must not
    call an error."""
    try:
        description = None if find_atlas(result.model) is not None else load_model(result.model)
    except ModelError:
        description = None
    if description is None or description.is_conservative:
        return "energy error", f"{result.energy_error:.3g} (relative)"
    if description.is_time_dependent and not description.inputs:
        return _balance_row(result)
    return "energy change", (f"{result.energy_error:.3g} (relative; the work of "
                             f"{in_words(description.work_done_by)}, not an error)")


def _balance_row(result: SimulationResult) -> tuple[str, str]:
    """A time-dependent model's E changes by the work of its drives (the moving pivot,
    forces in t): what the balance E - E0 = W - D + M leaves is the run's energy error."""
    balance = energy_balance(result)
    worst = float(np.nanmax(balance.residual, initial=0.0)) / float(result.energy_scale)
    return ("energy balance", f"{worst:.3g} (relative: |E - E0 - (W - D + M)|, W the work of the forces, "
                              f"D dissipated, M the prescribed motion's work)")


def summary_html(result: SimulationResult) -> str:
    """The summary rows (`summary_rows`) as an HTML table.

    Parameters
    ----------
    result : SimulationResult
        A run.

    Returns
    -------
    str
        One <table>, every value HTML-escaped.

    Examples
    --------
    >>> import derive
    >>> r = derive.simulate("planar", [1.0, 0.5, 0, 0], [0.0, 1.0], [1, 1, 1, 1, 9.81], backend="numpy")
    >>> summary_html(r).startswith("<table>") and "<td style='text-align:left'>planar</td>" in summary_html(r)
    True
    """
    body = "".join(f"<tr><th style='text-align:left'>{escape(k)}</th><td style='text-align:left'>"
                   f"{escape(v)}</td></tr>" for k, v in summary_rows(result))
    return f"<table><caption>derive.SimulationResult</caption>{body}</table>"
