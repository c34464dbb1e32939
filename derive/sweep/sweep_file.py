"""Read and validate a sweep file: a scene plus the axes to sweep and what to record.

    title = "Flip-time map"
    record = ["flip_time", "final_state", "lyapunov_exponent", "energy_error", "max_abs_theta2"]
    [pendulum]  ...                  # the scene's tables (derive/scene/scene.py), as in `derive run`
    [initial]   ...                  # the base state; an axis overrides one of its values
    [time]      stop = 10.0, outputs = 201    # outputs: the samples of each trajectory
    [accuracy]  method = "dop853", rtol = 1e-10, atol = 1e-13

    [axes]                           # the Cartesian product of the grid axes, in this order
    theta1 = { linspace = ["-pi", "pi"], num = 1000 }
    m2     = { logspace = [0.1, 10], num = 21 }        # geometric: 0.1 ... 10
    l2     = { list = [0.5, 1.0, 2.0] }
    theta1_dot = { uniform = [-0.1, 0.1], samples = 500, seed = 1 }   # random axes share
    theta2_dot = { normal = [0.0, 0.05], samples = 500, seed = 2 }    # one dimension, `sample`

    [events.flip]                    # the first time |theta2| reaches pi
    coordinate = "theta2"
    level = "pi"
    accuracy = 1e-6                  # optional: verify each time found (chunk.verify_events)

    [sweep]
    chunk = 10000                    # trajectories per task (and per store chunk)
    mirror = true                    # compute one of each mirror pair (mirror.py; the default)

An axis is a state name (an initial value), a parameter or an input of the model.
Numbers may be written as expressions of pi ("-pi/2").  Every mistake is one
SceneError line that names the file and the key.
"""
from __future__ import annotations

import itertools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ModelError, SceneError
from ..paths import exists, read_input_text
from ..codegen.contract import DEFAULT_METHOD, TAYLOR, TOLERANCE_METHODS
from ..model import load_model, model_names
from ..model.atlas import ATLAS
from ..model.expressions import parse_expression
from ..scene.scene import SCENE_KEYS, Scene, scene_from_table, scene_path
from ..codegen.taylor import taylor_problem
from ..model.description import parameter_problem
from ..runtime import constraints

SWEEP_KEYS = ("axes", "events", "record", "sweep")
GRID_KINDS = ("linspace", "logspace", "list")
RANDOM_KINDS = ("uniform", "normal")
PER_TRAJECTORY = ("final_state", "lyapunov_exponent", "energy_error")   # besides <event>_time, max_abs_<q>
DEFAULT_CHUNK = 10_000
MAX_TRAJECTORIES = 10 ** 9
SAMPLE_DIM = "sample"
DEFAULT_ACCURACY = {"method": DEFAULT_METHOD, "rtol": 1e-10, "atol": 1e-13}


@dataclass(frozen=True)
class Axis:
    name: str                 # a state, parameter or input of the model
    kind: str                 # linspace, logspace, list, uniform, normal
    values: np.ndarray        # the axis's coordinate values (random: the samples)
    target: str               # "state", "parameter" or "input"
    index: int                # position in the state vector, or in p = (parameters, inputs)

    @property
    def random(self) -> bool:
        return self.kind in RANDOM_KINDS


@dataclass(frozen=True)
class Event:
    name: str
    coordinate: str
    index: int                # the coordinate's position in the state; its rate is index + n/2
    level: float              # the event: |coordinate| reaches level
    accuracy: float | None = None    # verify each time found to this (chunk.verify_events)


