"""`derive run` at the limits of its file system: eight runs on one empty cache at once, a
cache that cannot be written, a full disk under the cache and under the output folder.

Each case is a subprocess run of one small scene (the default scene to t = 1) compared with
the same run on a cache of its own: the state line and the CSV must be the same bytes.
Writes are denied for real: as root (where chmod does not stop a write) by a read-only
bind mount or a small tmpfs in a mount namespace of the run's own (`unshare -m`); a
machine where no mount namespace can be made runs the full-disk cases under a file-size
limit (RLIMIT_FSIZE, SIGXFSZ ignored: a write past it fails with EFBIG) and the read-only
case with chmod as a user that is not root.  Each case first checks that the write is
refused."""
from __future__ import annotations

import os
import resource
import signal
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
AS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


def _scene(folder: Path) -> Path:
    text = (ROOT / "derive" / "scenes" / "default.toml").read_text()
    assert "stop = 5.0" in text and 'trajectory = ["csv"]' in text
    scene = folder / "s.toml"
    scene.write_text(text.replace("stop = 5.0", "stop = 1.0"))
    return scene


def _env(cache: Path, **extra) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT), DERIVE_CACHE_DIR=str(cache), **extra)
    env.pop("DERIVE_DEBUG", None)
    return env


def _run_cmd(scene: Path, out: Path, *flags: str) -> list[str]:
    return [sys.executable, "-W", "error", "-m", "derive", "run", str(scene), "--output-dir", str(out), *flags]


def _state(stdout: str) -> str:
    lines = [line for line in stdout.splitlines() if line.startswith("state ")]
    assert len(lines) == 1, stdout
    return lines[0]


def _steps(stdout: str) -> list[str]:
    """The report's lines on what was derived, generated and compiled (or reused)."""
    return [line.strip() for line in stdout.splitlines()
            if line.strip().startswith(("derivation of", "generated code of", "compiled C for"))]


def _one_line_error(run, *words: str) -> None:
    assert run.returncode != 0, (run.returncode, run.stdout[-2000:], run.stderr)
    assert "Traceback" not in run.stderr and run.stderr.count("\n") == 1, run.stderr
    for word in words:
        assert word in run.stderr, (word, run.stderr)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The scene, a cache made by one run of it, and that run's state line and CSV."""
    folder = tmp_path_factory.mktemp("reference")
    scene = _scene(folder)
    cache = folder / "cache"
    run = subprocess.run(_run_cmd(scene, folder / "out"), env=_env(cache), capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0 and run.stderr == "", run.stderr
    return scene, cache, _state(run.stdout), (folder / "out" / "s.csv").read_bytes()


# -- eight at once -----------------------------------------------------------------------

@pytest.mark.slow
def test_eight_concurrent_runs_on_one_empty_cache(reference, tmp_path):
    """Eight `derive run` of one scene start together on one empty cache: every one exits 0
    without a word on stderr, with the reference's state line and CSV; a ninth run then
    reuses every derivation, rendering and build."""
    scene, _, state, csv = reference
    cache = tmp_path / "cache"
    procs = [subprocess.Popen(_run_cmd(scene, tmp_path / f"out{i}"), env=_env(cache), text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE) for i in range(8)]
    outs = [p.communicate(timeout=1800) for p in procs]
    assert [p.returncode for p in procs] == [0] * 8, [e for _, e in outs]
    assert [e for _, e in outs] == [""] * 8
    assert {_state(o) for o, _ in outs} == {state}
    assert all((tmp_path / f"out{i}" / "s.csv").read_bytes() == csv for i in range(8))
    ninth = subprocess.run(_run_cmd(scene, tmp_path / "out9"), env=_env(cache), capture_output=True, text=True,
                           timeout=900)
    assert ninth.returncode == 0 and ninth.stderr == "", ninth.stderr
    steps = _steps(ninth.stdout)
    assert len(steps) == 3 and all(s.endswith("reused (cached)") for s in steps), ninth.stdout
    assert _state(ninth.stdout) == state and (tmp_path / "out9" / "s.csv").read_bytes() == csv


# -- a cache that cannot be written -------------------------------------------------------

READ_ONLY = """set -eu
mount --bind "$1" "$1"
mount -o remount,ro,bind "$1" "$1"
if touch "$1/.probe" 2>/dev/null; then echo "the cache is writable" >&2; exit 99; fi
shift
exec "$@"
"""


def _read_only_run(cache: Path, cmd: list[str], env: dict, tmp_path: Path):
    """`cmd` with `cache` read-only for it (denied writes checked first)."""
    if AS_ROOT:
        script = tmp_path / "read_only.sh"
        script.write_text(READ_ONLY)
        run = subprocess.run(["unshare", "-m", "sh", str(script), str(cache), *cmd], env=env,
                             capture_output=True, text=True, timeout=900)
        assert run.returncode != 99, "a read-only bind mount did not stop a write"
        assert "mount:" not in run.stderr and "unshare:" not in run.stderr, run.stderr
        return run
    for folder in [cache, *[p for p in cache.rglob("*") if p.is_dir()]]:
        folder.chmod(0o555)
    with pytest.raises(PermissionError):
        (cache / ".probe").write_text("x")
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900)


