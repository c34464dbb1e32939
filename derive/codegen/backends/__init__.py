"""Target languages: one backend object per language, each in a folder of its own.

A backend is everything derive knows about one target language: the folder of its
templates (derive/templates/<name>/) and of its files in a generated tree, the file
suffixes it writes there, its SymPy printer (derive/codegen/printers.py), the words
the language reserves, and the artifacts it emits for a model (kernels, integrators,
fixed-step loops) and for a chart atlas.  `derive generate`, the run-time cache and
the golden-file check take the list from `backends()`, which discovers every
subpackage here: adding a language is one new folder with an `__init__.py` defining
`BACKEND` (see c/ and numpy/), and one template folder.
"""
from __future__ import annotations

import importlib
import pkgutil
from functools import cache

from .base import Backend

__all__ = ["Backend", "backends", "managed_suffixes"]


@cache
def backends() -> tuple[Backend, ...]:
    """Every backend under derive/codegen/backends/, by name (so generation order, and
    with it every generated tree, does not depend on the file system)."""
    found = []
    for info in pkgutil.iter_modules(__path__):
        if info.ispkg:
            module = importlib.import_module(f"{__name__}.{info.name}")
            backend = getattr(module, "BACKEND", None)
            if not isinstance(backend, Backend):
                raise TypeError(f"derive/codegen/backends/{info.name}: no BACKEND (a Backend instance)")
            found.append(backend)
    return tuple(sorted(found, key=lambda b: b.name))


def managed_suffixes() -> dict[str, tuple[str, ...]]:
    """{folder of a generated tree: the suffixes its backend writes there}."""
    return {b.name: b.suffixes for b in backends()}
