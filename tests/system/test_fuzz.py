"""Fuzz: mutated scenes through `derive run` (in-process, derive.cli.main) and bad or extreme
arguments to derive.simulate, each with its exact expected outcome.

Every scene case says what must happen: the exit status and a pattern the one line on
stderr must match, or (status 0 or 3) a result checked against a run of the unmutated
scene or against the physics.  In every case: no traceback, no warning, --json is valid
JSON whose exit_status is the exit status, and never "ok" for a missed target.  The
mutations are generated from the example scenes (derive/scenes/*.toml) with a fixed
seed, so a failure is reproducible by its test id.
"""
from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import random
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

from derive import SimulationInputError, simulate
from derive.cli import main

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "derive" / "scenes"
SEED = 13
# example scenes as fuzz bases: short spans, no plots (plots are cases of their own)
BASES = {
    "default": {"time": {"stop": 2.0, "outputs": 101}},
    "compound_seed001": {"time": {"stop": 1.0, "outputs": 101}},
    "compound_equivalent": {"time": {"stop": 1.0, "outputs": 51}},
    "spherical_pole": {"time": {"stop": 1.0, "outputs": 51}},
    "spherical_in_plane": {"time": {"stop": 1.0, "outputs": 51}},
}


# -- a small TOML writer (the fuzz writes its own scenes) -------------------------------

def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)               # JSON's escapes are TOML basic-string escapes (BMP)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def dumps(scene: dict) -> str:
    top = [f"{json.dumps(k)} = {_value(v)}" for k, v in scene.items() if not isinstance(v, dict)]
    tables = [f"\n[{json.dumps(k)}]\n" + "\n".join(f"{json.dumps(kk)} = {_value(vv)}" for kk, vv in v.items())
              for k, v in scene.items() if isinstance(v, dict)]
    return "\n".join(top) + "\n" + "\n".join(tables) + "\n"


def base(name: str) -> dict:
    scene = tomllib.loads((SCENES / f"{name}.toml").read_text())
    scene.pop("output", None)
    for table, values in BASES[name].items():
        scene[table].update(values)
    return scene


# -- the cases -----------------------------------------------------------------------

class Case:
    def __init__(self, name, scene, status, pattern=None, check=None, flags=()):
        self.name, self.scene, self.status, self.pattern = name, scene, status, pattern
        self.check, self.flags = check, flags        # check(summary, base_summary) for a run

    def text(self) -> str:
        return self.scene if isinstance(self.scene, str) else dumps(self.scene)


def _leaves(scene: dict):
    """(path, value) of every number of a scene (the fuzz's targets)."""
    for table, values in scene.items():
        if not isinstance(values, dict):
            continue
        for key, v in values.items():
            if isinstance(v, dict):
                for k2, v2 in v.items():
                    if isinstance(v2, list):
                        for i, x in enumerate(v2):
                            yield (table, key, k2, i), x
                    elif isinstance(v2, (int, float)) and not isinstance(v2, bool):
                        yield (table, key, k2), v2
            elif isinstance(v, (int, float)) and not isinstance(v, bool):
                yield (table, key), v


def _set(scene: dict, path, value) -> dict:
    s = copy.deepcopy(scene)
    node = s
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return s


def _delete(scene: dict, path) -> dict:
    s = copy.deepcopy(scene)
    node = s
    for k in path[:-1]:
        node = node[k]
    del node[path[-1]]
    return s


def _key(path) -> str:
    """The key a message names: pendulum.parameters.m1, initial.cartesian.x1, time.stop."""
    return ".".join(str(p) for p in path if not isinstance(p, int))


WRONG = ["1.0", True, [1.0], {"a": 1.0}]
NONFINITE = [math.nan, math.inf, -math.inf]


def _type_case(bname, path, value, rng) -> list[Case]:
    key = _key(path)
    out = []
    for bad in rng.sample(WRONG, 2):
        if path[-1] == "outputs":
            pattern = "'time.outputs' must be a whole number >= 2"
        elif isinstance(path[-1], int):
            pattern = rf"'{re.escape(key)}' must be a number"
        else:
            pattern = rf"'{re.escape(key)}' must be a number, got"
        out.append(Case(f"{bname}-{key}{'' if not isinstance(path[-1], int) else path[-1]}-type-{type(bad).__name__}",
                        _set(base(bname), path, bad), 2, pattern))
    for bad in NONFINITE:
        pattern = ("'time.outputs' must be a whole number >= 2" if path[-1] == "outputs"
                   else rf"'{re.escape(key)}' must be finite, got {re.escape(str(bad))}")
        out.append(Case(f"{bname}-{key}{'' if not isinstance(path[-1], int) else path[-1]}-{bad}",
                        _set(base(bname), path, bad), 2, pattern))
    return out


ROLE = {"m1": "a mass", "m2": "a mass", "l1": "a length", "l2": "a length"}


