"""Derive, generate and compile only what one model needs, reusing every cache.

Each step reports whether it was reused or done now, so `derive run` can say so:
- the derivation: the disk cache of derive.derivation (keyed by description,
  SymPy version and derivation code);
- the generated code: rendered once into the cache (derive.codegen.sources, keyed
  by everything that shapes it); generated/ in a checkout is never written here;
- the compiled library: the build cache (keyed by sources, compiler and flags).
"""
from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

from ..codegen import sources
from ..derivation import derive
from ..derivation.derivation import is_cached
from ..paths import cache_dir
from ..runtime.loader import load
from ..runtime.runner import library_path


@dataclass
class Step:
    what: str
    reused: bool
    seconds: float
    detail: str = ""

    def line(self) -> str:
        how = "reused (cached)" if self.reused else f"done in {self.seconds:.2f} s"
        return f"{self.what}: {how}{'; ' + self.detail if self.detail else ''}"


def _derivation(name: str) -> Step:
    cached = is_cached(name)
    start = time.perf_counter()
    derive(name)
    return Step(f"derivation of {name}", cached, time.perf_counter() - start)


def _generated(name: str) -> Step:
    """Render the model's generated code into the cache (never into generated/)."""
    reused = sources.is_rendered(name)
    start = time.perf_counter()
    folder = sources.model_sources(name)
    return Step(f"generated code of {name}", reused, time.perf_counter() - start,
                "" if reused else f"rendered into {folder}")


def _library(name: str) -> Step:
    start = time.perf_counter()
    before = set((cache_dir() / "c-build").glob("*/*.so"))
    # a time-dependent model's integrators too: they pass each stage's t
    builds = [lambda: library_path(name)]
    builds += [lambda model=model: load(model).path for model in sources.members(name)]
    # side by side: the threads wait on compilers (the loader runs one per core at once)
    with ThreadPoolExecutor(max_workers=len(builds)) as pool:
        libraries = list(pool.map(lambda build: build(), builds))
    # Only this model's libraries count: another process may build others meanwhile.
    built = set(libraries) - before
    return Step(f"compiled C for {name}", not built, time.perf_counter() - start)


def prepare(name: str, backend: str, stage=None) -> list[Step]:
    """Everything model `name` (or "spherical", the atlas) needs, cached where possible.
    `stage` (a derive.progress.Stage) is told what is being done, for a cold run's status line."""
    def doing(what: str) -> None:
        if stage is not None:
            stage.set(what)

    steps = _python_steps(name, doing)
    if backend == "c":
        doing(f"compiling the C of {name}")
        steps.append(_library(name))
    return steps


def _python_steps(name: str, doing) -> list[Step]:
    """The derivations and the rendered code of `name`: SymPy and Jinja2, in this thread."""
    steps = []
    for m in sources.members(name):
        doing(f"deriving {m}")
        steps.append(_derivation(m))
    doing(f"generating the code of {name}")
    steps.append(_generated(name))
    return steps


def prepare_c(names: list[str], stage=None, workers: int | None = None) -> list[Step]:
    """``prepare(name, "c")`` of every model of `names`, the compilers running side by side.

    Parameters
    ----------
    names : list of str
        Models (or atlases) to derive, render and compile.
    stage : derive.progress.Stage, optional
        Told what is being done.
    workers : int, optional
        Models compiled at once (default: all of them; the loader runs at most one
        compiler per core at once, derive.runtime.loader).

    Returns
    -------
    list of Step
        Every model's steps, in the order of `names`.
    """
    def doing(what: str) -> None:
        if stage is not None:
            stage.set(what)

    # SymPy and Jinja2 hold the interpreter: one model after another; a compiler is a
    # process of its own, so the compiles overlap (threads wait on them): every model's at
    # once, so that the cores stay busy to the last compile (an object two libraries
    # share, an atlas's and its chart's, is compiled once: the other waits for it)
    steps = {name: _python_steps(name, doing) for name in names}
    doing(f"compiling the C of {len(names)} models")
    with ThreadPoolExecutor(max_workers=workers or len(names) or 1) as pool:
        libraries = dict(zip(names, pool.map(_library, names)))
    return [step for name in names for step in (*steps[name], libraries[name])]
