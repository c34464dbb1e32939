"""Read and validate a scene file (TOML)."""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SceneError, SimulationInputError
from ..paths import exists, read_input_text
from ..model.description import NAME, parameter_problem
from ..paths import scenes_dir
from .examples import example_listing, example_scenes  # noqa: F401  (their home is examples.py)
from ..model import ModelError, is_model_file, load_model
from ..codegen.contract import ATLAS_CHARTS, EXTENDED, FIXED, MULTISTEP, RUN_METHODS, SCALARS as CONTRACT_SCALARS, TAYLOR     # the run contract

from ..model.atlas import ATLAS, atlas_for, find_atlas, standard_member  # noqa: E402  (chart atlases)
from ..runtime.events import parse_events
from ..runtime import constraints
from . import stepped
from types import SimpleNamespace
SPHERICAL_CHART_MODELS = ATLAS_CHARTS
FIXED_STEP = FIXED
SCALARS = CONTRACT_SCALARS      # the precision ladder, lowest first (the contract's table)
TRAJECTORY_FORMATS = ("csv", "npz")
PLOTS = ("paths", "energy", "animation")
# output.units: what the plots call a time, a length and an energy.  A scene's numbers are
# SI by convention (kg, m, s, g = 9.81); "model" says they are not (g = 1, unit lengths...).
# Angles are radians either way.
UNITS = {"SI": {"time": "s", "length": "m", "energy": "J"},
         "model": {"time": "model units", "length": "model units", "energy": "model units"}}
MAX_OUTPUTS = 10_000_000        # output times of one scene: ~3 GiB with its observables


@dataclass
class Scene:
    source: str
    title: str
    model: str                       # a model, or an atlas's key ("spherical", "<chain>_atlas")
    parameters: dict[str, float]
    initial: dict                    # {"state": {name: value}} or {"cartesian": [6 N numbers]}
    t_start: float
    t_stop: float
    outputs: int
    target: float | None             # accuracy target (final-state error), or None
    method: str | None
    step: float | None
    rtol: float | None
    atol: float | None
    scalar: str
    backend: str
    output_dir: Path
    trajectory: tuple[str, ...] = ()
    inputs: dict | None = None       # a model's run-time inputs (pendulum.inputs): numbers, or expressions in t
    plots: tuple[str, ...] = ()
    units: str = "SI"                # output.units: a key of UNITS
    events: dict | None = None       # [events]: name -> expression or {expression, direction, terminal}
    atlas: bool | None = None        # pendulum.atlas; None: the chart atlas where the motion needs it
    guard: tuple | None = None       # abm12: (rtol, atol) of its stability guard (None: simulate's default)
    specialise: bool = False         # pendulum.specialise: the run's kernels with the parameters folded in


def _table(t: dict, key: str, where: str, required: bool = True) -> dict:
    if key not in t:
        if required:
            raise SceneError(f"{where}: missing table [{key}]")
        return {}
    if not isinstance(t[key], dict):
        raise SceneError(f"{where}: '{key}' must be a table")
    return t[key]


def _known(t: dict, known: tuple[str, ...], where: str) -> None:
    for key in t:
        if key not in known:
            raise SceneError(f"{where}: unknown key '{key}' (allowed: {', '.join(known)})")


