"""The catalogue's reductions as data (derive/model/catalog/reductions.toml): which scene of
a model a cheaper model represents exactly, and how the two are matched."""
from __future__ import annotations

import tomllib
from dataclasses import dataclass
from functools import cache

from ..errors import ModelError
from ..paths import catalog_dir

KINDS = ("parameters", "vertical_plane")


@dataclass(frozen=True)
class Reduction:
    source: str                  # the scene's model (for an atlas: its standard member)
    target: str                  # the model that runs instead
    kind: str                    # one of KINDS
    holds: str                   # the planner's reason when the reduction applies
    fails: str                   # its reason when the condition does not hold
    unknowns: tuple = ()         # (target parameter, its stand-in in the match), kind "parameters"
    same: tuple = ()             # target parameters equal to the source's of the same name
    solve_for: tuple = ()        # source parameters the match fixes: the condition


@cache
def reductions() -> tuple[Reduction, ...]:
    path = catalog_dir() / "reductions.toml"
    try:
        tables = tomllib.loads(path.read_text()).get("reduction", [])
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ModelError(f"{path}: {exc}") from None
    out = []
    for i, t in enumerate(tables, 1):
        unknown = set(t) - set(Reduction.__dataclass_fields__)
        if unknown or t.get("kind") not in KINDS:
            raise ModelError(f"{path}: reduction {i}: unknown key or kind ({sorted(unknown) or t.get('kind')})")
        out.append(Reduction(t["source"], t["target"], t["kind"], t["holds"], t["fails"],
                             tuple(t.get("unknowns", {}).items()), tuple(t.get("same", ())),
                             tuple(t.get("solve_for", ()))))
    return tuple(out)


def reductions_of(model: str) -> tuple[Reduction, ...]:
    """The reductions whose source is `model`, in the file's order."""
    return tuple(r for r in reductions() if r.source == model)


def reduction(source: str, target: str) -> Reduction:
    for r in reductions_of(source):
        if r.target == target:
            return r
    raise ModelError(f"no reduction of {source} to {target} in the catalogue")
