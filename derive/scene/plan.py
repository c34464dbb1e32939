"""Model only what a scene requires: pick the cheapest model that represents
the scene exactly, and say why.

The reductions are catalogue data (derive/model/catalog/reductions.toml), each derived
(derive/derivation/reduction_maps.py); the planner tries those of the scene's model and knows
no model by name:

- "vertical_plane": a spherical chain's scene whose initial positions and velocities lie
  in one vertical plane through the pivot stays in that plane (gravity and the link
  forces have no component out of it), so it runs the planar chain; the results are
  mapped back into the plane in 3-D.
- "parameters": a scene runs the target model when the condition derived by matching the
  two Lagrangians holds at the scene's parameters (the compound pendulum whose first rod
  has L1 = m1 l1^2/4 *is* a point-mass double pendulum), with the derived parameters.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import load_model
from ..model.atlas import find_atlas, standard_member
from .scene import Scene
from ..runtime.simulate import normalise_params, normalise_y0
from ..derivation.reduction_maps import parameter_map
from ..model.reductions import Reduction, reductions_of

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
    """Planar angles and rates of a chain moving in the plane span(u, e_z) (the chart of seed
    000 section 1), from its Cartesian state (every bob's position, then every velocity)."""
    n = len(c) // 6
    x, v = c[:3 * n].reshape(n, 3), c[3 * n:].reshape(n, 3)
    out_q, out_qd = [], []
    for i in range(n):
        d = x[i] - (x[i - 1] if i else 0.0)             # link i, from its parent bob
        w = v[i] - (v[i - 1] if i else 0.0)
        a, b = d[:2] @ u, d[2]              # along u, and up
        da, db = w[:2] @ u, w[2]
        out_q.append(float(np.arctan2(a, -b)))
        out_qd.append(float((a * db - b * da) / (a * a + b * b)))
    return out_q + out_qd


def target_parameters(r: Reduction, params: dict[str, float]) -> dict[str, float] | None:
    """The target's parameters of a "parameters" reduction at the scene's, or None when its
    condition does not hold there (to rounding of the given numbers)."""
    derived = parameter_map(r)
    if derived is None:
        raise RuntimeError(f"the reduction {r.source} -> {r.target} no longer derives")
    value = lambda e: float(e.subs({x: params[x.name] for x in e.free_symbols}))
    for name, required in derived.condition.items():
        needed = value(required)
        if abs(params[name] - needed) > RELATIVE_TOLERANCE * max(abs(needed), 1e-300):
            return None
    return {k: value(e) for k, e in derived.target.items()}


def _by_parameters(scene: Scene, r: Reduction) -> Plan | None:
    source = load_model(r.source)
    state = [scene.initial["state"][n] for n in source.state_names]
    mapped = target_parameters(r, scene.parameters)
    if mapped is not None and not scene.events:      # events are in the scene model's names
        changed = ", ".join(f"{k}' = {mapped[k]:.6g}" for k in parameter_map(r).changed)
        return Plan(r.target, mapped, state, f"{r.holds} (derived): {changed}")
    why = f"its [events] are in the {r.source}'s names" if mapped is not None else r.fails
    return Plan(scene.model, scene.parameters, state, f"{r.source}: {why}")


def _in_a_vertical_plane(scene: Scene, r: Reduction, c: np.ndarray) -> Plan | None:
    u = vertical_plane(c)
    if u is None or scene.events:           # events are in the scene model's names
        return None
    params = {k: scene.parameters[k] for k in load_model(r.target).parameters}
    return Plan(r.target, params, planar_state(c, u), r.holds, plane=u)


def plan(scene: Scene) -> Plan:
    description = load_model(standard_member(scene.model))
    found = reductions_of(description.name)
    for r in found:
        if r.kind == "parameters":
            return _by_parameters(scene, r)
    spherical = description.dimension == 3 and all(link.chart.polar_sine for link in description.links)
    if spherical:
        atlas = find_atlas(scene.model) is not None
        c = cartesian_state(scene)
        for r in found:
            chosen = _in_a_vertical_plane(scene, r, c) if r.kind == "vertical_plane" else None
            if chosen is not None:
                return chosen
        planes = any(r.kind == "vertical_plane" for r in found)
        if atlas or "cartesian" in scene.initial:
            # the atlas picks its chart from the Cartesian state anyway (seed 000 §5.1)
            return Plan(scene.model, scene.parameters, {"cartesian": list(c)}, "spherical motion")
        names = load_model(scene.model).state_names
        return Plan(scene.model, scene.parameters, [scene.initial["state"][n] for n in names],
                    "one chart: its [events] are in the chart's names"
                    if planes and vertical_plane(c) is not None else "spherical motion in one chart")
    state = [scene.initial["state"][n] for n in scene.initial["state"]]
    return Plan(scene.model, scene.parameters, state, f"{scene.model} as described")


def planar_positions_in_3d(positions: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Map planar positions (..., 2, 2) into the vertical plane span(u, e_z) in 3-D."""
    horizontal, vertical = positions[..., 0], positions[..., 1]
    return np.stack([horizontal * u[0], horizontal * u[1], vertical], axis=-1)
