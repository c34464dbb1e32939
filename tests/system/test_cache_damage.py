"""Cache damage, for real: every kind of cache entry (derivation and rendered-code JSON,
the rendered C and Python, the compiled libraries and their checksums) truncated, filled
with random bytes, bit-flipped or replaced by a planted link or a file of another user;
a cache of another owner or writable by its group; four processes on one empty cache;
a process killed while its compiler runs.  Each is a rebuild with a one-line note (or
a one-line refusal), never a crash and never a different result.

The runs are subprocesses (a damaged library must not be mapped into the test process),
each on its own copy of one pristine cache."""
from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SEED = 13
OTHER_UID = 54321            # a user that is not us (the tests chown to it when run as root)
# one worker runs the file: the pristine cache (a derivation and a build from nothing, the
# fixture below) is made once, not once on each pytest-xdist worker that draws one of its tests
pytestmark = pytest.mark.xdist_group("cache_damage")

# the run every case repeats: a derivation, the C and the NumPy backend; prints its results
PROBE = """
import hashlib, numpy as np, sympy as sp
import derive
from derive.derivation import derive as derive_model
d = derive_model("planar")
print("M", hashlib.sha256(sp.srepr(d.M).encode()).hexdigest())
for backend in ("c", "numpy"):
    r = derive.simulate("planar", [2.5, 2.0, 0.0, 0.0], np.linspace(0, 2, 5), [1, 1, 1, 1, 9.81],
                        rtol=1e-10, backend=backend)
    print(backend, r.status, np.array2string(np.asarray(r.y, float), precision=12))
    print(backend, np.array2string(np.asarray(r.energy, float), precision=12))   # the kernel library
"""


def probe(cache: Path, timeout: float = 600, **popen):
    env = dict(os.environ, PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(cache))
    env.pop("DERIVE_DEBUG", None)
    return subprocess.run([sys.executable, "-W", "error", "-c", PROBE], env=env, capture_output=True,
                          text=True, timeout=timeout, **popen)


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    """A cache made by one run, and that run's output."""
    cache = tmp_path_factory.mktemp("pristine") / "cache"
    run = probe(cache)
    assert run.returncode == 0 and run.stderr == "", run.stderr
    return cache, run.stdout


def copy_of(pristine, tmp_path) -> Path:
    cache = tmp_path / "cache"
    shutil.copytree(pristine[0], cache, symlinks=True)
    return cache


ENTRIES = {   # kind -> glob of its files in the cache
    "derivation": "derivations/planar-*.json",
    "rendered": "rendered/planar-*.json",
    "kernels.c": "generated/planar-*/c/planar.c",
    "integrate.c": "generated/planar-*/c/planar_integrate.c",
    "kernels.py": "generated/planar-*/numpy/planar.py",
    "integrate.py": "generated/planar-*/numpy/planar_integrate.py",
    "listing": "generated/planar-*/.complete",
    "library": "c-build/*/libplanar_integrate.so",
    "kernel library": "c-build/*/libplanar.so",
    "checksum": "c-build/*/libplanar_integrate.so.sha256",
}
# the rendering is read only when the code made from it is written into the cache again
NEEDS_RENDERING = {"rendered"}


def truncate(path: Path, rng) -> None:
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])


def random_bytes(path: Path, rng) -> None:
    path.write_bytes(bytes(rng.randrange(256) for _ in range(path.stat().st_size)))


