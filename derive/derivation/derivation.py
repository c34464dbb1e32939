"""Assemble a model's full derivation (one object) and cache it on disk."""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field
from pathlib import Path

import sympy as sp

from .. import cachefile
from ..model import Model, load_model
from ..paths import cache_dir, package_root
from . import hamilton, lagrange, loop_closure
from .loop_closure import ConstraintForm
from .paper import PaperForms, paper_forms
from .symbols import ModelSymbols, model_symbols


@cachefile.register
@dataclass
class HamiltonianForm:
    """H = 1/2 p^T M^-1 p + V.  The closed forms (M^-1, H, q'(p), p'(q, p)) are written
    out for up to two coordinates; beyond, they are None and the generated code solves
    M q' = p instead (dL_dq at that q' is p')."""
    M_inv: sp.Matrix | None
    H: sp.Expr | None
    qdot: sp.Matrix | None    # dH/dp = M^-1 p, in (q, p)
    pdot: sp.Matrix | None    # -dH/dq, in (q, p)
    dL_dq: sp.Matrix          # dL/dq in (q, q'): p' once q' = M^-1 p is substituted


@cachefile.register
@dataclass
class Derivation:
    model: Model
    symbols: ModelSymbols
    tips: list[sp.Matrix]          # Cartesian position of each link's tip
    centres: list[sp.Matrix]       # Cartesian position of each body's mass centre
    M: sp.Matrix                   # mass matrix, M q'' = F
    F: sp.Matrix                   # forcing
    T: sp.Expr
    V: sp.Expr
    hamiltonian: HamiltonianForm | None = None
    paper: PaperForms | None = None
    dissipation: sp.Expr | None = None     # Rayleigh's R(q', q); F includes -dR/dq'
    forces: sp.Matrix | None = None        # applied generalized forces Q; F includes them
    polar_sines: list[sp.Expr] = field(default_factory=list)
    constraints: ConstraintForm | None = None  # a closed loop: M q'' + J^T lambda = F, J q'' = gamma
    seconds: float = 0.0           # time the derivation took when it was computed

    @property
    def L(self) -> sp.Expr:
        return self.T - self.V

    @property
    def energy(self) -> sp.Expr:
        return self.T + self.V

    @property
    def name(self) -> str:
        return self.model.name


def compute(model: Model) -> Derivation:
    start = time.perf_counter()
    s = model_symbols(model)
    if model.is_chain:              # today's structured chain form (the catalogue's path)
        form = lagrange.chain_form(model, s)
        tips, centres = lagrange.tip_positions(model, s), lagrange.mass_centres(model, s)
        pivot = lagrange.pivot_terms(model, s)
    else:                           # a kinematic tree: positions, Jacobians, M, V
        geo = lagrange.tree_geometry(model, s)
        form, T_time = lagrange.tree_form(model, s, geo)
        tips, centres = geo.tips, geo.centres
        pivot = lagrange.PivotTerms(T_time, sp.S.Zero, lagrange.explicit_time_forcing(T_time, s))
    M = lagrange.mass_matrix(form)
    V = lagrange.potential_energy(form)
    R = lagrange.dissipation_function(model, s)
    Q = lagrange.generalized_forces(model, s, tips, centres)
    F = lagrange.forcing(form, s) + lagrange.moving_mass_forcing(M, s)
    if R is not None or Q is not None:
        F = F + lagrange.non_conservative(R, Q, s)
    T = lagrange.kinetic_energy(M, s)
    if pivot is not None:           # explicit time (a moving pivot): T, V and F gain its terms
        T, V, F = T + pivot.T, V + pivot.V, F + pivot.F
    for potential in (lagrange.model_potential(model, s),
                      lagrange.spring_potential(model, s, tips, centres)):
        if potential is not None:   # the model's own potential and its springs', beside gravity's
            V = V + potential
            F = F - sp.Matrix([sp.factor_terms(sp.expand(potential.diff(qj))) for qj in s.q])
    d = Derivation(model=model, symbols=s, tips=tips, centres=centres,
                   M=M, F=F, T=T, V=V, dissipation=R, forces=Q,
                   constraints=loop_closure.constraint_form(model, s))
    for link in model.links:
        sine = link.chart.polar_sine_of([s.q[j] for j in model.link_coordinates(link)])
        if sine is not None:
            d.polar_sines.append(sine)
    if "hamiltonian" in model.forms:
        dL_dq = hamilton.lagrangian_gradient(form, s)
        if len(s.q) <= 2:           # closed forms are short: seed 001 writes them out
            M_inv = hamilton.inverse_mass_matrix(M)
            H = hamilton.hamiltonian(M_inv, V, s)
            d.hamiltonian = HamiltonianForm(M_inv, H, *hamilton.hamilton_equations(H, s), dL_dq)
        else:                       # no symbolic inverse: the code solves M q' = p
            d.hamiltonian = HamiltonianForm(None, None, None, None, dL_dq)
    if "paper" in model.forms:
        d.paper = paper_forms(model, s)
    d.seconds = time.perf_counter() - start
    return d


# -- the disk cache ---------------------------------------------------------

def _code_hash() -> str:
    """The derivation code itself is part of the key: editing it invalidates the cache."""
    h = hashlib.sha256()
    for path in sorted((package_root() / "derivation").glob("*.py")):
        h.update(path.read_bytes())
    h.update((package_root() / "model" / "description.py").read_bytes())
    return h.hexdigest()


def cache_key(model: Model) -> str:
    text = "\0".join([model.content_hash, sp.__version__, _code_hash()])
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def cache_path(model: Model) -> Path:
    """Where the derivation of `model` is (or will be) cached."""
    return cache_dir() / "derivations" / f"{model.name}-{cache_key(model)}.json"


def is_cached(name: str | Model) -> bool:
    """Whether derive() will read this model from the disk cache."""
    return cache_path(load_model(name) if isinstance(name, str) else name).is_file()


_memory: dict[str, Derivation] = {}


def derive(name: str | Model, use_cache: bool = True) -> Derivation:
    """The derivation of a model, from memory, the disk cache, or computed now."""
    model = load_model(name) if isinstance(name, str) else name
    key = cache_key(model)
    if use_cache and key in _memory:
        return _memory[key]
    path = cache_path(model)
    if use_cache and path.is_file():
        d = cachefile.load(path)        # checked and parsed as data; MISSING if damaged
        if isinstance(d, Derivation) and d.model.text == model.text:
            d.model = model
            _memory[key] = d
            return d
    d = compute(model)
    if use_cache:
        cachefile.store(path, d)
        _memory[key] = d
    return d
