"""Integration: generated integrators (C and NumPy), the chart atlas and `simulate`.

Tableaus are data (*.toml here); codegen.py renders the integrator templates;
build.py compiles them; simulate.py is the user-facing API; atlas.py runs the
spherical chart atlas.
"""
from .simulate import SimulationError, SimulationInputError, SimulationResult, simulate

__all__ = ["SimulationError", "SimulationInputError", "SimulationResult", "simulate"]
