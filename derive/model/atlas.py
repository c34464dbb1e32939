"""Chart atlases as data (catalog/atlases.toml): the member charts of one chain, the
switching rule of seed 000 section 5.1 and its thresholds.

Two kinds of atlas:

* catalogue atlases (``[spherical]``): the members are catalogue models named in the file;
* the atlas of a user's chain (``[chain]``): any model whose links are all spherical and
  written in the standard chart has one, with no file of its own.  Its members are the
  same chain with every link's chart replaced by the second and by the rotated chart,
  derived in memory from the description (``<name>_second``, ``<name>_rotated``) and
  registered so that they load by name like any model: they go through the whole pipeline
  (derivation, kernels, <chart>_to_<chart> conversions) as ordinary models.  The atlas's
  key is ``<name>_atlas`` (its generated files: ``<name>_atlas.c`` ...).
"""
from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass
from functools import cache

from ..errors import ModelError
from ..paths import catalog_dir
from .description import Model, load_model, parse_model, register_derived_model

THRESHOLDS = ("sine_rule", "sine_switch", "sine_min")


@dataclass(frozen=True)
class Atlas:
    name: str                      # the key: "spherical", or "<model>_atlas" for a chain's
    title: str
    source: str
    charts: tuple[str, ...]        # member models, in chart-number order; the first is standard
    rule: str
    sine_rule: str                 # thresholds as decimal text (printed into the generated code)
    sine_switch: str
    sine_min: str
    stem: str = ""                 # generated files and C prefix: <stem>.c, <stem>_integrate(...)

    @property
    def prefix(self) -> str:
        return self.stem or f"{self.name}_atlas"


@dataclass(frozen=True)
class ChainRule:
    """The [chain] table: how a spherical chain's atlas is made from its description."""
    title: str
    source: str
    link_charts: tuple[str, ...]   # member k has every link in link_charts[k]; the first is the model's
    member_names: tuple[str, ...]  # "{model}" is the model's name
    rule: str
    sine_rule: str
    sine_switch: str
    sine_min: str


def _atlases_file():
    return catalog_dir() / "atlases.toml"


@cache
def _tables() -> dict:
    path = _atlases_file()
    try:
        return tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ModelError(f"{path}: {exc}") from None


def _fields(cls, name: str, t: dict) -> dict:
    path = _atlases_file()
    fields = {k: t.get(k) for k in cls.__dataclass_fields__ if k not in ("name", "stem")}
    missing = [k for k, v in fields.items() if v is None]
    if missing:
        raise ModelError(f"{path}: atlas '{name}': missing key '{missing[0]}'")
    for key in THRESHOLDS:
        if not 0 < float(fields[key]) < 1:
            raise ModelError(f"{path}: atlas '{name}': '{key}' must be in (0, 1)")
    if not float(fields["sine_min"]) < float(fields["sine_switch"]) < float(fields["sine_rule"]):
        raise ModelError(f"{path}: atlas '{name}': thresholds must be sine_min < sine_switch < sine_rule")
    return {k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()}


@cache
def atlases() -> dict[str, Atlas]:
    """The catalogue atlases (tables naming their member models)."""
    return {name: Atlas(name=name, **_fields(Atlas, name, t))
            for name, t in _tables().items() if name != CHAIN}


@cache
def chain_rule() -> ChainRule:
    return ChainRule(**_fields(ChainRule, CHAIN, _tables()[CHAIN]))


def atlas_names() -> list[str]:
    return sorted(atlases())


def load_atlas(name: str) -> Atlas:
    """A catalogue atlas, or a chain atlas made before (by its key)."""
    found = find_atlas(name)
    if found is None:
        raise ModelError(f"unknown atlas '{name}' (known: {', '.join(atlas_names())}; or the "
                         f"atlas of a spherical chain: simulate(model, ..., atlas=True))")
    return found


def find_atlas(name: str) -> Atlas | None:
    """The atlas with key `name` (catalogue, or a chain's made in this process), or None."""
    return atlases().get(name) or _chains.get(name)


# -- the atlas of a user's chain ----------------------------------------------------------

