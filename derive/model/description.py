"""Read and validate model and chart descriptions (TOML) into plain objects."""
from __future__ import annotations

import hashlib
import math
import os
import re
import sys
import tomllib
from dataclasses import dataclass, field, replace
from functools import cache, cached_property
from pathlib import Path

import sympy as sp

from .. import cachefile
from ..errors import ModelError
from ..paths import read_input_text
from ..paths import catalog_dir
from .expressions import FUNCTIONS, parse_expression
from .listing import DATA_FILES, is_model_file, model_names  # noqa: F401  (their home is listing.py)

# Names a model may not give a parameter, input or coordinate: the functions of the
# expression grammar and the constants (a parameter `sin` would shadow sin()).
# Names the generated code uses itself (M, F, p, y, u, lambda, ...) are allowed:
# the code generators rename them where a target language needs it.
# The time symbol `t` is reserved too: forces, dissipation and the pivot's motion may use it.
TIME = "t"
RESERVED_NAMES = frozenset(FUNCTIONS) | {"pi", TIME}
# a model's NumPy module is <name>.py: it may not shadow what the generated code imports
SHADOWING = frozenset(sys.stdlib_module_names) | {"numpy", "scipy", "sympy", "mpmath", "derive", "kernels"}
# A model's generated files are <name><suffix>.c/.h/.py for these suffixes (the kernels:
# none; the integrators, Taylor scalar, lanes and quad, loops, the linearisation, a chain's atlas and its
# derived members); a name that ends with one would write another model's files, and a
# name with derive's prefix the library files every model shares (derive_integrators.h,
# derive_driver.h, derive_tableaus.h).  tests/test_hardening_inputs.py checks these
# against every file every backend writes.
ARTIFACT_SUFFIXES = ("_integrate", "_taylor", "_taylor_lanes", "_taylor_quad", "_throughput",
                     "_fixed", "_linearize", "_atlas", "_second", "_rotated")
SHARED_PREFIX = "derive_"
MAX_NAME = 64                # characters: a model's name is a file name's and a C prefix's part


def in_words(items) -> str:
    """("a", "b", "c") -> "a, b and c" (the sources of work in `Model.work_done_by`)."""
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1] if items else ""


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
        return sp.Matrix([parse_expression(c, local, f"chart '{self.name}': unit") for c in self.unit])

    def coordinates_of(self, e) -> list[sp.Expr]:
        """The chart's coordinates of a unit vector ``e`` (robust atan2 forms)."""
        local = dict(zip("xyz", e))
        return [parse_expression(c, local, f"chart '{self.name}': inverse") for c in self.inverse]

    def polar_sine_of(self, coords: list[sp.Symbol]) -> sp.Expr | None:
        if self.polar_sine is None:
            return None
        local = {name: sym for name, sym in zip(self.coordinates, coords)}
        return parse_expression(self.polar_sine, local, f"chart '{self.name}': polar_sine")


@dataclass(frozen=True)
class Body:
    kind: str            # "point", "rod" or "rigid"
    mass: str            # parameter name
    com: str = "1"       # centre of mass along the link, fraction of its length
    inertia: str = "0"   # moment of inertia about the centre of mass
    # a rigid body's: its centre of mass in the link's frame from the joint (None: the
    # link's tip) and its inertia tensor about that centre in the link's frame (3 x 3)
    centre: tuple[str, ...] | None = None
    tensor: tuple[tuple[str, ...], ...] | None = None


# The joints a link may have (sympy.physics.mechanics' words): a chart joint is the
# hinge or ball of charts.toml (absolute angles of the link's direction); a prismatic
# joint slides along an axis fixed in its parent's frame (its coordinate is a length); a
# revolute joint (3-D) turns the link about an axis fixed in its parent's frame (its
# angle is relative to the parent, zero where the link points down the parent's -z).
CHART_JOINT, PRISMATIC, REVOLUTE = "chart", "prismatic", "revolute"
JOINTS = (CHART_JOINT, PRISMATIC, REVOLUTE)
PIVOT = "pivot"           # the parent name of a link that hangs from the pivot


@dataclass(frozen=True)
class Link:
    chart: Chart                 # a slider's or revolute joint's is a stand-in: its coordinate, no unit vector
    length: str                  # "0" for a slider (its body sits where it slides to)
    body: Body | None            # None: a massless link (a frame for its children)
    name: str = ""
    parent: int = -1             # index of the parent link, -1 for the pivot
    joint: str = CHART_JOINT
    axis: tuple[str, ...] = ()   # a slider's or revolute joint's axis in its parent's frame
    offset: tuple[str, ...] | None = None   # the joint's place in the parent's frame (None: its tip)
    coordinates: tuple[str, ...] = ()       # the names of the joint's coordinates in the model
    prescribed: tuple[str, ...] = ()        # a joint driven in time: its coordinate's f(t; p), no state


@dataclass(frozen=True)
class Spring:
    """A linear spring between two points (`between`: "pivot", a link's name for its tip, or
    "<link>.centre" for its body's centre of mass), or a torsional spring at a hinge
    (`joint`: a link's name; it pulls the link's angle towards its parent's + `rest`)."""
    stiffness: str
    rest: str = "0"
    between: tuple[str, str] | None = None
    joint: int | None = None             # the link index of a torsional spring


@dataclass(frozen=True)
class Load:
    """A force applied at a point of the model (sympy.physics.mechanics' Force on a Point):
    `point` is "pivot", a link's name for its tip or "<link>.centre"; `force` its components
    (x, y[, z]) in the fixed frame, expressions in the state, parameters, inputs and t.  Its
    generalized force is Q_j = force . dr/dq_j (the point's Jacobian)."""
    point: str
    force: tuple[str, ...]


