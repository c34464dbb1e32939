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
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..codegen.contract import (ADAPTIVE, DEFAULT_METHOD, EXTENDED, LADDER, PRECISION as LADDER_TABLE,
                                PRECISION_NAMES, PRECISION_TABLE, TAYLOR)
from ..runtime.result import as_fields
from ..runtime.simulate import SimulationError, SimulationResult, normalise_params, simulate
from ..measurement.trust import (Lyapunov, REFERENCE_RTOL, atlas_lyapunov, initial_error,
                                 largest_lyapunov, trust_horizon, unit_roundoff)
from ..model.atlas import find_atlas, standard_member
from .artifacts import Step, prepare
from .plan import Plan, plan, planar_positions_in_3d
from ..progress import Progress, Stage
from .scene import Scene, SceneError
from ..runtime.model_sizes import model_info
from ..runtime.events import locate, parse_events
from ..model import load_model
from ..runtime.loader import load, numpy_module

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
    velocities: np.ndarray | None = None     # like positions
    show_progress: bool = False          # whether writing the outputs may draw a status line


def _lyapunov(p: Plan, scene: Scene) -> Lyapunov | None:
    """None when the motion cannot be followed (e.g. a single chart meets its
    singularity): the scene's own run then reports why."""
    try:
        if find_atlas(p.model) is not None:
            return atlas_lyapunov(p.y0, p.params, scene.t_stop - scene.t_start, atlas=p.model,
                                  backend=scene.backend)
        return largest_lyapunov(p.model, p.y0, p.params, scene.t_stop - scene.t_start,
                                inputs=scene.inputs, backend=scene.backend)
    except SimulationError:
        return None


def choose(scene: Scene, lyap: Lyapunov | None) -> Choice:
    if scene.method is not None:
        return Choice(scene.method, scene.rtol, None if scene.scalar in EXTENDED else scene.atol, scene.step,
                      _dtype_of(scene.scalar), None, "as the scene asks")
    growth = lyap.error_growth(scene.t_stop - scene.t_start) if lyap else 1.0
    rtol = min(scene.target / (SAFETY * growth), RTOL_MAX)
    method, dtype, rtol, note = climb(rtol, scene.target)
    if scene.scalar == "long double" and dtype in ("float64", "longdouble"):
        dtype = "longdouble"
    elif scene.scalar in EXTENDED:
        method, dtype = "taylor", scene.scalar
        rtol = max(rtol, REFERENCE_RTOL_MIN[dtype])
    elif scene.scalar == "float":            # the lowest precision: float where it can, else climb
        if rtol >= FLOAT_RTOL_MIN:
            method, dtype = DEFAULT_METHOD, "float32"
        else:
            why = (f"target {scene.target:g} needs rtol {rtol:.2g}, beyond float: climbed the precision "
                   f"ladder to {PRECISION.get(dtype, dtype)}")
            note = note or why               # (climb's note, beyond long double, says it all)
    atol = None if dtype in EXTENDED else rtol
    return Choice(method, rtol, atol, None, dtype, rtol * growth, note)


def _dtype_of(scalar: str) -> str:
    return PRECISION_NAMES.get(scalar, scalar)


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
        floor = 100 * LADDER_TABLE[key].rtol_floor if key == top else LADDER_TABLE[key].rtol_floor
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
              tighten: float = 1.0, dtype: str | None = None) -> SimulationResult:
    """The scene's run in CHUNKS pieces (fixed, so results do not depend on the display);
    a fixed-step run in one piece: its grid t0 + k step must not restart at a piece's start."""
    t = np.linspace(scene.t_start, scene.t_stop, scene.outputs)
    pieces = 1 if c.step is not None and c.method not in ADAPTIVE else min(CHUNKS, len(t) - 1)
    bounds = np.linspace(0, len(t) - 1, pieces + 1).astype(int)
    y0, parts = p.y0, []
    for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        r = simulate(p.model, y0, t[a:b + 1], p.params, method=c.method,
                     rtol=None if c.rtol is None else c.rtol / tighten,
                     atol=None if c.atol is None or (dtype or c.dtype) in EXTENDED else c.atol / tighten,
                     step=None if c.step is None else c.step / tighten,
                     dtype=dtype or c.dtype, backend=scene.backend, inputs=scene.inputs)
        parts.append(r)
        if progress:
            progress.update(k + 1)
        if not r.ok:
            break
        last = r.y[-1] if r.y_exact is None else list(r.y_exact[-1])    # the ladder's rungs restart exactly
        y0 = last if find_atlas(p.model) is None else {"chart": r.chart[-1], "state": list(r.y[-1])}
    return _join(parts)


