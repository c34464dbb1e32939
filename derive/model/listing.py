"""The catalogue's model names and the test for a model file: what the command line's
help and argument check need, without SymPy (derive/model/description.py parses models)."""
from __future__ import annotations

import os

from ..paths import catalog_dir

DATA_FILES = ("charts", "atlases", "reductions")      # catalogue files that are not models


def model_names() -> list[str]:
    """The catalogue's models.

    Returns
    -------
    list of str
        The name of every model file of ``catalog/`` (not its data files), sorted.
    """
    return sorted(p.stem for p in catalog_dir().glob("*.toml") if p.stem not in DATA_FILES)


def is_model_file(text: str | os.PathLike) -> bool:
    """Whether a model argument names a file (a path or a .toml name), not a catalogue entry.

    Parameters
    ----------
    text : str or os.PathLike
        A model argument as the user gave it.

    Returns
    -------
    bool
        True for a path (it has a separator) or a name ending in ``.toml``.
    """
    s = os.fspath(text)
    return s.endswith(".toml") or "/" in s or os.sep in s