@dataclass
class Sweep:
    source: str
    scene: Scene
    model_text: str | None    # a model read from a file: its description, for the workers
    axes: tuple[Axis, ...]
    events: tuple[Event, ...]
    record: tuple[str, ...]
    chunk: int
    mirror: bool                          # use the mirror symmetry where the sweep has it (mirror.py)
    state_names: tuple[str, ...]
    parameter_names: tuple[str, ...]      # p = (parameters, inputs), in the kernels' order
    y0: np.ndarray                        # the base state
    p: np.ndarray                         # the base parameters (and inputs)
    text: str = field(repr=False, default="")    # the file as read (its hash names the sweep)
    free: tuple[int, ...] = ()            # a closed loop's free coordinates (each start closed from them)
    swept: tuple[str, ...] = ()           # the parameters on an axis (pendulum.specialise folds the others)

    @property
    def grid_axes(self) -> tuple[Axis, ...]:
        return tuple(a for a in self.axes if not a.random)

    @property
    def random_axes(self) -> tuple[Axis, ...]:
        return tuple(a for a in self.axes if a.random)

    @property
    def dims(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.grid_axes) + ((SAMPLE_DIM,) if self.random_axes else ())

    @property
    def shape(self) -> tuple[int, ...]:
        samples = (len(self.random_axes[0].values),) if self.random_axes else ()
        return tuple(len(a.values) for a in self.grid_axes) + samples

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    @property
    def events_only(self) -> bool:
        """Whether every recorded quantity is an event time: a trajectory may then stop
        once its events have happened."""
        return all(q.endswith("_time") and q[:-5] in {e.name for e in self.events} for q in self.record)


def _where(source: str, key: str) -> str:
    return f"{source}: '{key}'"


def number(value, where: str) -> float:
    """A finite number, or an expression of pi such as "-pi/2" (parsed, never evaluated as Python)."""
    if isinstance(value, bool):
        raise SceneError(f"{where} must be a number, got {value!r}")
    if isinstance(value, str):
        try:
            value = float(parse_expression(value, {}, where))
        except (ModelError, TypeError) as exc:
            raise SceneError(f"{where} must be a number or an expression of pi, got {value!r}"
                             + (f" ({exc})" if isinstance(exc, ModelError) else "")) from None
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(f"{where} must be a finite number, got {value!r}")
    return float(value)


