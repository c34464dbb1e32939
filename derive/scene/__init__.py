"""Scenes: what a user wants simulated, read from TOML and validated.

A scene names a pendulum (model and parameters), an initial state (in a
chart, or Cartesian), a time span, an accuracy target or an explicit method,
a scalar type and the outputs.  Every problem is a SceneError whose message
names the key.

The names below are imported on first use: ``derive.scene.examples`` (the example
scenes, for `derive run --list`) is then read without the scene stage's imports.
"""
import importlib

__all__ = ["Scene", "SceneError", "load_scene", "parse_scene"]


def __getattr__(name):
    if name not in __all__:
        raise AttributeError(f"module 'derive.scene' has no attribute {name!r}")
    value = getattr(importlib.import_module(".scene", __name__), name)
    globals()[name] = value            # resolved once: later uses find it directly
    return value
