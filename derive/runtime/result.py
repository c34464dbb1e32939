"""The result of a run: plain data (derive/runtime/simulate.py and atlas.py fill it).

What a run means for trust (its largest Lyapunov exponent, its trust horizon) is
measured from a result by derive/measurement/trust.py: trust.lyapunov_exponent(r),
trust.trust_horizon_of(r, target), public as derive.trust_horizon(r, target).
"""
from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields

import numpy as np

from ..codegen.contract import STATUS_NAMES, STATUS
from ..errors import ModelError, SimulationError
from ..model.atlas import atlas_for, find_atlas
from .energy_error import exact_energy_error, relative_energy_error
from .model_sizes import model_info


@dataclass
class SimulationResult:
    """One run of derive.simulate.

    error_estimate, error_kind: the run's estimate of its own error, and what it is.
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
            return self.stop_description
        return self.stop_description + self._pole_note()

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
        """The largest relative energy error max |E(t) - E0| / energy_scale over the run's
        outputs (NaN where none is finite); above long double from its exact states
        (derive/runtime/energy_error.py).  With applied forces or damping it is the work
        they did, not an error."""
        return self._energy_error()[0]

    @property
    def energy_scale(self) -> float:
        """What energy_error is relative to: max(|E0|, W), W = |g| sum_k m_k d_k the depth
        of the potential well (derive/model/energy_scale.py): it cannot vanish, as |E0|
        can for a motion like any other."""
        return self._energy_error()[1]

    def _energy_error(self) -> tuple[float, float]:
        if "_energy_error_of" not in self.__dict__:
            self.__dict__["_energy_error_of"] = (
                exact_energy_error(self) if self.y_exact is not None else
                relative_energy_error(self.energy, self.model, np.asarray(self.params, np.float64)))
        return self.__dict__["_energy_error_of"]

    def raise_for_status(self) -> "SimulationResult":
        if not self.ok:
            raise SimulationError(self.message)
        return self


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
