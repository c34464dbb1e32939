"""`derive run SCENE`: plan, prepare, integrate to the accuracy asked, write outputs.

Choosing the method for an accuracy target (the final-state error):
1. the largest Lyapunov exponent lambda of the scene's motion (trust.py) says
   how much an early error grows by the end: G = exp(lambda T);
2. DOP853 with rtol = target / (SAFETY G), in double while that tolerance is
   at least 10 eps of double, else in long double; past long double the plan
   climbs the precision ladder to Taylor's method in double-double and says so
   (quad, about 15 times the cost, where the scene asks for it: scalar = "quad"; a
   `target` beyond what the precision can deliver is reported as out of reach, not
   pretended);
3. a reference run a thousand times tighter measures the achieved error, and
   the trust horizon says until when the run resolves the true motion.

A scene that fixes its method (and no target) is judged by the same reference run
(for a fixed step: DOP853 far tighter than the step's local error h^order): its
error is measured and printed, a run past its trust horizon says so, and a result
that means nothing (a conservative model's relative energy error above 1, a
non-finite state) is no "ok" (verdict()).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from ..codegen.contract import (ADAPTIVE, CONSTRAINT_START_TOLERANCE, DEFAULT_METHOD, EXTENDED, FIXED_ORDER, LADDER, MULTISTEP,
                                PRECISION as LADDER_TABLE, PRECISION_NAMES, PRECISION_TABLE,
                                REFERENCE_METHOD, STATUS, STATUS_NAMES, TAYLOR)
from ..errors import ModelError
from ..runtime.energy_error import SCALE_TEXT, relative_energy_error
from ..runtime import constraints
from ..runtime.loop_state import consistent_state
from ..runtime.result import as_fields
from ..runtime.simulate import SimulationError, SimulationResult, normalise_params, simulate
from ..runtime.specialised import folded_model
from ..measurement.trust import (Lyapunov, REFERENCE_RTOL, atlas_lyapunov, initial_error,
                                 largest_lyapunov, trust_horizon, unit_roundoff)
from ..model.atlas import Atlas, atlas_for, find_atlas, standard_member
from .artifacts import Step, prepare
from .plan import Plan, plan, planar_positions_in_3d
from ..progress import Progress, Stage
from .scene import Scene, SceneError
from ..runtime.model_sizes import model_info
from ..runtime.events import locate, parse_events
from ..model import load_model
from ..runtime.loader import load, numpy_module
from ..runtime.observables import call_kernel
from ..runtime.stage_solution import StageSolution, locate_on_steps
from . import stepped

SAFETY = 10.0
RTOL_MAX = 1e-3            # a looser target is met at this tolerance: DOP853 is not run looser
# The precision ladder is the contract's table: each rung's floor for a run, the tightest
# tolerance a reference run may use in it (10 eps of simulate, with margin; long double's
# is the platform's), its name in reports.
FLOAT_RTOL_MIN = LADDER_TABLE["float32"].rtol_floor
REFERENCE_RTOL_MIN = {p.key: p.reference_floor or 20 * float(np.finfo(np.dtype(p.key)).eps)
                      for p in PRECISION_TABLE}
PRECISION = {p.key: p.title for p in PRECISION_TABLE}
# The rungs the planner climbs on its own, lowest first: quad (software binary128) costs about
# 15 times double-double, so a scene asks for it (scalar = "quad").
CLIMB = ("float64", "longdouble", "double-double")
EXIT_TARGET_MISSED = 3     # `derive run`: the run finished, but its accuracy target was not met
EXIT_FAILED = 1            # `derive run`: the run stopped, or its result means nothing
HORIZON_ERROR = 1e-8       # the error a trust horizon is for, where the scene sets no target
CHUNKS = 20          # the integration runs in this many pieces, for the progress bar


@dataclass
class Choice:
    method: str
    rtol: float | None
    atol: float | None
    step: float | None
    dtype: str
    predicted: float | None        # predicted final-state error
    note: str = ""
    guard: tuple | None = None     # abm12: (rtol, atol) of its stability guard (None: simulate's)


@dataclass
class Outcome:
    scene: Scene
    plan: Plan
    steps: list[Step]
    choice: Choice
    lyapunov: Lyapunov | None
    trust_horizon: float | None
    result: SimulationResult
    positions: np.ndarray
    energy: np.ndarray
    achieved: float | None
    seconds: float
    files: list[str] = field(default_factory=list)
    file_notes: dict[str, str] = field(default_factory=dict)   # file -> what writing it took
    velocities: np.ndarray | None = None     # like positions
    show_progress: bool = False          # whether writing the outputs may draw a status line
    early_error: float | None = None     # the error the run commits early on (its trust horizon's e0)
    unmeasured: str = ""                 # why the achieved error was not measured ("" if it was)
    energy_error: tuple | None = None    # (relative energy error, scale), once computed (energy_error())


def _lyapunov(p: Plan, scene: Scene) -> Lyapunov | None:
    """None when the motion cannot be followed (e.g. a single chart meets its
    singularity): the scene's own run then reports why.  None for a stepped scene (the
    estimate runs the generated integrators, which do not pass t)."""
    if stepped.is_stepped(scene):
        return None
    try:
        if find_atlas(p.model) is not None:
            return atlas_lyapunov(p.y0, p.params, scene.t_stop - scene.t_start, atlas=p.model,
                                  backend=scene.backend)
        return largest_lyapunov(p.model, p.y0, p.params, scene.t_stop - scene.t_start,
                                inputs=scene.inputs, backend=scene.backend)
    except SimulationError:
        return None


def choose(scene: Scene, lyap: Lyapunov | None) -> Choice:
    if stepped.is_stepped(scene):
        return _stepped_choice(scene)
    if scene.method is not None:
        return Choice(scene.method, scene.rtol, None if scene.scalar in EXTENDED else scene.atol, scene.step,
                      _dtype_of(scene.scalar), None, "as the scene asks", guard=scene.guard)
    growth = lyap.error_growth(scene.t_stop - scene.t_start) if lyap else 1.0
    needed = min(scene.target / (SAFETY * growth), RTOL_MAX)
    method, dtype, rtol, note = climb(needed, scene.target)
    if scene.scalar == "long double" and dtype in ("float64", "longdouble"):
        dtype = "longdouble"
    elif scene.scalar in EXTENDED:          # the rung the scene asks for, whatever climb would pick
        method, dtype = TAYLOR, scene.scalar
        rtol = max(needed, _run_floor(dtype))
        note = (f"target {scene.target:g} needs rtol {needed:.2g}, beyond {PRECISION[dtype]}: run at its "
                f"floor rtol {rtol:g}, which reports what it achieves" if rtol > needed else "")
    elif scene.scalar == "float":            # the lowest precision: float where it can, else climb
        if rtol >= FLOAT_RTOL_MIN:
            method, dtype = DEFAULT_METHOD, "float32"
        else:
            why = (f"target {scene.target:g} needs rtol {rtol:.2g}, beyond float: climbed the precision "
                   f"ladder to {PRECISION.get(dtype, dtype)}")
            note = note or why               # (climb's note, beyond long double, says it all)
    atol = None if dtype in EXTENDED else rtol
    return Choice(method, rtol, atol, None, dtype, rtol * growth, note)


def _stepped_choice(scene: Scene) -> Choice:
    """A stepped scene's run (stepped.py): its own method, else dop853 at the target / SAFETY
    (no Lyapunov estimate to scale it by), in float64."""
    if scene.method is not None:
        return Choice(scene.method, scene.rtol, scene.atol, scene.step, "float64", None, "as the scene asks")
    rtol = min(max(scene.target / SAFETY, stepped.RTOL_MIN), RTOL_MAX)
    return Choice(stepped.METHOD, rtol, rtol, None, "float64", None,
                  "each stage at its own time t (explicit time or inputs in t): dop853 in float64, "
                  "no Lyapunov estimate")


def _dtype_of(scalar: str) -> str:
    return PRECISION_NAMES.get(scalar, scalar)


def _run_floor(key: str) -> float:
    """The tightest rtol the planner gives a run on a rung at the top of its ladder: 100
    times the rung's floor, so that its reference run stays tighter than the run."""
    return 100 * LADDER_TABLE[key].rtol_floor


