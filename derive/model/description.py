"""Read and validate model and chart descriptions (TOML) into plain objects."""
from __future__ import annotations

import hashlib
import os
import re
import tomllib
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import sympy as sp

from ..errors import ModelError
from ..paths import catalog_dir



def charts_file() -> Path:
    return catalog_dir() / "charts.toml"


@dataclass(frozen=True)
class Chart:
    name: str
    dimension: int
    coordinates: tuple[str, ...]
    latex: tuple[str, ...]
    unit: tuple[str, ...]
    inverse: tuple[str, ...]
    polar_sine: str | None
    singular_axis: str | None
    source: str

    def unit_vector(self, coords: list[sp.Symbol]) -> sp.Matrix:
        """The link direction e(u, v) with this chart's coordinates replaced by ``coords``."""
        local = {name: sym for name, sym in zip(self.coordinates, coords)}
        return sp.Matrix([sp.sympify(c, locals=local) for c in self.unit])

    def coordinates_of(self, e) -> list[sp.Expr]:
        """The chart's coordinates of a unit vector ``e`` (robust atan2 forms)."""
        local = dict(zip("xyz", e))
        return [sp.sympify(c, locals=local) for c in self.inverse]

    def polar_sine_of(self, coords: list[sp.Symbol]) -> sp.Expr | None:
        if self.polar_sine is None:
            return None
        local = {name: sym for name, sym in zip(self.coordinates, coords)}
        return sp.sympify(self.polar_sine, locals=local)


@dataclass(frozen=True)
class Body:
    kind: str            # "point" or "rod"
    mass: str            # parameter name
    com: str = "1"       # centre of mass along the link, fraction of its length
    inertia: str = "0"   # moment of inertia about the centre of mass


@dataclass(frozen=True)
class Link:
    chart: Chart
    length: str
    body: Body


@dataclass(frozen=True)
class Model:
    name: str
    title: str
    source: str
    dimension: int
    parameters: tuple[str, ...]
    forms: tuple[str, ...]
    links: tuple[Link, ...]
    text: str = field(repr=False)   # the description as read, for hashing

    @property
    def content_hash(self) -> str:
        charts = charts_file().read_text()
        return hashlib.sha256((self.text + "\0" + charts).encode()).hexdigest()

    @property
    def coordinate_names(self) -> list[str]:
        return [f"{c}{i}" for i, link in enumerate(self.links, 1) for c in link.chart.coordinates]

    @property
    def rate_names(self) -> list[str]:
        return [f"{c}_dot" for c in self.coordinate_names]

    @property
    def state_names(self) -> list[str]:
        return self.coordinate_names + self.rate_names


def _require(table: dict, key: str, kind: type, where: str):
    if key not in table:
        raise ModelError(f"{where}: missing key '{key}'")
    value = table[key]
    if not isinstance(value, kind):
        raise ModelError(f"{where}: '{key}' must be {kind.__name__}, got {type(value).__name__}")
    return value


def _no_unknown(table: dict, known: set[str], where: str) -> None:
    unknown = sorted(set(table) - known)
    if unknown:
        raise ModelError(f"{where}: unknown key '{unknown[0]}'")


@cache
def _charts() -> dict[str, dict]:
    return tomllib.loads(charts_file().read_text())


def load_chart(name: str) -> Chart:
    charts = _charts()
    if name not in charts:
        raise ModelError(f"unknown chart '{name}' (known: {', '.join(sorted(charts))})")
    t = charts[name]
    where = f"chart '{name}'"
    _no_unknown(t, {"dimension", "coordinates", "latex", "unit", "inverse", "polar_sine",
                    "singular_axis", "source"}, where)
    chart = Chart(name=name, dimension=_require(t, "dimension", int, where),
                  coordinates=tuple(_require(t, "coordinates", list, where)),
                  latex=tuple(_require(t, "latex", list, where)),
                  unit=tuple(_require(t, "unit", list, where)),
                  inverse=tuple(_require(t, "inverse", list, where)),
                  polar_sine=t.get("polar_sine"), singular_axis=t.get("singular_axis"),
                  source=t.get("source", ""))
    if len(chart.unit) != chart.dimension:
        raise ModelError(f"{where}: unit has {len(chart.unit)} components, dimension is {chart.dimension}")
    if len(chart.inverse) != len(chart.coordinates):
        raise ModelError(f"{where}: inverse has {len(chart.inverse)} entries for "
                         f"{len(chart.coordinates)} coordinates")
    return chart


