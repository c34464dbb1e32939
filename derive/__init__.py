"""derive: symbolic derivation and code generation for pendulum dynamics.

``derive.simulate(model, y0, t, params, ...)`` runs the generated integrators
(imported on first use, so ``import derive`` stays light); ``derive.trust_horizon(result,
target)`` says until when a run resolves the true motion to target; ``derive.sweep(file, ...)``
runs a sweep file on Dask and returns an xarray Dataset (the `sweep` extra);
``derive.load_model(name_or_path)`` is a model as one object (derive/api.py): its equations
as SymPy objects, and `derive generate` and `derive latex` as methods.  Every failure derive
expects is a ``derive.DeriveError`` (see derive/errors.py).
"""
import importlib

from .paths import VERSION as __version__
from .errors import (BuildError, CompilerMissingError, DeriveError, InputError,  # noqa: E402
                     ModelError, SceneError, SimulationError, SimulationInputError,
                     ToolMissingError)

__all__ = ["BuildError", "CompilerMissingError", "DeriveError", "InputError", "ModelError",
           "SceneError", "EnsembleResult", "SimulationError", "SimulationInputError", "SimulationResult", "ToolMissingError",
           "Pendulum", "__version__", "consistent_state", "ensemble", "equations", "equilibria", "linearize", "load_model", "scipy_rhs", "simulate", "sweep",
           "trust_horizon"]


# The public functions, imported on first use (``import derive`` stays light): the name,
# the module that defines it, and its name there.  ``derive.sweep`` is the sweep stage itself.
_LAZY = {"simulate": ("runtime.simulate", "simulate"), "ensemble": ("runtime.ensemble", "ensemble"),
         "scipy_rhs": ("runtime.scipy_rhs", "scipy_rhs"),
         "SimulationResult": ("runtime.result", "SimulationResult"),
         "EnsembleResult": ("runtime.ensemble", "EnsembleResult"),
         "trust_horizon": ("measurement.trust", "trust_horizon_of"), "sweep": ("sweep", None),
         "load_model": ("api", "load_model"), "equations": ("api", "equations"), "Pendulum": ("api", "Pendulum"),
         "linearize": ("runtime.linearize", "linearize"),
         "consistent_state": ("runtime.loop_state", "consistent_state"), "equilibria": ("runtime.linearize", "equilibria")}


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module 'derive' has no attribute {name!r}")
    module, attr = _LAZY[name]
    value = importlib.import_module(f".{module}", __name__)
    if attr is None:
        return value
    value = getattr(value, attr)
    globals()[name] = value            # resolved once: later calls find it directly
    return value