def _join(parts: list[SimulationResult]) -> SimulationResult:
    first, last = parts[0], parts[-1]
    cat = lambda attr: np.concatenate([getattr(parts[0], attr)] + [getattr(r, attr)[1:] for r in parts[1:]])
    out = SimulationResult(**{**as_fields(first), "t": cat("t"), "y": cat("y"), "energy": cat("energy"),
                              "positions": cat("positions"), "velocities": cat("velocities"),
                              "y_exact": None if first.y_exact is None else cat("y_exact")})
    for attr in ("status", "status_name", "t_stop", "y_stop", "chart_stop"):
        setattr(out, attr, getattr(last, attr))
    for attr in ("nfev", "njev", "nsteps", "naccepted", "nrejected", "nnewton", "switches"):
        setattr(out, attr, sum(getattr(r, attr) for r in parts))
    if first.chart is not None:
        out.chart = cat("chart")
        # a piece that starts in another chart than the last one ended in (the rule picks
        # the chart of a start): a switch too
        out.switches += sum(r.chart[0] != prev.chart[-1] for prev, r in zip(parts, parts[1:]))
    if first.sol is not None:                 # the dense output over the joined rows
        inputs = None if first.sol.inputs is None else \
            np.concatenate([first.sol.inputs] + [r.sol.inputs[1:] for r in parts[1:]])
        out.sol = first.sol.rows_of(out.t, out.y, inputs, last.sol.t_end)
    return out


def _events(p: Plan, scene: Scene, c: Choice, result: SimulationResult) -> SimulationResult:
    """The scene's [events] on the run's dense output (after its accuracy was measured:
    a terminal event then truncates the outputs)."""
    if not scene.events or result.sol is None:
        return result
    return locate(result, parse_events(model_info(p.model), scene.events), c.rtol)


