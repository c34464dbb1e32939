"""Target languages: one backend object per language, each in a folder of its own.

A backend is everything derive knows about one target language: the folder of its
templates (derive/templates/<name>/) and of its files in a generated tree, the file
suffixes it writes there, its SymPy printer (derive/codegen/printers.py), the words
the language reserves, and the artifacts it emits for a model (kernels, integrators,
fixed-step loops) and for a chart atlas.  `derive generate`, the run-time cache and
the golden-file check take the list from `backends()`, which discovers every
subpackage here: adding a language is one new folder with an `__init__.py` defining
`BACKEND` (see c/, numpy/ and jax/), and one template folder.  A backend with
`by_default = False` (jax: its code needs the jax extra) is rendered only when chosen
by name (`selected`).
"""
from __future__ import annotations

import importlib
import pkgutil
from functools import cache

from ...errors import UsageError
from .base import Backend

__all__ = ["Backend", "backends", "default_names", "managed_suffixes", "selected"]


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


def default_names() -> tuple[str, ...]:
    """The names of the backends rendered when none is chosen (`Backend.by_default`).

    Returns
    -------
    tuple of str
        Sorted by name: what generated/ and the run time's cache hold.

    Examples
    --------
    >>> default_names()
    ('c', 'numpy')
    """
    return tuple(b.name for b in backends() if b.by_default)


def selected(names=None) -> tuple[Backend, ...]:
    """The backends called `names`, in discovery order (None: the default ones).

    Parameters
    ----------
    names : iterable of str, optional
        Backend names, as their folders under derive/codegen/backends/ are called.

    Returns
    -------
    tuple of Backend
        Each named backend once, sorted by name (so the files do not depend on the order
        the names were given in).

    Raises
    ------
    UsageError
        A name no backend has, or no name at all; the message lists the known names.

    Examples
    --------
    >>> [b.name for b in selected(["numpy", "jax"])]
    ['jax', 'numpy']
    >>> selected(["fortran"])
    Traceback (most recent call last):
    ...
    derive.errors.UsageError: unknown backend 'fortran' (known: c, jax, numpy)
    """
    every = backends()
    if names is None:
        return tuple(b for b in every if b.by_default)
    if isinstance(names, str):
        names = (names,)
    wanted = set(names)
    known = {b.name for b in every}
    unknown = sorted(wanted - known)
    if unknown or not wanted:
        what = f"unknown backend {unknown[0]!r}" if unknown else "no backend given"
        raise UsageError(f"{what} (known: {', '.join(sorted(known))})")
    return tuple(b for b in every if b.name in wanted)
