"""A model's sizes and names at run time, without its derivation.

A run needs of a model only its sizes and names (states, parameters, inputs, chart
guards: codegen.integrators.ModelInfo), but the derivation that has them is SymPy
objects, slow to read back even from the disk cache.  The first process that derives a
model writes its ModelInfo beside the derivation cache, under the same key (the model's
text, SymPy's version and the derivation code), so an entry is exactly as valid as the
derivation it summarises; every later process reads those few fields as JSON.  An entry
that is unreadable or malformed is ignored and written again.
"""
from __future__ import annotations

import json
from dataclasses import asdict, fields
from functools import lru_cache

from ..codegen.integrators import ModelInfo, model_info as derived_info
from ..derivation.derivation import cache_key
from ..errors import DeriveError
from ..model import load_model
from ..model.description import forget_on_model_change
from ..paths import cache_dir, replace_file

_TYPES = {"name": str, "title": str, "n": int, "n_params": int, "has_ham": bool, "nguards": int,
          "state_names": tuple, "param_names": tuple, "input_names": tuple}


@forget_on_model_change
@lru_cache(maxsize=None)
def model_info(name: str) -> ModelInfo:
    """The sizes and names of model `name` (a resolved name): from the cache, else from
    its derivation (then cached).

    Parameters
    ----------
    name : str

    Returns
    -------
    ModelInfo
    """
    model = load_model(name)
    path = cache_dir() / "model-info" / f"{model.name}-{cache_key(model)}.json"
    info = _read(path, name)
    if info is None:
        info = derived_info(name)
        try:
            replace_file(path, lambda tmp: tmp.write_text(json.dumps(asdict(info))))
        except (DeriveError, OSError):      # a read-only cache: the next process derives again
            pass
    return info


def _read(path, name: str) -> ModelInfo | None:
    """The entry at `path` when it is well formed and of model `name`, else None."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or set(data) != {f.name for f in fields(ModelInfo)} or data["name"] != name:
        return None
    values = {}
    for key, kind in _TYPES.items():
        value = data[key]
        if kind is tuple:
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                return None
            value = tuple(value)
        elif type(value) is not kind:
            return None
        values[key] = value
    return ModelInfo(**values)
