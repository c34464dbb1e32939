"""Scenes whose run steps in Python with each stage at its own time (issue 23 items 3, 4):
a time-dependent model (t in its forces, dissipation or pivot), or inputs written as
expressions in t (and the state and parameters), `inputs = { tau = "0.5*sin(2*t)" }`,
evaluated at every stage (derive/runtime/continuous_inputs.py).

Such a run is derive.simulate's explicit RK methods in float64: no chart atlas, no
Lyapunov estimate (the generated integrators it runs are for autonomous models), one
piece (its continuous solution is its own steps: derive/runtime/stage_solution.py).
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from ..errors import ModelError, SceneError
from ..model import load_model
from ..model.atlas import find_atlas, standard_member
from ..model.description import TIME
from ..model.expressions import parse_expression
from ..runtime.continuous_inputs import CONTINUOUS_METHODS

METHOD = "dop853"          # what a stepped scene runs unless it names a method
RTOL_MIN = 1e-13           # the tightest a stepped run (float64) is asked for, its reference too


def input_value(value, key: str, model: str):
    """A scene's input: a number (held constant) or an expression string in t, the
    model's states and parameters, checked by the model grammar (kept as written)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise SceneError(f"'{key}' must be a number or an expression in t (a string), got "
                         f"{type(value).__name__} {value!r}")
    if not isinstance(value, str):
        return value
    try:
        parse_expression(value, _symbols(model), key)
    except ModelError as exc:
        raise SceneError(str(exc)) from None
    return value


def _symbols(model: str) -> dict:
    d = load_model(standard_member(model))
    return {n: sp.Symbol(n) for n in (TIME, *d.state_names, *d.parameters)}


def is_stepped(scene) -> bool:
    """Whether the scene's run steps in Python: a time-dependent model or inputs in t."""
    timed = find_atlas(scene.model) is None and load_model(scene.model).is_time_dependent
    return timed or any(isinstance(v, str) for v in (scene.inputs or {}).values())


def check(scene) -> None:
    """A stepped scene's method and precision, or one line saying what it takes."""
    if not is_stepped(scene):
        return
    why = ("explicit time in the model" if load_model(standard_member(scene.model)).is_time_dependent
           else "inputs in t")
    if find_atlas(scene.model) is not None:
        raise SceneError(f"'pendulum.model': {why} steps one chart model, not the chart atlas")
    if scene.method is not None and scene.method not in CONTINUOUS_METHODS:
        raise SceneError(f"'accuracy.method': {why} runs {', '.join(CONTINUOUS_METHODS)} (each stage at its "
                         f"own time t), not {scene.method}")
    if scene.scalar != "double":
        raise SceneError(f"'accuracy.scalar': {why} runs in double (the stages in Python over the "
                         f"kernels), not {scene.scalar}")


def run_inputs(scene):
    """What derive.simulate takes as the scene's inputs: the numbers by name (held), or
    u(t, y) where one is an expression (every input evaluated at each stage)."""
    inputs = scene.inputs
    if not inputs or not any(isinstance(v, str) for v in inputs.values()):
        return inputs
    d = load_model(scene.model)
    symbols = _symbols(scene.model)
    args = [symbols[n] for n in (TIME, *d.state_names)]
    params = {symbols[n]: float(scene.parameters[n]) for n in d.parameters}
    functions = [sp.lambdify(args, parse_expression(inputs[n], symbols, f"pendulum.inputs.{n}").xreplace(params),
                             "numpy") for n in d.inputs]

    def u(t, y):
        return np.array([float(f(t, *y)) for f in functions])

    return u
