"""The cache is checked, not trusted: entries are data with a checksum (never pickle),
damaged ones are recomputed, a library that does not match its checksum is rebuilt, a
cache directory of another owner or writable by others is refused, and outputs never
write through a planted symbolic link."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp

from derive import cachefile, errors, paths
from derive.derivation import derivation as dv
from derive.model import load_model

ROOT = Path(__file__).resolve().parents[2]


def test_entries_round_trip_as_data(tmp_path):
    x = sp.Symbol("x", real=True)
    value = {"m": sp.Matrix([[sp.sin(x) ** 2, sp.Rational(1, 3)], [sp.atan2(x, 1), sp.pi]]),
             "t": (1, 2.5, "s", None, True), "e": [x + 1]}
    cachefile.store(tmp_path / "v.json", value)
    back = cachefile.load(tmp_path / "v.json")
    assert back["m"] == value["m"] and back["t"] == value["t"] and back["e"] == value["e"]
    assert back["m"][0, 0].free_symbols == {x}                  # the assumptions survive


@pytest.mark.parametrize("model", ["compound", "spherical_std", "examples/models/cart_pole.toml"])
def test_a_derivation_stored_loads_as_the_same_expressions(model, tmp_path):
    """Entries write sums and products in their own argument order (not srepr's sorted
    display order): read back, every matrix and expression of a derivation is the same."""
    d = dv.derive(model)
    value = {"M": d.M, "F": d.F, "T": d.T, "V": d.V}
    cachefile.store(tmp_path / "d.json", value)
    back = cachefile.load(tmp_path / "d.json")
    assert set(back) == set(value)
    for key in value:
        assert back[key] == value[key], key
        assert type(back[key]) is type(value[key])


def test_a_function_named_like_sympys_is_not_read_as_sympys(tmp_path):
    """An undefined function called sin stays a stranger: the entry is refused (recomputed),
    never read back as the sine."""
    x = sp.Symbol("x")
    cachefile.store(tmp_path / "f.json", [sp.Function("sin")(x) + sp.cos(x)])
    assert cachefile.load(tmp_path / "f.json") is cachefile.MISSING


def test_a_flipped_bit_is_recomputed_not_used(tmp_path, monkeypatch):
    monkeypatch.setenv("DERIVE_CACHE_DIR", str(tmp_path / "cache"))
    model = load_model("planar")
    dv._memory.clear()                        # derived in this cache, not taken from memory
    good = dv.derive(model, use_cache=True)
    path = dv.cache_path(model)
    entry = json.loads(path.read_text())
    entry["payload"] = entry["payload"].replace("Integer(2)", "Integer(3)", 1)   # a wrong mass matrix
    path.write_text(json.dumps(entry))
    assert cachefile.load(path) is cachefile.MISSING                          # the checksum says so
    dv._memory.clear()
    again = dv.derive(model)
    assert again.M == good.M


def test_an_entry_that_would_run_code_is_refused(tmp_path):
    marker = tmp_path / "ran"
    payload = json.dumps({"__sympy__": f"__import__('os').system('touch {marker}')"})
    import hashlib
    (tmp_path / "evil.json").write_text(json.dumps({
        "format": cachefile.FORMAT, "payload": payload,
        "sha256": hashlib.sha256(payload.encode()).hexdigest()}))      # a valid checksum
    assert cachefile.load(tmp_path / "evil.json") is cachefile.MISSING
    assert not marker.exists()
    (tmp_path / "junk.json").write_bytes(os.urandom(300))
    assert cachefile.load(tmp_path / "junk.json") is cachefile.MISSING


def test_a_cache_writable_by_others_is_refused(tmp_path):
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    env = dict(os.environ, PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(shared))
    run = subprocess.run([sys.executable, "-m", "derive", "derive", "planar"], env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 2 and run.stderr.count("\n") == 1
    assert "writable by others" in run.stderr and "DERIVE_CACHE_DIR" in run.stderr


def test_a_cache_of_another_owner_is_refused(tmp_path, monkeypatch):
    folder = tmp_path / "theirs"
    folder.mkdir(mode=0o700)
    owner = folder.stat().st_uid
    monkeypatch.setattr(os, "getuid", lambda: owner + 1)      # as if another user ran derive
    paths._checked_cache.cache_clear()
    try:
        with pytest.raises(errors.CacheError, match="belongs to another user"):
            paths._checked_cache(str(folder))
    finally:
        paths._checked_cache.cache_clear()


def test_a_new_cache_is_private(tmp_path):
    paths._checked_cache.cache_clear()
    folder = paths._checked_cache(str(tmp_path / "fresh" / "cache"))
    assert folder.stat().st_mode & 0o777 == 0o700


def test_outputs_do_not_write_through_a_planted_link(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n")
    out = tmp_path / "out"
    out.mkdir()
    scene = (ROOT / "scenes" / "default.toml").read_text()
    (tmp_path / "s.toml").write_text(scene)
    (out / "s.csv").symlink_to(victim)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-m", "derive", "run", str(tmp_path / "s.toml"), "--quiet",
                          "--output-dir", str(out)], env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert victim.read_text() == "keep me\n"
    assert not (out / "s.csv").is_symlink() and (out / "s.csv").read_text().startswith("t,")


def test_a_verdict_entry_is_read_by_a_process_that_has_not_imported_its_class(tmp_path):
    """Verdicts hold claims.Result: a fresh process reading the cache before anything imported
    claims used to find an "unknown class" and judge every formula again (the cache never
    hit); now the entry loads, with no note."""
    entry = tmp_path / "verdicts.json"
    env = dict(os.environ, PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(tmp_path / "cache"))
    write = ("from pathlib import Path; from derive import cachefile; from derive.verification.claims import Result; "
             f"cachefile.store(Path({str(entry)!r}), [Result('000', '(1)', 'x', 'planar', 'match', 'ok')])")
    subprocess.run([sys.executable, "-c", write], env=env, check=True, timeout=300)
    read = (f"from pathlib import Path; from derive.verification import cached; "
            f"v = cached._read(Path({str(entry)!r})); print(type(v[0]).__name__, v[0].verdict)")
    run = subprocess.run([sys.executable, "-c", read], env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and run.stdout.strip() == "Result match" and run.stderr == "", run.stderr