def _not_below(scene: Scene, climbed: tuple, wanted: float) -> tuple[str, str, float]:
    """(method, dtype, rtol) of a rerun at tolerance `wanted`: climb's choice, kept on the
    rung the scene asks for (accuracy.scalar) where climb picks a lower one (a scene that
    asks for quad runs in quad, at the tolerance wanted down to its floor)."""
    method, dtype, rtol = climbed
    asked = _dtype_of(scene.scalar)
    if asked in LADDER and LADDER.index(dtype) < LADDER.index(asked) and asked != "float32":
        if asked in EXTENDED:
            return TAYLOR, asked, max(wanted, _run_floor(asked))
        return method, asked, rtol
    return method, dtype, rtol


def local_tolerance(c: Choice) -> float:
    """What a run's tolerance is for its early error (as derive.trust_horizon takes it).

    Parameters
    ----------
    c : Choice

    Returns
    -------
    float
        rtol; for a fixed step h^order; 0 where neither is known.
    """
    if c.rtol is not None:
        return c.rtol
    return c.step ** FIXED_ORDER[c.method] if c.step is not None and c.method in FIXED_ORDER else 0.0


def _rung_method(key: str) -> str:
    return TAYLOR if LADDER_TABLE[key].taylor_only else DEFAULT_METHOD


def climb(rtol: float, target: float | None) -> tuple[str, str, float, str]:
    """(method, dtype, rtol, note) for a tolerance: the lowest rung of CLIMB whose floor
    takes it (DOP853 in the hardware types, Taylor's method above them), the note saying
    why a run climbed past the hardware types.  The top rung's floor for a run is 100 times
    its tightest, so that the reference there stays tighter than the run; a tolerance
    below it runs at that floor and reports what it achieves."""
    top = CLIMB[-1]
    hardware = [k for k in CLIMB if not LADDER_TABLE[k].taylor_only]
    why = f"target {target:g} needs rtol {rtol:.2g}, beyond {LADDER_TABLE[hardware[-1]].title}"
    for key in CLIMB:
        floor = _run_floor(key) if key == top else LADDER_TABLE[key].rtol_floor
        if rtol >= floor:
            climbed = LADDER_TABLE[key].taylor_only
            note = f"{why}: climbed the precision ladder to {LADDER_TABLE[key].title} (Taylor)" if climbed else ""
            return _rung_method(key), key, rtol, note
    name = LADDER_TABLE[top].title
    return _rung_method(top), top, floor, (
        f"{why} and {name}: climbed the precision ladder to {name} (Taylor) at rtol "
        f"{floor:g}, which reports what it achieves (scalar = \"quad\" goes further)")