SI_UNITS = {"length": "m", "mass": "kg", "inertia": "kg m²", "gravity": "m/s²", "fraction": ""}


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
    inputs: tuple[str, ...] = ()                 # run-time inputs (a kernel argument u)
    dissipation: str | None = None               # Rayleigh dissipation function R(q', q; p)
    forces: tuple[tuple[str, str], ...] = ()     # generalized force Q_j per coordinate name
    origin: str = ""                             # the file it was read from
    pivot: tuple[str, ...] | None = None         # the pivot's prescribed position r0(t; p), or fixed at 0
    potential: str | None = None                 # a potential V(q, p, t) added to gravity's
    order: tuple[str, ...] | None = None         # the coordinates' order in the state, when not the links'
    springs: tuple[Spring, ...] = ()
    constraints: tuple[str, ...] = ()            # holonomic loop closures Phi(q; p) = 0
    loads: tuple[Load, ...] = ()                 # forces applied at points ([[loads]])

    @property
    def is_chain(self) -> bool:
        """Whether the model is a serial chain of chart joints with a body on every link,
        each hanging from the tip of the link before (today's chain form derives it);
        otherwise a kinematic tree (lagrange.tree_form)."""
        return self.order is None and all(
            link.joint == CHART_JOINT and link.parent == i - 1 and link.offset is None
            and link.body is not None and not link.prescribed for i, link in enumerate(self.links))

    @property
    def is_conservative(self) -> bool:
        """Whether the model's energy is conserved: no dissipation, no applied forces and
        no explicit time (a moving pivot does work on the chain)."""
        return (self.dissipation is None and not self.forces and not self.loads
                and not self.is_time_dependent)

    @property
    def work_done_by(self) -> tuple[str, ...]:
        """What changes the model's energy E = T + V, in words, for the texts that say why
        it is not conserved: "the moving pivot", "the time-dependent potential", "the
        applied forces", "the loads", "the damping" (those the model has; none: conserved)."""
        names = {n: sp.Symbol(n) for n in (*self.parameters, *self.inputs, *self.state_names, TIME)}
        where = self.origin or self.name

        def timed(texts) -> bool:
            return any(names[TIME] in parse_expression(text, names, where).free_symbols for text in texts)
        out = []
        if self.pivot is not None and timed(self.pivot):
            out.append("the moving pivot")
        if any(link.prescribed for link in self.links):
            out.append("the prescribed joint motion")
        if self.potential is not None and timed([self.potential]):
            out.append("the time-dependent potential")
        if self.forces:
            out.append("the applied forces")
        if self.loads:
            out.append("the loads")
        if self.dissipation is not None:
            out.append("the damping")
        return tuple(out)

    @cached_property
    def is_time_dependent(self) -> bool:
        """Whether the time `t` occurs anywhere in the description (forces, dissipation,
        the pivot's motion): the equations are then M q'' = F(q, q', p, u, t)."""
        names = {n: sp.Symbol(n) for n in (*self.parameters, *self.inputs, *self.state_names, TIME)}
        where = self.origin or self.name
        texts = [*(text for _, text in self.forces), *(self.pivot or ()),
                 *(text for load in self.loads for text in load.force),
                 *(text for link in self.links for text in link.prescribed)]
        texts += [text for text in (self.dissipation, self.potential) if text is not None]
        return any(names[TIME] in parse_expression(text, names, where).free_symbols for text in texts)

    @property
    def is_constrained(self) -> bool:
        """Whether the model closes a loop: holonomic constraints Phi(q; p) = 0 on its
        coordinates, enforced by Lagrange multipliers (derive/derivation/loop_closure.py)."""
        return bool(self.constraints)

    @property
    def bodies(self) -> int:
        """The number of bobs (one body per link)."""
        return len(self.links)

    def link_coordinates(self, link: Link) -> list[int]:
        """Where `link`'s coordinates sit in the state's coordinates q.

        Parameters
        ----------
        link : Link
            One of this model's links.

        Returns
        -------
        list of int
            The indices of its coordinates in coordinate_names.
        """
        names = self.coordinate_names
        return [names.index(c) for c in link.coordinates]

    def parameter_roles(self) -> dict[str, str]:
        """'length', 'mass', 'inertia' or 'fraction' for each parameter a link uses that
        way; 'gravity' for g; other parameters (damping, ...) have no role."""
        roles = {"g": "gravity"}
        role_of = {"length": "length", "body mass": "mass", "body inertia": "inertia",
                   "body com": "fraction"}
        for link in self.links:
            for value, role in ((text, role_of[key]) for key, text in link_quantities(link)
                                if key in role_of):      # a tensor's or a centre's entries: no role
                name = _bare_parameter(value, self.parameters)      # l1, but also 1*l1, +l1, (l1)
                if name is not None:
                    roles.setdefault(name, role)
        return roles

    def unit_of(self, name: str) -> str | None:
        """The SI unit of a coordinate, rate or parameter called `name` (a scene's numbers
        are SI by convention): rad and rad/s for the chart angles and their rates, m, kg,
        kg m² and m/s² for lengths, masses, inertias and g, "" for a fraction of a length;
        None where it is not known (a damping coefficient, an input, another name).

        Parameters
        ----------
        name : str
            A state or parameter name of this model.

        Returns
        -------
        str or None
        """
        lengths = {c for link in self.links if link.joint == PRISMATIC for c in link.coordinates}
        if name in self.coordinate_names:
            return "m" if name in lengths else "rad"
        if name in self.rate_names:
            return "m/s" if name[:-len("_dot")] in lengths else "rad/s"
        return SI_UNITS.get(self.parameter_roles().get(name, "") if name in self.parameters else "")

    @cached_property
    def content_hash(self) -> str:
        """SHA-256 of the model file and the chart file (as read with the model: an edit of
        either is a new Model object, so computing it once per object is exact)."""
        charts = charts_file().read_text()
        return hashlib.sha256((self.text + "\0" + charts).encode()).hexdigest()

    @property
    def coordinate_names(self) -> list[str]:
        """The generalized coordinates: the links' in link order (a chart's letters and the
        link's number, theta1, unless the link names them), or in the model's `coordinates`."""
        if self.order is not None:
            return list(self.order)
        return [c for link in self.links for c in link.coordinates]

    @property
    def rate_names(self) -> list[str]:
        return [f"{c}_dot" for c in self.coordinate_names]

    @property
    def state_names(self) -> list[str]:
        return self.coordinate_names + self.rate_names


def link_quantities(link: Link) -> list[tuple[str, str]]:
    """(key, text) of a link's length (a chart joint's: a slider has none) and its body's
    mass, com and inertia (none for a massless link), a rigid body's centre and tensor.

    Parameters
    ----------
    link : Link

    Returns
    -------
    list of (str, str)
        (key, expression text): "length", "body mass", "body com", "body inertia",
        "body centre", "body inertia tensor".
    """
    joint_frame = link.body is None and link.length == "0"     # a massless hinge without an arm
    out = [("length", link.length)] if link.joint != PRISMATIC and not joint_frame else []
    if link.body is not None:
        out += [("body mass", link.body.mass), ("body com", link.body.com),
                ("body inertia", link.body.inertia)]
        out += [("body centre", c) for c in link.body.centre or ()]
        out += [("body inertia tensor", x) for row in link.body.tensor or () for x in row]
    return out


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