def _negative_case(bname, path, value) -> list[Case]:
    """A negative value: refused where the key's meaning forbids it, else a run."""
    key = _key(path)
    name = path[-1]
    if path[:2] == ("pendulum", "parameters") and name in ROLE:
        return [Case(f"{bname}-{key}-negative", _set(base(bname), path, -abs(value) - 0.5), 2,
                     rf"'{re.escape(key)}' must be positive \({ROLE[name]}\), got -")]
    if path[:2] == ("pendulum", "parameters") and name in ("L1", "L2"):
        return [Case(f"{bname}-{key}-negative", _set(base(bname), path, -0.25), 2,
                     rf"'{re.escape(key)}' must be >= 0 \(a moment of inertia\), got -0.25")]
    if path == ("time", "outputs"):
        return [Case(f"{bname}-outputs-{v}", _set(base(bname), path, v), 2,
                     rf"'time.outputs' must be a whole number >= 2, got {v}") for v in (-3, 0, 1)]
    if path == ("time", "stop"):
        return [Case(f"{bname}-stop-negative", _set(base(bname), path, -1.0), 2,
                     r"'time.stop' \(-1\) must be after 'time.start' \(0\)")]
    if path in (("accuracy", "target"), ("accuracy", "step")):
        return [Case(f"{bname}-{key}-{v}", _set(base(bname), path, v), 2,
                     rf"'{re.escape(key)}' must be positive, got {v:g}") for v in (-1e-6, 0.0)]
    return []


def _structure_cases(bname, rng) -> list[Case]:
    s = base(bname)
    out = []
    for table in ("pendulum", "initial", "time"):        # required tables
        out.append(Case(f"{bname}-no-{table}", _delete(s, (table,)), 2, rf"missing table \[{table}\]"))
        out.append(Case(f"{bname}-{table}-not-a-table", _set(s, (table,), 3), 2,
                        rf"'{table}' must be a table"))
    for table in ("pendulum", "initial", "time", "accuracy"):   # unknown keys
        word = rng.choice(["colour", "Stop", "tmax", "seed", "dt"])
        t = copy.deepcopy(s)
        t.setdefault(table, {})[word] = 1
        out.append(Case(f"{bname}-{table}-unknown-{word}", t, 2, rf"unknown key '{word}'"))
    t = copy.deepcopy(s)
    t["extra"] = {"x": 1}
    out.append(Case(f"{bname}-unknown-table", t, 2, r"unknown key 'extra' \(allowed: title, "))
    out.append(Case(f"{bname}-no-model", _delete(s, ("pendulum", "model")), 2, r"\[pendulum\]: missing key 'model'"))
    out.append(Case(f"{bname}-model-number", _set(s, ("pendulum", "model"), 7), 2,
                    r"'pendulum.model' must be a string, got 7"))
    out.append(Case(f"{bname}-model-unknown", _set(s, ("pendulum", "model"), "planer"), 2,
                    r"'pendulum.model': .*planer"))
    out.append(Case(f"{bname}-no-stop", _delete(s, ("time", "stop")), 2, r"\[time\]: missing key 'stop'"))
    for name in list(s["pendulum"]["parameters"]):
        out.append(Case(f"{bname}-no-{name}", _delete(s, ("pendulum", "parameters", name)), 2,
                        rf"'pendulum.parameters.{name}' is missing"))
    t = copy.deepcopy(s)
    t["pendulum"]["parameters"]["k"] = 1.0
    out.append(Case(f"{bname}-unknown-parameter", t, 2, r"'pendulum.parameters.k': unknown parameter of"))
    if "state" in s["initial"]:
        state = s["initial"]["state"]
        coord = next(iter(state))
        out.append(Case(f"{bname}-no-{coord}", _delete(s, ("initial", "state", coord)), 2,
                        rf"'initial.state' misses the coordinate {coord}"))
        t = copy.deepcopy(s)
        t["initial"]["state"]["psi"] = 0.0
        pattern = (r"'initial.state': names .* are not the state of one spherical chart"
                   if s["pendulum"]["model"] == "spherical" else r"'initial.state.psi': not a state of")
        out.append(Case(f"{bname}-unknown-state", t, 2, pattern))
        out.append(Case(f"{bname}-state-number", _set(s, ("initial", "state"), 1.0), 2,
                        r"'initial.state' must be a table of named values or a list"))
        out.append(Case(f"{bname}-cartesian-too", _set(s, ("initial", "cartesian"), {}), 2,
                        r"give exactly one of 'state' or 'cartesian'"))
        if s["pendulum"]["model"] != "spherical":       # [initial] cartesian on a planar model
            cart = _delete(s, ("initial", "state"))
            cart["initial"]["cartesian"] = {"x1": [0.0, 0.0, -1.0], "x2": [0.0, 0.0, -2.0],
                                            "v1": [0.0, 0.0, 0.0], "v2": [0.0, 0.0, 0.0]}
            out.append(Case(f"{bname}-cartesian-on-{s['pendulum']['model']}", cart, 2,
                            rf"'initial.cartesian' is for spherical chains .* give "
                            rf"'{s['pendulum']['model']}' its 'initial.state'"))
    else:
        for k in ("x1", "v2"):
            out.append(Case(f"{bname}-no-{k}", _delete(s, ("initial", "cartesian", k)), 2,
                            rf"'initial.cartesian.{k}' is missing"))
        out.append(Case(f"{bname}-x1-short", _set(s, ("initial", "cartesian", "x1"), [0.0, 1.0]), 2,
                        r"'initial.cartesian.x1' must be a list of 3 numbers"))
        out.append(Case(f"{bname}-x1-off-sphere", _set(s, ("initial", "cartesian", "x1"), [0.0, 0.0, -1.5]), 2,
                        r"\|x1\| = 1.5 but link 1's length is 1"))
    out.append(Case(f"{bname}-outputs-2**63-1", _set(s, ("time", "outputs"), 2 ** 63 - 1), 2,
                    r"'time.outputs' = 9223372036854775807 is more than 10,000,000 output times"))
    out.append(Case(f"{bname}-outputs-2**70", _set(s, ("time", "outputs"), 2 ** 70), 2,
                    r"is more than 10,000,000 output times"))
    out.append(Case(f"{bname}-outputs-float", _set(s, ("time", "outputs"), 101.0), 2,
                    r"'time.outputs' must be a whole number >= 2, got 101.0"))
    out.append(Case(f"{bname}-stop-1e300", _set(s, ("time", "stop"), 1e300), 2,
                    r"t = 0 to 1e\+300 needs about .* steps with its reference run .* give a shorter span")
               if "target" in s.get("accuracy", {"target": 1}) else
               Case(f"{bname}-stop-1e300", _set(s, ("time", "stop"), 1e300), 2,
                    r"step = 0.001 over t = 0 to 1e\+300 means 1e\+303 steps \(limit 1e\+10\): refused"))
    t = _set(s, ("time", "start"), -1e308)
    t["time"]["stop"] = 1e308
    out.append(Case(f"{bname}-span-overflows", t, 2, r"'time.stop' - 'time.start' = inf is not a finite span"))
    out.append(Case(f"{bname}-title-number", _set(s, ("title",), 5), 2, r"'title' must be a string"))
    out.append(Case(f"{bname}-method-unknown", _set(_delete(s, ("accuracy",)), ("accuracy",), {"method": "euler"}), 2,
                    r"'accuracy.method' must be one of rk4, "))
    out.append(Case(f"{bname}-scalar-half", _set(s, ("accuracy", "scalar"), "half"), 2,
                    r"'accuracy.scalar' must be one of float, double, long double, double-double, quad; got 'half'"))
    out.append(Case(f"{bname}-backend-gpu", _set(s, ("accuracy", "backend"), "gpu"), 2,
                    r"'accuracy.backend' must be one of c, numpy; got 'gpu'"))
    return out