def model_names() -> list[str]:
    return sorted(p.stem for p in catalog_dir().glob("*.toml") if p.stem != "charts")


def _parse_body(t: dict, where: str) -> Body:
    _no_unknown(t, {"kind", "mass", "com", "inertia"}, where)
    kind = _require(t, "kind", str, where)
    if kind not in ("point", "rod"):
        raise ModelError(f"{where}: body kind must be 'point' or 'rod', got '{kind}'")
    mass = _require(t, "mass", str, where)
    if kind == "point":
        if "com" in t or "inertia" in t:
            raise ModelError(f"{where}: a point body has no 'com' or 'inertia'")
        return Body(kind, mass)
    return Body(kind, mass, _require(t, "com", str, where), _require(t, "inertia", str, where))


def parse_model(text: str, origin: str) -> Model:
    try:
        t = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"{origin}: not valid TOML ({exc})") from None
    _no_unknown(t, {"name", "title", "source", "dimension", "parameters", "forms", "links"}, origin)
    dimension = _require(t, "dimension", int, origin)
    params = tuple(_require(t, "parameters", list, origin))
    links = []
    for i, lt in enumerate(_require(t, "links", list, origin), 1):
        where = f"{origin}: link {i}"
        _no_unknown(lt, {"chart", "length", "body"}, where)
        try:
            chart = load_chart(_require(lt, "chart", str, where))
        except ModelError as exc:
            raise ModelError(str(exc) if str(exc).startswith(where) else f"{where}: 'chart': {exc}") from None
        if chart.dimension != dimension:
            raise ModelError(f"{where}: chart '{chart.name}' is {chart.dimension}-D in a {dimension}-D model")
        link = Link(chart, _require(lt, "length", str, where),
                    _parse_body(_require(lt, "body", dict, where), where + " body"))
        for p in (link.length, link.body.mass, link.body.inertia):
            if not p.lstrip("-").replace("/", "").isdigit() and p not in params:
                raise ModelError(f"{where}: '{p}' is not a declared parameter")
        links.append(link)
    if "g" not in params:
        raise ModelError(f"{origin}: parameters must include the gravity 'g'")
    forms = tuple(t.get("forms", ["lagrangian"]))
    for f in forms:
        if f not in ("lagrangian", "hamiltonian", "paper"):
            raise ModelError(f"{origin}: unknown form '{f}'")
    name = _require(t, "name", str, origin)
    if not NAME.match(name):
        raise ModelError(f"{origin}: 'name' must be an identifier (letters, digits, _), got {name!r}")
    return Model(name=name, title=t.get("title", ""),
                 source=t.get("source", ""), dimension=dimension, parameters=params,
                 forms=forms, links=tuple(links), text=text)


NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_from_files: dict[str, Model] = {}          # models read from files, by name, in this process


def is_model_file(text: str | os.PathLike) -> bool:
    """Whether a model argument names a file (a path or a .toml name), not a catalogue entry."""
    s = os.fspath(text)
    return s.endswith(".toml") or "/" in s or os.sep in s


def load_model_file(path: str | os.PathLike) -> Model:
    """A model description from a TOML file anywhere; afterwards its name loads it too."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise ModelError(f"model file '{path}' does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"cannot read model file '{path}': {exc}") from None
    model = parse_model(text, str(path))
    if model.name in model_names() and load_model(model.name).text != text:
        raise ModelError(f"{path}: name '{model.name}' is a catalogue model's; give the model "
                         f"another name")
    known = _from_files.get(model.name)
    if known is not None and known.text != text:
        raise ModelError(f"{path}: another model file named '{model.name}' was read first; "
                         f"give the model another name")
    _from_files[model.name] = model
    return model


def load_model(name: str | os.PathLike) -> Model:
    """A catalogue model by name, a model file by path, or a model file read before by name."""
    if is_model_file(name):
        return load_model_file(name)
    if name in _from_files:
        return _from_files[name]
    return _catalogue_model(name)


@cache
def _catalogue_model(name: str) -> Model:
    path = catalog_dir() / f"{name}.toml"
    if name == "charts" or not NAME.match(name) or not path.is_file():
        raise ModelError(f"unknown model '{name}' (known: {', '.join(model_names())}; "
                         f"or give the path of a model file)")
    return parse_model(path.read_text(), path.name)
