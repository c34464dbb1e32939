"""derive: symbolic derivation and code generation for double-pendulum dynamics.

``derive.simulate(model, y0, t, params, ...)`` runs the generated integrators
(imported on first use, so ``import derive`` stays light).
"""

__all__ = ["simulate"]


def __getattr__(name):
    if name == "simulate":
        from .integration.simulate import simulate
        return simulate
    raise AttributeError(f"module 'derive' has no attribute {name!r}")