def _special_cases() -> list[Case]:
    d = base("default")
    text = dumps(d)
    out = [
        Case("deeply-nested-inline-tables", "x = " + "{ a = " * 5000 + "1" + " }" * 5000 + "\n" + text, 2,
             r"not valid TOML: tables nested too deeply"),
        Case("nested-200", _set(d, ("pendulum", "inputs"), json.loads('{"a":' * 200 + '1' + '}' * 200)), 2,
             r"'pendulum.inputs.a': not an input of 'planar'"),
        Case("not-toml", text + "= =\n", 2, r"not valid TOML"),
        Case("binary", "\x00\x01\x02" + text, 2, r"not valid TOML"),
        Case("nul-in-output-dir", _set(d, ("output",), {"directory": "out/a\0b", "trajectory": ["csv"]}), 2,
             r"'output.directory' contains a NUL byte"),
        Case("nul-in-model-path", _set(d, ("pendulum", "model"), "../m\0.toml"), 2,
             r"'pendulum.model' contains a NUL byte"),
        Case("model-path-outside", _set(d, ("pendulum", "model"), "../../../../no/such/model.toml"), 2,
             r"'pendulum.model': model file '.*no/such/model.toml' does not exist"),
        Case("model-path-not-toml", _set(d, ("pendulum", "model"), "/etc/hostname"), 2,
             r"'pendulum.model': /etc/hostname: "),
        Case("model-name-traversal", _set(d, ("pendulum", "model"), ".."), 2, r"'pendulum.model': "),
        Case("empty-output-dir", _set(d, ("output",), {"directory": ""}), 2,
             r"'output.directory' must be a non-empty string"),
        Case("plot-unknown", _set(d, ("output",), {"plots": ["3d"]}), 2, r"'output.plots' must be one of paths"),
        Case("target-and-method", _set(d, ("accuracy",), {"target": 1e-8, "method": "rk4"}), 2,
             r"give either 'target' or 'method', not both"),
        Case("rk4-no-step", _set(d, ("accuracy",), {"method": "rk4"}), 2, r"method 'rk4' needs 'step'"),
        Case("rk4-rtol", _set(d, ("accuracy",), {"method": "rk4", "step": 0.01, "rtol": 1e-6}), 2,
             r"'accuracy.rtol' does not apply here"),
        Case("atol-zero", _set(d, ("accuracy",), {"method": "dop853", "atol": 0.0}), 2,
             r"'accuracy.atol' must be positive, got 0"),
        Case("rtol-one", _set(d, ("accuracy",), {"method": "dop853", "rtol": 1.0}), 2,
             r"rtol = 1 is outside \[10 eps, 1\) for float64"),
        Case("rtol-below-eps", _set(d, ("accuracy",), {"method": "dop853", "rtol": 1e-300}), 2,
             r"rtol = 1e-300 is outside \[10 eps, 1\) for float64"),
        Case("rk4-step-1e-30", _set(d, ("accuracy",), {"method": "rk4", "step": 1e-30}), 2,
             r"step = 1e-30 over t = 0 to 2 means 2e\+30 steps \(limit 1e\+10\): refused before any work"),
        Case("rk4-step-1e300", _set(d, ("accuracy",), {"method": "rk4", "step": 1e300}), 2,
             r"'accuracy.step' = 1e\+300 is longer than the span"),
        Case("l1-huge", _set(d, ("pendulum", "parameters", "l1"), 1e300), 1,
             r"run failed: integration stopped at t = 0: non-finite state or derivative"),
        # a run that fails, at its start or on the way, still writes readable plots (no NaN limits)
        Case("failed-at-start-with-plots", _set(_set(d, ("pendulum", "parameters", "l1"), 1e300), ("output",),
                                                {"plots": ["paths", "energy", "animation"]}), 1,
             r"run failed: integration stopped at t = 0: non-finite state or derivative"),
        Case("stopped-on-the-way-with-plots", _set(_set(d, ("pendulum", "parameters", "m1"), 1e-300), ("output",),
                                                   {"plots": ["paths", "energy", "animation"]}), 1,
             r"run failed: integration stopped at t = 0.7\d+: step-size underflow"),
        Case("rest-not-bool", _set(d, ("initial", "rest"), "yes"), 2, r"'initial.rest' must be true or false"),
        Case("rates-missing", _set(d, ("initial", "state"), {"theta1": 1.0, "theta2": 0.5}), 2,
             r"'initial.state' misses theta1_dot, theta2_dot: give them, or set 'initial.rest = true'"),
        Case("state-list-short", _set(d, ("initial", "state"), [1.0, 2.0]), 2,
             r"'initial.state' has 2 values; 'planar' needs 4"),
        Case("trajectory-not-list", _set(d, ("output",), {"trajectory": "csv"}), 2,
             r"'output.trajectory' must be a list"),
        Case("inputs-on-planar", _set(d, ("pendulum", "inputs"), {"u": 1.0}), 2,
             r"'pendulum.inputs.u': not an input of 'planar'"),
        Case("float-climbs", _set(d, ("accuracy",), {"target": 1e-8, "scalar": "float"}), 0,
             check=lambda s, b: s["target_met"] is True and s["dtype"] != "float32"),
        Case("target-1e-300", _set(d, ("accuracy",), {"target": 1e-300}), 3,
             r"target 1e-300 out of reach with double-double at rtol 1e-27: its early error, about "
             r"2.5e-27, is above the target from the start",
             check=lambda s, b: s["target_met"] is False and s["achieved_error"] > 1e-300),
        Case("g-1e6", _set(d, ("pendulum", "parameters", "g"), 1e6), 3,
             r"target 1e-08 out of reach after t = 0.0\d+ with double-double at rtol \S+: its early error, "
             r"about \S+, grows past the target there \(the trust horizon of the motion's largest Lyapunov",
             check=lambda s, b: s["target_met"] is False),
    ]
    return out