def _listing(cache: Path) -> dict[str, bytes]:
    return {str(p.relative_to(cache)): p.read_bytes() for p in sorted(cache.rglob("*")) if p.is_file()}


@pytest.mark.slow
@pytest.mark.parametrize("filled", [True, False], ids=["filled", "empty"])
def test_a_read_only_cache_runs_in_a_temporary_one_with_one_note(reference, tmp_path, filled):
    """A cache that cannot be written: the run works (in a private temporary cache, removed
    at exit), says so in one note on stderr, gives the reference's results, and leaves the
    read-only cache as it was."""
    scene, pristine, state, csv = reference
    cache = tmp_path / "cache"
    if filled:
        shutil.copytree(pristine, cache, symlinks=True)
    else:
        cache.mkdir(mode=0o700)
    before = _listing(cache)
    scratch = tmp_path / "tmp"              # where the temporary cache goes
    scratch.mkdir()
    run = _read_only_run(cache, _run_cmd(scene, tmp_path / "out"), _env(cache, TMPDIR=str(scratch)), tmp_path)
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr and run.stderr.count("\n") == 1, run.stderr
    assert run.stderr.startswith(f"derive: note: the cache directory '{cache}' is not writable ("), run.stderr
    assert "temporary cache" in run.stderr
    assert _state(run.stdout) == state and (tmp_path / "out" / "s.csv").read_bytes() == csv
    assert _listing(cache) == before
    assert list(scratch.iterdir()) == []     # the temporary cache is gone


# -- a full disk ---------------------------------------------------------------------------

FULL_THEN_ROOMY = """set -u
dir=$1; size=$2; log=$3; shift 3
mount -t tmpfs -o "size=$size,mode=0700" tmpfs "$dir" || exit 97
if head -c 4194304 /dev/zero > "$dir/.fill" 2>/dev/null; then exit 96; fi
rm -f "$dir/.fill"
"$@" > "$log.out1" 2> "$log.err1"; echo $? > "$log.rc1"
find "$dir" -mindepth 1 -printf '%P\\n' > "$log.files1"
mount -o remount,size=64m "$dir" || exit 98
"$@" > "$log.out2" 2> "$log.err2"; echo $? > "$log.rc2"
cp -a "$dir" "$log.copy"
"""


def _tmpfs_possible(tmp_path: Path) -> bool:
    probe = tmp_path / "mount-probe"
    probe.mkdir()
    try:
        return subprocess.run(["unshare", "-m", "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs '{probe}'"],
                              capture_output=True, timeout=60).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


class Runs:
    def __init__(self, rc, out, err):
        self.returncode, self.stdout, self.stderr = rc, out, err