def bit_flip(path: Path, rng) -> None:
    data = bytearray(path.read_bytes())
    k = rng.randrange(len(data) * 8)
    data[k // 8] ^= 1 << (k % 8)
    path.write_bytes(bytes(data))


def planted_link(path: Path, rng) -> None:
    decoy = path.with_name(".decoy" + path.suffix)
    shutil.copyfile(path, decoy)
    bit_flip(decoy, rng)
    path.unlink()
    path.symlink_to(decoy)


def other_owner(path: Path, rng) -> None:
    os.chown(path, OTHER_UID, OTHER_UID)


DAMAGE = {"truncate": truncate, "random": random_bytes, "bitflip": bit_flip, "link": planted_link,
          "owner": other_owner}
AS_ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False


def _one_entry(cache: Path, kind: str) -> Path:
    found = sorted(cache.glob(ENTRIES[kind]))
    assert len(found) == 1, (kind, found)
    return found[0]


def _damage_and_run(pristine, tmp_path, kind, damage):
    if damage == "owner" and not AS_ROOT:
        pytest.skip("chown to another user needs root (the owner check is tested by "
                    "monkeypatch in test_cache.py)")
    cache = copy_of(pristine, tmp_path)
    path = _one_entry(cache, kind)
    DAMAGE[damage](path, random.Random(f"{SEED}-{kind}-{damage}"))
    if kind in NEEDS_RENDERING:        # make the run read it: nothing made from it is cached
        shutil.rmtree(cache / "generated")
    run = probe(cache)
    assert run.returncode == 0, run.stderr
    assert run.stdout == pristine[1]                       # never a different result
    lines = run.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("derive: note: "), run.stderr
    assert "again" in lines[0] or "rebuilding" in lines[0], run.stderr
    assert "Traceback" not in run.stderr
    again = probe(cache)                                    # repaired: no note the next time
    assert again.returncode == 0 and again.stderr == "" and again.stdout == pristine[1], again.stderr


# every kind of entry with one damage in the quick tier, every damage of every kind as slow
KINDS = sorted(ENTRIES)
QUICK = [(kind, list(DAMAGE)[i % len(DAMAGE)]) for i, kind in enumerate(KINDS)]
FULL = [(k, d) for k in KINDS for d in DAMAGE if (k, d) not in QUICK]


@pytest.mark.parametrize("kind, damage", QUICK, ids=[f"{k}-{d}" for k, d in QUICK])
def test_damaged_entry_is_rebuilt(pristine, tmp_path, kind, damage):
    _damage_and_run(pristine, tmp_path, kind, damage)


@pytest.mark.slow
@pytest.mark.parametrize("kind, damage", FULL, ids=[f"{k}-{d}" for k, d in FULL])
def test_every_damage_of_every_entry_is_rebuilt(pristine, tmp_path, kind, damage):
    _damage_and_run(pristine, tmp_path, kind, damage)


@pytest.mark.skipif(not AS_ROOT, reason="chown to another user needs root (monkeypatched in test_cache.py)")
def test_a_cache_of_another_owner_is_refused_for_real(pristine, tmp_path):
    cache = copy_of(pristine, tmp_path)
    os.chown(cache, OTHER_UID, OTHER_UID)
    run = probe(cache)
    assert run.returncode != 0
    lines = run.stderr.strip().splitlines()
    assert "belongs to another user" in lines[-1] and "DERIVE_CACHE_DIR" in lines[-1]
    cli = subprocess.run([sys.executable, "-m", "derive", "run", "default", "--quiet"], cwd=tmp_path,
                         env=dict(os.environ, PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(cache)),
                         capture_output=True, text=True, timeout=300)
    assert cli.returncode == 2 and cli.stderr.count("\n") == 1 and "belongs to another user" in cli.stderr


def test_a_group_writable_cache_is_refused(pristine, tmp_path):
    cache = copy_of(pristine, tmp_path)
    cache.chmod(0o770)
    cli = subprocess.run([sys.executable, "-m", "derive", "run", "default", "--quiet"], cwd=tmp_path,
                         env=dict(os.environ, PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(cache)),
                         capture_output=True, text=True, timeout=300)
    assert cli.returncode == 2 and cli.stderr.count("\n") == 1
    assert "writable by others (mode 770)" in cli.stderr


def test_planted_links_in_the_output_directory_are_replaced(tmp_path):
    """Every output file of a scene (CSV, NPZ, PNGs) with a link planted at its name: the
    link is replaced by the file, its target is untouched."""
    scene = (ROOT / "derive" / "scenes" / "default.toml").read_text().replace("stop = 5.0", "stop = 1.0")
    scene = scene.replace('trajectory = ["csv"]', 'trajectory = ["csv", "npz"]\nplots = ["paths", "energy"]')
    (tmp_path / "s.toml").write_text(scene)
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "victim"
    victim.write_text("keep me\n")
    names = ["s.csv", "s.npz", "s_paths.png", "s_energy.png"]
    for name in names:
        (out / name).symlink_to(victim)
    run = subprocess.run([sys.executable, "-m", "derive", "run", str(tmp_path / "s.toml"), "--quiet",
                          "--output-dir", str(out)], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0 and run.stderr == "", run.stderr
    assert victim.read_text() == "keep me\n"
    assert all((out / n).is_file() and not (out / n).is_symlink() for n in names)


@pytest.mark.slow
def test_four_processes_on_an_empty_cache(tmp_path):
    """Four processes start the same run on one empty cache at once: all succeed, with the
    same result, and the cache they leave is used by the next run without a note."""
    cache = tmp_path / "cache"
    env = dict(os.environ, PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(cache))
    procs = [subprocess.Popen([sys.executable, "-W", "error", "-c", PROBE], env=env, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE) for _ in range(4)]
    outs = [p.communicate(timeout=900) for p in procs]
    assert all(p.returncode == 0 for p in procs), [e for _, e in outs]
    assert all(e == "" for _, e in outs), [e for _, e in outs]
    assert len({o for o, _ in outs}) == 1
    again = probe(cache)
    assert again.returncode == 0 and again.stderr == "" and again.stdout == outs[0][0]


def _compiling(cache: Path) -> bool:
    """Whether a build is under way: build_library's temporary folder exists only while the
    compiler runs."""
    return any(p.is_dir() for p in cache.glob("c-build/*/tmp*"))


@pytest.mark.slow
def test_killed_while_compiling(tmp_path, pristine):
    """SIGKILL to the process (and its compiler) mid-build leaves a cache the next run uses."""
    cache = tmp_path / "cache"
    env = dict(os.environ, PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(cache))
    proc = subprocess.Popen([sys.executable, "-c", PROBE], env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 600
    while not _compiling(cache) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert proc.poll() is None and _compiling(cache), "the build was not caught while compiling"
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    run = probe(cache)
    assert run.returncode == 0 and run.stderr == "", run.stderr
    assert run.stdout == pristine[1]