def _same_final(s, b, tol=1e-6):
    return s["target_met"] is not False and np.allclose(s["final_state"], b["final_state"], atol=tol, rtol=0)


def _run_cases() -> list[Case]:
    """Mutations that must run, each with a result checked against the base run or physics."""
    d = base("default")
    out = [
        Case("title-matplotlib-cannot-parse", _set(_set(d, ("title",), r"a $\frac{ b $x^ _"), ("output",),
                                                   {"plots": ["paths", "energy"], "trajectory": ["csv"]}), 0,
             check=lambda s, b: _same_final(s, b) and len(s["files"]) == 3),
        Case("title-nul-and-unicode", _set(d, ("title",), "pendule \u00e9\u00e0 \0 %s {} \\n"), 0, check=_same_final),
        Case("integers-for-floats", _set(_set(d, ("pendulum", "parameters"),
                                              {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}),
                                         ("initial", "rest"), True), 0, check=_same_final),
        Case("state-as-list", _set(d, ("initial", "state"), [2.5, 2.0, 0.0, 0.0]), 0, check=_same_final),
        Case("rest-with-rates-omitted", _set(_set(d, ("initial", "state"), {"theta1": 2.5, "theta2": 2.0}),
                                             ("initial", "rest"), True), 0, check=_same_final),
        Case("g-zero-stays-at-rest", _set(d, ("pendulum", "parameters", "g"), 0.0), 0,
             check=lambda s, b: np.allclose(s["final_state"], [2.5, 2.0, 0.0, 0.0], atol=1e-12, rtol=0)),
        # g < 0 is gravity upwards: the same motion turned upside down (theta -> theta - pi)
        Case("g-negative-is-upside-down", _set(_set(d, ("pendulum", "parameters", "g"), -9.81),
                                               ("initial", "state"), {"theta1": 2.5 - math.pi,
                                                                      "theta2": 2.0 - math.pi,
                                                                      "theta1_dot": 0.0, "theta2_dot": 0.0}), 0,
             check=lambda s, b: np.allclose(np.array(s["final_state"]) + [math.pi, math.pi, 0, 0],
                                            b["final_state"], atol=1e-6, rtol=0)),
        # the system is autonomous: the same span started at t = -2 ends in the same state
        Case("start-negative", _set(_set(d, ("time", "start"), -2.0), ("time", "stop"), 0.0), 0,
             check=_same_final),
        Case("target-1e300", _set(d, ("accuracy",), {"target": 1e300}), 0,
             check=lambda s, b: s["rtol"] <= 1e-3 and s["target_met"] is True),
        Case("long-double", _set(d, ("accuracy", "scalar"), "long double"), 0,
             check=lambda s, b: _same_final(s, b) and s["dtype"] == "longdouble"),
        Case("numpy-backend", _set(d, ("accuracy", "backend"), "numpy"), 0, check=_same_final),
        Case("outputs-2", _set(d, ("time", "outputs"), 2), 0, check=_same_final),
        Case("dop853-fixed-tolerances", _set(d, ("accuracy",), {"method": "dop853", "rtol": 1e-12, "atol": 1e-14}),
             0, check=lambda s, b: _same_final(s, b, 1e-5) and s["target_met"] is None),
    ]
    return out


