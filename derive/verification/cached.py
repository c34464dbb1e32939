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
from pathlib import Path

import mpmath
import sympy as sp

from ..derivation.derivation import cache_dir, cache_key
from ..model import load_model, model_names


def verification_key() -> str:
    h = hashlib.sha256()
    for name in model_names():
        h.update(cache_key(load_model(name)).encode())
    for path in sorted(Path(__file__).parent.glob("*.py")):
        h.update(path.read_bytes())
    h.update(f"{sp.__version__} {mpmath.__version__}".encode())
    return h.hexdigest()[:24]


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
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_bytes(pickle.dumps((results, checks)))
    tmp.replace(path)
    return results, checks, False