def _quantity(t: dict, key: str, where: str) -> str:
    value = t[key]
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise ModelError(f"{where}: '{key}' must be a parameter name or a number, got {value!r}")
    return str(value)


def _parse_rigid_body(t: dict, mass: str, where: str) -> Body:
    """A rigid body: `inertia` a symmetric 3 x 3 tensor about its centre of mass in the link's
    frame, `centre` (optional) that centre in the link's frame from the joint."""
    _no_unknown(t, {"kind", "mass", "centre", "inertia"}, where)
    rows = t.get("inertia")
    if (not isinstance(rows, list) or len(rows) != 3
            or not all(isinstance(r, list) and len(r) == 3 for r in rows)):
        raise ModelError(f"{where}: a rigid body's 'inertia' is its 3 x 3 tensor about its centre "
                         f"of mass in the link's frame, a list of three rows")
    tensor = tuple(tuple(_quantity({"inertia": v}, "inertia", where) for v in row) for row in rows)
    if any(tensor[i][j] != tensor[j][i] for i in range(3) for j in range(i)):
        raise ModelError(f"{where}: a rigid body's 'inertia' must be symmetric (row i, column j "
                         f"equal to row j, column i)")
    centre = t.get("centre")
    if centre is not None:
        if not isinstance(centre, list) or len(centre) != 3:
            raise ModelError(f"{where}: 'centre' must be a list of 3 numbers or expressions (in the "
                             f"link's frame, from its joint)")
        centre = tuple(_quantity({"centre": v}, "centre", where) for v in centre)
    return Body("rigid", mass, centre=centre, tensor=tensor)


def _parse_body(t: dict, where: str) -> Body:
    kind = _require(t, "kind", str, where)
    if kind not in ("point", "rod", "rigid"):
        raise ModelError(f"{where}: body kind must be 'point' or 'rod' (or 'rigid' on a revolute "
                         f"joint), got '{kind}'")
    if "mass" not in t:
        raise ModelError(f"{where}: missing key 'mass'")
    mass = _quantity(t, "mass", where)
    if kind == "rigid":
        return _parse_rigid_body(t, mass, where)
    _no_unknown(t, {"kind", "mass", "com", "inertia"}, where)
    if kind == "point":
        if "com" in t or "inertia" in t:
            raise ModelError(f"{where}: a point body has no 'com' or 'inertia'")
        return Body(kind, mass)
    for key in ("com", "inertia"):
        if key not in t:
            raise ModelError(f"{where}: missing key '{key}' (a rod has a centre of mass and an inertia)")
    return Body(kind, mass, _quantity(t, "com", where), _quantity(t, "inertia", where))


def _names(t: dict, key: str, where: str) -> tuple[str, ...]:
    values = t.get(key, [])
    if not isinstance(values, list) or not all(isinstance(v, str) for v in values):
        raise ModelError(f"{where}: '{key}' must be a list of names")
    for v in values:
        if not NAME.match(v):
            raise ModelError(f"{where}: '{key}': {v!r} is not a name (letters, digits, _)")
        if v in RESERVED_NAMES:
            raise ModelError(f"{where}: '{key}': '{v}' is reserved: a function or constant of the expression "
                                 f"grammar, an expression could not use it as a name (reserved: "
                                 f"{', '.join(sorted(RESERVED_NAMES))})")
    seen = set()
    for v in values:
        if v in seen:
            raise ModelError(f"{where}: '{key}': '{v}' is given twice")
        seen.add(v)
    return tuple(values)


def _check_signs(link: Link, params: tuple[str, ...], where: str) -> None:
    """Refuse a length or mass that no positive parameter values make positive (`-l2`,
    `m1*(1-2)`), and an inertia that none make >= 0, when the model is read: the run-time
    check would only catch them when a run starts, after derive, verify and generate had
    passed them.  (The roles' own values are checked per run: parameter_problem.)"""
    positive = {n: sp.Symbol(n, real=True) if n == "g" else sp.Symbol(n, positive=True)
                for n in params}                         # g may be zero or negative
    bad_if = {"length": lambda e: e.is_nonpositive, "body mass": lambda e: e.is_nonpositive,
              "body inertia": lambda e: e.is_negative}
    for key, text, bad in ((k, text, bad_if[k]) for k, text in link_quantities(link) if k in bad_if):
        try:
            expr = parse_expression(text, positive, key)
        except ModelError:
            continue                      # the derivation reports a bad expression, in its words
        if expr.free_symbols and bad(expr):
            need = "positive" if key != "body inertia" else ">= 0"
            raise ModelError(f"{where}: {key} = {text} is never {need} (its parameters are "
                             f"positive numbers)")


def _check_com_is_a_fraction(link: Link, params: tuple[str, ...], where: str) -> None:
    """Refuse a rod's `com` that grows with its own link's length (`com = "L/2"`): that is a
    distance where a fraction of the length is meant, and it would pass the run-time [0, 1]
    check for L <= 2 while giving a wrong inertia.  A fraction built from lengths (`d/L`)
    is fine: it scales as L^-1."""
    if link.body is None or link.body.kind != "rod":
        return
    symbols = {n: sp.Symbol(n) for n in params}
    try:
        com = parse_expression(link.body.com, symbols, "com")
        length = parse_expression(link.length, symbols, "length")
    except ModelError:
        return                       # the derivation reports a bad expression, in its words
    for L in length.free_symbols & com.free_symbols:
        scaling = sp.simplify(L * sp.diff(com, L) / com)     # com ~ L^scaling
        if scaling.is_number and scaling > 0:
            raise ModelError(f"{where} body: com = {link.body.com!r} grows with the link's length "
                             f"{L}: com is a fraction of the length in [0, 1] "
                             f"(com = \"1/2\" is the middle)")


def _quantity_problem(key: str, value: float) -> str | None:
    """Why a link's length, mass, inertia or centre of mass cannot be `value`, or None."""
    if key in ("length", "body mass") and not value > 0:
        return "must be positive"
    if key == "body inertia" and not value >= 0:
        return "must be >= 0 (a moment of inertia)"
    if key == "body com" and not 0 <= value <= 1:
        return "must be in [0, 1] (a fraction of the link's length)"
    return None


