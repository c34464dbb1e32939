"""derive: symbolic derivation and code generation for pendulum dynamics.

``derive.simulate(model, y0, t, params, ...)`` runs the generated integrators
(imported on first use, so ``import derive`` stays light); ``derive.trust_horizon(result,
target)`` says until when a run resolves the true motion to target; ``derive.sweep(file, ...)``
runs a sweep file on Dask and returns an xarray Dataset (the `sweep` extra).  Every failure derive
expects is a ``derive.DeriveError`` (see derive/errors.py).
"""
from .paths import VERSION as __version__
from .errors import (BuildError, CompilerMissingError, DeriveError, InputError,  # noqa: E402
                     ModelError, SceneError, SimulationError, SimulationInputError,
                     ToolMissingError)

__all__ = ["BuildError", "CompilerMissingError", "DeriveError", "InputError", "ModelError",
           "SceneError", "SimulationError", "SimulationInputError", "ToolMissingError",
           "__version__", "ensemble", "scipy_rhs", "simulate", "sweep", "trust_horizon"]


def __getattr__(name):
    if name == "simulate":
        from .runtime.simulate import simulate
        globals()["simulate"] = simulate        # resolved once: later calls find it directly
        return simulate
    if name == "ensemble":
        from .runtime.ensemble import ensemble
        globals()["ensemble"] = ensemble
        return ensemble
    if name == "scipy_rhs":
        from .runtime.scipy_rhs import scipy_rhs
        globals()["scipy_rhs"] = scipy_rhs
        return scipy_rhs
    if name == "trust_horizon":           # derive.trust_horizon(result, target): the measurement stage
        from .measurement.trust import trust_horizon_of
        globals()["trust_horizon"] = trust_horizon_of
        return trust_horizon_of
    if name == "sweep":                   # the sweep stage, callable: derive.sweep(SWEEP.toml, ...)
        import importlib
        return importlib.import_module(".sweep", __name__)
    raise AttributeError(f"module 'derive' has no attribute {name!r}")