def _full_then_roomy(folder: Path, size: int, fsize: int, cmd: list[str], env: dict, tmp_path: Path):
    """`cmd` run twice: first with `folder` on a file system of `size` bytes (a tmpfs), or
    under a file-size limit of `fsize` bytes; then with room to spare.  -> (first run,
    the files the first run left in `folder`, second run, a copy of `folder` after it)."""
    if _tmpfs_possible(tmp_path):
        script, log = tmp_path / "full.sh", tmp_path / "log"
        script.write_text(FULL_THEN_ROOMY)
        folder.mkdir(exist_ok=True)
        setup = subprocess.run(["unshare", "-m", "sh", str(script), str(folder), str(size), str(log), *cmd],
                               env=env, capture_output=True, text=True, timeout=1800)
        assert setup.returncode not in (96, 97, 98), (setup.returncode, setup.stderr)
        read = lambda suffix: Path(f"{log}{suffix}").read_text()
        first = Runs(int(read(".rc1")), read(".out1"), read(".err1"))
        second = Runs(int(read(".rc2")), read(".out2"), read(".err2"))
        return first, read(".files1").split(), second, Path(f"{log}.copy")

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
    fill = subprocess.run(["sh", "-c", f"head -c {2 * fsize} /dev/zero > '{tmp_path / 'fill'}'"],
                          preexec_fn=limit, capture_output=True)
    assert fill.returncode != 0, "the file-size limit did not refuse a write"
    first = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=1800, preexec_fn=limit)
    files = [str(p.relative_to(folder)) for p in folder.rglob("*")] if folder.exists() else []
    second = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=1800)
    return first, files, second, folder


def _no_leftovers(files: list[str]) -> None:
    """Nothing half-written: no temporary file or folder (theirs start with '.') beside the
    entries, the '.complete' listings of finished renderings and the checksums apart."""
    for rel in files:
        name = Path(rel).name
        assert not name.startswith(".") or name == ".complete", f"left behind: {rel}"


@pytest.mark.slow
def test_a_full_disk_under_the_cache(reference, tmp_path):
    """The cache on a 1 MiB file system (it needs about 1.2 MiB: the derivation and the
    rendered code fit, the compiled libraries do not; under a file-size limit instead, 256 KiB:
    the rendered code does not fit): one line naming the path and the
    system's reason, exit 2, nothing half-written left; the same cache with room then gives
    the reference's results without a note."""
    scene, _, state, csv = reference
    cache = tmp_path / "cache"
    first, files, second, _ = _full_then_roomy(cache, 1 << 20, 256 << 10, _run_cmd(scene, tmp_path / "out", "--quiet"),
                                               _env(cache), tmp_path)
    _one_line_error(first, "derive: error: cannot write '", str(cache))
    assert first.returncode == 2
    assert "No space left on device" in first.stderr or "File too large" in first.stderr, first.stderr
    _no_leftovers(files)
    assert second.returncode == 0 and second.stderr == "", second.stderr
    assert (tmp_path / "out" / "s.csv").read_bytes() == csv


@pytest.mark.slow
def test_a_full_disk_under_the_output_folder(reference, tmp_path):
    """The output folder on a 64 KiB file system (the CSV is about 140 KB): one line naming
    the CSV and the reason, exit 2, no partial CSV; with room, the reference's CSV."""
    scene, pristine, state, csv = reference
    cache = tmp_path / "cache"
    shutil.copytree(pristine, cache, symlinks=True)
    out = tmp_path / "out"
    first, files, second, copy = _full_then_roomy(out, 64 << 10, 64 << 10, _run_cmd(scene, out), _env(cache), tmp_path)
    _one_line_error(first, f"derive: error: cannot write '{out / 's.csv'}': ")
    assert first.returncode == 2
    assert "No space left on device" in first.stderr or "File too large" in first.stderr, first.stderr
    assert files == [], files                  # no partial CSV, no temporary file
    assert second.returncode == 0 and second.stderr == "", second.stderr
    assert _state(second.stdout) == state
    assert (copy / "s.csv").read_bytes() == csv