ROLE_PROBLEMS = {"length": (lambda v: v > 0, "must be positive (a length)"),
                 "mass": (lambda v: v > 0, "must be positive (a mass)"),
                 "inertia": (lambda v: v >= 0, "must be >= 0 (a moment of inertia)"),
                 "fraction": (lambda v: 0 <= v <= 1, "must be in [0, 1] (a centre of mass along its link)")}


def parameter_problem(model: "Model", values: dict) -> tuple[str | None, str] | None:
    """The first parameter value the model's links make impossible, as (name, why): by the
    parameter's role (a length, a mass, an inertia, a centre of mass), else (None, why) for
    a link quantity written as an expression of parameters; None when all are possible."""
    roles = model.parameter_roles()
    for n, v in values.items():
        ok, why = ROLE_PROBLEMS.get(roles.get(n), (None, ""))
        if ok is not None and not ok(v):
            return n, why
    problem = check_link_values(model, {n: float(v) for n, v in values.items()})
    return (None, problem) if problem else None


def _bare_parameter(text: str, parameters: tuple[str, ...]) -> str | None:
    """The parameter a link quantity is, however it is spelled (`l1`, `1*l1`, `+l1`), or None."""
    if text in parameters:
        return text
    try:
        expr = parse_expression(text, {n: sp.Symbol(n) for n in parameters}, "link quantity")
    except ModelError:
        return None
    return expr.name if expr.is_Symbol else None


def check_link_values(model: "Model", values: dict) -> str | None:
    """The first link quantity (length, mass, inertia, centre of mass; a parameter or an
    expression of them) that the parameter values make impossible, as a message, or None."""
    for i, key, text, names, f in _link_quantities(model):
        if any(n not in values for n in names):
            continue
        try:
            value = complex(f(*[values[n] for n in names]))
        except (ZeroDivisionError, OverflowError, ValueError, TypeError):
            value = complex(math.nan)
        if value.imag != 0 or not math.isfinite(value.real):
            return f"link {i} {key} = {text} is not a finite real number at these parameter values"
        value = value.real
        problem = _quantity_problem(key, value)
        if problem:
            return f"link {i} {key} = {text} = {value:g} {problem}"
    return None


_quantities: dict[str, list] = {}


def _link_quantities(model: "Model") -> list:
    """(link, key, text, parameter names, function) of every link quantity that is an
    expression of parameters, compiled once per model description."""
    if model.content_hash not in _quantities:
        params = {n: sp.Symbol(n) for n in model.parameters}
        out = []
        for i, link in enumerate(model.links, 1):
            for key, text in link_quantities(link):
                expr = parse_expression(text, params, f"link {i} {key}")
                if expr.free_symbols:     # every spelling, a bare parameter too (1*l1 is l1)
                    names = sorted(s.name for s in expr.free_symbols)
                    out.append((i, key, text, names, sp.lambdify([params[n] for n in names], expr, "math")))
        _quantities[model.content_hash] = out
    return _quantities[model.content_hash]


def _check_expressions(model: "Model", where: str) -> None:
    """Every expression of the model parses and uses only names it declares (and the time)."""
    names = {n: sp.Symbol(n) for n in (*model.parameters, *model.inputs, *model.state_names, TIME)}
    params = {n: sp.Symbol(n) for n in model.parameters}
    for i, link in enumerate(model.links, 1):
        for key, value in link_quantities(link):
            expr = parse_expression(value, params, f"{where}: link {i} {key}")
            if not expr.free_symbols:
                problem = _quantity_problem(key, float(expr))
                if problem:
                    raise ModelError(f"{where}: link {i} {key} = {value} {problem}")
    rates = {n: names[n] for n in model.rate_names}
    if model.dissipation is not None:
        R = parse_expression(model.dissipation, names, f"{where}: dissipation")
        if not R.free_symbols & set(rates.values()):
            raise ModelError(f"{where}: dissipation uses no rate ({', '.join(model.rate_names)})")
    for coord, text in model.forces:
        parse_expression(text, names, f"{where}: forces.{coord}")
    for i, load in enumerate(model.loads, 1):
        for axis, text in zip("xyz", load.force):
            parse_expression(text, names, f"{where}: load {i} force {axis}")
    motion = {n: names[n] for n in (*model.parameters, TIME)}     # prescribed: no state, no input
    for axis, text in zip("xyz", model.pivot or ()):
        parse_expression(text, motion, f"{where}: pivot {axis}")
    for i, link in enumerate(model.links, 1):
        for text in link.prescribed:
            parse_expression(text, motion, f"{where}: link {i} prescribed")
    if model.potential is not None:               # V(q, p, t): no rate, no input
        configuration = {n: names[n] for n in (*model.parameters, *model.coordinate_names, TIME)}
        parse_expression(model.potential, configuration, f"{where}: potential")
    for i, link in enumerate(model.links, 1):
        for key, texts in (("offset", link.offset or ()), ("axis", link.axis)):
            for text in texts:
                parse_expression(text, params, f"{where}: link {i} {key}")
        if link.axis and all(sp.sympify(0) == parse_expression(a, params, "axis") for a in link.axis):
            raise ModelError(f"{where}: link {i} axis is the zero vector (a slider needs a direction)")
    _check_constraints(model, names, where)


def _check_constraints(model: "Model", names: dict, where: str) -> None:
    """Each loop closure is an expression of the coordinates and parameters that uses a
    coordinate: holonomic and scleronomic (no rate, no input, no time)."""
    allowed = {n: names[n] for n in (*model.parameters, *model.coordinate_names)}
    coordinates = {names[n] for n in model.coordinate_names}
    for i, text in enumerate(model.constraints, 1):
        key = f"{where}: constraints[{i}]"
        used = parse_expression(text, names, key).free_symbols
        if names[TIME] in used:
            raise ModelError(f"{key}: uses the time t: only constraints fixed in time "
                             f"(scleronomic, Phi(q; p) = 0) are supported")
        rates = sorted(n for n in model.rate_names if names[n] in used)
        if rates:                      # a velocity constraint: rolling without slipping, a knife edge
            raise ModelError(f"{key}: uses the rate {rates[0]}: a non-holonomic (velocity) constraint, "
                             f"such as a rolling disc's, is out of scope; constraints are holonomic, "
                             f"Phi(q; p) = 0 in the coordinates and parameters")
        expr = parse_expression(text, allowed, key + " (a holonomic constraint: coordinates "
                                                      "and parameters only)")
        if not expr.free_symbols & coordinates:
            raise ModelError(f"{key}: {text!r} uses no coordinate ({', '.join(model.coordinate_names)})")
    if not model.coordinate_names:
        raise ModelError(f"{where}: every joint is prescribed: the model has no coordinate to integrate "
                         f"(leave at least one joint free)")
    if len(model.constraints) >= len(model.coordinate_names):
        raise ModelError(f"{where}: {len(model.constraints)} constraints on "
                         f"{len(model.coordinate_names)} coordinates leave no degree of freedom")
    _check_constraints_independent(model, allowed, where)