def _number(value, key: str, positive: bool = False, nonnegative: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(f"'{key}' must be a number, got {type(value).__name__} {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise SceneError(f"'{key}' must be finite, got {value}")
    if positive and value <= 0:
        raise SceneError(f"'{key}' must be positive, got {value:g}")
    if nonnegative and value < 0:
        raise SceneError(f"'{key}' must not be negative, got {value:g}")
    return value


def _choice(value, key: str, choices: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise SceneError(f"'{key}' must be one of {', '.join(choices)}; got {value!r}")
    return value


def _parameter_names(model: str) -> tuple[str, ...]:
    return load_model(standard_member(model)).parameters


def _parse_pendulum(t: dict, folder: Path) -> tuple[str, dict[str, float], bool | None]:
    _known(t, ("model", "parameters", "inputs", "atlas", "specialise"), "[pendulum]")
    atlas = t.get("atlas")
    if atlas is not None and not isinstance(atlas, bool):
        raise SceneError(f"'pendulum.atlas' must be true or false, got {atlas!r}")
    if "model" not in t:
        raise SceneError("[pendulum]: missing key 'model'")
    model = t["model"]
    if not isinstance(model, str):
        raise SceneError(f"'pendulum.model' must be a string, got {model!r}")
    if "\0" in model:
        raise SceneError(f"'pendulum.model' contains a NUL byte: {model!r}")
    try:
        if is_model_file(model):            # a model file, relative to the scene file
            path = Path(model)
            model = load_model(path if path.is_absolute() else folder / path).name
        if atlas:                           # the chain run through its chart atlas
            model = atlas_for(model).name
        names = _parameter_names(model)
    except ModelError as exc:
        hint = "" if is_model_file(t["model"]) else f"; or '{ATLAS}', the chart atlas"
        raise SceneError(f"'pendulum.model': {exc}{hint}") from None
    given = _table(t, "parameters", "[pendulum]")
    for key in given:
        if key not in names:
            raise SceneError(f"'pendulum.parameters.{key}': unknown parameter of '{model}' "
                             f"(its parameters: {', '.join(names)})")
    params = {}
    for name in names:
        if name not in given:
            raise SceneError(f"'pendulum.parameters.{name}' is missing")
        params[name] = _number(given[name], f"pendulum.parameters.{name}")
    description = load_model(standard_member(model))
    problem = parameter_problem(description, params)      # the roles come from the model's links
    if problem is not None:
        name, why = problem
        raise SceneError(f"'pendulum.parameters.{name}' {why}, got {params[name]:g}" if name else
                         f"'pendulum.parameters': {why}")
    return model, params, atlas


def _parse_inputs(t: dict, model: str) -> dict | None:
    """pendulum.inputs: every run-time input of the model, a number (held constant) or an
    expression in t, the states and the parameters (evaluated at every stage: stepped.py)."""
    names = load_model(standard_member(model)).inputs
    given = t.get("inputs")
    if given is None:
        if names:
            raise SceneError(f"'pendulum.inputs' is missing: '{model}' has the run-time inputs "
                             f"{', '.join(names)}")
        return None
    if not isinstance(given, dict):
        raise SceneError("'pendulum.inputs' must be a table of input values")
    for key in given:
        if key not in names:
            raise SceneError(f"'pendulum.inputs.{key}': not an input of '{model}' "
                             f"(its inputs: {', '.join(names) or 'none'})")
    missing = [n for n in names if n not in given]
    if missing:
        raise SceneError(f"'pendulum.inputs.{missing[0]}' is missing")
    values = {n: stepped.input_value(given[n], f"pendulum.inputs.{n}", model) for n in names}
    return {n: v if isinstance(v, str) else _number(v, f"pendulum.inputs.{n}") for n, v in values.items()}


def _missing_rates(state: dict, names, coordinates, rest: bool, where: str) -> dict:
    """Every value named: a missing coordinate is an error; a missing rate is zero only
    where the scene says `rest = true` (a scene that forgets a value is not run silently)."""
    missing = [n for n in names if n not in state]
    coords = [n for n in missing if n in coordinates]
    if coords:
        raise SceneError(f"'{where}' misses the coordinate{'s' * (len(coords) > 1)} {', '.join(coords)}")
    if missing and not rest:
        raise SceneError(f"'{where}' misses {', '.join(missing)}: give them, or set "
                         f"'initial.rest = true' to start those rates at zero")
    return {n: state.get(n, 0.0) for n in names}


def _parse_initial(t: dict, model: str) -> dict:
    _known(t, ("state", "cartesian", "rest", "independent"), "[initial]")
    if "independent" in t:
        return _parse_loop_initial(t, model)
    rest = t.get("rest", False)
    if not isinstance(rest, bool):
        raise SceneError(f"'initial.rest' must be true or false, got {rest!r}")
    if ("state" in t) == ("cartesian" in t):
        raise SceneError("[initial]: give exactly one of 'state' or 'cartesian'")
    if "cartesian" in t:
        return {"cartesian": _parse_cartesian(t["cartesian"], model)}
    state = t["state"]
    names = load_model(standard_member(model)).state_names
    if isinstance(state, dict):
        if find_atlas(model) is not None:
            return {"state": _atlas_state(state, model, rest)}
        for key in state:
            if key not in names:
                raise SceneError(f"'initial.state.{key}': not a state of '{model}' "
                                 f"(its states: {', '.join(names)})")
        coordinates = load_model(model).coordinate_names
        full = _missing_rates(state, names, coordinates, rest, "initial.state")
        return {"state": {n: _number(full[n], f"initial.state.{n}") for n in names}}
    if isinstance(state, list):
        if len(state) != len(names):
            raise SceneError(f"'initial.state' has {len(state)} values; '{model}' needs "
                             f"{len(names)} ({', '.join(names)})")
        return {"state": {n: _number(v, f"initial.state[{i}]") for i, (n, v) in
                          enumerate(zip(names, state))}}
    raise SceneError("'initial.state' must be a table of named values or a list")


def _parse_loop_initial(t: dict, model: str) -> dict:
    """[initial] of a closed loop given by its free coordinates (`independent`): those and
    their rates as for any state; the other coordinates optional, guesses (default 0)
    that pick the loop's branch; their rates not given (the loop determines them).  The
    state is closed when the parameters are known (close_loop_start)."""
    if find_atlas(model) is not None or not load_model(model).is_constrained:
        raise SceneError(f"'initial.independent': model '{model}' has no constraints (a closed loop's "
                         f"free coordinates); give its whole 'initial.state'")
    independent = t["independent"]
    if isinstance(independent, str):
        independent = [independent]
    if not isinstance(independent, list) or not all(isinstance(c, str) for c in independent):
        raise SceneError(f"'initial.independent' must be a list of coordinate names, got {t['independent']!r}")
    try:
        free = constraints.free_indices(model, independent)
    except SimulationInputError as exc:
        raise SceneError(f"'initial.independent': {str(exc).split(': ', 1)[1]}") from None
    state, rest = t.get("state"), t.get("rest", False)
    if not isinstance(state, dict):
        raise SceneError("'initial.state' must be a table of named values with 'initial.independent'")
    if not isinstance(rest, bool):
        raise SceneError(f"'initial.rest' must be true or false, got {rest!r}")
    d = load_model(model)
    names, coordinates = d.state_names, d.coordinate_names
    free_names = [coordinates[i] for i in free]
    nq = len(coordinates)
    determined = [names[nq + i] for i in range(nq) if i not in free]
    for key in state:
        if key not in names:
            raise SceneError(f"'initial.state.{key}': not a state of '{model}' (its states: {', '.join(names)})")
        if key in determined:
            raise SceneError(f"'initial.state.{key}': the loop determines it from the free rates "
                             f"({', '.join(names[nq + i] for i in free)}); leave it out")
    wanted = free_names + [names[nq + i] for i in free]
    full = _missing_rates({k: v for k, v in state.items() if k in wanted}, wanted, free_names, rest,
                          "initial.state")
    values = {n: _number(state.get(n, 0.0), f"initial.state.{n}") for n in names if n not in wanted}
    values.update({n: _number(full[n], f"initial.state.{n}") for n in wanted})
    return {"state": {n: values[n] for n in names}, "independent": tuple(free_names)}


def close_loop_start(initial: dict, model: str, parameters: dict, inputs: dict | None = None) -> dict:
    """A loop's [initial] given by its free coordinates, closed at the scene's parameters:
    the other coordinates and their rates solved (derive.consistent_state with
    independent=).  Any other [initial] is returned as it is."""
    if "independent" not in initial:
        return initial
    d = load_model(model)
    p = [parameters[n] for n in d.parameters]
    y = [initial["state"][n] for n in d.state_names]
    free = constraints.free_indices(model, initial["independent"])
    closed, ok = constraints.close_from_free(model, np.array([y]), np.array(p, float), free)
    if not ok[0]:
        at = ", ".join(f"{c} = {initial['state'][c]:.6g}" for c in initial["independent"])
        raise SceneError(f"'initial': the loop of '{model}' does not close at {at} from the guesses of "
                         f"the other coordinates in 'initial.state' (out of the linkage's reach, or a "
                         f"singular configuration): change them")
    return {**initial, "state": dict(zip(d.state_names, map(float, closed[0])))}


def _atlas_state(state: dict, atlas: str = ATLAS, rest: bool = False) -> dict:
    """An atlas accepts a state in any of its charts: the names say which."""
    for chart_model in find_atlas(atlas).charts:
        names = load_model(chart_model).state_names
        if set(state) <= set(names) and set(state) & set(load_model(chart_model).coordinate_names):
            full = _missing_rates(state, names, load_model(chart_model).coordinate_names, rest, "initial.state")
            values = {n: _number(full[n], f"initial.state.{n}") for n in names}
            return {"chart": chart_model, **values}
    raise SceneError(f"'initial.state': names {', '.join(sorted(state))} are not the state of "
                     f"one spherical chart of '{atlas}' (e.g. {', '.join(load_model(standard_member(atlas)).state_names)})")


def _parse_cartesian(value, model: str) -> list[float]:
    description = load_model(standard_member(model))
    if description.dimension != 3 or not all(link.chart.polar_sine for link in description.links):
        raise SceneError(f"'initial.cartesian' is for spherical chains (an atlas or one of its "
                         f"charts); give '{model}' its 'initial.state'")
    dim, n = 3, description.bodies
    keys = tuple(f"x{i}" for i in range(1, n + 1)) + tuple(f"v{i}" for i in range(1, n + 1))
    if not isinstance(value, dict):
        raise SceneError(f"'initial.cartesian' must be a table with {', '.join(keys)}")
    _known(value, keys, "[initial.cartesian]")
    numbers = []
    for k in keys:
        if k not in value:
            raise SceneError(f"'initial.cartesian.{k}' is missing")
        vec = value[k]
        if not isinstance(vec, list) or len(vec) != dim:
            raise SceneError(f"'initial.cartesian.{k}' must be a list of {dim} numbers")
        numbers += [_number(x, f"initial.cartesian.{k}") for x in vec]
    return numbers


def _parse_time(t: dict) -> tuple[float, float, int]:
    _known(t, ("start", "stop", "outputs"), "[time]")
    if "stop" not in t:
        raise SceneError("[time]: missing key 'stop'")
    start = _number(t.get("start", 0.0), "time.start")
    stop = _number(t["stop"], "time.stop")
    if stop <= start:
        raise SceneError(f"'time.stop' ({stop:g}) must be after 'time.start' ({start:g})")
    outputs = t.get("outputs", 1001)
    if isinstance(outputs, bool) or not isinstance(outputs, int) or outputs < 2:
        raise SceneError(f"'time.outputs' must be a whole number >= 2, got {outputs!r}")
    if outputs > MAX_OUTPUTS:
        raise SceneError(f"'time.outputs' = {outputs} is more than {MAX_OUTPUTS:,} output times "
                         f"(about {outputs * 8 * 40 / 2**30:.3g} GiB of trajectory and observables); "
                         f"give fewer")
    if not math.isfinite(stop - start):
        raise SceneError(f"'time.stop' - 'time.start' = {stop - start:g} is not a finite span")
    return start, stop, outputs


def _parse_accuracy(t: dict) -> dict:
    _known(t, ("target", "method", "step", "rtol", "atol", "scalar", "backend"), "[accuracy]")
    out = {"target": None, "method": None, "step": None, "rtol": None, "atol": None}
    if "target" in t and "method" in t:
        raise SceneError("[accuracy]: give either 'target' or 'method', not both")
    if "target" in t:
        out["target"] = _number(t["target"], "accuracy.target", positive=True)
    elif "method" in t:
        method = out["method"] = _choice(t["method"], "accuracy.method", RUN_METHODS)
        if method in FIXED_STEP:
            if "step" not in t:
                raise SceneError(f"[accuracy]: method '{method}' needs 'step'")
            out["step"] = _number(t["step"], "accuracy.step", positive=True)
            if method in MULTISTEP:       # rtol, atol: the threshold of its stability guard
                out["guard"] = tuple(_number(t[k], f"accuracy.{k}", positive=True) if k in t else None
                                     for k in ("rtol", "atol"))
        else:
            out["rtol"] = _number(t.get("rtol", 1e-9), "accuracy.rtol", positive=True)
            out["atol"] = _number(t.get("atol", 1e-12), "accuracy.atol", positive=True)
    else:
        out["target"] = 1e-8
    for key in ("step", "rtol", "atol"):
        if key in t and out[key] is None and not (key != "step" and "guard" in out):
            raise SceneError(f"'accuracy.{key}' does not apply here")
    out["scalar"] = _choice(t.get("scalar", "double"), "accuracy.scalar", SCALARS)
    if out["scalar"] in EXTENDED and out["method"] not in (None, TAYLOR):
        raise SceneError(f"[accuracy]: scalar '{out['scalar']}' runs method 'taylor', not '{out['method']}'")
    out["backend"] = _choice(t.get("backend", "c"), "accuracy.backend", ("c", "numpy"))
    return out


def _parse_output(t: dict) -> dict:
    _known(t, ("directory", "trajectory", "plots", "units"), "[output]")
    directory = t.get("directory", "out")
    if not isinstance(directory, str) or not directory:
        raise SceneError("'output.directory' must be a non-empty string")
    if "\0" in directory:
        raise SceneError(f"'output.directory' contains a NUL byte: {directory!r}")
    lists = {}
    for key, allowed in (("trajectory", TRAJECTORY_FORMATS), ("plots", PLOTS)):
        value = t.get(key, [])
        if not isinstance(value, list):
            raise SceneError(f"'output.{key}' must be a list")
        lists[key] = tuple(_choice(v, f"output.{key}", allowed) for v in value)
    units = _choice(t.get("units", "SI"), "output.units", tuple(UNITS))
    return {"output_dir": Path(directory), "units": units, **lists}


def _parse_events(t: dict, model: str, accuracy: dict) -> dict | None:
    """[events]: zero crossings in the model's states, parameters and inputs, checked here
    (before any work) by the grammar of derive/model/expressions.py."""
    if "events" not in t:
        return None
    events = _table(t, "events", "[events]")
    if model == ATLAS:
        raise SceneError(f"[events] are not available on the chart atlas '{ATLAS}' (its state changes "
                         f"chart); use one chart model ({', '.join(SPHERICAL_CHART_MODELS)})")
    if accuracy["method"] in FIXED_STEP:
        raise SceneError(f"[events] need the dense output of an adaptive method, not "
                         f"'accuracy.method' = {accuracy['method']!r}")
    d = load_model(model)
    names = SimpleNamespace(state_names=d.state_names, param_names=d.parameters, input_names=d.inputs)
    parse_events(names, events, "events", SceneError)
    return events


SCENE_KEYS = ("title", "pendulum", "initial", "time", "accuracy", "output", "events")


def parse_scene(text: str, source: str = "<scene>") -> Scene:
    try:
        t = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{source}: not valid TOML: {exc}") from None
    except RecursionError:             # tomllib recurses once per nested inline table
        raise SceneError(f"{source}: not valid TOML: tables nested too deeply") from None
    if "axes" in t:
        raise SceneError(f"{source}: a sweep file (it has [axes]): run it with `derive sweep`")
    _known(t, SCENE_KEYS, source)
    return scene_from_table(t, source)


def scene_from_table(t: dict, source: str = "<scene>") -> Scene:
    """A scene from its parsed TOML table (a sweep file is a scene plus tables of its own)."""
    model, params, atlas = _parse_pendulum(_table(t, "pendulum", source), Path(source).parent)
    inputs = _parse_inputs(_table(t, "pendulum", source), model)
    initial = _parse_initial(_table(t, "initial", source), model)
    start, stop, outputs = _parse_time(_table(t, "time", source))
    accuracy = _parse_accuracy(_table(t, "accuracy", source, required=False))
    output = _parse_output(_table(t, "output", source, required=False))
    events = _parse_events(t, model, accuracy)
    output["output_dir"] = _output_folder(output["output_dir"], source)
    title = t.get("title", Path(source).stem)
    if not isinstance(title, str):
        raise SceneError("'title' must be a string")
    initial = close_loop_start(initial, model, params)
    specialise = _parse_specialise(_table(t, "pendulum", source), model, accuracy)
    scene = Scene(source=source, title=title, model=model, parameters=params, initial=initial,
                  t_start=start, t_stop=stop, outputs=outputs, inputs=inputs, events=events,
                  atlas=atlas, specialise=specialise, **accuracy, **output)
    stepped.check(scene)
    return scene


def _parse_specialise(t: dict, model: str, accuracy: dict) -> bool:
    """pendulum.specialise: true runs the scene on kernels with its parameters folded in
    (derive.simulate's specialise=); refused where no such kernels run: the chart atlas, the
    NumPy backend."""
    value = t.get("specialise", False)
    if not isinstance(value, bool):
        raise SceneError(f"'pendulum.specialise' must be true or false, got {value!r}")
    if value and find_atlas(model) is not None:
        raise SceneError(f"'pendulum.specialise' runs one chart's model, not the chart atlas '{model}': "
                         f"leave it out, or run one chart")
    if value and accuracy.get("backend", "c") != "c":
        raise SceneError("'pendulum.specialise' folds the parameters into compiled C: it runs with "
                         "accuracy.backend = \"c\"")
    return value


def _output_folder(directory: Path, source: str) -> Path:
    """A relative output directory is relative to the scene file, as a model path is, so
    a scene runs the same from any folder; an example scene shipped with derive writes
    relative to the current folder instead (never into the installed package)."""
    if directory.is_absolute() or source.startswith("<"):
        return directory
    folder = Path(source).resolve().parent
    try:
        if folder.is_relative_to(scenes_dir().resolve()):
            return directory
    except Exception:                 # no package data: a broken install is reported elsewhere
        pass
    return Path(source).parent / directory


def scene_path(arg: str | Path) -> Path:
    """A scene file's path: the path given, or the example scene of that name."""
    path = Path(arg)
    if not exists(path) and NAME.match(str(arg)) and len(str(arg)) <= 64 and (scenes_dir() / f"{arg}.toml").is_file():
        return scenes_dir() / f"{arg}.toml"
    return path


def load_scene(path: str | Path) -> Scene:
    """A scene from a file, or one of the example scenes by name (`default`)."""
    path = scene_path(path)
    if not exists(path) and len(str(path)) <= 255:
        raise SceneError(f"scene file '{path}' does not exist (example scenes: "
                         f"{', '.join(example_scenes())})")
    text = read_input_text(path, "scene", SceneError)       # a regular file of bounded size
    try:
        return parse_scene(text, str(path))
    except SceneError as exc:          # every mistake names the file, then the key
        message = str(exc)
        raise SceneError(message if message.startswith(str(path)) else f"{path}: {message}") from None