# steps ~ rtol^(-1/order); Taylor's order grows with the digits, so its steps a unit of
# time hardly change with rtol (taken as the DOP853 rate measured at REFERENCE_RTOL)
ORDER = {"dop853": 8, "dopri5": 5, "taylor": 1000}


MAX_SCENE_STEPS = 1e7     # the run and its reference together: about a minute of DOP853 on a two-link model


def check_effort(scene: Scene, lyap: Lyapunov | None, c: Choice) -> None:
    """Refuse, with the figure, a scene whose adaptive run and reference run would take more
    than MAX_SCENE_STEPS steps: the steps a unit of time measured for the Lyapunov estimate,
    scaled to each run's tolerance (steps ~ rtol^(-1/order)), times the span.  (A fixed step
    is checked by simulate itself.)"""
    span = scene.t_stop - scene.t_start
    if c.step is not None:
        if not c.step <= span:
            raise SceneError(f"'accuracy.step' = {c.step:g} is longer than the span t = {scene.t_start:g} "
                             f"to {scene.t_stop:g}: give a step of at most {span:g}")
        if span / c.step > MAX_SCENE_STEPS * 1000:      # simulate's limit (MAX_FIXED_STEPS)
            raise SceneError(f"step = {c.step:g} over t = {scene.t_start:g} to {scene.t_stop:g} means "
                             f"{span / c.step:.3g} steps (limit {MAX_SCENE_STEPS * 1000:.0e}): refused "
                             f"before any work")
        return
    if lyap is None or not lyap.steps_per_time or c.method not in ORDER or c.rtol is None:
        return
    if c.rtol < 10 * unit_roundoff(c.dtype):
        return                      # simulate refuses it, naming the tolerance

    def rate(rtol: float) -> float:
        return lyap.steps_per_time * max(1.0, (REFERENCE_RTOL / rtol) ** (1 / ORDER[c.method]))
    steps = (rate(c.rtol) + rate(reference_rtol(c)[0])) * span
    if steps > MAX_SCENE_STEPS:
        raise SceneError(f"t = {scene.t_start:g} to {scene.t_stop:g} needs about {steps:.2g} {c.method} "
                         f"steps with its reference run ({rate(c.rtol):.3g} a unit of time at rtol "
                         f"{c.rtol:.2g}, measured over the first {lyap.t_end:g}): more than "
                         f"{MAX_SCENE_STEPS:.0e}; give a shorter span or a looser target")


def integrate(p: Plan, scene: Scene, c: Choice, progress: Progress | None,
              tighten: float = 1.0, dtype: str | None = None, specialise: bool = False) -> SimulationResult:
    """The scene's run in CHUNKS pieces (fixed, so results do not depend on the display);
    a fixed-step run in one piece: its grid t0 + k step must not restart at a piece's start.
    `specialise`: on kernels with the parameters folded in (specialised_model), on the rungs
    that have them (not double-double or quad, which read p at run time)."""
    t = np.linspace(scene.t_start, scene.t_stop, scene.outputs)
    # a stepped run in one piece too: its continuous solution is its own steps
    pieces = 1 if (c.step is not None and c.method not in ADAPTIVE) or stepped.is_stepped(scene) else \
        min(CHUNKS, len(t) - 1)
    bounds = np.linspace(0, len(t) - 1, pieces + 1).astype(int)
    y0, parts = p.y0, []
    for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        # abm12's rtol and atol are its guard's (its step is the step; it runs untightened)
        rtol, atol = c.guard if c.guard is not None and c.method in MULTISTEP else (c.rtol, c.atol)
        r = simulate(p.model, y0, t[a:b + 1], p.params, method=c.method,
                     rtol=None if rtol is None else rtol / tighten,
                     atol=None if atol is None or (dtype or c.dtype) in EXTENDED else atol / tighten,
                     step=None if c.step is None else c.step / tighten,
                     dtype=dtype or c.dtype, backend=scene.backend, inputs=stepped.run_inputs(scene),
                     specialise=specialise and (dtype or c.dtype) not in EXTENDED)
        parts.append(r)
        if progress:
            progress.update(k + 1)
        if not r.ok:
            break
        last = r.y[-1] if r.y_exact is None else list(r.y_exact[-1])    # the ladder's rungs restart exactly
        last = _on_the_loop(p, last)
        y0 = last if find_atlas(p.model) is None else {"chart": r.chart[-1], "state": list(r.y[-1])}
    return _join(parts)


def specialised_model(p: Plan, scene: Scene) -> str | None:
    """The model a scene with pendulum.specialise = true runs: the planned model with the
    plan's parameters folded into its kernels (derive/runtime/specialised.py); None without
    the key, or on the chart atlas (a scene whose chart meets its pole runs again there,
    with p at run time).  Only the scene's own run takes it: the reference it is measured
    against runs the general kernels, so the measured error includes what folding changed."""
    if not scene.specialise or find_atlas(p.model) is not None:
        return None
    return folded_model(p.model, model_info(p.model).param_names, normalise_params(p.model, p.params))