def scene_cases() -> list[Case]:
    rng = random.Random(SEED)
    cases = []
    for bname in BASES:
        for path, value in _leaves(base(bname)):
            cases += _type_case(bname, path, value, rng)
            cases += _negative_case(bname, path, value)
        cases += _structure_cases(bname, rng)
    cases += _special_cases() + _run_cases()
    names = [c.name for c in cases]
    assert len(names) == len(set(names)), [n for n in names if names.count(n) > 1]
    return cases


CASES = scene_cases()


def test_the_fuzz_is_large_enough():
    assert len(CASES) >= 200, len(CASES)


def run_cli(argv: list[str]) -> tuple[int, str, str, list]:
    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = main(argv)
    return status, out.getvalue(), err.getvalue(), [str(w.message) for w in caught]


_base_summaries: dict[str, dict] = {}


def _base_summary(tmp_path_factory) -> dict:
    if "default" not in _base_summaries:
        path = tmp_path_factory.mktemp("base") / "default.toml"
        path.write_text(dumps(base("default")))
        status, out, err, caught = run_cli(["run", str(path), "--json"])
        assert status == 0 and not caught, err
        _base_summaries["default"] = json.loads(out)
    return _base_summaries["default"]


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_scene(case: Case, tmp_path, tmp_path_factory):
    path = tmp_path / "scene.toml"
    path.write_text(case.text())
    status, out, err, caught = run_cli(["run", str(path), "--json", "--output-dir", str(tmp_path / "out")]
                                       if "output" not in case.text() else ["run", str(path), "--json"])
    assert not caught, caught                                   # no warning leaks
    assert "Traceback" not in err and "internal error" not in err, err
    assert status == case.status, (status, err)
    lines = err.splitlines()
    summary = json.loads(out)                                   # JSON for errors too
    assert summary["exit_status"] == status
    if case.status == 0:
        assert lines == [], err
    else:
        assert len(lines) == 1 and lines[0].startswith("derive: "), err
        assert re.search(case.pattern, lines[0]), (case.pattern, lines[0])
    if case.status == 3:                                        # never "ok" for a missed target
        assert summary["target_met"] is False and summary["reason"] in lines[0]
    if case.check is not None:
        assert case.check(summary, _base_summary(tmp_path_factory)), summary


def test_a_missed_target_is_never_reported_ok(tmp_path):
    """The human summary of a missed target says MISSED, and stderr why (exit 3)."""
    path = tmp_path / "scene.toml"
    path.write_text(dumps(_set(base("default"), ("accuracy",), {"target": 1e-40})))
    status, out, err, caught = run_cli(["run", str(path)])
    assert status == 3 and "MISSED" in out and "target 1e-40" in err and not caught


# -- the API: derive.simulate with bad or extreme arguments -------------------------------