def _observables(scene: Scene, p: Plan, r: SimulationResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities and energy of the scene's own pendulum (not of the model that ran)."""
    if p.plane is not None:
        return (planar_positions_in_3d(r.positions, p.plane),
                planar_positions_in_3d(r.velocities, p.plane), r.energy)
    if p.model != scene.model and find_atlas(scene.model) is None:
        # a reduction with the same coordinates: the scene's own kernels on the run's states
        own = normalise_params(scene.model, scene.parameters).astype(np.float64)
        m = load(scene.model) if scene.backend == "c" else numpy_module(scene.model)   # no compiler needed
        y = r.y.astype(np.float64)
        return m.positions(y, own), m.velocities(y, own), m.energy(y, own)
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
    """(tolerance, precision) of the reference run: a thousand times tighter than the run,
    in the run's precision or the rung of the ladder above it that takes that tolerance;
    never tighter than quad can take (then the reference is only as much tighter as it
    can be, and says so)."""
    tight = (c.rtol or 1.0) / 1000
    above = LADDER[LADDER.index(CLIMB[-1]) + 1:]          # rungs a scene asks for (quad)
    ladder = CLIMB + (above[:above.index(c.dtype) + 1] if c.dtype in above else ())
    start = ladder.index(c.dtype) if c.dtype in ladder else 0
    for dtype in ladder[start:]:
        if tight >= REFERENCE_RTOL_MIN[dtype]:
            return tight, dtype
    return REFERENCE_RTOL_MIN[ladder[-1]], ladder[-1]


def _reference(p: Plan, scene: Scene, c: Choice) -> SimulationResult:
    """The same run, far tighter (reference_rtol); above long double with Taylor's method."""
    rtol, dtype = reference_rtol(c)
    if dtype in EXTENDED and c.method != "taylor":
        c = Choice("taylor", c.rtol, None, None, dtype, c.predicted, c.note)
    return integrate(p, scene, c, None, tighten=c.rtol / rtol, dtype=dtype)


def run(scene: Scene, show_progress: bool = True) -> Outcome:
    start = time.perf_counter()
    p = plan(scene)
    with Stage("preparing", enabled=None if show_progress else False) as stage:
        steps = prepare(p.model, scene.backend, stage)
        if scene.step is not None:
            check_effort(scene, None, choose(scene, None))     # a fixed step: before any work
        stage.set("estimating the largest Lyapunov exponent")
        lyap = _lyapunov(p, scene)
    c = choose(scene, lyap)
    check_effort(scene, lyap, c)
    progress = Progress("integrating", CHUNKS) if show_progress else None
    result = integrate(p, scene, c, progress)
    if progress:
        progress.close()
    achieved = None
    measurable = c.method in ("dop853", "dopri5", "taylor")
    if result.ok and measurable:
        reference, ref_rtol = _reference(p, scene, c), reference_rtol(c)[0]
        achieved = _final_error(result, reference) if reference.ok else None
        # Tolerance proportionality is only approximate: when the measured error
        # misses the target, tighten by the observed ratio and run again.
        for _ in range(MAX_TIGHTENINGS if scene.target is not None else 0):
            if achieved is None or achieved <= scene.target or c.rtol <= REFERENCE_RTOL_MIN[c.dtype]:
                break
            factor = SAFETY * achieved / scene.target
            if scene.method is not None:
                break                     # the scene fixed its method: measured, not changed
            if c.dtype == "float32" and c.rtol / factor < FLOAT_RTOL_MIN:     # float cannot go tighter
                c.note = (c.note + "; " if c.note else "") + "beyond float: climbed the precision ladder"
            method, dtype, rtol, climbed = climb(c.rtol / factor, scene.target)
            if dtype == c.dtype and rtol >= c.rtol:
                break                     # at the top rung's floor: a rerun would change nothing
            if climbed and dtype != c.dtype:      # a new rung: say why (once)
                c.note = (c.note + "; " if c.note else "") + climbed
            c.method, c.dtype, c.rtol = method, dtype, rtol
            c.atol = None if c.dtype in EXTENDED else c.rtol
            c.note = (c.note + "; " if c.note else "") + f"tightened rtol after measuring {achieved:.2g}"
            result = integrate(p, scene, c, None)
            if not result.ok:
                break
            if c.rtol < 100 * ref_rtol:           # the reference must stay far tighter
                reference, ref_rtol = _reference(p, scene, c), reference_rtol(c)[0]
            achieved = _final_error(result, reference) if reference.ok else None
    result = _events(p, scene, c, result)
    horizon = None
    if lyap is not None:
        e0 = initial_error(c.rtol if c.rtol is not None else 0.0, c.dtype,
                           float(np.max(np.abs(np.asarray(result.y[0], float)))))
        horizon = trust_horizon(lyap, scene.target or 1e-8, e0) + scene.t_start
    positions, velocities, energy = _observables(scene, p, result)
    return Outcome(scene, p, steps, c, lyap, horizon, result, positions, energy, achieved,
                   time.perf_counter() - start, velocities=velocities, show_progress=show_progress)


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
    """One line: why the target was not met, with the trust horizon where it explains it."""
    precision = PRECISION.get(o.choice.dtype, o.choice.dtype)
    if o.trust_horizon is not None and o.trust_horizon < o.scene.t_stop:
        return (f"target {o.scene.target:g} out of reach after t = {o.trust_horizon:.3g} with {precision}: "
                f"the motion's trust horizon (largest Lyapunov exponent "
                f"{o.lyapunov.exponent:.3g}); achieved {o.achieved:.2g} at t = {o.scene.t_stop:g}")
    return (f"target {o.scene.target:g} missed with {precision} at rtol {o.choice.rtol:.2g}: "
            f"achieved {o.achieved:.2g} at t = {o.scene.t_stop:g}")


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


def summary(o: Outcome) -> dict:
    r = o.result
    e = np.asarray(o.energy, float)
    change = np.abs(e - e[0])
    change = change[np.isfinite(change)]            # a run that stopped is NaN after its stop
    drift = float(change.max() / max(abs(e[0]), 1e-300)) if change.size else math.nan
    reference = reference_rtol(o.choice) if o.choice.rtol is not None else None
    return {
        "scene": o.scene.source, "title": o.scene.title,
        "model": o.plan.model, "model_reason": o.plan.reason,
        "method": o.choice.method, "rtol": o.choice.rtol, "step": o.choice.step,
        "last_step": r.last_step,
        "dtype": o.choice.dtype, "backend": o.scene.backend,
        "target": o.scene.target, "predicted_error": o.choice.predicted, "achieved_error": o.achieved,
        "target_met": target_met(o), "precision": PRECISION.get(o.choice.dtype, o.choice.dtype),
        "reference_rtol": reference[0] if reference else None,
        "reference_precision": PRECISION.get(reference[1], reference[1]) if reference else None,
        "lyapunov_exponent": o.lyapunov.exponent if o.lyapunov else None,
        "lyapunov_window": o.lyapunov.t_end if o.lyapunov else None,   # the span it was measured over
        "lyapunov_note": o.lyapunov.window_note if o.lyapunov else "",
        "trust_horizon": o.trust_horizon,
        "status": r.status_name, "ok": r.ok, "message": r.message, "t_stop": float(r.t_stop), "nfev": int(r.nfev),
        "chart_switches": int(r.switches) if r.chart is not None else None,
        "final_state": [float(v) for v in (r.y[-1] if r.ok and not r.terminal_event else r.y_stop)],
        "state_names": final_state_names(o),         # of final_state's entries, in final_chart
        "final_chart": final_chart(o),
        "events": _event_summary(r), "terminal_event": r.terminal_event,
        "relative_energy_error": drift,
        # with applied forces or damping the energy changes by the work they do: not an error
        "conservative": conservative(o),
        "steps": [s.line() for s in o.steps], "files": o.files, "seconds": o.seconds,
        "note": o.choice.note,
    }