def _on_the_loop(p: Plan, y):
    """A closed loop's next piece starts on its constraints: a piece's last state, drifted
    off them beyond the start tolerance simulate holds every start to, is projected back
    (derive.consistent_state); within it, and for an open chain, it is kept as it is."""
    if not constraints.is_constrained(p.model):
        return y
    phi, phi_dot = constraints.residuals(p.model, np.asarray(y, dtype=float), normalise_params(p.model, p.params))
    if max(np.abs(phi).max(), np.abs(phi_dot).max()) <= CONSTRAINT_START_TOLERANCE:
        return y
    return consistent_state(p.model, np.asarray(y, dtype=float), p.params)


def _join(parts: list[SimulationResult]) -> SimulationResult:
    first, last = parts[0], parts[-1]
    cat = lambda attr: np.concatenate([getattr(parts[0], attr)] + [getattr(r, attr)[1:] for r in parts[1:]])
    out = SimulationResult(**{**as_fields(first), "t": cat("t"), "y": cat("y"), "energy": cat("energy"),
                              "positions": cat("positions"), "velocities": cat("velocities"),
                              "y_exact": None if first.y_exact is None else cat("y_exact")})
    for attr in ("status", "status_name", "t_stop", "y_stop", "chart_stop"):
        setattr(out, attr, getattr(last, attr))
    if first.constraint_drift is not None:        # a closed loop: the largest over the pieces
        out.constraint_drift = constraints.ConstraintDrift(max(r.constraint_drift.phi for r in parts),
                                                           max(r.constraint_drift.phi_dot for r in parts))
    for attr in ("nfev", "njev", "nsteps", "naccepted", "nrejected", "nnewton", "switches"):
        setattr(out, attr, sum(getattr(r, attr) for r in parts))
    if first.chart is not None:
        out.chart = cat("chart")
        # a piece that starts in another chart than the last one ended in (the rule picks
        # the chart of a start): a switch too
        out.switches += sum(r.chart[0] != prev.chart[-1] for prev, r in zip(parts, parts[1:]))
    if isinstance(first.sol, StageSolution):  # a stepped run, in one piece: its own steps
        out.sol = first.sol
    elif first.sol is not None:               # the dense output over the joined rows
        inputs = None if first.sol.inputs is None else \
            np.concatenate([first.sol.inputs] + [r.sol.inputs[1:] for r in parts[1:]])
        out.sol = first.sol.rows_of(out.t, out.y, inputs, last.sol.t_end)
    return out


def _events(p: Plan, scene: Scene, c: Choice, result: SimulationResult) -> SimulationResult:
    """The scene's [events] on the run's dense output (after its accuracy was measured:
    a terminal event then truncates the outputs)."""
    if not scene.events or result.sol is None:
        return result
    events = parse_events(model_info(p.model), scene.events)
    if isinstance(result.sol, StageSolution):       # a stepped run: on its own steps
        return locate_on_steps(result, events, c.rtol)
    return locate(result, events, c.rtol)