def _check_constraints_independent(model: "Model", allowed: dict, where: str) -> None:
    """The closures' Jacobian dPhi/dq has full rank at a generic configuration: dependent
    constraints (one a multiple of another) leave the multipliers undetermined."""
    if len(model.constraints) < 2:
        return
    coordinates = [allowed[n] for n in model.coordinate_names]
    J = sp.Matrix([parse_expression(text, allowed, where) for text in model.constraints]).jacobian(coordinates)
    rng = __import__("random").Random(1)
    ranks = []
    for _ in range(2):                 # two generic points: a rank drop at both is no coincidence
        at = {sym: sp.Float(rng.uniform(0.5, 1.5)) for sym in allowed.values()}
        values = J.xreplace(at).evalf()
        ranks.append(sp.Matrix(values).rank(iszerofunc=lambda x: abs(x) < 1e-12))
    if max(ranks) < len(model.constraints):
        raise ModelError(f"{where}: the {len(model.constraints)} constraints are dependent (their Jacobian "
                         f"dPhi/dq has rank {max(ranks)}): keep only independent ones")


def _constraints(t: dict, where: str) -> tuple[str, ...]:
    """The model's loop closures, each an expression that is zero on the constrained motion."""
    value = t.get("constraints", [])
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ModelError(f"{where}: 'constraints' must be a list of expressions (strings), each "
                         f"zero when the loop is closed")
    return tuple(value)


def _pivot(t: dict, dimension: int, where: str) -> tuple[str, ...] | None:
    """The pivot's position, one expression per axis, or None (fixed at the origin)."""
    if "pivot" not in t:
        return None
    value = t["pivot"]
    if not isinstance(value, list) or len(value) != dimension:
        raise ModelError(f"{where}: 'pivot' must be a list of {dimension} expressions "
                         f"(x, {'y' if dimension == 2 else 'y, z'}) in the parameters and the time t")
    return tuple(_quantity({"pivot": v}, "pivot", where) for v in value)


LINK_KEYS = {"chart", "length", "body", "name", "parent", "joint", "axis", "offset", "coordinate",
             "coordinates", "prescribed"}


def _vector(lt: dict, key: str, dimension: int, where: str) -> tuple[str, ...] | None:
    """A link's `offset` or `axis`: a list of `dimension` numbers or parameter expressions."""
    if key not in lt:
        return None
    value = lt[key]
    if not isinstance(value, list) or len(value) != dimension:
        raise ModelError(f"{where}: '{key}' must be a list of {dimension} numbers or expressions "
                         f"(in the parent's frame)")
    return tuple(_quantity({key: v}, key, where) for v in value)


def _joint_coordinates(lt: dict, n: int, default: tuple[str, ...], where: str) -> tuple[str, ...]:
    """The names a link gives its joint's `n` coordinates (`coordinate = "x"` for one,
    `coordinates = [...]`), or `default`."""
    if "coordinate" in lt and "coordinates" in lt:
        raise ModelError(f"{where}: give 'coordinate' or 'coordinates', not both")
    if "coordinate" in lt:
        if n != 1:
            raise ModelError(f"{where}: this joint has {n} coordinates: name them with "
                             f"'coordinates = [...]'")
        if not isinstance(lt["coordinate"], str):
            raise ModelError(f"{where}: 'coordinate' must be a name (a string)")
        given = _names({"coordinate": [lt["coordinate"]]}, "coordinate", where)
    elif "coordinates" in lt:
        given = _names(lt, "coordinates", where)
    else:
        return default
    if len(given) != n:
        raise ModelError(f"{where}: the joint has {n} coordinate{'s' * (n != 1)}, "
                         f"'coordinates' names {len(given)}")
    return given


def _axis_chart(joint: str, coordinate: str, dimension: int) -> Chart:
    """The stand-in chart of a prismatic or revolute joint: one coordinate (a length or an
    angle), no unit vector of its own (its axis is in the parent's frame)."""
    return Chart(name=joint, dimension=dimension, coordinates=(coordinate,), latex=(coordinate,),
                 unit=(), inverse=(), polar_sine=None, singular_axis=None,
                 source=f"a {joint} joint about or along an axis in its parent's frame")


def _parse_link(lt: dict, i: int, dimension: int, named: dict[str, int], where: str) -> Link:
    """One [[links]] table: its joint (chart or prismatic), its parent, its body; a joint
    with `prescribed` motion has no coordinate in the state (its value is f(t; p))."""
    link = _parse_joint(lt, i, dimension, named, where)
    if "prescribed" not in lt:
        return link
    text = lt["prescribed"]
    if len(link.coordinates) != 1:
        raise ModelError(f"{where}: 'prescribed' drives a joint of one coordinate (a planar hinge, a "
                         f"revolute joint or a slider); this one has {len(link.coordinates)}")
    if not isinstance(text, (str, int, float)) or isinstance(text, bool):
        raise ModelError(f"{where}: 'prescribed' must be an expression in t and the parameters, "
                         f"e.g. prescribed = \"w*t\"")
    if "coordinate" in lt or "coordinates" in lt:
        raise ModelError(f"{where}: a prescribed joint has no coordinate of the state (leave out "
                         f"'coordinate'): its value is 'prescribed'")
    return replace(link, coordinates=(), prescribed=(str(text),))


