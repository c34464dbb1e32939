"""Stage 1, the model: pendulum descriptions read from data files.

A model is a chain of links hanging from a pivot at the origin, or a tree of them (a
link may name its parent, sit at an offset on it, slide along an axis or turn about
one: docs/models.md).  Each link has a joint (a chart: how its unit vector depends
on its coordinates, see ``catalog/charts.toml``; or a prismatic or revolute joint),
a length and a body (a point mass at its tip, or a rod with its centre of mass
somewhere along it and a moment of inertia about that centre; none: massless).  Nothing downstream knows a model by name: a new model is a new
TOML file, in ``catalog/`` or anywhere (pass its path).

The names below are imported on first use: ``derive.model.listing`` (the catalogue's
names, for the command line's help) is then read without SymPy, which the descriptions need.
"""
import importlib

from .listing import is_model_file, model_names

__all__ = ["Body", "Chart", "Link", "Model", "ModelError", "is_model_file", "load_chart",
           "load_model", "load_model_file", "model_names"]

_FROM_DESCRIPTION = {"Body", "Chart", "Link", "Model", "ModelError", "load_chart", "load_model",
                     "load_model_file"}


def __getattr__(name):
    if name not in _FROM_DESCRIPTION:
        raise AttributeError(f"module 'derive.model' has no attribute {name!r}")
    value = getattr(importlib.import_module(".description", __name__), name)
    globals()[name] = value            # resolved once: later uses find it directly
    return value
