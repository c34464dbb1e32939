"""Model only what a scene requires: pick the cheapest model that represents
the scene exactly, and say why.

- A spherical scene whose initial positions and velocities lie in one
  vertical plane through the pivot stays in that plane (gravity and the link
  forces have no component out of it), so it runs the `planar` model; the
  results are mapped back into the plane in 3-D.
- A compound scene runs the `planar` model when the compound pendulum *is* a
  point-mass double pendulum.  The condition and the parameter map are derived
  by matching the two Lagrangians (verification/physics.py); nothing here
  knows the answer in advance.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import sympy as sp

from ..model import load_model
from ..model.atlas import find_atlas, standard_member
from .scene import ATLAS, SPHERICAL_CHART_MODELS, Scene
from ..runtime.simulate import normalise_params, normalise_y0
from ..verification.physics import compound_point_mass_equivalence

RELATIVE_TOLERANCE = 1e-12   # "exactly": equal to rounding of the given numbers


@dataclass
class Plan:
    model: str                      # model to integrate ("spherical" = the atlas)
    params: dict[str, float]
    y0: object                      # chart state (list) or {"cartesian": [...]}
    reason: str
    plane: np.ndarray | None = None  # unit horizontal direction of the plane (spherical -> planar)


def cartesian_state(scene: Scene) -> np.ndarray:
    """The Cartesian state (every bob's position, then velocity) of a spherical scene's
    initial state, validated by the integration layer (link lengths, tangent velocities)."""
    p = normalise_params(scene.model, scene.parameters)
    if "cartesian" in scene.initial:
        y0 = {"cartesian": scene.initial["cartesian"]}
    else:
        state = dict(scene.initial["state"])
        chart = state.pop("chart", scene.model)
        y0 = {"chart": chart, "state": [state[n] for n in load_model(chart).state_names]}
    return np.asarray(normalise_y0(scene.model, y0, p)[2], float)


def vertical_plane(c: np.ndarray) -> np.ndarray | None:
    """A horizontal unit vector u with every position and velocity in span(u, e_z), or None."""
    horizontal = c.reshape(-1, 3)[:, :2]
    norms = np.linalg.norm(horizontal, axis=1)
    if norms.max() == 0:
        return np.array([1.0, 0.0])
    u = horizontal[np.argmax(norms)] / norms.max()
    off_plane = np.abs(horizontal[:, 0] * u[1] - horizontal[:, 1] * u[0])
    if off_plane.max() > RELATIVE_TOLERANCE * max(1.0, norms.max()):
        return None
    return u


def planar_state(c: np.ndarray, u: np.ndarray) -> list[float]:
    """Planar angles and rates of a motion in the plane span(u, e_z) (chart of seed 000 §1)."""
    x1, x2, v1, v2 = c[0:3], c[3:6], c[6:9], c[9:12]
    out_q, out_qd = [], []
    for d, w in ((x1, v1), (x2 - x1, v2 - v1)):
        a, b = d[:2] @ u, d[2]              # along u, and up
        da, db = w[:2] @ u, w[2]
        out_q.append(float(np.arctan2(a, -b)))
        out_qd.append(float((a * db - b * da) / (a * a + b * b)))
    return out_q + out_qd


@cache
def _compound_equivalence():
    check, solution = compound_point_mass_equivalence()
    if not check.passed:
        raise RuntimeError("the compound/point-mass equivalence no longer derives: " + check.detail)
    return {k.name: v for k, v in solution.items()}


def compound_as_planar(params: dict[str, float]) -> dict[str, float] | None:
    """Planar parameters of an equivalent point-mass pendulum, or None."""
    solution = _compound_equivalence()
    values = {sp.Symbol(k, positive=True): v for k, v in params.items()}
    needed_L1 = float(solution["L1"].subs(values))
    if abs(params["L1"] - needed_L1) > RELATIVE_TOLERANCE * max(needed_L1, 1e-300):
        return None
    value = lambda k: float(solution[k].subs(values))
    return {"m1": value("M1"), "m2": value("M2"), "l1": value("a"), "l2": value("b"), "g": params["g"]}


def plan(scene: Scene) -> Plan:
    if scene.model == "compound":
        planar = compound_as_planar(scene.parameters)
        state = [scene.initial["state"][n] for n in ("theta1", "theta2", "theta1_dot", "theta2_dot")]
        if planar is not None and not scene.events:      # events are in the scene model's names
            return Plan("planar", planar, state,
                        "compound with L1 = m1 l1^2/4 is exactly a point-mass double pendulum "
                        f"(derived): m1' = {planar['m1']:.6g}, m2' = {planar['m2']:.6g}, "
                        f"l2' = {planar['l2']:.6g}")
        why = "its [events] are in the compound's names" if planar is not None else "rods with inertia (L1 != m1 l1^2/4)"
        return Plan("compound", scene.parameters, state, f"compound: {why}")
    description = load_model(standard_member(scene.model))
    spherical = description.dimension == 3 and all(link.chart.polar_sine for link in description.links)
    if spherical:
        atlas = find_atlas(scene.model) is not None
        c = cartesian_state(scene)
        u = vertical_plane(c) if description.name in SPHERICAL_CHART_MODELS else None
        if u is not None and not scene.events:    # the catalogue's double pendulum has a planar twin
            params = {k: scene.parameters[k] for k in ("m1", "m2", "l1", "l2", "g")}
            return Plan("planar", params, planar_state(c, u),
                        "spherical scene starts in a vertical plane with no velocity out of it: "
                        "it stays there, so the planar model is exact", plane=u)
        if atlas or "cartesian" in scene.initial:
            # the atlas picks its chart from the Cartesian state anyway (seed 000 §5.1)
            return Plan(scene.model, scene.parameters, {"cartesian": list(c)}, "spherical motion")
        names = load_model(scene.model).state_names
        return Plan(scene.model, scene.parameters, [scene.initial["state"][n] for n in names],
                    "spherical motion in one chart" if u is None else
                    "one chart: its [events] are in the chart's names")
    state = [scene.initial["state"][n] for n in scene.initial["state"]]
    return Plan(scene.model, scene.parameters, state, f"{scene.model} as described")


def planar_positions_in_3d(positions: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Map planar positions (..., 2, 2) into the vertical plane span(u, e_z) in 3-D."""
    horizontal, vertical = positions[..., 0], positions[..., 1]
    return np.stack([horizontal * u[0], horizontal * u[1], vertical], axis=-1)