def _parse_joint(lt: dict, i: int, dimension: int, named: dict[str, int], where: str) -> Link:
    """One [[links]] table's joint, parent and body (_parse_link)."""
    _no_unknown(lt, LINK_KEYS, where)
    name = lt.get("name", "")
    if not isinstance(name, str) or (name and not NAME.match(name)):
        raise ModelError(f"{where}: 'name' must be an identifier (letters, digits, _)")
    if name == PIVOT or name in named:
        raise ModelError(f"{where}: 'name' = {name!r} is taken ("
                         f"{'the pivot' if name == PIVOT else 'by an earlier link'})")
    parent = lt.get("parent", None)
    if parent is None:
        parent_index = i - 2           # the link before (0-based), the pivot for the first
    elif not isinstance(parent, str) or (parent != PIVOT and parent not in named):
        raise ModelError(f"{where}: 'parent' = {parent!r} is not '{PIVOT}' or an earlier link's name "
                         f"(named: {', '.join(named) or 'none'})")
    else:
        parent_index = -1 if parent == PIVOT else named[parent]
    joint = lt.get("joint", CHART_JOINT)
    if joint not in JOINTS:
        raise ModelError(f"{where}: unknown joint {joint!r} (known: {', '.join(JOINTS)}; a hinge "
                         f"or ball joint is a 'chart')")
    body = _parse_body(lt["body"], where + " body") if isinstance(lt.get("body"), dict) else None
    if "body" in lt and body is None:
        raise ModelError(f"{where}: 'body' must be a table")
    offset = _vector(lt, "offset", dimension, where)
    if joint == PRISMATIC:
        for key in ("chart", "length"):
            if key in lt:
                raise ModelError(f"{where}: a prismatic joint has no '{key}' (its coordinate is the "
                                 f"length it slides)")
        axis = _vector(lt, "axis", dimension, where)
        if axis is None:
            raise ModelError(f"{where}: a prismatic joint needs 'axis' (its direction in the "
                             f"parent's frame, e.g. axis = [1, 0])")
        if "coordinate" not in lt and "coordinates" not in lt and "prescribed" not in lt:
            raise ModelError(f"{where}: a prismatic joint needs 'coordinate' (the name of the "
                             f"length it slides, e.g. coordinate = \"x\")")
        coordinates = _joint_coordinates(lt, 1, (f"s{i}",), where)     # s_i: a driven slider's stand-in
        if body is not None and body.kind != "point":
            raise ModelError(f"{where}: a slider's body is a point (a cart), got '{body.kind}'")
        return Link(_axis_chart(PRISMATIC, coordinates[0], dimension), "0", body, name, parent_index,
                    joint, axis, offset, coordinates)
    if joint == REVOLUTE:
        if dimension != 3:
            raise ModelError(f"{where}: a revolute joint is 3-D; a planar hinge is chart = \"planar\" "
                             f"(its angle absolute, from the downward vertical)")
        if "chart" in lt:
            raise ModelError(f"{where}: a revolute joint has no 'chart' (its axis is 'axis')")
        axis = _vector(lt, "axis", dimension, where)
        if axis is None:
            raise ModelError(f"{where}: a revolute joint needs 'axis' (in the parent's frame, "
                             f"e.g. axis = [0, 1, 0])")
        coordinates = _joint_coordinates(lt, 1, (f"theta{i}",), where)
        length = (_require(lt, "length", str, where) if (body is not None and body.centre is None)
                  or "length" in lt else "0")
        return Link(_axis_chart(REVOLUTE, coordinates[0], dimension), length, body, name,
                    parent_index, joint, axis, offset, coordinates)
    if body is not None and body.kind == "rigid":
        raise ModelError(f"{where}: a rigid body needs a frame that turns with it (a revolute "
                         f"joint); a chart gives only the link's direction, not its spin "
                         f"(a planar link's body is a 'rod')")
    if "axis" in lt:
        raise ModelError(f"{where}: 'axis' is a prismatic joint's (a chart's axes are in charts.toml)")
    try:
        chart = load_chart(_require(lt, "chart", str, where))
    except ModelError as exc:
        raise ModelError(str(exc) if str(exc).startswith(where) else f"{where}: 'chart': {exc}") from None
    if chart.dimension != dimension:
        raise ModelError(f"{where}: chart '{chart.name}' is {chart.dimension}-D in a {dimension}-D model")
    length = _require(lt, "length", str, where) if body is not None or "length" in lt else "0"
    coordinates = _joint_coordinates(lt, len(chart.coordinates),
                                     tuple(f"{c}{i}" for c in chart.coordinates), where)
    return Link(chart, length, body, name, parent_index, joint, (), offset, coordinates)


def _parse_links(tables: list, dimension: int, params: tuple[str, ...], origin: str) -> list[Link]:
    links, named = [], {}
    for i, lt in enumerate(tables, 1):
        where = f"{origin}: link {i}"
        if not isinstance(lt, dict):
            raise ModelError(f"{where}: must be a table")
        link = _parse_link(lt, i, dimension, named, where)
        for _, p in link_quantities(link):
            if NAME.match(p) and p not in params:
                raise ModelError(f"{where}: '{p}' is not a declared parameter")
        _check_com_is_a_fraction(link, params, where)
        _check_signs(link, params, where)
        if link.name:
            named[link.name] = i - 1
        links.append(link)
    coordinates = [c for link in links for c in link.coordinates]
    for c in coordinates:
        if coordinates.count(c) > 1:
            raise ModelError(f"{origin}: the coordinate '{c}' is named by two links")
    return links


def _order(t: dict, links: list[Link], origin: str) -> tuple[str, ...] | None:
    """The model's `coordinates`: the links' coordinates in the state's order, or None."""
    if "coordinates" not in t:
        return None
    order = _names(t, "coordinates", origin)
    own = [c for link in links for c in link.coordinates]
    if sorted(order) != sorted(own):
        raise ModelError(f"{origin}: 'coordinates' must list the links' coordinates "
                         f"({', '.join(own)}) once each, in the state's order")
    return None if list(order) == own else order


CENTRE = ".centre"        # a spring's end at a link's body centre, "<link>.centre"


def _spring_point(text, links: list[Link], where: str) -> str:
    names = {link.name for link in links if link.name}
    link = text[:-len(CENTRE)] if isinstance(text, str) and text.endswith(CENTRE) else text
    if text != PIVOT and link not in names:
        raise ModelError(f"{where}: 'between': {text!r} is not '{PIVOT}', a link's name (its tip) "
                         f"or '<link>{CENTRE}' (named links: {', '.join(sorted(names)) or 'none'})")
    return text


