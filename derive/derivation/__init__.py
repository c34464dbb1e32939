"""Stage 2, the derivation: Lagrange's equations of every model with SymPy.

``derive(name)`` returns a :class:`Derivation`: positions, T, V, the mass
matrix M and forcing F with M q'' = F, the energy, and where the model asks
for them the Hamiltonian form and the seed's A/B/Q forms.  Results are cached
on disk keyed by the model description, the SymPy version and this code.
"""
from .derivation import Derivation, HamiltonianForm, cache_dir, compute, derive
from .symbols import ModelSymbols, model_symbols

__all__ = ["Derivation", "HamiltonianForm", "ModelSymbols", "cache_dir", "compute",
           "derive", "model_symbols"]
