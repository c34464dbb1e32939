"""Derive, generate and compile only what one model needs, reusing every cache.

Each step reports whether it was reused or done now, so `derive run` can say so:
- the derivation: the disk cache of derive.derivation (keyed by description,
  SymPy version and derivation code);
- the generated code: the model's files are rendered and compared with
  generated/ (rewritten when stale); a marker keyed by everything that shapes
  them (derivation key, templates, code generators) skips the rendering next time;
- the compiled library: the build cache (keyed by sources, compiler and flags).
"""
from __future__ import annotations

import hashlib
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ..derivation import derive
from ..derivation.derivation import cache_dir, cache_key, is_cached
from ..model import load_model

ROOT = Path(__file__).resolve().parents[2]
ATLAS_CHARTS = ("spherical_std", "spherical_alt", "spherical_rot")


@dataclass
class Step:
    what: str
    reused: bool
    seconds: float
    detail: str = ""

    def line(self) -> str:
        how = "reused (cached)" if self.reused else f"done in {self.seconds:.2f} s"
        return f"{self.what}: {how}{'; ' + self.detail if self.detail else ''}"


def _tree_hash(*folders: Path) -> str:
    h = hashlib.sha256()
    for folder in folders:
        for path in sorted(folder.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                h.update(str(path.relative_to(ROOT)).encode())
                h.update(path.read_bytes())
    return h.hexdigest()


def _write_atomically(path: Path, text: str) -> None:
    """Write through a temporary file in the same folder, then rename: a concurrent
    reader (another `derive run`, another test worker) sees the old or the new file,
    never a partial one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _derivation(name: str) -> Step:
    cached = is_cached(name)
    start = time.perf_counter()
    derive(name)
    return Step(f"derivation of {name}", cached, time.perf_counter() - start)


def _render(name: str) -> dict[str, str]:
    from ..codegen.generate import render_model
    from ..integration.codegen import render_atlas, render_c, render_numpy
    files = dict(render_model(name))
    files.update(render_c(name))
    files.update(render_numpy(name))
    if name == ATLAS_CHARTS[0]:
        files.update(render_atlas())
    return files


def _generated(name: str) -> Step:
    key = hashlib.sha256("\0".join([
        str(ROOT),                   # the marker vouches for this checkout's generated/ only
        cache_key(load_model(name)),
        _tree_hash(ROOT / "templates", ROOT / "derive" / "codegen", ROOT / "derive" / "integration"),
    ]).encode()).hexdigest()[:24]
    marker = cache_dir() / "generated" / f"{name}-{key}.ok"
    start = time.perf_counter()
    if marker.is_file():
        return Step(f"generated code of {name}", True, 0.0)
    rewritten = []
    for rel, text in sorted(_render(name).items()):
        path = ROOT / "generated" / rel
        if not path.is_file() or path.read_text() != text:
            _write_atomically(path, text)
            rewritten.append(f"generated/{rel}")
    _write_atomically(marker, "\n".join(rewritten))
    detail = f"rewrote {', '.join(rewritten)}" if rewritten else "generated/ was current"
    return Step(f"generated code of {name}", False, time.perf_counter() - start, detail)


def _library(name: str) -> Step:
    from ..integration import build
    start = time.perf_counter()
    before = set((cache_dir() / "c-build").glob("*/*.so"))
    if name == "spherical":
        from ..integration.atlas import atlas_library
        libraries = [atlas_library().path]
    else:
        libraries = [build.integrator_library(name).path]
    from ..codegen.loader import load
    for model in (ATLAS_CHARTS if name == "spherical" else (name,)):
        libraries.append(load(model).path)
    # Only this model's libraries count: another process may build others meanwhile.
    built = set(libraries) - before
    return Step(f"compiled C for {name}", not built, time.perf_counter() - start)


def prepare(name: str, backend: str) -> list[Step]:
    """Everything model `name` (or "spherical", the atlas) needs, cached where possible."""
    models = ATLAS_CHARTS if name == "spherical" else (name,)
    steps = [_derivation(m) for m in models] + [_generated(m) for m in models]
    if backend == "c":
        steps.append(_library(name))
    return steps
