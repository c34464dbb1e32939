"""Verification results cached on disk.

Judging 200+ formulas exactly takes tens of seconds; the verdicts depend only
on the derivations (their cache keys), the verification code and the SymPy
and mpmath versions, so a warm `derive verify` reads them back.  Any change to
a model, the derivation or the verification code gives a new key.
"""
from __future__ import annotations

import hashlib

import mpmath
import sympy as sp

from .. import cachefile
from ..derivation.derivation import cache_key
from ..paths import cache_dir, package_root
from ..model import Model, load_model, model_names
from ..derivation.workers import run_all
from . import claims, judge, physics   # claims and physics register the dataclasses entries hold


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


def _read(path):
    """A cached value (checked, parsed as data), or None when there is none usable."""
    value = cachefile.load(path) if path.is_file() else cachefile.MISSING
    return None if value is cachefile.MISSING else value


def physics_model(model):
    """The physics checks concerning one model (a catalogue name or a Model, e.g. a user's
    model file), cached per model: the model's own checks and, for a catalogue model,
    those relating it to the others (whose derivations are then part of the key)."""
    m = model if isinstance(model, Model) else load_model(model)
    catalogue = m.name in model_names() and load_model(m.name).content_hash == m.content_hash
    extra = verification_key() if catalogue else ""
    key = hashlib.sha256(f"{cache_key(m)} {_code_key()} {extra}".encode()).hexdigest()[:24]
    path = cache_dir() / "verification" / f"physics-{m.name}-{key}.json"
    checks = _read(path)
    if isinstance(checks, list):
        return checks
    checks = physics.model_checks(m.name if catalogue else m)
    cachefile.store(path, checks)
    return checks


def verify_model(name: str):
    """The seed verdicts of one model's printed formulas (none for a model without seed
    formulas), cached per model: rendering one model's document verifies only that model."""
    whole = _read(cache_dir() / "verification" / f"results-{verification_key()}.json")
    if isinstance(whole, tuple):
        return [r for r in whole[0] if r.model == name]
    key = hashlib.sha256(f"{cache_key(load_model(name))} {_code_key()}".encode()).hexdigest()[:24]
    path = cache_dir() / "verification" / f"{name}-{key}.json"
    results = _read(path)
    if isinstance(results, list):
        return results
    results = [judge.judge(c) for c in judge.all_claims() if c.model == name]
    cachefile.store(path, results)
    return results


def _judged_side_by_side(alongside) -> tuple[list, list]:
    """judge.run_all() and physics.run_all(), their calls shared among worker processes
    (derive.workers) with the calls `alongside`: the longest kinds first."""
    claim_calls, check_calls = judge.judging_calls(), physics.check_calls()
    done = run_all(list(alongside) + check_calls + claim_calls)[len(alongside):]
    checks = done[:len(check_calls)]
    return [r for share in done[len(check_calls):] for r in share], checks


def verify_all(fresh: bool = False, alongside=()):
    """(seed results, physics checks, whether they came from the cache).

    Parameters
    ----------
    fresh : bool
        Judge again even when the verdicts are in the cache.
    alongside : sequence of (callable, tuple)
        Independent calls of the command (rendering the generated code, say) for the same
        worker processes to make meanwhile; their results are dropped.
    """
    path = cache_dir() / "verification" / f"results-{verification_key()}.json"
    cached = None if fresh else _read(path)
    if isinstance(cached, tuple):
        run_all(alongside)
        results, checks = cached
        return results, checks, True
    results, checks = _judged_side_by_side(alongside)
    cachefile.store(path, (results, checks))
    return results, checks, False