from tests.parameters import UNIT_PARAMS as P, UNIT_VECTOR as SPH  # noqa: E402
Y = [2.5, 2.0, 0.0, 0.0]
T = np.linspace(0, 1, 11)
REFUSED = [   # (id, kwargs for simulate over the planar defaults, message pattern)
    ("dtype-int32", dict(dtype="int32"), r"unknown dtype 'int32'"),
    ("dtype-float16", dict(dtype=np.float16), r"unknown dtype"),
    ("dtype-complex", dict(dtype=complex), r"unknown dtype"),
    ("dtype-object", dict(dtype=object), r"unknown dtype"),
    ("y0-3", dict(y0=[1.0, 2.0, 3.0]), r"model 'planar' takes y0 with 4 numbers .* got 3"),
    ("y0-5", dict(y0=[0.0] * 5), r"got 5"),
    ("y0-empty", dict(y0=[]), r"got 0"),
    ("y0-2x2", dict(y0=[[1.0, 2.0], [3.0]]), r"y0 must be numbers"),
    ("y0-string", dict(y0="1 2 3 4"), r"y0 must be 4 numbers, got a string"),
    ("y0-strings", dict(y0=["a", "b", "c", "d"]), r"y0 must be numbers"),
    ("y0-nan", dict(y0=[math.nan, 0.0, 0.0, 0.0]), r"y0 contains NaN or infinity"),
    ("y0-inf", dict(y0=[0.0, 0.0, math.inf, 0.0]), r"y0 contains NaN or infinity"),
    ("y0-mapping", dict(y0={"theta1": 1.0}), r"model 'planar' takes y0 as a sequence of 4 numbers"),
    ("y0-number-as-text", dict(y0=[1.0, "0.5", 0.0, 0.0]), r"y0 must be numbers, got the string '0.5'"),
    ("params-nan", dict(params={**P, "g": math.nan}), r"params contains NaN or infinity"),
    ("params-number-as-text", dict(params={**P, "g": "9.81"}), r"parameter g must be a number, got str '9.81'"),
    ("params-list-text", dict(params=[1.0, 1.0, 1.0, 1.0, "9.81"]), r"parameter g must be a number, got str"),
    ("params-bool", dict(params={**P, "m1": True}), r"parameter m1 must be a number, got bool True"),
    ("params-inf", dict(params={**P, "m1": math.inf}), r"params contains NaN or infinity"),
    ("params-4", dict(params=[1.0, 1.0, 1.0, 9.81]), r"model 'planar' takes 5 parameters"),
    ("params-6", dict(params=[1.0] * 6), r"model 'planar' takes 5 parameters"),
    ("params-missing", dict(params={"m1": 1.0}), r"missing parameter 'm2'"),
    ("params-unknown", dict(params={**P, "k": 1.0}), r"unknown parameter 'k'"),
    ("params-string", dict(params="m1=1"), r"params must be a mapping by name or a sequence"),
    ("params-number", dict(params=3.0), r"params must be a mapping by name or a sequence"),
    ("l1-negative", dict(params={**P, "l1": -1.0}), r"parameter l1 = -1 must be positive \(a length\)"),
    ("l2-zero", dict(params={**P, "l2": 0.0}), r"parameter l2 = 0 must be positive \(a length\)"),
    ("m2-negative", dict(params={**P, "m2": -2.0}), r"parameter m2 = -2 must be positive \(a mass\)"),
    ("t-scalar", dict(t=1.0), r"t must be a sequence of output times"),
    ("t-empty", dict(t=[]), r"t is empty"),
    ("t-not-monotone", dict(t=[0.0, 1.0, 0.5]), r"strictly increasing or strictly decreasing"),
    ("t-repeated", dict(t=[0.0, 0.0]), r"strictly increasing or strictly decreasing"),
    ("t-nan", dict(t=[0.0, math.nan]), r"t contains NaN or infinity"),
    ("t-text", dict(t=["0", 1.0]), r"t must be numbers, got the string '0'"),
    ("t-inf", dict(t=[0.0, math.inf]), r"t contains NaN or infinity"),
    ("t-overflowing-span", dict(t=[-1e308, 1e308]), r"the time span .* is not finite"),
    ("t-1e9-outputs", dict(t=np.broadcast_to(np.float32(0), (10 ** 9,))), r"output times are more than one run can hold"),
    ("method-unknown", dict(method="euler"), r"unknown method 'euler'"),
    ("method-number", dict(method=3), r"unknown method 3"),
    ("backend-unknown", dict(backend="gpu"), r"unknown backend 'gpu'"),
    ("rtol-zero", dict(rtol=0.0), r"rtol = 0 is outside \[10 eps, 1\) for float64"),
    ("rtol-one", dict(rtol=1.0), r"rtol = 1 is outside"),
    ("rtol-negative", dict(rtol=-1e-6), r"rtol = -1e-06 must be a finite number >= 0"),
    ("rtol-nan", dict(rtol=math.nan), r"rtol = nan must be a finite number >= 0"),
    ("rtol-string", dict(rtol="1e-6"), r"rtol = '1e-6' must be a finite number >= 0"),
    ("rtol-float32-too-tight", dict(rtol=1e-9, dtype="float32"), r"rtol = 1e-09 is outside .* for float32"),
    ("atol-negative", dict(atol=-1.0), r"atol = -1.0 must be a finite number >= 0"),
    ("atol-inf", dict(atol=math.inf), r"atol = inf must be a finite number >= 0"),
    ("hmax-1e-300", dict(hmax=1e-300), r"hmax = 1e-300 over a span of 1 means 1e\+300 steps \(limit 1e\+10\)"),
    ("hmax-negative", dict(hmax=-1.0), r"hmax = -1.0 must be a finite number >= 0"),
    ("hmax-huge-span", dict(hmax=1.0, t=[0.0, 1e300]), r"hmax = 1 over a span of 1e\+300 means 1e\+300 steps"),
    ("rk4-no-step", dict(method="rk4"), r"method 'rk4' has a fixed step: give step="),
    ("rk4-step-zero", dict(method="rk4", step=0.0), r"step = 0.0 must be a positive finite number"),
    ("rk4-step-negative", dict(method="rk4", step=-0.01), r"step = -0.01 must be a positive finite number"),
    ("rk4-step-nan", dict(method="rk4", step=math.nan), r"step = nan must be a positive finite number"),
    ("rk4-step-1e-30", dict(method="rk4", step=1e-30), r"step = 1e-30 over a span of 1 means 1e\+30 steps"),
    ("gauss2-step-1e-12", dict(method="gauss2", step=1e-12), r"means 1e\+12 steps \(limit 1e\+10\)"),
    ("max-steps-zero", dict(max_steps=0), r"max_steps = 0 must be a positive integer"),
    ("max-steps-float", dict(max_steps=10.5), r"max_steps = 10.5 must be a positive integer"),
    ("newton-max-zero", dict(method="gauss2", step=0.01, newton_max=0), r"newton_max = 0 must be a positive integer"),
    ("sine-min-one", dict(sine_min=1.0), r"sine_min = 1.0 must be in \[0, 1\)"),
    ("inputs-on-planar", dict(inputs={"u": 1.0}), r"model 'planar' has no inputs"),
    ("model-unknown", dict(model="planer"), r"planer"),
    ("model-number", dict(model=3), r"model must be a name or the path of a model file, got 3"),
    ("model-path-missing", dict(model="../../nowhere.toml"), r"model file '../../nowhere.toml' does not exist"),
    ("model-nul", dict(model="a\0b.toml"), r"cannot read model file"),
    ("sph-cartesian-short", dict(model="spherical", params=SPH, y0={"cartesian": [0.0] * 11}),
     r"y0\['cartesian'\] must have 12 numbers"),
    ("sph-cartesian-off", dict(model="spherical", params=SPH, y0={"cartesian": [0, 0, -2, 0, 0, -3] + [0] * 6}),
     r"\|x1\| = 2 but link 1's length is 1"),
    ("sph-not-tangent", dict(model="spherical", params=SPH,
                             y0={"cartesian": [0, 0, -1, 0, 0, -2, 0, 0, 1, 0, 0, 1]}),
     r"the velocities are not tangent to the links"),
    ("sph-chart-unknown", dict(model="spherical", params=SPH, y0={"chart": "planar", "state": [0] * 8}),
     r"y0 as a mapping must be"),
    ("sph-state-7", dict(model="spherical", params=SPH, y0={"chart": "spherical_std", "state": [0.5] * 7}),
     r"y0\['state'\] must have 8 numbers, got 7"),
    ("theta-1e300", dict(y0=[1e300, 0.0, 0.0, 0.0]), r"y0: theta1 = 1e\+300 rad is too large for float64"),
    ("theta-1e6-float32", dict(y0=[0.0, 1e6, 0.0, 0.0], dtype="float32"),
     r"y0: theta2 = 1e\+06 rad is too large for float32"),
    ("driven-no-inputs", dict(model=str(ROOT / "examples" / "models" / "driven.toml"), params=None, y0=None),
     r"needs its inputs"),
]