def _whole(value, where: str, least: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        raise SceneError(f"{where} must be a whole number >= {least}, got {value!r}")
    return value


def _pair(value, where: str) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise SceneError(f"{where} must be a list of two numbers [start, stop]")
    return number(value[0], f"{where}[0]"), number(value[1], f"{where}[1]")


def symmetric(values: np.ndarray) -> np.ndarray:
    """A grid over [-a, a] made symmetric to the bit (value i is minus value N-1-i; NumPy's
    linspace misses it by an ulp here and there), so a mirror image of a grid point is one
    (mirror.py); each value moves by an ulp at most."""
    return (values - values[::-1]) / 2


def _axis_values(name: str, spec, where: str) -> tuple[str, np.ndarray]:
    if not isinstance(spec, dict):
        raise SceneError(f"{where} must be a table such as {{ linspace = [0, 1], num = 11 }}")
    kinds = [k for k in spec if k in GRID_KINDS + RANDOM_KINDS]
    if len(kinds) != 1:
        raise SceneError(f"{where} needs exactly one of {', '.join(GRID_KINDS + RANDOM_KINDS)}")
    kind = kinds[0]
    allowed = {"linspace": ("num",), "logspace": ("num",), "list": (),
               "uniform": ("samples", "seed"), "normal": ("samples", "seed")}[kind]
    for key in spec:
        if key != kind and key not in allowed:
            raise SceneError(f"{where}: unknown key '{key}' for a {kind} axis "
                             f"(allowed: {', '.join((kind,) + allowed)})")
    if kind == "list":
        values = spec["list"]
        if not isinstance(values, list) or not values:
            raise SceneError(f"{where}.list is empty: give at least one value")
        return kind, np.array([number(v, f"{where}.list[{i}]") for i, v in enumerate(values)])
    if kind in GRID_KINDS:
        start, stop = _pair(spec[kind], f"{where}.{kind}")
        if "num" not in spec:
            raise SceneError(f"{where}: missing key 'num' (the number of values)")
        num = spec["num"]
        if isinstance(num, int) and not isinstance(num, bool) and num < 1:
            raise SceneError(f"{where}.num = {num}: the axis is empty; give at least one value")
        num = _whole(num, f"{where}.num")
        if num > MAX_TRAJECTORIES:           # before an array of that length is allocated
            raise SceneError(f"{where}.num = {num:,}: more values than one sweep takes "
                             f"({MAX_TRAJECTORIES:,} trajectories); split it")
        if kind == "logspace":
            if start <= 0 or stop <= 0:
                raise SceneError(f"{where}.logspace: both ends must be positive (a geometric range), "
                                 f"got [{start:g}, {stop:g}]")
            return kind, np.geomspace(start, stop, num)
        return kind, symmetric(np.linspace(start, stop, num)) if start == -stop else np.linspace(start, stop, num)
    a, b = _pair(spec[kind], f"{where}.{kind}")
    if kind == "uniform" and not a < b:
        raise SceneError(f"{where}.uniform: need low < high, got [{a:g}, {b:g}]")
    if kind == "normal" and b < 0:
        raise SceneError(f"{where}.normal: the standard deviation must not be negative, got {b:g}")
    for key in ("samples", "seed"):
        if key not in spec:
            raise SceneError(f"{where}: missing key '{key}' (a random axis draws `samples` values "
                             f"from a generator seeded with `seed`)")
    samples = spec["samples"]
    if isinstance(samples, int) and not isinstance(samples, bool) and samples < 1:
        raise SceneError(f"{where}.samples = {samples}: the axis is empty; give at least one sample")
    samples, seed = _whole(samples, f"{where}.samples"), _whole(spec["seed"], f"{where}.seed", 0)
    if samples > MAX_TRAJECTORIES:
        raise SceneError(f"{where}.samples = {samples:,}: more samples than one sweep takes "
                         f"({MAX_TRAJECTORIES:,} trajectories); split it")
    rng = np.random.default_rng(seed)
    values = rng.uniform(a, b, samples) if kind == "uniform" else rng.normal(a, b, samples)
    return kind, values


def _targets(description) -> dict[str, tuple[str, int]]:
    """What an axis may name: a state (index in y), a parameter or an input (index in p)."""
    names = {n: ("state", i) for i, n in enumerate(description.state_names)}
    names.update({n: ("parameter", i) for i, n in enumerate(description.parameters)})
    names.update({n: ("input", len(description.parameters) + i) for i, n in enumerate(description.inputs)})
    return names


# what a time-dependent model's sweep cannot record: its energy is not conserved (the
# drive does work), and the Lyapunov estimate runs Taylor's jet, which carries no t
TIMED_UNRECORDED = {"energy_error": "its energy is not conserved (the drive does work)",
                    "lyapunov_exponent": "the estimate runs Taylor's method, which does not pass t"}


def _check_timed_record(record, events, description, source: str) -> None:
    """One line for a record a time-dependent model's sweep cannot make."""
    if not description.is_time_dependent:
        return
    if events:
        # level_crossings refines a crossing by a run from the sample before it started at
        # time 0: a time shift, which a model with explicit time does not have
        raise SceneError(f"{source}: 'events': a sweep of '{description.name}' (explicit time in the model) "
                         f"locates no events yet (their refinement restarts each sample at t = 0); record "
                         f"the states, or run derive.simulate with events=")
    for name, why in TIMED_UNRECORDED.items():
        if name in record:
            raise SceneError(f"{source}: 'record': {name} of '{description.name}' (explicit time in the model): "
                             f"{why}")


def _parse_axes(table, description, source: str) -> tuple[Axis, ...]:
    if not isinstance(table, dict) or not table:
        raise SceneError(f"{source}: missing table [axes] (at least one axis to sweep)")
    targets = _targets(description)
    axes = []
    for name, spec in table.items():
        where = _where(source, f"axes.{name}")
        if name not in targets:
            raise SceneError(f"{where}: unknown axis: not a state, parameter or input of "
                             f"'{description.name}' (states: {', '.join(description.state_names)}; "
                             f"parameters: {', '.join(description.parameters)}"
                             + (f"; inputs: {', '.join(description.inputs)}" if description.inputs else "")
                             + ")")
        kind, values = _axis_values(name, spec, where)
        target, index = targets[name]
        axes.append(Axis(name, kind, values, target, index))
    random = [a for a in axes if a.random]
    if len({len(a.values) for a in random}) > 1:
        counts = ", ".join(f"{a.name}: {len(a.values)}" for a in random)
        raise SceneError(f"{source}: the random axes share one dimension '{SAMPLE_DIM}' and must "
                         f"draw the same number of samples (got {counts})")
    if SAMPLE_DIM in {a.name for a in axes}:
        raise SceneError(f"{source}: an axis may not be named '{SAMPLE_DIM}'")
    return tuple(axes)


def _parse_events(table, description, source: str) -> tuple[Event, ...]:
    if table is None:
        return ()
    if not isinstance(table, dict):
        raise SceneError(f"{source}: 'events' must be a table of events ([events.flip] ...)")
    coordinates = description.coordinate_names
    events = []
    for name, spec in table.items():
        where = _where(source, f"events.{name}")
        if not isinstance(spec, dict):
            raise SceneError(f"{where} must be a table with 'coordinate' and 'level'")
        for key in spec:
            if key not in ("coordinate", "level", "accuracy"):
                raise SceneError(f"{where}: unknown key '{key}' (allowed: coordinate, level, accuracy)")
        for key in ("coordinate", "level"):
            if key not in spec:
                raise SceneError(f"{where}: missing key '{key}'")
        q = spec["coordinate"]
        if q not in coordinates:
            raise SceneError(f"{where}.coordinate: '{q}' is not a coordinate of '{description.name}' "
                             f"(coordinates: {', '.join(coordinates)})")
        level = number(spec["level"], f"{where}.level")
        if level <= 0:
            raise SceneError(f"{where}.level must be positive (the event is |{q}| reaching it), got {level:g}")
        accuracy = None
        if "accuracy" in spec:
            accuracy = number(spec["accuracy"], f"{where}.accuracy")
            if accuracy <= 0:
                raise SceneError(f"{where}.accuracy must be positive, got {accuracy:g}")
        events.append(Event(name, q, coordinates.index(q), level, accuracy))
    return tuple(events)


def known_quantities(description, events) -> tuple[str, ...]:
    return (*(f"{e.name}_time" for e in events), *PER_TRAJECTORY,
            *(f"max_abs_{q}" for q in description.coordinate_names))


def _parse_record(value, description, events, source: str) -> tuple[str, ...]:
    known = known_quantities(description, events)
    if value is None:
        raise SceneError(f"{source}: missing key 'record' (the quantities per trajectory; known: "
                         f"{', '.join(known)})")
    if not isinstance(value, list) or not value:
        raise SceneError(f"{source}: 'record' must be a non-empty list of quantities (known: {', '.join(known)})")
    for q in value:
        if q not in known:
            hint = "; declare the event in [events]" if isinstance(q, str) and q.endswith("_time") else ""
            raise SceneError(f"{source}: 'record': unknown quantity {q!r} (known: {', '.join(known)}){hint}")
    if len(set(value)) != len(value):
        raise SceneError(f"{source}: 'record' names a quantity twice")
    return tuple(value)


def _parse_options(table, source: str) -> tuple[int, bool]:
    """[sweep]: chunk (trajectories per task) and mirror (use the model's mirror symmetry
    where the sweep has it, mirror.py; default true)."""
    if table is None:
        return DEFAULT_CHUNK, True
    if not isinstance(table, dict):
        raise SceneError(f"{source}: 'sweep' must be a table")
    for key in table:
        if key not in ("chunk", "mirror"):
            raise SceneError(f"{source}: [sweep]: unknown key '{key}' (allowed: chunk, mirror)")
    mirror = table.get("mirror", True)
    if not isinstance(mirror, bool):
        raise SceneError(f"{source}: 'sweep.mirror' must be true or false, got {mirror!r}")
    return _whole(table.get("chunk", DEFAULT_CHUNK), f"{source}: 'sweep.chunk'"), mirror


def _accuracy(raw: dict, scene: Scene, source: str) -> None:
    """A sweep runs one method at one tolerance for every trajectory: the scene's
    accuracy.method, or DOP853 at rtol 1e-10 (a per-trajectory target is the scene's)."""
    given = raw.get("accuracy", {})
    if isinstance(given, dict) and "target" in given:
        raise SceneError(f"{source}: 'accuracy.target' is for one scene; a sweep takes "
                         f"accuracy.method with rtol/atol (or step)")
    if scene.method is None:
        scene.method, scene.rtol, scene.atol = (DEFAULT_ACCURACY[k] for k in ("method", "rtol", "atol"))
        scene.target = None
    if scene.scalar != "double":
        raise SceneError(f"{source}: 'accuracy.scalar': a sweep runs in double")
    if scene.backend != "c":
        raise SceneError(f"{source}: 'accuracy.backend': a sweep runs the compiled C integrators")


def _taylor_accuracy(table: dict, source: str) -> bool:
    """accuracy.method = "taylor" (a sweep's, not yet a scene's): the scene is read as for
    DOP853 (the same rtol rules) and is given Taylor's method after (_use_taylor)."""
    accuracy = table.get("accuracy")
    if not isinstance(accuracy, dict) or accuracy.get("method") != TAYLOR:
        return False
    if "atol" in accuracy:
        raise SceneError(f"{source}: 'accuracy.atol' does not apply to taylor (its tolerance is rtol, "
                         f"relative to max(1, |y|) component by component)")
    table["accuracy"] = {**accuracy, "method": "dop853"}
    return True


def _use_taylor(scene: Scene, source: str) -> None:
    problem = taylor_problem(scene.model)
    if problem is not None:
        raise SceneError(f"{source}: 'accuracy.method': model '{scene.model}' has no Taylor integrator ({problem})")
    scene.method, scene.atol = TAYLOR, None


def _loop_free(scene: Scene, description, source: str) -> tuple[int, ...]:
    """A closed loop's free coordinates ([initial] independent): a sweep's axes set
    states and parameters independently, so each start is closed on the loop from them
    (chunk.py), and a sweep of a loop without them is refused."""
    if not description.is_constrained:
        return ()
    if "independent" not in scene.initial:
        raise SceneError(f"{source}: '{description.name}' has constraints (a closed loop): name its free "
                         f"coordinates in [initial], e.g. independent = [\"{description.coordinate_names[0]}\"], "
                         f"so that each start is solved onto the loop from them (the axes set states and "
                         f"parameters independently, which moves a start off the loop)")
    return tuple(constraints.free_indices(description.name, scene.initial["independent"]))


def _check_loop_axes(axes, free: tuple[int, ...], description, source: str) -> None:
    """A loop's sweep: an axis may not set what the loop determines (its other
    coordinates' values are guesses only, their rates solved)."""
    if not free:
        return
    nq = len(description.coordinate_names)
    for a in axes:
        if a.target == "state" and a.index % nq not in free:
            kind = "guess" if a.index < nq else "rate"
            raise SceneError(f"{_where(source, f'axes.{a.name}')}: the loop determines {a.name} from its free "
                             f"coordinates ({', '.join(description.coordinate_names[i] for i in free)}) "
                             f"and their rates, so it cannot be an axis"
                             + (" (its value in [initial] is only the guess that picks the branch)"
                                if kind == "guess" else ""))


def _base_state(scene: Scene, description, source: str) -> np.ndarray:
    if "state" not in scene.initial:
        raise SceneError(f"{source}: a sweep starts from 'initial.state' (axes override its values)")
    state = scene.initial["state"]
    return np.array([state[n] for n in description.state_names], float)


def parse_sweep(text: str, source: str = "<sweep>", run_as: str | None = None) -> Sweep:
    """A sweep from its text; `source` names it in messages, `run_as` is how the user named
    it (for the hint that a scene is run by derive run)."""
    try:
        t = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{source}: not valid TOML: {exc}") from None
    except RecursionError:             # tomllib recurses once per nested inline table
        raise SceneError(f"{source}: not valid TOML: tables nested too deeply") from None
    for key in t:
        if key not in set(SCENE_KEYS + SWEEP_KEYS):
            raise SceneError(f"{source}: unknown key '{key}' (allowed: {', '.join(dict.fromkeys(SCENE_KEYS + SWEEP_KEYS))})")
    if "axes" not in t and "record" not in t:
        raise SceneError(f"{source}: a scene, not a sweep (it has no [axes] and no record); "
                         f"run it with `derive run {run_as or source}`")
    pendulum = t.get("pendulum")
    model = pendulum.get("model") if isinstance(pendulum, dict) else None
    # a sweep's [events] are its own (a coordinate and a level), not a scene's expressions
    table = {k: v for k, v in t.items() if k in SCENE_KEYS and k != "events"}
    taylor = _taylor_accuracy(table, source)
    scene = None if model == ATLAS else scene_from_table(table, source)
    if scene is None:
        raise SceneError(f"{source}: 'pendulum.model': a sweep runs one chart model (e.g. spherical_std), "
                         f"not the chart atlas '{ATLAS}'")
    _accuracy(t, scene, source)
    if any(isinstance(v, str) for v in (scene.inputs or {}).values()):
        # a model with explicit time runs (the batch integrators pass each stage's t); inputs
        # given as expressions of t would need u(t, y) at every stage, which only Python steps
        raise SceneError(f"{source}: 'pendulum': inputs in t: a sweep runs the generated batch integrators, "
                         f"which hold the inputs constant; run each case as a scene (`derive run`) or "
                         f"with derive.simulate (inputs u(t, y))")
    description = load_model(scene.model)
    free = _loop_free(scene, description, source)
    if taylor:
        _use_taylor(scene, source)
    axes = _parse_axes(t.get("axes"), description, source)
    _check_loop_axes(axes, free, description, source)
    events = _parse_events(t.get("events"), description, source)
    record = _parse_record(t.get("record"), description, events, source)
    _check_timed_record(record, events, description, source)
    if scene.method not in TOLERANCE_METHODS and any(e.accuracy is not None for e in events):
        raise SceneError(f"{source}: 'events': an event's accuracy is verified by tightening the "
                         f"tolerance: it needs a method with one (dopri5, dop853, taylor), not {scene.method}")
    chunk, mirror = _parse_options(t.get("sweep"), source)
    y0 = _base_state(scene, description, source)
    p = np.array([scene.parameters[n] for n in description.parameters]
                 + [scene.inputs[n] for n in description.inputs], float)
    sweep = Sweep(source=source, scene=scene, model_text=None,
                  axes=axes, events=events, record=record, chunk=chunk, mirror=mirror,
                  state_names=tuple(description.state_names),
                  parameter_names=tuple(description.parameters) + tuple(description.inputs),
                  y0=y0, p=p, text=text, free=free,
                  swept=tuple(a.name for a in axes if a.target == "parameter"))
    if sweep.size > MAX_TRAJECTORIES:
        raise SceneError(f"{source}: {sweep.size:,} trajectories are more than one sweep takes "
                         f"({MAX_TRAJECTORIES:,}); split it")
    if scene.model not in model_names():        # a model file: the workers get its text
        sweep.model_text = description.text
    _check_parameters(sweep, description, source)
    return sweep


def _check_parameters(sweep: Sweep, description, source: str) -> None:
    """Every parameter combination the axes make passes the model's role checks
    (lengths and masses positive, fractions in [0, 1]), before any work."""
    grid = [a for a in sweep.axes if a.target == "parameter" and not a.random]
    random = [a for a in sweep.axes if a.target == "parameter" and a.random]
    if not grid and not random:
        return
    base = dict(zip(description.parameters, sweep.p))
    samples = range(len(random[0].values)) if random else [None]
    for values in itertools.product(*(a.values for a in grid)):
        for s in samples:
            trial = {**base, **{a.name: float(v) for a, v in zip(grid, values)},
                     **{a.name: float(a.values[s]) for a in random}}
            problem = parameter_problem(description, trial)
            if problem is not None:
                name, why = problem
                raise SceneError(f"{source}: 'axes': parameter {name} = {trial[name]:g} {why}" if name
                                 else f"{source}: 'axes': {why}")


def load_sweep(path: str | Path) -> Sweep:
    """A sweep from a file, or one of the example sweeps shipped with derive by name (flip_map)."""
    name, path = path, scene_path(path)
    if not exists(path) and len(str(path)) <= 255:
        raise SceneError(f"sweep file '{path}' does not exist")
    text = read_input_text(path, "sweep", SceneError)       # a regular file of bounded size
    try:
        return parse_sweep(text, str(path), str(name))
    except SceneError as exc:
        message = str(exc)
        raise SceneError(message if message.startswith(str(path)) else f"{path}: {message}") from None
