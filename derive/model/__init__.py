"""Stage 1, the model: pendulum descriptions read from data files.

A model is a chain of links hanging from a pivot at the origin.  Each link has
a joint chart (how its unit vector depends on its coordinates, see
``catalog/charts.toml``), a length and a body (a point mass at its tip, or a
rod with its centre of mass somewhere along it and a moment of inertia about
that centre).  Nothing downstream knows a model by name: a new model is a new
TOML file, in ``catalog/`` or anywhere (pass its path).
"""
from .description import (Body, Chart, Link, Model, ModelError, is_model_file, load_chart,
                          load_model, load_model_file, model_names)

__all__ = ["Body", "Chart", "Link", "Model", "ModelError", "is_model_file", "load_chart",
           "load_model", "load_model_file", "model_names"]