def _call(kw: dict):
    kw = dict(kw)
    model = kw.pop("model", "planar")
    if kw.get("params", P) is None:          # a model file: its own parameters and state
        from derive.model import load_model
        m = load_model(model)
        kw["params"] = {n: 1.0 for n in m.parameters}
        kw["y0"] = [0.1] * len(m.state_names)
    return simulate(model, kw.pop("y0", Y), kw.pop("t", T), kw.pop("params", P), **kw)


@pytest.mark.parametrize("kw, pattern", [(kw, p) for _, kw, p in REFUSED], ids=[i for i, _, _ in REFUSED])
def test_simulate_refuses(kw, pattern):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(SimulationInputError) as info:
            _call(kw)
    message = str(info.value)
    assert "\n" not in message and re.search(pattern, message), message


def _energy_kept(bound):
    def check(r):
        e = np.asarray(r.energy, float)
        return r.ok and np.isfinite(e).all() and np.max(np.abs(e - e[0])) <= bound * max(1.0, abs(e[0]))
    return check


def _at_rest(r):
    return r.ok and np.all(np.asarray(r.y, float) == 0.0)


RUNS = [   # (id, kwargs, check(result)): extreme but valid runs, each with a right answer
    ("atol-zero-from-rest", dict(y0=[0.0] * 4, atol=0.0), _at_rest),
    ("atol-zero-from-rest-dopri5", dict(y0=[0.0] * 4, atol=0.0, method="dopri5"), _at_rest),
    ("atol-zero-from-rest-longdouble", dict(y0=[0.0] * 4, atol=0.0, dtype="longdouble", rtol=1e-15), _at_rest),
    ("atol-zero-from-rest-numpy", dict(y0=[0.0] * 4, atol=0.0, backend="numpy"), _at_rest),
    ("atol-zero-moving", dict(atol=0.0, rtol=1e-10), _energy_kept(1e-8)),
    ("g-1e6", dict(params={**P, "g": 1e6}, rtol=1e-10, t=np.linspace(0, 0.1, 11)), _energy_kept(1e-7)),
    ("theta1-dot-1e4", dict(y0=[0.3, 0.1, 1e4, 0.0], rtol=1e-10, t=np.linspace(0, 0.01, 11)),
     _energy_kept(1e-7)),
    ("g-zero", dict(params={**P, "g": 0.0}, y0=[1.0, 0.5, 0.0, 0.0]), 
     lambda r: r.ok and np.allclose(np.asarray(r.y, float), [1.0, 0.5, 0.0, 0.0], atol=1e-12, rtol=0)),
    ("g-negative", dict(params={**P, "g": -9.81}), _energy_kept(1e-7)),
    ("m1-tiny", dict(params={**P, "m1": 1e-6}, rtol=1e-10), _energy_kept(1e-6)),
    ("float32", dict(dtype="float32"), lambda r: r.ok and r.y.dtype == np.float32),
    ("longdouble", dict(dtype="longdouble", rtol=1e-15), lambda r: r.ok and r.y.dtype == np.longdouble),
    ("backwards", dict(t=np.linspace(0, -1, 11)), _energy_kept(1e-7)),
    ("one-output", dict(t=[0.5]), lambda r: r.ok and np.array_equal(np.asarray(r.y[0], float), Y)),
    # at t = 1e15 a double's rounding (0.125) is coarser than the steps needed: said, not hidden
    ("start-1e15", dict(t=1e15 + np.linspace(0, 1, 3)),
     lambda r: r.status == 1 and "step-size underflow" in r.message and r.t_stop == 1e15),
    ("max-steps-hit", dict(t=[0.0, 1e300], max_steps=1000),
     lambda r: r.status == 2 and r.nsteps == 1000 and not r.ok and np.isnan(np.asarray(r.y[-1], float)).all()),
    ("rk4-step-longer-than-span", dict(method="rk4", step=10.0, t=[0.0, 0.01]), lambda r: r.ok),
    ("int-params", dict(params=[1, 1, 1, 1, 10]), _energy_kept(1e-7)),
    ("numpy-params", dict(params=np.array([1.0, 1.0, 1.0, 1.0, 9.81], np.float32)), _energy_kept(1e-7)),
    ("spherical-at-pole", dict(model="spherical", params=SPH, y0=[0.0, 0.0, 0.5, 0.0, 0.7, 0.0, 0.0, 0.0]),
     _energy_kept(1e-7)),
]


@pytest.mark.parametrize("kw, check", [(kw, c) for _, kw, c in RUNS], ids=[i for i, _, _ in RUNS])
def test_simulate_extremes(kw, check):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = _call(kw)
    assert check(r), (r.status_name, r.message)
    if not r.ok:
        assert r.message and "\n" not in r.message


def test_the_api_fuzz_is_large_enough():
    assert len(REFUSED) + len(RUNS) >= 60


def test_a_fixed_step_is_the_step_asked():
    r = simulate("planar", Y, np.linspace(0, 1, 7), P, method="rk4", step=0.1)
    # the 10 steps of the grid 0, 0.1, ..., 1, and one short step from the grid to each of
    # the 4 outputs between grid points (1/6, 1/3, 2/3, 5/6); the grid goes on unchanged
    assert r.ok and r.step == 0.1 and r.nsteps == 10 + 4
    on_grid = simulate("planar", Y, [0, 0.5, 1.0], P, method="rk4", step=0.1)
    assert np.array_equal(r.y[[0, 3, 6]], on_grid.y)


@pytest.mark.slow
def test_a_huge_span_is_refused_before_the_work():
    with pytest.raises(SimulationInputError, match="steps"):
        simulate("planar", Y, [0.0, 1e300], P)
