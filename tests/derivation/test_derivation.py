"""The derivation: exact identities every correct Lagrangian system satisfies, and the cache."""
import random

import mpmath
import pytest
import sympy as sp
from sympy.core.function import AppliedUndef

from derive import cachefile
from derive.derivation import compute, derive
from derive.derivation.derivation import cache_dir, cache_key
from derive.model import load_model, model_names
from derive.model.description import parse_model
from derive.verification.physics import accelerations
from derive.verification.zero import DIGITS, random_point, trig_is_zero


@pytest.mark.parametrize("name", model_names())
def test_plain_symbols_only(name):
    d = derive(name)
    exprs = list(d.M) + list(d.F) + [d.energy]
    assert not any(e.atoms(AppliedUndef) for e in exprs), "q(t) leaked into the derivation"
    allowed = set(d.symbols.state + d.symbols.params)
    assert set().union(*(e.free_symbols for e in exprs)) <= allowed


@pytest.mark.parametrize("name", model_names())
def test_energy_is_conserved_along_the_equations(name):
    """dE/dt = dE/dq q' + dE/dq' q'' vanishes when q'' solves M q'' = F (30 digits)."""
    d = derive(name)
    q, qd = d.symbols.q, d.symbols.qd
    qdd = sp.symbols(f"a0:{len(q)}")
    dE = sum(d.energy.diff(a) * b for a, b in zip(q, qd)) + sum(d.energy.diff(a) * b for a, b in zip(qd, qdd))
    f = sp.lambdify(list(d.symbols.state + d.symbols.params) + list(qdd), dE, modules="mpmath")
    rng = random.Random(3)
    with mpmath.workdps(DIGITS):
        for _ in range(20):
            pt = random_point(d.symbols.state + d.symbols.params, rng)
            acc = accelerations(d, pt)
            rate = f(*([pt[s] for s in d.symbols.state + d.symbols.params] + list(acc)))
            assert abs(rate) < mpmath.mpf(10) ** -30


# compound's (rods with inertia: about 10 s of CPU in trig_is_zero) in the slow tier; its
# Hamiltonian is held against seed 001's printed H in the fast tier (tests/verification)
@pytest.mark.parametrize("name", ["planar", pytest.param("compound", marks=pytest.mark.slow)])
def test_hamiltonian_force_is_lagrangian_gradient(name):
    """-dH/dq at p = M q' is dL/dq (seed 001's form of p'), exactly."""
    d = derive(name)
    h = d.hamiltonian
    p_of_rates = dict(zip(d.symbols.p, d.M * sp.Matrix(d.symbols.qd)))
    for lhs, rhs in zip(h.pdot, h.dL_dq):
        assert trig_is_zero(lhs.xreplace(p_of_rates) - rhs, d.symbols.q)
    rates = [e.xreplace(p_of_rates) for e in h.qdot]
    for rate, qd in zip(rates, d.symbols.qd):
        assert trig_is_zero(rate - qd, d.symbols.q)


def test_cache_round_trip_and_key():
    model = load_model("planar")
    key = cache_key(model)
    path = cache_dir() / "derivations" / f"planar-{key}.json"
    d = derive("planar")
    assert path.is_file()
    assert cachefile.load(path).M == d.M          # data with a checksum, not a pickle
    edited = parse_model(model.text.replace('title = "', 'title = "Edited: '), "planar.toml")
    assert cache_key(edited) != key, "a changed description must not hit the old cache entry"


def test_cached_equals_fresh():
    fresh = compute(load_model("compound"))
    cached = derive("compound")
    assert fresh.M == cached.M and fresh.F == cached.F and fresh.energy == cached.energy