CHAIN = "chain"
_chains: dict[str, Atlas] = {}          # chain atlases made in this process, by key


def _toml(value) -> str:
    """A TOML value (strings, numbers, booleans, arrays, inline tables): enough for a
    model description, whose tables are all inline-able."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)              # JSON's escapes are TOML basic-string escapes
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML for {type(value).__name__}")


def chain_problem(model: Model) -> str | None:
    """Why `model` has no chain atlas, or None."""
    first = chain_rule().link_charts[0]
    if not model.is_chain:
        return "an atlas is for a serial chain of spherical links (this model is a tree)"
    if any(link.chart.name != first for link in model.links):
        return f"an atlas is for a chain whose links are all spherical in the '{first}' chart"
    if not model.is_conservative or model.inputs:
        return ("an atlas is for a conservative chain without inputs (forces and dissipation "
                "are written in one chart's coordinates)")
    if model.is_constrained:
        return ("an atlas is for an open chain: a closed loop's constraints are written in one "
                "chart's coordinates")
    return None


def member_model(model: Model, chart: str, name: str) -> Model:
    """The same chain with every link in `chart`, named `name`: a model description of its
    own (its text is TOML, so it is cached, hashed and re-read as any model's)."""
    t = tomllib.loads(model.text)
    t["name"] = name
    t["title"] = f"{t.get('title') or model.name}; every link in the {chart} chart (atlas member)"
    t["links"] = [dict(link, chart=chart) for link in t["links"]]
    return parse_model(description_text(t), f"{model.origin or model.name} (atlas member '{name}')")


def description_text(table: dict) -> str:
    """A model description's TOML text from its table (as tomllib reads one): each key a
    line, every table inline.  What a description derived from another is written as (an
    atlas member here, a specialised model: derive/codegen/specialise.py), so that it is
    hashed, cached and read again as any model file is.

    Parameters
    ----------
    table : dict
        The description's keys and values.

    Returns
    -------
    str
    """
    return "".join(f"{json.dumps(k)} = {_toml(v)}\n" for k, v in table.items())


def chain_atlas(model: Model) -> Atlas:
    """The atlas of a spherical chain written in the standard chart (see the module doc)."""
    problem = chain_problem(model)
    if problem:
        raise ModelError(f"model '{model.name}': {problem}")
    rule = chain_rule()
    names = [n.format(model=model.name) for n in rule.member_names]
    if names[0] != model.name:
        raise ModelError(f"{_atlases_file()}: [chain] member_names must start with '{{model}}'")
    for chart, name in zip(rule.link_charts[1:], names[1:]):
        register_derived_model(member_model(model, chart, name))
    key = f"{model.name}_atlas"
    atlas = Atlas(name=key, title=rule.title.format(model=model.name), source=rule.source,
                  charts=tuple(names), rule=rule.rule, sine_rule=rule.sine_rule,
                  sine_switch=rule.sine_switch, sine_min=rule.sine_min, stem=key)
    _chains[key] = atlas
    return atlas


def atlas_for(name: str | Model) -> Atlas:
    """The atlas that runs model `name` across its charts' singularities: the catalogue
    atlas whose standard chart it is, else the atlas of its chain."""
    if isinstance(name, str) and find_atlas(name) is not None:
        return find_atlas(name)
    model = load_model(name) if isinstance(name, str) else name
    for atlas in atlases().values():
        if atlas.charts[0] == model.name:
            return atlas
    return chain_atlas(model)


def atlas_family(model: Model) -> Atlas | None:
    """The atlas `model` is a member of (catalogue, or a chain's; a standard-chart chain's
    atlas is made now), or None: its members are the targets of its chart conversions."""
    for atlas in (*atlases().values(), *_chains.values()):
        if model.name in atlas.charts:
            return atlas
    if chain_problem(model) is None and all(link.chart.polar_sine for link in model.links):
        return chain_atlas(model)
    return None


# The one atlas of the catalogue, by the names the runtime uses
ATLAS = "spherical"


def standard_member(name: str) -> str:
    """The model a run name stands for: an atlas's standard chart, else the name itself."""
    atlas = find_atlas(name)
    return atlas.charts[0] if atlas is not None else name