def _observables(scene: Scene, p: Plan, r: SimulationResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities and energy of the scene's own pendulum (not of the model that ran)."""
    if p.plane is not None:
        return (planar_positions_in_3d(r.positions, p.plane),
                planar_positions_in_3d(r.velocities, p.plane), r.energy)
    if p.model != scene.model and find_atlas(scene.model) is None:
        # a reduction with the same coordinates: the scene's own kernels on the run's states
        own = normalise_params(scene.model, scene.parameters).astype(np.float64)
        m = load(scene.model) if scene.backend == "c" else numpy_module(scene.model)   # no compiler needed
        y, t = r.y.astype(np.float64), np.asarray(r.t, np.float64)
        return tuple(call_kernel(k, t, y, own) for k in (m.positions, m.velocities, m.energy))
    return r.positions, r.velocities, r.energy


def _final_error(run_: SimulationResult, reference: SimulationResult) -> float:
    """Largest difference of the final states; for the atlas, of the final bob
    positions (the two runs may end in different charts)."""
    if run_.y_exact is not None and reference.y_exact is not None:      # beyond long double
        return float(max(abs(x - y) for x, y in zip(run_.y_exact[-1], reference.y_exact[-1])))
    a, b = (run_.positions[-1], reference.positions[-1]) if run_.chart is not None else \
        (run_.y[-1], reference.y[-1])
    return float(np.max(np.abs(np.asarray(a, np.longdouble) - np.asarray(b, np.longdouble))))


MAX_TIGHTENINGS = 3


def reference_rtol(c: Choice) -> tuple[float, str]:
    """(tolerance, precision) of the reference run: a thousand times tighter than the run
    (a fixed step: than its local error h^order), in the run's precision or the rung of
    the ladder above it that takes that tolerance; never tighter than quad can take (then
    the reference is only as much tighter as it can be), never looser than RTOL_MAX / 1000.
    A fixed-step run's reference stays in the hardware types (DOP853): its error is far
    above their floor."""
    tight = min(local_tolerance(c) or 1.0, RTOL_MAX) / 1000    # a huge step: as for the loosest target
    above = LADDER[LADDER.index(CLIMB[-1]) + 1:]          # rungs a scene asks for (quad)
    ladder = CLIMB + (above[:above.index(c.dtype) + 1] if c.dtype in above else ())
    if c.rtol is None:
        ladder = tuple(k for k in ladder if not LADDER_TABLE[k].taylor_only)
    start = ladder.index(c.dtype) if c.dtype in ladder else 0
    for dtype in ladder[start:]:
        if tight >= REFERENCE_RTOL_MIN[dtype]:
            return tight, dtype
    return REFERENCE_RTOL_MIN[ladder[-1]], ladder[-1]


def reference_method(c: Choice) -> str:
    """The method of a run's reference run.

    Parameters
    ----------
    c : Choice

    Returns
    -------
    str
        The run's own where it has a tolerance ("taylor" above long double), else (a
        fixed step) REFERENCE_METHOD, DOP853.
    """
    if reference_rtol(c)[1] in EXTENDED:
        return TAYLOR
    return c.method if c.rtol is not None else REFERENCE_METHOD


def _reference(p: Plan, scene: Scene, c: Choice) -> SimulationResult:
    """The same run, far tighter (reference_rtol); above long double with Taylor's method;
    a fixed-step run's with DOP853; a stepped run's in float64 at no less than stepped.RTOL_MIN."""
    if stepped.is_stepped(scene):
        rtol = max(reference_rtol(c)[0], stepped.RTOL_MIN / 10)
        method = c.method if c.rtol is not None and c.method in ADAPTIVE else REFERENCE_METHOD
        return integrate(p, scene, Choice(method, rtol, rtol, None, "float64", None), None)
    rtol, dtype = reference_rtol(c)
    if c.rtol is None:
        c = Choice(reference_method(c), rtol, None if dtype in EXTENDED else rtol, None, dtype, None)
    elif dtype in EXTENDED and c.method != TAYLOR:
        c = Choice(TAYLOR, c.rtol, None, None, dtype, c.predicted, c.note)
    return integrate(p, scene, c, None, tighten=c.rtol / rtol, dtype=dtype)


def reference_steps(scene: Scene, lyap: Lyapunov | None, c: Choice) -> float | None:
    """About how many steps a run's reference run takes.

    Parameters
    ----------
    scene : Scene
    lyap : Lyapunov or None
        Its steps a unit of time (at REFERENCE_RTOL) are scaled to the reference's tolerance.
    c : Choice

    Returns
    -------
    float or None
        The steps over the scene's span; None where the rate is not known.
    """
    if lyap is None or not lyap.steps_per_time:
        return None
    rtol, dtype = reference_rtol(c)
    order = ORDER.get(reference_method(c), ORDER[REFERENCE_METHOD])
    return lyap.steps_per_time * max(1.0, (REFERENCE_RTOL / rtol) ** (1 / order)) * (scene.t_stop - scene.t_start)


CHART_SINGULAR = STATUS_NAMES[STATUS["CHART_SINGULAR"]]


def run(scene: Scene, show_progress: bool = True) -> Outcome:
    """Plan, prepare and run `scene` to the accuracy it asks (see the module doc).

    A spherical chain run in one chart whose motion meets that chart's pole runs again on
    the chain's chart atlas, unless the scene asked for one chart (``pendulum.atlas =
    false``): the atlas is built only where the motion needs it.

    Parameters
    ----------
    scene : Scene
        The parsed scene (`derive.scene.load_scene`).
    show_progress : bool
        Draw the stage and integration status lines.

    Returns
    -------
    Outcome
        The run, its accuracy figures and what it prepared.
    """
    start = time.perf_counter()
    p = plan(scene)
    o = _run_plan(scene, p, show_progress, start)
    atlas = _atlas_for_the_pole(scene, p, o.result)
    if atlas is None:
        return o
    on_atlas = dataclasses.replace(scene, model=atlas.name, atlas=True, initial=_on_the_atlas(scene))
    again = _run_plan(on_atlas, plan(on_atlas), show_progress, start)
    again.plan.reason = f"{p.model}'s chart meets its pole at t = {o.result.t_stop:.4g}: ran on its chart atlas"
    again.steps = o.steps + again.steps
    return again


def _atlas_for_the_pole(scene: Scene, p: Plan, result: SimulationResult) -> Atlas | None:
    """The chart atlas to run the scene on, where its one-chart run stopped at the chart's
    pole and the scene did not ask for one chart; else None."""
    if scene.atlas is not None or result.status_name != CHART_SINGULAR or p.model != scene.model \
            or find_atlas(p.model) is not None:
        return None
    return _chart_atlas(p.model)[0]     # None: no atlas for this chain (its stop says why)


def _chart_atlas(model: str) -> tuple[Atlas | None, str]:
    """The chart atlas that runs `model` across its charts' poles, or None and why not."""
    try:
        return atlas_for(model), ""
    except ModelError as exc:
        return None, str(exc)


def _on_the_atlas(scene: Scene) -> dict:
    """A one-chart scene's initial state as its atlas takes it: the state in the scene's
    chart, which is the atlas's first member."""
    if "state" not in scene.initial:
        return scene.initial                    # Cartesian: the atlas picks its chart
    return {"state": {"chart": scene.model, **scene.initial["state"]}}


def pole_hint(o: Outcome) -> str:
    """The way out of a stop at a chart's pole, for the one-line reason ("" for another stop)."""
    if o.result.status_name != CHART_SINGULAR or find_atlas(o.plan.model) is not None:
        return ""
    atlas, why_not = _chart_atlas(o.plan.model)
    if atlas is None:
        return (f" (the motion meets a pole of {o.plan.model}'s chart; {why_not}: write its links in a chart "
                f"whose poles the motion avoids, e.g. chart = \"second\")")
    return (f" (the motion meets a pole of {o.plan.model}'s chart; the scene asked for one chart: "
            f"pendulum.atlas = true runs it on the chart atlas, which switches charts there)")


def _run_plan(scene: Scene, p: Plan, show_progress: bool, start: float) -> Outcome:
    """`run` of one plan: prepare, estimate the motion's Lyapunov exponent, choose the method,
    integrate, measure the achieved error (tightening where it misses the target)."""
    with Stage("preparing", enabled=None if show_progress else False) as stage:
        steps = prepare(p.model, scene.backend, stage)
        if scene.step is not None:
            check_effort(scene, None, choose(scene, None))     # a fixed step: before any work
        specialised = specialised_model(p, scene)
        if specialised is not None:
            steps += prepare(specialised, scene.backend, stage)
        stage.set("estimating the largest Lyapunov exponent")
        lyap = _lyapunov(p, scene)
    c = choose(scene, lyap)
    check_effort(scene, lyap, c)
    progress = Progress("integrating", CHUNKS) if show_progress else None
    result = integrate(p, scene, c, progress, specialise=specialised is not None)
    if progress:
        progress.close()
    achieved, unmeasured = None, ""
    steps_needed = reference_steps(scene, lyap, c) if c.rtol is None else None
    if steps_needed is not None and steps_needed > MAX_SCENE_STEPS:     # a fixed step's judge, too dear
        unmeasured = (f"its reference run ({REFERENCE_METHOD} at rtol {reference_rtol(c)[0]:.2g}) would take "
                      f"about {steps_needed:.2g} steps")
    if result.ok and not unmeasured:
        reference, ref_rtol = _reference(p, scene, c), reference_rtol(c)[0]
        achieved = _final_error(result, reference) if reference.ok else None
        # Tolerance proportionality is only approximate: when the measured error
        # misses the target, tighten by the observed ratio and run again.
        for _ in range(MAX_TIGHTENINGS if scene.target is not None else 0):
            if achieved is None or achieved <= scene.target or c.rtol <= REFERENCE_RTOL_MIN[c.dtype]:
                break
            factor = SAFETY * achieved / scene.target
            if scene.method is not None:
                break                     # the scene fixed its method: measured, reported
            if stepped.is_stepped(scene):  # dop853 in float64, stepped in Python: only rtol tightens
                method, dtype, rtol, climbed = c.method, c.dtype, max(c.rtol / factor, stepped.RTOL_MIN), None
            else:
                method, dtype, rtol, climbed = climb(c.rtol / factor, scene.target)
                method, dtype, rtol = _not_below(scene, (method, dtype, rtol), c.rtol / factor)
            if dtype == c.dtype and rtol >= c.rtol:
                break                     # at the top rung's floor: a rerun would change nothing
            if c.dtype == "float32" and dtype != c.dtype:     # float cannot go tighter
                c.note = (c.note + "; " if c.note else "") + \
                    f"beyond float: climbed the precision ladder to {PRECISION[dtype]}"
            elif climbed and dtype != c.dtype:      # a new rung: say why (once)
                c.note = (c.note + "; " if c.note else "") + climbed
            c.method, c.dtype, c.rtol = method, dtype, rtol
            c.atol = None if c.dtype in EXTENDED else c.rtol
            c.note = (c.note + "; " if c.note else "") + f"tightened rtol after measuring {achieved:.2g}"
            result = integrate(p, scene, c, None, specialise=specialised is not None)
            if not result.ok:
                break
            if c.rtol < 100 * ref_rtol:           # the reference must stay far tighter
                reference, ref_rtol = _reference(p, scene, c), reference_rtol(c)[0]
            achieved = _final_error(result, reference) if reference.ok else None
        if result.ok and not reference.ok:
            unmeasured = f"its reference run stopped at t = {reference.t_stop:g} ({reference.status_name})"
    result = _events(p, scene, c, result)
    horizon = e0 = None
    if lyap is not None:
        e0 = initial_error(local_tolerance(c), c.dtype, float(np.max(np.abs(np.asarray(result.y[0], float)))))
        horizon = trust_horizon(lyap, horizon_error(scene), e0) + scene.t_start
    positions, velocities, energy = _observables(scene, p, result)
    return Outcome(scene, p, steps, c, lyap, horizon, result, positions, energy, achieved,
                   time.perf_counter() - start, velocities=velocities, show_progress=show_progress,
                   early_error=e0, unmeasured=unmeasured)


def horizon_error(scene: Scene) -> float:
    """The error a scene's trust horizon is for.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    float
        Its accuracy target, else HORIZON_ERROR (1e-8).
    """
    return scene.target if scene.target is not None else HORIZON_ERROR


def conservative(o: Outcome) -> bool:
    """Whether the scene's pendulum conserves energy (no applied forces, no damping)."""
    return load_model(standard_member(o.scene.model)).is_conservative


def target_met(o: Outcome) -> bool | None:
    """Whether the run met its accuracy target: None where there is no target or the
    achieved error could not be measured (a fixed-step method, a failed reference)."""
    if o.scene.target is None or o.achieved is None or not o.result.ok:
        return None
    return bool(o.achieved <= o.scene.target)


def missed_reason(o: Outcome) -> str:
    """One line: why the target was not met: the precision (or its floor tolerance) where
    the run's early error is above the target from the start, that early error and the
    motion's chaos where it grows past the target before the end (the trust horizon), else
    the figures."""
    precision = PRECISION.get(o.choice.dtype, o.choice.dtype)
    if never_trusted(o):
        return (f"target {o.scene.target:g} out of reach with {precision} at rtol {o.choice.rtol:.2g}: "
                f"its early error, about {o.early_error:.2g}, is above the target from the start; "
                f"achieved {o.achieved:.2g} at t = {o.scene.t_stop:g}")
    if o.trust_horizon is not None and o.trust_horizon < o.scene.t_stop:
        return (f"target {o.scene.target:g} out of reach after t = {o.trust_horizon:.3g} with {precision} at "
                f"rtol {o.choice.rtol:.2g}: its early error, about {o.early_error:.2g}, grows past the target "
                f"there (the trust horizon of the motion's largest Lyapunov exponent {o.lyapunov.exponent:.3g}); "
                f"achieved {o.achieved:.2g} at t = {o.scene.t_stop:g}")
    return (f"target {o.scene.target:g} missed with {precision} at rtol {o.choice.rtol:.2g}: "
            f"achieved {o.achieved:.2g} at t = {o.scene.t_stop:g}")


def never_trusted(o: Outcome) -> bool:
    """Whether a run's early error is above its trust horizon's error from the start.

    Parameters
    ----------
    o : Outcome

    Returns
    -------
    bool
        True for a trust horizon at the start: not "trust nothing" but "never within
        that error".
    """
    return o.trust_horizon is not None and o.trust_horizon <= o.scene.t_start


def energy_error(o: Outcome) -> tuple[float, float]:
    """The relative energy error of the scene's pendulum over the run, and its scale.

    Parameters
    ----------
    o : Outcome

    Returns
    -------
    (float, float)
        max |E - E0| / scale and the scale max(|E0|, m g l) (derive/runtime/energy_error.py);
        above long double from the exact states.
    """
    if o.energy_error is None:
        r, p = o.result, o.plan
        if r.y_exact is not None and (p.model == o.scene.model or p.plane is not None):
            o.energy_error = (r.energy_error, r.energy_scale)
        else:
            o.energy_error = relative_energy_error(o.energy, o.scene.model,
                                                   normalise_params(o.scene.model, o.scene.parameters))
    return o.energy_error


def meaningless(o: Outcome) -> str | None:
    """Why a finished run's result plainly means nothing, if it does.

    Parameters
    ----------
    o : Outcome

    Returns
    -------
    str or None
        One line for a non-finite state or energy, or a conservative model whose relative
        energy error is above 1; None otherwise (and for a run that stopped: its stop says why).
    """
    r = o.result
    if not r.ok:
        return None
    fix = ("give a smaller accuracy.step" if o.choice.step is not None and o.choice.method not in ADAPTIVE
           else "give a smaller accuracy.rtol") + " or an accuracy.target"
    knob = f"step {o.choice.step:g}" if o.choice.rtol is None else f"rtol {o.choice.rtol:.2g}"
    t = np.asarray(r.t, float)
    ran = (t - r.t_stop) * np.sign(t[-1] - t[0]) <= 0         # the rows up to a terminal event's stop
    for what, values in (("state", r.y), ("energy", o.energy)):
        if not np.all(np.isfinite(np.asarray(values, float)[ran])):
            return f"result meaningless: the {what} is not finite by t = {r.t_stop:g}; {fix}"
    error, scale = energy_error(o)
    if conservative(o) and not error <= 1:
        return (f"result meaningless: relative energy error {error:.2g} at t = {r.t_stop:g} (above 1): "
                f"{o.choice.method} at {knob} does not follow the motion; {fix}")
    return None


def verdict(o: Outcome) -> tuple[int, str | None]:
    """The judgement of a scene's run, for `derive run`.

    Parameters
    ----------
    o : Outcome

    Returns
    -------
    (int, str or None)
        The exit status and the one line that says why: EXIT_FAILED for a stop or a
        meaningless result, EXIT_TARGET_MISSED for a missed target, else (0, None).
    """
    if not o.result.ok:
        return EXIT_FAILED, f"run failed: {o.result.stop_description}{pole_hint(o)}"
    why = meaningless(o)
    if why is not None:
        return EXIT_FAILED, why
    if target_met(o) is False:
        return EXIT_TARGET_MISSED, missed_reason(o)
    return 0, None


def run_warnings(o: Outcome) -> list[str]:
    """The warnings of a scene's run, one line each.

    Parameters
    ----------
    o : Outcome

    Returns
    -------
    list of str
        A run with no target that goes past its trust horizon (a run with a target is
        judged by it instead), unless its measured error is within the horizon's error
        all the same (the horizon is a prediction; the measurement is the run's).
    """
    if o.scene.target is not None or not o.result.ok or o.trust_horizon is None:
        return []
    level = horizon_error(o.scene)
    if o.achieved is not None and o.achieved <= level:
        return []
    if never_trusted(o):
        return [f"warning: the run is never within error {level:g} of the true motion: its early "
                f"error, about {o.early_error:.2g}, is above it from the start"]
    if o.trust_horizon < o.scene.t_stop:
        return [f"warning: t = {o.scene.t_stop:g} is past the trust horizon t = {o.trust_horizon:.3g} "
                f"for error {level:g}: the run does not resolve the true motion beyond it"]
    return []


def _event_summary(r: SimulationResult) -> dict | None:
    """Per event: its expression, and the time, direction and state of every crossing."""
    if r.events is None:
        return None
    return {name: {"expression": e.expression, "t": [float(v) for v in e.t],
                   "direction": [int(d) for d in e.direction], "y": np.asarray(e.y, float).tolist()}
            for name, e in r.events.items()}


def final_chart(o: Outcome) -> str | None:
    """The chart of the final state of an atlas run (the chart then in use), or None."""
    r = o.result
    if r.chart is None:
        return None
    last = r.chart[-1] if r.ok and not r.terminal_event else None
    return last if last is not None else r.chart_stop


def final_state_names(o: Outcome) -> list[str]:
    """The names of the final state's entries: the state of the model that ran, in the
    final chart for an atlas run."""
    chart = final_chart(o)
    return list(load_model(chart).state_names if chart else model_info(o.plan.model).state_names)


def final_state(o: Outcome) -> list[float]:
    """The state a run ended in.

    Parameters
    ----------
    o : Outcome
        The scene's run.

    Returns
    -------
    list of float
        Its last output row, or the state where it stopped (a failed run, a terminal
        event), in the entries of final_state_names(o).
    """
    r = o.result
    return [float(v) for v in (r.y[-1] if r.ok and not r.terminal_event else r.y_stop)]


def summary(o: Outcome) -> dict:
    r = o.result
    drift, scale = energy_error(o)
    nonsense = meaningless(o)
    reference = None if o.unmeasured else reference_rtol(o.choice)
    return {
        "scene": o.scene.source, "title": o.scene.title,
        "model": o.plan.model, "model_reason": o.plan.reason,
        # pendulum.specialise: the kernels the run took, the parameters folded in (or None)
        "specialised": r.model if o.scene.specialise and r.model != o.plan.model else None,
        "method": o.choice.method, "rtol": o.choice.rtol, "step": o.choice.step,
        "last_step": r.last_step,
        "dtype": o.choice.dtype, "backend": o.scene.backend,
        "target": o.scene.target, "predicted_error": o.choice.predicted, "achieved_error": o.achieved,
        "target_met": target_met(o), "precision": PRECISION.get(o.choice.dtype, o.choice.dtype),
        "reference_rtol": reference[0] if reference else None,
        "reference_precision": PRECISION.get(reference[1], reference[1]) if reference else None,
        "reference_method": reference_method(o.choice) if reference else None,
        "not_measured": o.unmeasured or None,
        "error_estimate": r.error_estimate, "error_kind": r.error_kind,     # the run's own (result.py)
        "lyapunov_exponent": o.lyapunov.exponent if o.lyapunov else None,
        "lyapunov_window": o.lyapunov.t_end if o.lyapunov else None,   # the span it was measured over
        "lyapunov_note": o.lyapunov.window_note if o.lyapunov else "",
        "t_start": o.scene.t_start, "trust_horizon": o.trust_horizon, "horizon_error": horizon_error(o.scene),
        "early_error": o.early_error,
        "status": "meaningless" if nonsense else r.status_name, "ok": r.ok and nonsense is None,
        "message": nonsense or r.stop_description, "t_stop": float(r.t_stop), "nfev": int(r.nfev),
        "chart_switches": int(r.switches) if r.chart is not None else None,
        "final_state": final_state(o),
        "state_names": final_state_names(o),         # of final_state's entries, in final_chart
        # the same by name (an atlas run's names are those of final_chart's coordinates)
        "final_state_by_name": dict(zip(final_state_names(o), final_state(o))),
        "final_chart": final_chart(o),
        "events": _event_summary(r), "terminal_event": r.terminal_event,
        "relative_energy_error": drift, "energy_scale": scale, "energy_scale_is": SCALE_TEXT,
        # with applied forces or damping the energy changes by the work they do: not an error
        "conservative": conservative(o),
        # what does that work, in words, from the model's description ("the moving pivot", ...)
        "work_done_by": list(load_model(standard_member(o.scene.model)).work_done_by),
        # a closed loop: its largest |Phi| and |J q'| over the run, and their bound
        "constraint_drift": None if r.constraint_drift is None else
        {"phi": r.constraint_drift.phi, "phi_dot": r.constraint_drift.phi_dot, "bound": r.constraint_drift.bound,
         "exceeded": r.constraint_drift.exceeded},
        "steps": [s.line() for s in o.steps], "files": o.files,
        "file_notes": o.file_notes, "seconds": o.seconds,
        "note": o.choice.note, "warnings": run_warnings(o),
    }