def _parse_loads(t: dict, links: list[Link], dimension: int, origin: str) -> tuple[Load, ...]:
    """The [[loads]] tables: a force (`force`, one expression per axis) at a `point`."""
    tables = t.get("loads", [])
    if not isinstance(tables, list):
        raise ModelError(f"{origin}: 'loads' must be an array of tables ([[loads]])")
    out = []
    for i, lt in enumerate(tables, 1):
        where = f"{origin}: load {i}"
        if not isinstance(lt, dict):
            raise ModelError(f"{where}: must be a table")
        _no_unknown(lt, {"point", "force"}, where)
        for key in ("point", "force"):
            if key not in lt:
                raise ModelError(f"{where}: missing key '{key}'")
        force = lt["force"]
        if not isinstance(force, list) or len(force) != dimension or \
                not all(isinstance(c, (str, int, float)) and not isinstance(c, bool) for c in force):
            raise ModelError(f"{where}: 'force' must be a list of {dimension} expressions (its "
                             f"{', '.join('xyz'[:dimension])} components in the fixed frame)")
        point = _load_point(lt["point"], links, where)
        if point == PIVOT and "pivot" not in t:
            raise ModelError(f"{where}: a load at the fixed pivot does no work (it never moves): "
                             f"put it at a link's tip or '<link>{CENTRE}'")
        out.append(Load(point, tuple(str(c) for c in force)))
    return tuple(out)


def _load_point(text, links: list[Link], where: str) -> str:
    try:
        return _spring_point(text, links, where)
    except ModelError as exc:          # the same points as a spring's ends, named by this key
        raise ModelError(str(exc).replace("'between'", "'point'")) from None


def _parse_springs(t: dict, links: list[Link], params: tuple[str, ...], origin: str) -> tuple[Spring, ...]:
    """The [[springs]] tables: linear (`between`, `stiffness`, `rest_length`) or torsional
    (`joint`, `stiffness`, `rest_angle`)."""
    tables = t.get("springs", [])
    if not isinstance(tables, list):
        raise ModelError(f"{origin}: 'springs' must be an array of tables ([[springs]])")
    out, by_name = [], {link.name: i for i, link in enumerate(links) if link.name}
    for i, st in enumerate(tables, 1):
        where = f"{origin}: spring {i}"
        if not isinstance(st, dict):
            raise ModelError(f"{where}: must be a table")
        if ("between" in st) == ("joint" in st):
            raise ModelError(f"{where}: give 'between' (two points: a linear spring) or 'joint' "
                             f"(a link's name: a torsional spring), one of them")
        if "between" in st:
            _no_unknown(st, {"between", "stiffness", "rest_length"}, where)
            ends = st["between"]
            if not isinstance(ends, list) or len(ends) != 2:
                raise ModelError(f"{where}: 'between' must be a list of two points")
            spring = Spring(_quantity(st, "stiffness", where) if "stiffness" in st else "",
                            _quantity(st, "rest_length", where) if "rest_length" in st else "0",
                            between=tuple(_spring_point(e, links, where) for e in ends))
            if ends[0] == ends[1]:
                raise ModelError(f"{where}: 'between' names {ends[0]!r} twice: a spring joins two points")
        else:
            _no_unknown(st, {"joint", "stiffness", "rest_angle"}, where)
            joint = st["joint"]
            if joint not in by_name:
                raise ModelError(f"{where}: 'joint' = {joint!r} is not a link's name "
                                 f"(named links: {', '.join(sorted(by_name)) or 'none'})")
            link = links[by_name[joint]]
            if link.joint == PRISMATIC or len(link.coordinates) != 1:
                raise ModelError(f"{where}: a torsional spring is at a hinge of one angle; link "
                                 f"'{joint}' has {'a slider' if link.joint == PRISMATIC else 'a ball joint'}")
            spring = Spring(_quantity(st, "stiffness", where) if "stiffness" in st else "",
                            _quantity(st, "rest_angle", where) if "rest_angle" in st else "0",
                            joint=by_name[joint])
        if not spring.stiffness:
            raise ModelError(f"{where}: missing key 'stiffness'")
        symbols = {n: sp.Symbol(n, positive=True) for n in params}
        for key, text in (("stiffness", spring.stiffness), ("rest", spring.rest)):
            value = parse_expression(text, symbols, f"{where}: {key}")
            if key == "rest" and spring.between is not None and value.is_negative:
                raise ModelError(f"{where}: rest_length = {text!r} is negative: a length is >= 0")
        out.append(spring)
    return tuple(out)


def parse_model(text: str, origin: str) -> Model:
    try:
        t = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"{origin}: not valid TOML ({exc})") from None
    except RecursionError:             # tomllib recurses once per nested inline table
        raise ModelError(f"{origin}: not valid TOML (tables nested too deeply)") from None
    _no_unknown(t, {"name", "title", "source", "dimension", "parameters", "forms", "links",
                    "inputs", "dissipation", "forces", "pivot", "potential", "coordinates", "springs",
                    "constraints", "loads"}, origin)
    dimension = _require(t, "dimension", int, origin)
    if dimension not in (2, 3):
        raise ModelError(f"{origin}: 'dimension' must be 2 (planar) or 3 (spherical), got {dimension}")
    _require(t, "parameters", list, origin)
    params = _names(t, "parameters", origin)
    inputs = _names(t, "inputs", origin)
    links = _parse_links(_require(t, "links", list, origin), dimension, params, origin)
    if not links:
        raise ModelError(f"{origin}: a model needs at least one [[links]] table")
    if "g" not in params:
        raise ModelError(f"{origin}: parameters must include the gravity 'g'")
    forms = t.get("forms", ["lagrangian"])
    if not isinstance(forms, list):
        raise ModelError(f"{origin}: 'forms' must be a list")
    for f in forms:
        if f not in ("lagrangian", "hamiltonian", "paper"):
            raise ModelError(f"{origin}: unknown form '{f}' (known: lagrangian, hamiltonian, paper)")
    forms = tuple(forms)
    name = _require(t, "name", str, origin)
    if len(name) > MAX_NAME + 16:          # a user's name <= MAX_NAME, an atlas member's a suffix more
        raise ModelError(f"{origin}: 'name' is {len(name)} characters long (at most {MAX_NAME})")
    if not NAME.match(name):
        raise ModelError(f"{origin}: 'name' must be an identifier (letters, digits, _), got {name!r}")
    if name in SHADOWING or name.startswith("_"):
        raise ModelError(f"{origin}: 'name' = {name!r} would shadow a Python module in the generated "
                         f"NumPy code ({name}.py); give the model another name")
    dissipation = t.get("dissipation")
    if dissipation is not None and not isinstance(dissipation, str):
        raise ModelError(f"{origin}: 'dissipation' must be an expression (a string)")
    potential = t.get("potential")
    if potential is not None and not isinstance(potential, str):
        raise ModelError(f"{origin}: 'potential' must be an expression (a string)")
    forces_table = t.get("forces", {})
    if not isinstance(forces_table, dict):
        raise ModelError(f"{origin}: 'forces' must be a table from coordinate name to expression")
    model = Model(name=name, title=_text(t, "title", origin), source=_text(t, "source", origin),
                  dimension=dimension, parameters=params, forms=forms, links=tuple(links), text=text,
                  inputs=inputs, dissipation=dissipation, origin=origin,
                  pivot=_pivot(t, dimension, origin), potential=potential,
                  order=_order(t, links, origin), springs=_parse_springs(t, links, params, origin), constraints=_constraints(t, origin),
                  loads=_parse_loads(t, links, dimension, origin),
                  forces=tuple((k, _quantity(forces_table, k, f"{origin}: forces")) for k in forces_table))
    _check_names(model, origin)
    _check_expressions(model, origin)
    if "hamiltonian" in forms and not model.is_conservative:
        why = ("dissipation" if dissipation else "applied forces" if model.forces or model.loads
               else "explicit time (a moving pivot)")
        raise ModelError(f"{origin}: the Hamiltonian form is for conservative models; this one has "
                         f"{why} (remove 'hamiltonian' from 'forms')")
    if not model.is_chain and ("hamiltonian" in forms or "paper" in forms):
        raise ModelError(f"{origin}: the Hamiltonian and 'paper' forms are a chain's; this model is "
                         f"a tree (a parent, an offset, a slider, a massless link or a coordinate "
                         f"order): remove them from 'forms'")
    if model.is_constrained and ("hamiltonian" in forms or "paper" in forms):
        raise ModelError(f"{origin}: the {'Hamiltonian' if 'hamiltonian' in forms else 'paper'} form "
                         f"is for unconstrained chains; this model has constraints (a closed loop): "
                         f"keep forms = [\"lagrangian\"]")
    if "paper" in forms and (dimension != 3 or len(links) != 2):
        raise ModelError(f"{origin}: the 'paper' forms are the seed's double spherical pendulum's "
                         f"(dimension 3, two links)")
    return model


