"""Chart atlases as data (catalog/atlases.toml): the member charts of one chain, the
switching rule of seed 000 section 5.1 and its thresholds."""
from __future__ import annotations

import tomllib
from dataclasses import dataclass
from functools import cache

from ..errors import ModelError
from ..paths import catalog_dir


@dataclass(frozen=True)
class Atlas:
    name: str
    title: str
    source: str
    charts: tuple[str, ...]        # member models, in chart-number order; the first is standard
    rule: str
    sine_rule: str                 # thresholds as decimal text (printed into the generated code)
    sine_switch: str
    sine_min: str


@cache
def atlases() -> dict[str, Atlas]:
    path = catalog_dir() / "atlases.toml"
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ModelError(f"{path}: {exc}") from None
    out = {}
    for name, t in data.items():
        fields = {k: t.get(k) for k in Atlas.__dataclass_fields__ if k != "name"}
        missing = [k for k, v in fields.items() if v is None]
        if missing:
            raise ModelError(f"{path}: atlas '{name}': missing key '{missing[0]}'")
        fields["charts"] = tuple(fields["charts"])
        atlas = Atlas(name=name, **fields)
        for key in ("sine_rule", "sine_switch", "sine_min"):
            if not 0 < float(getattr(atlas, key)) < 1:
                raise ModelError(f"{path}: atlas '{name}': '{key}' must be in (0, 1)")
        if not float(atlas.sine_min) < float(atlas.sine_switch) < float(atlas.sine_rule):
            raise ModelError(f"{path}: atlas '{name}': thresholds must be sine_min < sine_switch < sine_rule")
        out[name] = atlas
    return out


def atlas_names() -> list[str]:
    return sorted(atlases())


def load_atlas(name: str) -> Atlas:
    try:
        return atlases()[name]
    except KeyError:
        raise ModelError(f"unknown atlas '{name}' (known: {', '.join(atlas_names())})") from None


# The one atlas of the catalogue, by the names the runtime uses
ATLAS = "spherical"
