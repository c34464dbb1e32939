"""Verification results cached on disk.

Judging 200+ formulas exactly takes tens of seconds; the verdicts depend only
on the derivations (their cache keys), the verification code and the SymPy
and mpmath versions, so a warm `derive verify` reads them back.  Any change to
a model, the derivation or the verification code gives a new key.
"""
from __future__ import annotations

import hashlib
import os
import pickle

import mpmath
import sympy as sp

from ..derivation.derivation import cache_key
from ..paths import cache_dir, package_root
from ..model import load_model, model_names


def verification_key() -> str:
    h = hashlib.sha256()
    for name in model_names():
        h.update(cache_key(load_model(name)).encode())
    for path in sorted((package_root() / "verification").glob("*.py")):
        h.update(path.read_bytes())
    h.update(f"{sp.__version__} {mpmath.__version__}".encode())
    return h.hexdigest()[:24]


def _code_key() -> str:
    h = hashlib.sha256()
    for path in sorted((package_root() / "verification").glob("*.py")):
        h.update(path.read_bytes())
    h.update(f"{sp.__version__} {mpmath.__version__}".encode())
    return h.hexdigest()


def _write(path, value) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_bytes(pickle.dumps(value))
    tmp.replace(path)


def physics_model(model):
    """The physics checks concerning one model (a catalogue name or a Model, e.g. a user's
    model file), cached per model: the model's own checks and, for a catalogue model,
    those relating it to the others (whose derivations are then part of the key)."""
    from ..model import Model
    m = model if isinstance(model, Model) else load_model(model)
    catalogue = m.name in model_names() and load_model(m.name).content_hash == m.content_hash
    extra = verification_key() if catalogue else ""
    key = hashlib.sha256(f"{cache_key(m)} {_code_key()} {extra}".encode()).hexdigest()[:24]
    path = cache_dir() / "verification" / f"physics-{m.name}-{key}.pickle"
    if path.is_file():
        try:
            return pickle.loads(path.read_bytes())
        except Exception:
            pass
    from . import physics
    checks = physics.model_checks(m.name if catalogue else m)
    _write(path, checks)
    return checks


def verify_model(name: str):
    """The seed verdicts of one model's printed formulas (none for a model without seed
    formulas), cached per model: rendering one model's document verifies only that model."""
    whole = cache_dir() / "verification" / f"results-{verification_key()}.pickle"
    if whole.is_file():
        try:
            return [r for r in pickle.loads(whole.read_bytes())[0] if r.model == name]
        except Exception:     # unreadable: judge this model's formulas below
            pass
    key = hashlib.sha256(f"{cache_key(load_model(name))} {_code_key()}".encode()).hexdigest()[:24]
    path = cache_dir() / "verification" / f"{name}-{key}.pickle"
    if path.is_file():
        try:
            return pickle.loads(path.read_bytes())
        except Exception:
            pass
    from . import claims
    results = [claims.judge(c) for c in claims.all_claims() if c.model == name]
    _write(path, results)
    return results


def verify_all(fresh: bool = False):
    """(seed results, physics checks, whether they came from the cache)."""
    path = cache_dir() / "verification" / f"results-{verification_key()}.pickle"
    if not fresh and path.is_file():
        try:
            results, checks = pickle.loads(path.read_bytes())
            return results, checks, True
        except Exception:     # unreadable cache entry: verify afresh below
            pass
    from . import claims, physics
    results, checks = claims.run_all(), physics.run_all()
    _write(path, (results, checks))
    return results, checks, False