# A Model in the cache is its text and where it came from: parsed again on reading.
cachefile.register_codec("__model__", Model,
                         lambda m: {"__model__": m.text, "origin": m.origin or m.name},
                         lambda d: parse_model(d["__model__"], d["origin"]))


def _text(t: dict, key: str, where: str) -> str:
    value = t.get(key, "")
    if not isinstance(value, str):
        raise ModelError(f"{where}: '{key}' must be a string")
    return value


def _check_names(model: "Model", where: str) -> None:
    coords = model.coordinate_names
    for kind, names in (("parameter", model.parameters), ("input", model.inputs)):
        for n in names:
            if n in model.state_names:
                raise ModelError(f"{where}: the {kind} '{n}' has the name of a state ({', '.join(model.state_names)}): "
                                 f"an expression could not tell them apart")
    for n in set(model.parameters) & set(model.inputs):
        raise ModelError(f"{where}: '{n}' is both a parameter and an input: a name has one value")
    for coord, _ in model.forces:
        if coord not in coords:
            raise ModelError(f"{where}: forces.{coord}: not a coordinate (coordinates: {', '.join(coords)})")


NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_from_files: dict[str, Model] = {}          # models read from files, by name, in this process


def load_model_file(path: str | os.PathLike) -> Model:
    """A model description from a TOML file anywhere; afterwards its name loads it too."""
    path = Path(path)
    text = read_input_text(path, "model", ModelError)       # a regular file of bounded size
    model = parse_model(text, str(path))
    problem = model_name_problem(model.name)
    if problem:
        raise ModelError(f"{path}: 'name' = {model.name!r} {problem}; give the model another name")
    if model.name in model_names() and load_model(model.name).text != text:
        raise ModelError(f"{path}: name '{model.name}' is a catalogue model's; give the model "
                         f"another name")
    known = _from_files.get(model.name)
    if known is not None and known.text != text:
        if Path(known.origin).resolve() != path.resolve():
            raise ModelError(f"{path}: another model file ({known.origin}) named '{model.name}' was "
                             f"read first; give the model another name")
        for forget in _on_change:       # the file was edited: forget what was made of it
            forget()
    _from_files[model.name] = model
    return model


def model_name_problem(name: str) -> str | None:
    """Why a model file may not be called `name` (its generated files would be another
    artifact's, or too long a file name), or None."""
    if len(name) > MAX_NAME:
        return f"is {len(name)} characters long (at most {MAX_NAME})"
    if name.startswith(SHARED_PREFIX):
        return f"starts with '{SHARED_PREFIX}', the prefix of the library files every model shares"
    for suffix in ARTIFACT_SUFFIXES:
        if name.endswith(suffix):
            return (f"ends with '{suffix}': the generated files of the model '{name[:-len(suffix)]}' "
                    f"are called so")
    if name in _atlas_names():
        return f"is the name of the chart atlas '{name}'"
    return None


@cache
def _atlas_names() -> frozenset[str]:
    try:
        tables = tomllib.loads((catalog_dir() / "atlases.toml").read_text())
    except (OSError, tomllib.TOMLDecodeError):
        return frozenset()
    return frozenset(k for k, v in tables.items() if isinstance(v, dict) and "charts" in v)


_on_change: list = []
_derived: set[str] = set()          # names of models derived in memory (atlas members)


def register_derived_model(model: Model) -> Model:
    """Make a model derived in memory from another (an atlas member) loadable by its name,
    as a model file read before is.  A name taken by another model is refused."""
    other = _from_files.get(model.name)
    replaceable = other is None or other.text == model.text or model.name in _derived   # re-derived after an edit
    if model.name in model_names() or not replaceable:
        where = other.origin if other is not None else "the catalogue"
        raise ModelError(f"{model.origin}: the name '{model.name}' is taken by another model ({where})")
    _from_files[model.name] = model
    _derived.add(model.name)
    return model


def forget_on_model_change(cached):
    """Register an lru_cache'd function of a model name: cleared when a model file read
    before is read again with new content (an edit during a session), so nothing stale
    is ever used.  Returns the function, so it serves as a decorator."""
    _on_change.append(cached.cache_clear)
    return cached


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
    if name in DATA_FILES or not NAME.match(name) or len(name) > MAX_NAME or not path.is_file():
        raise ModelError(f"unknown model '{name}' (known: {', '.join(model_names())}; "
                         f"or give the path of a model file)")
    return parse_model(path.read_text(), path.name)
