"""Scenes: what a user wants simulated, read from TOML and validated.

A scene names a pendulum (model and parameters), an initial state (in a
chart, or Cartesian), a time span, an accuracy target or an explicit method,
a scalar type and the outputs.  Every problem is a SceneError whose message
names the key.
"""
from .scene import Scene, SceneError, load_scene, parse_scene

__all__ = ["Scene", "SceneError", "load_scene", "parse_scene"]
